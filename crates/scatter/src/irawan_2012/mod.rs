//! Irawan & Marschner 2012, *Specular reflection from woven cloth* (ACM TOG 31(1)): a woven
//! fabric as a periodic pattern of yarn segments (warp along `v`, weft along `u`), each a
//! curved cylinder of twisted fibers whose specular highlight is located in closed form.
//! Surface model `irawan-2012`.
//!
//! # Pattern
//! A [`WeavePattern`] is a `width × height` grid of cells (tiled in UV: the tile spans
//! `[0, 1)²`), each holding the 1-based id of the [`YarnSegment`] covering it, plus the
//! pattern-wide α (uniform scattering), β (von Mises forward-scattering concentration), `ss`
//! (filament smoothing), `h_width` (highlight width fraction) and the warp/weft areas. A
//! segment has a kind (warp or weft), twist ψ (0 for a filament yarn, otherwise a staple yarn),
//! maximum inclination `u_max`, spine curvature κ (> −1), width `w` and length `l` in cells,
//! its centre in cells, and diffuse/specular colours `k_d`, `k_s`. The text format is read by
//! `fiberlab_io::weave_pattern` (the pure model is here).
//!
//! # Evaluation at a point
//! The point's UV position is a textured parameter (`u`, `v`, see
//! [`SurfaceScattering::set_parameter`]). In the segment's frame (`y` along the yarn, `x`
//! across, `z` the normal; weft segments are the warp case rotated by π/2 about the normal)
//! the point sits at `(x, y)`, i.e. at inclination `u = y/(l/2)·u_max` and cross angle
//! `v = x·π/w`; `h = (ω_i + ω_o)/|ω_i + ω_o|`.
//! * **filament** (ψ = 0): the fiber tangent that mirrors `ω_i` into `ω_o` has inclination
//!   `u* = atan(h_y/h_z)` (needs |u*| < u_max); the highlight is seen where the point lies
//!   within `δ_y/2 = l·h_width/2` of `y(u*)`; value `G·f_c·A·π·l/δ_y`, with
//!   `G = a(R + a cos v)/(|ω_i + ω_o|·|(t × h)_x|)`, `t = (0, cos u*, −sin u*)`, `a = w/2`;
//! * **staple** (ψ ≠ 0): across the yarn the highlight sits at
//!   `v*(u) = atan2(−h_y sin u − h_z cos u, h_x) + acos D`,
//!   `D = (h_y cos u − h_z sin u)/(√(h_x² + (h_y sin u + h_z cos u)²)·tanψ)` (needs |D| < 1,
//!   |v*| < π/2), seen within `δ_x/2 = w·h_width/2` of `x(v*)`; value `G·f_c·A·2w·u_max/δ_x`,
//!   `G = a(R + a cos v*)/(|ω_i + ω_o|·(n·h)·|sinψ|)`;
//! * `f_c = α + exp(β·(−ω_i·ω_o))/(2π I₀(β))` (von Mises in the scattering angle), Seeliger
//!   attenuation `A = c_i c_o/(4π (c_i + c_o))` with `c = max(0, n·ω)` at the highlight's
//!   normal `n = (sin v, sin u cos v, cos u cos v)`;
//! * filament smoothing: `× (1 − ss) + ss·min(1, (u_max − |u*|)/(0.1·u_max))`, fading the
//!   highlight in over the last tenth of the inclination range;
//! * `× (A_warp + A_weft)/A_own` (the kind's share of the visible area).
//!
//! # Spines, fiber variation, u_max noise (all off by default; the presets use none)
//! * **Spine** (`spine=`): `circle` (default) — every spine a circular arc of half-chord
//!   `l/2` turning through ±u_max, `R = (l/2)/sin u_max`, κ ignored; `conic` — the paper's
//!   spine-curvature model (its spine section: circle, ellipse, parabola, hyperbola): the
//!   yarn's κ selects `r̂ = 1 + κ(1 + 1/tan u_max)`, a circle for `r̂ = 1` (κ = 0), an ellipse
//!   for `r̂ > 0`, a parabola for `r̂ = 0`, a hyperbola for `r̂ < 0`, and `R(u)` at the
//!   highlight's inclination is the conic's radius of curvature ([`conic_radius`], derived
//!   there; our chord convention keeps `r̂ = 1` equal to the default circle). κ > 0 flattens
//!   the crest, κ < 0 sharpens it.
//! * **Fineness** (`fineness=F`, fibers per grid cell): the random per-fiber intensity
//!   variation of the paper — the specular integrand is multiplied by `min(−ln ξ, 10)`, ξ
//!   uniform and hashed (deterministic) from the segment copy, the yarn id and the fiber
//!   strip `⌊F·(x cos ψ − y sin ψ)⌋` (fibers run at the twist ψ to the yarn axis).
//! * **u_max noise** (`umax_noise=A` degrees, `umax_noise_period=P` tiles): every `u_max`
//!   plus `A·n(u/P, v/P)`, `n` a smooth value noise in [−1, 1] (hashed lattice values with a
//!   quintic fade; the paper and Mitsuba use Perlin gradient noise — same role, a different
//!   noise), one field for warps and one for wefts, held in [0.5°, 89.5°].
//!
//! These options are fixed at construction and included in the normalisation tables (below).
//! Equation numbers are not quoted (no copy of the paper was checked; see
//! `docs/theory/irawan-2012.md`).
//!
//! # Normalisation (stays correct under textured α, β)
//! `f_r = k_d/π + k_s·X·s_n`, X the integrand above, `s_n = 1/(α·S₁ + S₂(β))`: the
//! diffuse-light average of X is linear in α, and `S₁`, `S₂` (on 65 values of β ∈ [0, 20])
//! are estimated at construction from 2·10⁵ sample pairs, so texturing α or β through
//! `set_parameter` renormalises (exactly in α, to the interpolation error in β). The average
//! does not bound the albedo pointwise (peaks of 4–12 per unit `k_s`); the presets' `k_s` keep
//! `∫ f_r cosθ_o dω_o ≤ 1` on a tested grid. Why, and the measured peaks:
//! `docs/theory/irawan-2012.md`.
//!
//! Reciprocal: everything depends on the directions through `h`, `|ω_i + ω_o|`, `ω_i·ω_o` and
//! the symmetric Seeliger factor (the harness checks the claim). Energy: `k_s + k_d ≤ 1` bounds the average
//! albedo; per direction it is checked on a grid for every preset (tested).
//!
//! # Sampling
//! Half cosine-weighted hemisphere, half a Phong lobe `(n + 1)/(2π)·cos^n` (n = 8) about the
//! mirror direction of `ω_o`; the pdf is the exact mixture density on the sphere, directions
//! below the surface carry weight 0.

