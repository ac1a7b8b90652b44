//! `leaf`: a two-sided leaf as a surface model — a rough dielectric cuticle on both faces over a
//! diffusing interior whose reflectance and transmittance come from the leaf's pigments by
//! PROSPECT-D ([`crate::feret_2017`]), so that a user sets contents, not colours. Leaf surface
//! reflection is nearly independent of wavelength and set by the cuticle's roughness (Bousquet,
//! Lachérade, Jacquemoud & Moya 2005); the interior is the plate model's body.
//!
//! Parameters: the registry entry below (`PARAMS`); `fiberlab models --model leaf` and the
//! book's page `docs/book/src/models/leaf.md` show it as a table.
//!
//! # Formula
//! Local frame z = normal; both faces are alike, so a direction pair below the surface is
//! evaluated mirrored (z → −z). With `μ = |cosθ|`:
//! * **Cuticle** (ω_i, ω_o on one side): Walter et al. 2007's GGX reflection
//!   `f_s = F(ω_i·h; η)·D(h)·G₂(ω_i, ω_o)/(4μ_iμ_o)`, `h = (ω_i + ω_o)/|ω_i + ω_o|`, D the GGX
//!   (Trowbridge–Reitz) distribution of α, G₂ Smith's height-correlated shadowing. Its directional
//!   albedo `E(μ)` is tabulated at construction (33 values of μ, by a 64 × 64 midpoint lattice
//!   over the visible normals of Heitz 2018, where `E = ⟨F·G₂/G₁⟩`) and interpolated linearly.
//! * **Body**: light the cuticle does not reflect enters; the body reflects `R_b` and transmits
//!   `T_b` of it (PROSPECT-D's body values, [`crate::feret_2017::body_rgb`]), diffusely, and what
//!   leaves crosses the cuticle of its face. Written reciprocally,
//!   `f_d = R_b·(1 − E(μ_i))(1 − E(μ_o))/(π(1 − Ē))` (one side) and
//!   `f_t = T_b·(1 − E(μ_i))(1 − E(μ_o))/(π(1 − Ē))` (opposite sides), `Ē = 2∫E(μ)μ dμ` of the
//!   interpolated E (exact), so that light from ω_i is reflected `E(μ_i) + (1 − E(μ_i))R_b` and
//!   transmitted `(1 − E(μ_i))T_b`: R + T ≤ 1 because R_b + T_b ≤ 1.
//!
//! Reciprocal, energy-conserving, transmitting (`transmits: true`: the BSDF `f(ω_i, ω_o)` with
//! `L_o = ∫ f L_i |cosθ_i| dω_i` over the whole sphere).
//!
//! # Sampling
//! A lobe from `u[0]` with probabilities ∝ `E(μ_o)`, `(1 − E(μ_o))Y(R_b)`, `(1 − E(μ_o))Y(T_b)`
//! (Y the luminance): the cuticle by GGX visible normals on ω_o's side (`u[1], u[2]`), the body
//! cosine-weighted on ω_o's side or the other (`u[1], u[2]`). The pdf is the mixture's.
//!
//! # Caveats
//! * The cuticle's rough *transmission* is not traced: light crosses it diffusely into and out
//!   of the body (PROSPECT's own assumption of isotropic light inside).
//! * The same cuticle on both faces (real leaves' adaxial and abaxial faces differ).
//! * Pigments are per material, not texturable (each change re-runs PROSPECT at 401
//!   wavelengths).

use crate::feret_2017::{LeafContents, body_rgb};
use crate::params::{ParamKind, ParamSet, ParamSpec, ParameterError, Range, parameter_error};
use crate::{LobeInfo, MIN_COS, ModelError, ModelInfo, Registered, Sample, SurfaceProperties, SurfaceScattering};
use fiberlab_math::{DVec3, Rgb, fresnel};
use std::f64::consts::{PI, TAU};

/// Intervals of the tabulated cuticle albedo E(μ), μ ∈ [0, 1].
const E_INTERVALS: usize = 32;
/// Midpoints per axis of the visible-normal lattice that integrates E(μ).
const E_LATTICE: usize = 64;