mod pattern;
mod presets;
#[cfg(test)]
mod tests;
mod variation;

use pattern::check;
pub use pattern::{PatternError, WeavePattern, YarnKind, YarnSegment};
pub use presets::IRAWAN_PRESETS;
pub use variation::{Spine, Variation, conic_radius, spine_shape};

use crate::params::{ParamKind, ParamSet, ParamSpec, Range};
use crate::sampling::cosine_hemisphere;
use crate::{LobeInfo, ModelError, ModelInfo, Registered, Sample, SurfaceProperties, SurfaceScattering};
use fiberlab_math::special::i0e;
use fiberlab_math::split_mix::SplitMix64;
use fiberlab_math::{DVec3, Rgb};
use std::f64::consts::{FRAC_PI_2, PI, TAU};
use std::sync::Arc;

/// Largest β of the normalisation table (and of the parameter range).
const BETA_MAX: f64 = 20.0;
/// Entries of the normalisation table in β.
const BETA_STEPS: usize = 65;
/// Sample pairs of the normalisation estimate.
const NORMALISATION_PAIRS: usize = 200_000;
/// Exponent of the sampling lobe.
const LOBE_EXPONENT: f64 = 8.0;
/// Probability of the cosine part of the sampler.
const COSINE_SHARE: f64 = 0.5;