const N_RANGE: Range = Range::closed(1.0, 3.0);
const CAB_RANGE: Range = Range::closed(0.0, 150.0);
const CAR_RANGE: Range = Range::closed(0.0, 40.0);
const ANTH_RANGE: Range = Range::closed(0.0, 40.0);
const CBROWN_RANGE: Range = Range::closed(0.0, 2.0);
const CW_RANGE: Range = Range::closed(0.0, 0.1);
const CM_RANGE: Range = Range::closed(0.0, 0.05);
const ROUGHNESS_RANGE: Range = Range::closed(0.01, 1.0);
const ETA_RANGE: Range = Range::closed(1.2, 2.0);

const fn number(
    key: &'static str,
    range: Range,
    unit: &'static str,
    default: &'static str,
    doc: &'static str,
) -> ParamSpec {
    ParamSpec { key, kind: ParamKind::Number(range), unit, default, doc }
}

const PARAMS: [ParamSpec; 9] = [
    number("n", N_RANGE, "", "1.5", "PROSPECT structure parameter (plates: 1 compact … 3 spongy)"),
    number("cab", CAB_RANGE, "µg/cm²", "40", "chlorophyll a+b"),
    number("car", CAR_RANGE, "µg/cm²", "8", "carotenoids"),
    number("anth", ANTH_RANGE, "µg/cm²", "0", "anthocyanins"),
    number("cbrown", CBROWN_RANGE, "", "0", "brown pigments (senescent leaves)"),
    number("cw", CW_RANGE, "cm", "0.01", "equivalent water thickness"),
    number("cm", CM_RANGE, "g/cm²", "0.009", "dry matter per area"),
    number("roughness", ROUGHNESS_RANGE, "", "0.3", "GGX α of the cuticle (both faces)"),
    number("eta", ETA_RANGE, "", "1.47", "cuticle index"),
];

/// Registry entry: `leaf`.
impl Registered for Leaf {
    const INFO: ModelInfo = ModelInfo {
        name: "leaf",
        summary: "two-sided leaf: GGX cuticle over a diffusing body from PROSPECT-D pigments (reflects and transmits)",
        citation: "Féret et al. 2017 (PROSPECT-D); Walter et al. 2007 (GGX); ours (coupling)",
        params: &PARAMS,
        data: None,
    };

    fn from_param_set(p: &ParamSet) -> Result<Self, ModelError> {
        Ok(Leaf::new(LeafParams::from_param_set(p)?)?)
    }
}

/// Parameters of [`Leaf`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LeafParams {
    /// PROSPECT-D structure and contents.
    pub contents: LeafContents,
    /// GGX α of the cuticle, [0.01, 1].
    pub roughness: f64,
    /// Cuticle index, [1.2, 2].
    pub eta: f64,
}

impl Default for LeafParams {
    /// A healthy green leaf ([`LeafContents::default`]) with a moderately rough cuticle (α 0.3,
    /// η 1.47).
    fn default() -> Self {
        Self { contents: LeafContents::default(), roughness: 0.3, eta: 1.47 }
    }
}

impl LeafParams {
    /// Reads the registry parameters.
    pub fn from_param_set(p: &ParamSet) -> Result<Self, ModelError> {
        Ok(Self {
            contents: LeafContents {
                n: p.number("n")?,
                cab: p.number("cab")?,
                car: p.number("car")?,
                anth: p.number("anth")?,
                cbrown: p.number("cbrown")?,
                cw: p.number("cw")?,
                cm: p.number("cm")?,
            },
            roughness: p.number("roughness")?,
            eta: p.number("eta")?,
        })
    }

    /// Checks every value against its range.
    pub fn validate(&self) -> Result<(), ParameterError> {
        let c = &self.contents;
        N_RANGE.check("n", c.n)?;
        CAB_RANGE.check("cab", c.cab)?;
        CAR_RANGE.check("car", c.car)?;
        ANTH_RANGE.check("anth", c.anth)?;
        CBROWN_RANGE.check("cbrown", c.cbrown)?;
        CW_RANGE.check("cw", c.cw)?;
        CM_RANGE.check("cm", c.cm)?;
        ROUGHNESS_RANGE.check("roughness", self.roughness)?;
        ETA_RANGE.check("eta", self.eta).map(|_| ())
    }
}

parameter_error! {
    /// Why a [`Leaf`] cannot be built: a parameter outside its range.
    LeafError
}

/// The two-sided leaf (see the module docs).
#[derive(Clone, Debug)]
pub struct Leaf {
    params: LeafParams,
    /// Body reflectance and transmittance (RGB).
    r_b: Rgb,
    t_b: Rgb,
    /// E(μ_k), μ_k = k/E_INTERVALS.
    e: [f64; E_INTERVALS + 1],
    /// `1/(π(1 − Ē))`.
    body_norm: f64,
}

impl Leaf {
    /// A leaf; the error names the parameter out of range.
    pub fn new(params: LeafParams) -> Result<Self, LeafError> {
        params.validate()?;
        let (r_b, t_b) = body_rgb(&params.contents);
        let ggx = Ggx { alpha: params.roughness };
        let e: [f64; E_INTERVALS + 1] =
            std::array::from_fn(|k| ggx.albedo((k as f64 / E_INTERVALS as f64).max(1e-4), params.eta));
        // Ē = 2∫ E(μ)μ dμ of the piecewise-linear E, exactly: on [a, b] with E linear,
        // ∫ E μ dμ = (b − a)(E_a(2a + b) + E_b(a + 2b))/6.
        let h = 1.0 / E_INTERVALS as f64;
        let e_avg = 2.0
            * (0..E_INTERVALS)
                .map(|k| {
                    let (a, b) = (k as f64 * h, (k + 1) as f64 * h);
                    h * (e[k] * (2.0 * a + b) + e[k + 1] * (a + 2.0 * b)) / 6.0
                })
                .sum::<f64>();
        Ok(Self { params, r_b, t_b, e, body_norm: 1.0 / (PI * (1.0 - e_avg)) })
    }

    /// The parameters.
    #[must_use]
    pub fn params(&self) -> &LeafParams {
        &self.params
    }

    /// The body's reflectance and transmittance `(R_b, T_b)` (RGB).
    #[must_use]
    pub fn body(&self) -> (Rgb, Rgb) {
        (self.r_b, self.t_b)
    }

    /// The cuticle's directional albedo `E(μ)` (interpolated from the table).
    #[must_use]
    pub fn cuticle_albedo(&self, mu: f64) -> f64 {
        let x = mu.clamp(0.0, 1.0) * E_INTERVALS as f64;
        let k = (x as usize).min(E_INTERVALS - 1);
        let t = x - k as f64;
        self.e[k] * (1.0 - t) + self.e[k + 1] * t
    }

    /// The table of the cuticle's albedo: `E(k/32)` for k = 0..=32, which
    /// [`Leaf::cuticle_albedo`] interpolates linearly.
    #[must_use]
    pub fn cuticle_albedo_table(&self) -> &[f64] {
        &self.e
    }

    /// The body's normalization `1/(π(1 − Ē))` (module docs).
    #[must_use]
    pub fn body_normalization(&self) -> f64 {
        self.body_norm
    }

    /// The cuticle's `f_s` for directions on the upper side.
    fn cuticle(&self, wi: DVec3, wo: DVec3) -> f64 {
        let h = (wi + wo).normalize_or_zero();
        if h.z <= 0.0 || wi.z <= 0.0 || wo.z <= 0.0 {
            return 0.0;
        }
        let ggx = Ggx { alpha: self.params.roughness };
        fresnel::dielectric(wi.dot(h).max(0.0), self.params.eta) * ggx.d(h.z) * ggx.g2(wi.z, wo.z)
            / (4.0 * wi.z.max(MIN_COS) * wo.z.max(MIN_COS))
    }

    /// The cuticle sampler's density for `wi` given `wo`, both on the upper side.
    fn cuticle_pdf(&self, wi: DVec3, wo: DVec3) -> f64 {
        let h = (wi + wo).normalize_or_zero();
        if h.z <= 0.0 || wo.dot(h) <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        let ggx = Ggx { alpha: self.params.roughness };
        ggx.g1(wo.z) * ggx.d(h.z) / (4.0 * wo.z.max(MIN_COS))
    }

    /// Lobe probabilities (cuticle, body reflection, body transmission) for a viewer at `μ_o`.
    fn lobe_weights(&self, mu_o: f64) -> [f64; 3] {
        let e = self.cuticle_albedo(mu_o);
        let w = [e, (1.0 - e) * self.r_b.luminance(), (1.0 - e) * self.t_b.luminance()];
        let sum = w[0] + w[1] + w[2];
        if sum > 0.0 { w.map(|x| x / sum) } else { [0.0; 3] }
    }