/// The specular integrand at one point split as `α·X₁ + X₁·vM(β)`: returns `(X₁, cos s)` with
/// `cos s = −ω_i·ω_o`, from which `X = X₁·(α + vM(β; cos s))`.
fn integrand_parts(pattern: &WeavePattern, var: &Variation, u: f64, v: f64, wi: DVec3, wo: DVec3) -> (f64, f64) {
    let at = pattern.locate(u, v);
    let (yarn, x, y) = (at.yarn, at.x, at.y);
    let u_max = var.u_max(yarn, u, v);
    // Directions in the segment frame: y along the yarn, x across, z the normal.
    let to_local = |d: DVec3| match yarn.kind {
        YarnKind::Warp => DVec3::new(d.x, d.y, d.z),
        YarnKind::Weft => DVec3::new(-d.y, d.x, d.z),
    };
    let (li, lo) = (to_local(wi), to_local(wo));
    let sum = li + lo;
    let len = sum.length();
    if len < 1e-12 || wi.z <= 0.0 || wo.z <= 0.0 {
        return (0.0, 0.0);
    }
    let hv = sum / len;
    let a = 0.5 * yarn.width;
    let area_share = (pattern.warp_area + pattern.weft_area)
        / match yarn.kind {
            YarnKind::Warp => pattern.warp_area,
            YarnKind::Weft => pattern.weft_area,
        };
    let seeliger = |n: DVec3| {
        let (ci, co) = (n.dot(li).max(0.0), n.dot(lo).max(0.0));
        if ci + co > 0.0 { ci * co / (4.0 * PI * (ci + co)) } else { 0.0 }
    };
    let cos_s = -wi.dot(wo);
    let value = if yarn.psi == 0.0 {
        // Filament: the highlight's inclination along the yarn.
        let u_star = hv.y.atan2(hv.z);
        if u_star.abs() >= u_max {
            return (0.0, cos_s);
        }
        let y_star = u_star / u_max * (0.5 * yarn.length);
        let delta_y = yarn.length * pattern.h_width;
        if (y_star - y).abs() >= 0.5 * delta_y {
            return (0.0, cos_s);
        }
        let vv = (x * PI / yarn.width).clamp(-FRAC_PI_2, FRAC_PI_2);
        let n = DVec3::new(vv.sin(), u_star.sin() * vv.cos(), u_star.cos() * vv.cos());
        let t = DVec3::new(0.0, u_star.cos(), -u_star.sin());
        let txh = t.cross(hv).x.abs();
        if txh < 1e-12 {
            return (0.0, cos_s);
        }
        let g = a * (var.radius(yarn, u_max, u_star) + a * vv.cos()) / (len * txh);
        let smooth = (1.0 - pattern.ss) + pattern.ss * ((u_max - u_star.abs()) / (0.1 * u_max)).min(1.0);
        g * seeliger(n) * smooth * PI * yarn.length / delta_y
    } else {
        // Staple: the highlight's angle across the yarn at this inclination.
        let uu = (y / (0.5 * yarn.length) * u_max).clamp(-u_max, u_max);
        let (su, cu) = uu.sin_cos();
        let denom = (hv.x * hv.x + (hv.y * su + hv.z * cu).powi(2)).sqrt() * yarn.psi.tan();
        if denom.abs() < 1e-300 {
            return (0.0, cos_s);
        }
        let d = (hv.y * cu - hv.z * su) / denom;
        if d.abs() >= 1.0 {
            return (0.0, cos_s);
        }
        let v_star = (-hv.y * su - hv.z * cu).atan2(hv.x) + d.acos();
        let v_star = fiberlab_math::frame::wrap_pi(v_star);
        if v_star.abs() >= FRAC_PI_2 {
            return (0.0, cos_s);
        }
        let x_star = v_star * yarn.width / PI;
        let delta_x = yarn.width * pattern.h_width;
        if (x_star - x).abs() >= 0.5 * delta_x {
            return (0.0, cos_s);
        }
        let n = DVec3::new(v_star.sin(), su * v_star.cos(), cu * v_star.cos());
        let nh = n.dot(hv);
        if nh <= 0.0 {
            return (0.0, cos_s);
        }
        let g = a * (var.radius(yarn, u_max, uu) + a * v_star.cos()) / (len * nh * yarn.psi.sin().abs());
        g * seeliger(n) * 2.0 * yarn.width * u_max / delta_x
    };
    (value * area_share * var.fiber_factor(&at), cos_s)
}

/// Von Mises density in the scattering angle, `exp(β cos s)/(2π I₀(β))`, computed stably.
fn von_mises(beta: f64, cos_s: f64) -> f64 {
    (beta * (cos_s - 1.0)).exp() / (TAU * i0e(beta))
}

/// The pattern with its normalisation tables (shared between copies of the model).
#[derive(Debug)]
struct Fabric {
    pattern: WeavePattern,
    variation: Variation,
    /// `S₁ = π·E[X₁]`.
    s1: f64,
    /// `S₂(β_k) = π·E[X₁·vM(β_k)]` on `BETA_STEPS` equal steps of [0, BETA_MAX].
    s2: [f64; BETA_STEPS],
}

/// A cosine-distributed direction on the upper hemisphere.
fn cosine_direction(u0: f64, u1: f64) -> DVec3 {
    cosine_hemisphere(DVec3::Z, DVec3::X, u0, u1)
}

impl Fabric {
    fn new(pattern: WeavePattern, variation: Variation) -> Self {
        let mut rng = SplitMix64::new(0x1a7a_2012);
        let (mut s1, mut s2) = (0.0, [0.0; BETA_STEPS]);
        let extent = variation.extent();
        for _ in 0..NORMALISATION_PAIRS {
            let wi = cosine_direction(rng.next_f64(), rng.next_f64());
            let wo = cosine_direction(rng.next_f64(), rng.next_f64());
            let (u, v) = (rng.next_f64() * extent, rng.next_f64() * extent);
            let (x1, cos_s) = integrand_parts(&pattern, &variation, u, v, wi, wo);
            if x1 == 0.0 {
                continue;
            }
            s1 += x1;
            for (k, s) in s2.iter_mut().enumerate() {
                *s += x1 * von_mises(BETA_MAX * k as f64 / (BETA_STEPS - 1) as f64, cos_s);
            }
        }
        let scale = PI / NORMALISATION_PAIRS as f64;
        Self { pattern, variation, s1: s1 * scale, s2: s2.map(|s| s * scale) }
    }

    /// `S₂(β)` interpolated linearly.
    fn s2_at(&self, beta: f64) -> f64 {
        let x = (beta / BETA_MAX).clamp(0.0, 1.0) * (BETA_STEPS - 1) as f64;
        let k = (x as usize).min(BETA_STEPS - 2);
        let t = x - k as f64;
        self.s2[k] * (1.0 - t) + self.s2[k + 1] * t
    }
}

/// The Irawan & Marschner 2012 woven-cloth BRDF at one UV position.
#[derive(Clone, Debug)]
pub struct Irawan2012 {
    fabric: Arc<Fabric>,
    alpha: f64,
    beta: f64,
    /// Scale of every yarn's `k_d` (textured, default 1).
    k_d_scale: Rgb,
    /// Scale of every yarn's `k_s` (textured, default 1).
    k_s_scale: Rgb,
    position: [f64; 2],
}

/// The lobes of [`Irawan2012`]'s sampler.
const IRAWAN_LOBES: [LobeInfo; 2] = [LobeInfo::smooth("cosine"), LobeInfo::smooth("mirror-lobe")];

/// The keys [`Irawan2012::set_parameter`] accepts.
const IRAWAN_TEXTURABLE: [&str; 6] = ["u", "v", "alpha", "beta", "k_d_scale", "k_s_scale"];

/// The spine choices of `spine=`.
const SPINES: [&str; 2] = ["circle", "conic"];