    /// Both directions mirrored so that `wo` is on the upper side.
    fn upper(wi: DVec3, wo: DVec3) -> (DVec3, DVec3) {
        if wo.z < 0.0 { (DVec3::new(wi.x, wi.y, -wi.z), DVec3::new(wo.x, wo.y, -wo.z)) } else { (wi, wo) }
    }
}

/// The GGX distribution of slope scale α (Walter et al. 2007; Heitz 2014, 2018).
#[derive(Clone, Copy, Debug)]
struct Ggx {
    alpha: f64,
}

impl Ggx {
    /// `D(m)` for `cosθ_m`.
    fn d(self, cos_m: f64) -> f64 {
        let a2 = self.alpha * self.alpha;
        let t = cos_m * cos_m * (a2 - 1.0) + 1.0;
        a2 / (PI * t * t)
    }

    /// Smith's Λ for a direction with `cosθ = c`.
    fn lambda(self, c: f64) -> f64 {
        let c2 = c * c;
        let tan2 = (1.0 - c2).max(0.0) / c2.max(MIN_COS * MIN_COS);
        0.5 * ((1.0 + self.alpha * self.alpha * tan2).sqrt() - 1.0)
    }

    fn g1(self, c: f64) -> f64 {
        1.0 / (1.0 + self.lambda(c))
    }

    fn g2(self, ci: f64, co: f64) -> f64 {
        1.0 / (1.0 + self.lambda(ci) + self.lambda(co))
    }

    /// A visible normal for `v` (upper side) from two uniforms (Heitz 2018).
    fn sample_visible(self, v: DVec3, u1: f64, u2: f64) -> DVec3 {
        let a = self.alpha;
        let vh = DVec3::new(a * v.x, a * v.y, v.z).normalize();
        let len2 = vh.x * vh.x + vh.y * vh.y;
        let t1 = if len2 > 0.0 { DVec3::new(-vh.y, vh.x, 0.0) / len2.sqrt() } else { DVec3::X };
        let t2 = vh.cross(t1);
        let r = u1.sqrt();
        let (sp, cp) = (TAU * u2).sin_cos();
        let p1 = r * cp;
        let s = 0.5 * (1.0 + vh.z);
        let p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * r * sp;
        let n = t1 * p1 + t2 * p2 + vh * (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt();
        DVec3::new(a * n.x, a * n.y, n.z.max(1e-12)).normalize()
    }

    /// Directional albedo of the GGX reflection of index `eta` for light at `cosθ = mu`:
    /// `⟨F(v·m)·G₂/G₁⟩` over visible normals, on a midpoint lattice.
    fn albedo(self, mu: f64, eta: f64) -> f64 {
        let v = DVec3::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu);
        let n = E_LATTICE;
        let mut sum = 0.0;
        for i in 0..n {
            for j in 0..n {
                let m = self.sample_visible(v, (i as f64 + 0.5) / n as f64, (j as f64 + 0.5) / n as f64);
                let vm = v.dot(m);
                let o = m * (2.0 * vm) - v;
                if o.z > 0.0 && vm > 0.0 {
                    sum += fresnel::dielectric(vm, eta) * self.g2(mu, o.z) / self.g1(mu);
                }
            }
        }
        sum / (n * n) as f64
    }
}

/// Cosine-weighted direction on the upper hemisphere.
fn cosine_upper(u1: f64, u2: f64) -> DVec3 {
    let r = u1.sqrt();
    let (s, c) = (TAU * u2).sin_cos();
    DVec3::new(r * c, r * s, (1.0 - u1).max(0.0).sqrt())
}

impl SurfaceScattering for Leaf {
    fn properties(&self) -> SurfaceProperties {
        SurfaceProperties { reciprocal: true, energy_conserving: true, has_delta: false, transmits: true }
    }