/// Parameter table of `irawan-2012`.
pub const IRAWAN_PARAMS: [ParamSpec; 12] = [
    ParamSpec {
        key: "preset",
        kind: ParamKind::Choice(&IRAWAN_PRESETS),
        unit: "",
        default: "cotton-denim",
        doc: "weave of the example set",
    },
    ParamSpec {
        key: "pattern",
        kind: ParamKind::Text,
        unit: "path",
        default: "",
        doc: "weave-pattern file (the book's irawan-2012 page, section Pattern files) instead of a preset; relative to the scene file or the working directory",
    },
    ParamSpec {
        key: "spine",
        kind: ParamKind::Choice(&SPINES),
        unit: "",
        default: "circle",
        doc: "yarn spine: circular arcs, or the conics of each yarn's curvature κ",
    },
    ParamSpec {
        key: "fineness",
        kind: ParamKind::Number(Range::closed(0.0, 1000.0)),
        unit: "1/cell",
        default: "0",
        doc: "fibers per grid cell for the random per-fiber intensity variation (0: off)",
    },
    ParamSpec {
        key: "umax_noise",
        kind: ParamKind::Number(Range::closed(0.0, 30.0)),
        unit: "degrees",
        default: "0",
        doc: "amplitude of the smooth noise added to every yarn's u_max (0: off)",
    },
    ParamSpec {
        key: "umax_noise_period",
        kind: ParamKind::Number(Range::closed(0.01, 1000.0)),
        unit: "tiles",
        default: "1",
        doc: "lattice spacing of the u_max noise, in weave tiles",
    },
    ParamSpec {
        key: "alpha",
        kind: ParamKind::Number(Range::closed(0.0, 10.0)),
        unit: "",
        default: "",
        doc: "uniform scattering α (overrides the pattern)",
    },
    ParamSpec {
        key: "beta",
        kind: ParamKind::Number(Range::closed(0.0, BETA_MAX)),
        unit: "",
        default: "",
        doc: "forward-scattering concentration β (overrides the pattern)",
    },
    ParamSpec {
        key: "k_d_scale",
        kind: ParamKind::Color(Range::UNIT),
        unit: "",
        default: "1",
        doc: "scale of every yarn's diffuse colour",
    },
    ParamSpec {
        key: "k_s_scale",
        kind: ParamKind::Color(Range::UNIT),
        unit: "",
        default: "1",
        doc: "scale of every yarn's specular colour",
    },
    ParamSpec {
        key: "u",
        kind: ParamKind::Number(Range::closed(-1e6, 1e6)),
        unit: "",
        default: "0.5",
        doc: "texture coordinate u of the point (textured: the renderer sets it per hit)",
    },
    ParamSpec {
        key: "v",
        kind: ParamKind::Number(Range::closed(-1e6, 1e6)),
        unit: "",
        default: "0.5",
        doc: "texture coordinate v of the point (textured: the renderer sets it per hit)",
    },
];

impl Irawan2012 {
    /// A fabric from a validated pattern (computes the normalisation tables).
    pub fn new(pattern: WeavePattern) -> Result<Self, PatternError> {
        Self::with_variation(pattern, Variation::default())
    }

    /// A fabric from a validated pattern with the options `variation`.
    pub fn with_variation(pattern: WeavePattern, variation: Variation) -> Result<Self, PatternError> {
        pattern.validate()?;
        check("fineness", variation.fineness, (0.0..=1000.0).contains(&variation.fineness), "in [0, 1000]")?;
        check(
            "umax_noise",
            variation.umax_noise,
            (0.0..=30f64.to_radians() * (1.0 + 1e-12)).contains(&variation.umax_noise),
            "in [0, 30] degrees",
        )?;
        let period = variation.umax_noise_period;
        check("umax_noise_period", period, (0.01..=1000.0).contains(&period), "in [0.01, 1000] tiles")?;
        let (alpha, beta) = (pattern.alpha, pattern.beta);
        Ok(Self {
            fabric: Arc::new(Fabric::new(pattern, variation)),
            alpha,
            beta,
            k_d_scale: Rgb::ONE,
            k_s_scale: Rgb::ONE,
            position: [0.5, 0.5],
        })
    }

    /// The preset `name` of [`IRAWAN_PRESETS`].
    #[must_use]
    pub fn preset(name: &str) -> Option<Self> {
        WeavePattern::preset(name).and_then(|p| Self::new(p).ok())
    }

    /// The pattern.
    #[must_use]
    pub fn pattern(&self) -> &WeavePattern {
        &self.fabric.pattern
    }

    /// The options fixed at construction (spine, fiber variation, `u_max` noise).
    #[must_use]
    pub fn options(&self) -> Variation {
        self.fabric.variation
    }

    /// Uniform scattering α and forward-scattering concentration β in use.
    #[must_use]
    pub fn alpha_beta(&self) -> (f64, f64) {
        (self.alpha, self.beta)
    }

    /// The scales of every yarn's `k_d` and `k_s`.
    #[must_use]
    pub fn colour_scales(&self) -> (Rgb, Rgb) {
        (self.k_d_scale, self.k_s_scale)
    }

    /// The evaluation point's UV position.
    #[must_use]
    pub fn position(&self) -> [f64; 2] {
        self.position
    }

    /// Moves the evaluation point to UV `(u, v)`.
    pub fn set_position(&mut self, u: f64, v: f64) {
        self.position = [u, v];
    }

    /// The normalisation `s_n` for the current α, β.
    #[must_use]
    pub fn normalisation(&self) -> f64 {
        let s = self.alpha * self.fabric.s1 + self.fabric.s2_at(self.beta);
        if s > 0.0 { 1.0 / s } else { 0.0 }
    }

    /// The raw specular integrand `X` at the current point (before `k_s` and `s_n`).
    #[must_use]
    pub fn integrand(&self, wi: DVec3, wo: DVec3) -> f64 {
        let f = &*self.fabric;
        let (x1, cos_s) = integrand_parts(&f.pattern, &f.variation, self.position[0], self.position[1], wi, wo);
        x1 * (self.alpha + von_mises(self.beta, cos_s))
    }

    fn mirror(wo: DVec3) -> DVec3 {
        DVec3::new(-wo.x, -wo.y, wo.z)
    }

    fn lobe_pdf(wi: DVec3, wo: DVec3) -> f64 {
        let c = wi.dot(Self::mirror(wo));
        if c > 0.0 { (LOBE_EXPONENT + 1.0) / TAU * c.powf(LOBE_EXPONENT) } else { 0.0 }
    }

    /// The options of registry parameters.
    fn variation(p: &ParamSet) -> Result<Variation, ModelError> {
        Ok(Variation {
            spine: if p.choice("spine")? == "conic" { Spine::Conic } else { Spine::Circle },
            fineness: p.number("fineness")?,
            umax_noise: p.degrees("umax_noise")?,
            umax_noise_period: p.number("umax_noise_period")?,
        })
    }

    /// Builds from registry parameters; a `pattern=FILE` must be read by the caller and
    /// given to [`Irawan2012::from_param_set_with`] (the model loader of `fiberlab-render`).
    pub fn from_param_set(p: &ParamSet) -> Result<Self, ModelError> {
        if p.text("pattern").is_some() {
            return Err(ModelError::Inconsistent(
                "irawan-2012: a pattern file is read by the model loader (fiberlab_render::model_loader), not here"
                    .into(),
            ));
        }
        Self::from_param_set_with(p, None)
    }

    /// Builds from registry parameters and, when given, a pattern read from a file (which
    /// replaces the preset: giving both is an error).
    pub fn from_param_set_with(p: &ParamSet, pattern: Option<WeavePattern>) -> Result<Self, ModelError> {
        let invalid = |e: PatternError| ModelError::Inconsistent(format!("irawan-2012: {e}"));
        let pattern = match pattern {
            Some(_) if p.is_given("preset") => {
                return Err(ModelError::Inconsistent("irawan-2012: give either preset= or pattern=, not both".into()));
            }
            Some(pattern) => pattern,
            None => {
                let name = p.choice("preset")?;
                WeavePattern::preset(name).ok_or_else(|| ModelError::BadValue {
                    key: "preset".into(),
                    value: name.into(),
                    expected: IRAWAN_PRESETS.join(", "),
                })?
            }
        };
        let mut m = Self::with_variation(pattern, Self::variation(p)?).map_err(invalid)?;
        if let Some(a) = p.number_opt("alpha") {
            m.alpha = a;
        }
        if let Some(b) = p.number_opt("beta") {
            m.beta = b;
        }
        m.k_d_scale = p.color("k_d_scale")?;
        m.k_s_scale = p.color("k_s_scale")?;
        m.position = [p.number("u")?, p.number("v")?];
        Ok(m)
    }
}