    fn eval(&self, wi: DVec3, wo: DVec3) -> Rgb {
        if wi.z == 0.0 || wo.z == 0.0 {
            return Rgb::ZERO;
        }
        let (wi, wo) = Self::upper(wi, wo);
        let body = (1.0 - self.cuticle_albedo(wi.z.abs())) * (1.0 - self.cuticle_albedo(wo.z)) * self.body_norm;
        if wi.z > 0.0 { Rgb::splat(self.cuticle(wi, wo)) + self.r_b * body } else { self.t_b * body }
    }

    fn pdf(&self, wi: DVec3, wo: DVec3) -> f64 {
        if wi.z == 0.0 || wo.z == 0.0 {
            return 0.0;
        }
        let (wi, wo) = Self::upper(wi, wo);
        let w = self.lobe_weights(wo.z);
        let cosine = wi.z.abs() / PI;
        if wi.z > 0.0 { w[0] * self.cuticle_pdf(wi, wo) + w[1] * cosine } else { w[2] * cosine }
    }

    fn sample(&self, wo: DVec3, u: [f64; 4]) -> Option<Sample> {
        if wo.z == 0.0 {
            return None;
        }
        let flip = wo.z < 0.0;
        let wo_up = DVec3::new(wo.x, wo.y, wo.z.abs());
        let w = self.lobe_weights(wo_up.z);
        let lobe = if u[0] < w[0] {
            0
        } else if u[0] < w[0] + w[1] {
            1
        } else {
            2
        };
        let wi_up = match lobe {
            0 => {
                let m = Ggx { alpha: self.params.roughness }.sample_visible(wo_up, u[1], u[2]);
                m * (2.0 * wo_up.dot(m)) - wo_up
            }
            1 => cosine_upper(u[1], u[2]),
            _ => {
                let d = cosine_upper(u[1], u[2]);
                DVec3::new(d.x, d.y, -d.z)
            }
        };
        if wi_up.z == 0.0 || (lobe == 0 && wi_up.z < 0.0) {
            return None;
        }
        let wi = if flip { DVec3::new(wi_up.x, wi_up.y, -wi_up.z) } else { wi_up };
        let (f, pdf) = (self.eval(wi, wo), self.pdf(wi, wo));
        (pdf > 0.0 && pdf.is_finite()).then(|| Sample { wi, weight: f * (wi.z.abs() / pdf), pdf, delta: false, lobe })
    }

    fn lobes(&self) -> Vec<LobeInfo> {
        ["cuticle", "body reflection", "body transmission"].map(LobeInfo::smooth).to_vec()
    }

    fn texturable_keys(&self) -> &'static [&'static str] {
        &[]
    }

    fn set_parameter(&mut self, key: &str, _value: Rgb) -> Result<(), ModelError> {
        Err(crate::not_texturable(&Self::INFO, key))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A nearly smooth cuticle reflects what Fresnel says, away from grazing.
    #[test]
    fn a_smooth_cuticle_reflects_fresnel() {
        let ggx = Ggx { alpha: 0.01 };
        for mu in [1.0, 0.8, 0.5, 0.3] {
            let (e, f) = (ggx.albedo(mu, 1.47), fresnel::dielectric(mu, 1.47));
            assert!((e - f).abs() < 2e-3 * f.max(0.01), "μ {mu}: {e} vs {f}");
        }
    }

    /// The albedo table against a brute hemisphere quadrature of the GGX BRDF (independent of
    /// visible-normal sampling), for a rough cuticle.
    #[test]
    fn cuticle_albedo_matches_a_hemisphere_quadrature() {
        let leaf = Leaf::new(LeafParams { roughness: 0.5, ..LeafParams::default() }).unwrap();
        for mu in [0.9f64, 0.6, 0.3] {
            let wi = DVec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
            let (nt, np) = (400, 800);
            let mut sum = 0.0;
            for a in 0..nt {
                let t = (a as f64 + 0.5) * 0.5 * PI / nt as f64;
                for b in 0..np {
                    let p = (b as f64 + 0.5) * TAU / np as f64;
                    let wo = DVec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos());
                    sum += leaf.cuticle(wi, wo) * wo.z * t.sin() * (0.5 * PI / nt as f64) * (TAU / np as f64);
                }
            }
            let e = leaf.cuticle_albedo(mu);
            assert!((e - sum).abs() < 3e-3 * sum + 1e-4, "μ {mu}: table {e} vs quadrature {sum}");
        }
    }
}