/// Registry entry: `irawan-2012` (a surface model).
impl Registered for Irawan2012 {
    const INFO: ModelInfo = ModelInfo {
        name: "irawan-2012",
        summary: "woven cloth: yarn-level specular highlights of a weave pattern (Irawan & Marschner 2012)",
        citation: "Irawan & Marschner 2012; presets of the Mitsuba 0.6 example set",
        params: &IRAWAN_PARAMS,
        data: Some(crate::ExternalData::WeavePattern { key: "pattern" }),
    };

    fn from_param_set(p: &ParamSet) -> Result<Self, ModelError> {
        Irawan2012::from_param_set(p)
    }
}

impl SurfaceScattering for Irawan2012 {
    fn properties(&self) -> SurfaceProperties {
        SurfaceProperties { reciprocal: true, energy_conserving: true, has_delta: false, transmits: false }
    }

    fn eval(&self, wi: DVec3, wo: DVec3) -> Rgb {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return Rgb::ZERO;
        }
        let yarn = self.fabric.pattern.locate(self.position[0], self.position[1]).yarn;
        let (k_d, k_s) = (yarn.k_d * self.k_d_scale, yarn.k_s * self.k_s_scale);
        k_d * (1.0 / PI) + k_s * (self.integrand(wi, wo) * self.normalisation())
    }

    fn pdf(&self, wi: DVec3, wo: DVec3) -> f64 {
        let cosine = if wi.z > 0.0 { wi.z / PI } else { 0.0 };
        COSINE_SHARE * cosine + (1.0 - COSINE_SHARE) * Self::lobe_pdf(wi, wo)
    }

    fn sample(&self, wo: DVec3, u: [f64; 4]) -> Option<Sample> {
        if wo.z <= 0.0 {
            return None;
        }
        let (wi, lobe) = if u[0] < COSINE_SHARE {
            (cosine_direction(u[1], u[2]), 0)
        } else {
            let axis = Self::mirror(wo);
            let cos_t = u[1].powf(1.0 / (LOBE_EXPONENT + 1.0));
            let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
            let frame = fiberlab_math::frame::FiberFrame::from_tangent(axis);
            let phi = TAU * u[2];
            let local = DVec3::new(cos_t, sin_t * phi.cos(), sin_t * phi.sin());
            (frame.to_world(local).normalize(), 1)
        };
        let pdf = self.pdf(wi, wo);
        if pdf.is_nan() || pdf <= 0.0 || !pdf.is_finite() {
            return None;
        }
        let weight = if wi.z > 0.0 { self.eval(wi, wo) * (wi.z / pdf) } else { Rgb::ZERO };
        Some(Sample { wi, weight, pdf, delta: false, lobe })
    }

    fn lobes(&self) -> Vec<LobeInfo> {
        IRAWAN_LOBES.to_vec()
    }

    fn texturable_keys(&self) -> &'static [&'static str] {
        &IRAWAN_TEXTURABLE
    }

    fn set_parameter(&mut self, key: &str, value: Rgb) -> Result<(), ModelError> {
        match key {
            "u" => self.position[0] = value[0],
            "v" => self.position[1] = value[0],
            "alpha" => self.alpha = value[0],
            "beta" => self.beta = value[0],
            "k_d_scale" => self.k_d_scale = value,
            "k_s_scale" => self.k_s_scale = value,
            _ => {
                return Err(ModelError::UnknownParameter {
                    model: "irawan-2012".into(),
                    key: key.into(),
                    known: IRAWAN_TEXTURABLE.join(", "),
                });
            }
        }
        Ok(())
    }
}
