//! Huang, Hullin & Hanika 2022, *A microfacet-based hair scattering model* (Computer Graphics
//! Forum 41(4), EGSR 2022), the hair model Blender's Cycles renders by default: a dielectric
//! fiber of elliptical cross-section whose surface is a GGX microfacet distribution about the
//! cuticle-tilted normal (the "mesonormal"). Built from the hair core ([`crate::hair`]: the
//! elliptical boundary of [`crate::hair::ellipse`], absorption, d'Eon's longitudinal function)
//! and the GGX of `fiberlab_math::microfacet`. The mathematics in our words is in
//! `docs/theory/hair.md`, "Microfacet fibers (Huang 2022)"; the differences from the paper, the
//! authors' code and Cycles in `docs/theory/peer-discrepancies.md`, "Huang 2022".
//!
//! The parameters are in the registry entry (`PARAMS`; `fiberlab models --model huang-2022`).
//!
//! # The model at one hit
//! fiberlab's `huang-2022` is near-field, like `chiang`: `eval(ω_i, ω_o, h)` is the light
//! scattered toward the camera direction `ω_o` from the point of the fiber seen at offset
//! `h ∈ [−1, 1]` across its projected width ([`crate::hair::ellipse::Ellipse::entry`]), so that
//! its average over h is the paper's far-field integral across the width. The camera ray
//! meets the boundary at the point `p₁` with outward normal `n₁` (in the normal plane) and
//! mesonormal `m₁ = cosα·n₁ − sinα·u` (α > 0 leans toward the root), and
//! `f_s(ω_i, ω_o; h) = g_h(ω_o, ω_i)/cosθ_i`, where `g_h` is the density over the light
//! direction of the paths the camera ray starts (a "backward form" as in
//! [`crate::hair::backward_form`]: radiance toward the camera is `∫ f_s L_i cosθ_i dω_i`):
//! * **R**: `g_R = F(ω_o·m)·D(m·m₁)·G₂(ω_o, ω_i)/(4 ω_o·m₁)`, m the half-vector of ω_o and ω_i
//!   — Walter et al. 2007's microfacet BRDF times `ω_i·m₁`, both directions above `n₁` and `m₁`.
//! * **TT**: the camera ray refracts through a microfacet normal drawn from those visible from
//!   ω_o (Heitz 2018) with weight `(1 − F)·G₂/G₁`, crosses the ellipse to `p₂` (absorption
//!   `exp(−σ_a ℓ)` over the 3D length ℓ), and leaves through the rough interface at `p₂`,
//!   whose density over ω_i is closed: `(1 − F(v·m))·D(m)·G₂·(v·m)|ω_i·m|/((v·n)·|ηv + ω_i|²)`
//!   with `v` the reversed internal direction, `n` the inner mesonormal and
//!   `m = (ηv + ω_i)/|ηv + ω_i|` the refraction half-vector (Walter 2007's BTDF with its
//!   Jacobian). The entry microfacet is integrated with a 3 × 3 lattice in the unit square of
//!   Heitz's sampler, shifted by a function of h (a Cranley–Patterson rotation): each
//!   `eval(…, h)` is deterministic, and averaging over h integrates the entry microfacets
//!   exactly (the paper and Cycles draw one random microfacet per node instead).
//! * **TRT**: the same, with one internal rough reflection at `p₂` (weight `F·G₂/G₁`, one
//!   internal microfacet per entry path, shifted along the R2 sequence: 9 paths), a second
//!   chord, and the closed-form exit at `p₃`.
//! * **TRRT+**: the rest, as a geometric series in the manner of Chiang 2016 and Cycles: of each
//!   TRT path's power at `p₃`, the rough interface reflects `E_R(μ₃)`
//!   ([`crate::hair::rough_interface`], μ₃ its incidence cosine); after that every chord (the
//!   cross-section's mean chord `π·area/perimeter` over the path's inclination, transmittance
//!   A) meets the interface at the incidences of all offsets, which pass on `A·Ē_R` and let
//!   out `A·Ē_T` (`InterfaceAlbedo::across_chords`): `E_R·A·Ē_T/(1 − A·Ē_R)` in all, spread as
//!   d'Eon's `M(θ_i; −θ_o)` with `v = 4α²` times `1/(2π)`. This is the model's approximation
//!   (`docs/book/src/models/huang-2022.md` gives its error against the explicit fiber).
//! * Lobe multipliers (Blender's Reflection, Transmission, Secondary Reflection) scale R, TT,
//!   TRT; values other than 1 break the energy balance (by design, as in Blender).
//! * `orientation = average`: the hit at offset h belongs to a fiber whose major axis is at
//!   `ψ(h)` (equidistributed in [0, π) as h varies), weighted by its projected width
//!   `W_ψ(ω_o)/W̄`, so that the h-average is the average over orientations of a fiber assembly.
//!
//! # Sampling and pdf
//! A mixture with an exact pdf: lobe R by visible-normal reflection (density
//! `G₁(ω_o)·D(m)/(4 ω_o·m₁)`); TT and TRT by choosing one of their paths (probability ∝ its
//! expected transmitted power) and a GGX lobe `D_α(ω·s)(ω·s)` about that path's smooth exit
//! direction `s`; TRRT+ by `M(θ_i; −θ_o)/(2π)`, mixed with the uniform sphere (a quarter), which
//! keeps the pdf positive wherever `f_s` is. Lobe probabilities ∝ the lobes' expected powers,
//! with at least 2% for the TRRT+/uniform component. `pdf` is the mixture's density, exactly,
//! and the sample weight is `f_s cosθ_i/pdf` (not constant: the proposal approximates TT and
//! TRT). Where the tilted scale surface faces away from the camera (a steep tilt seen at
//! grazing angles or near the silhouette) nothing is scattered (Cycles and the authors' code
//! return nothing there too); the pdf is then uniform and the samples carry weight 0.
//!
//! # Claims
//! Neither reciprocity nor a light-side energy bound is claimed (backward form; elliptical
//! fibers obey only the generalized reciprocity of `docs/theory/radiometry.md`). With the
//! multipliers at most 1, a fixed orientation and any σ_a, the camera-side integral
//! `∫ f_s cosθ_i dω_i` is at most 1 at every h (tested): every path's weight is a product of
//! Fresnel, masking and transmittance factors, and the residual is bounded by what reaches it.

use crate::hair::absorption::Absorption;
use crate::hair::ellipse::Ellipse;
use crate::hair::longitudinal::Longitudinal;
use crate::hair::parameters::{self, ALPHA_RANGE, ETA_RANGE};
use crate::hair::rough_interface::InterfaceAlbedo;
use crate::params::{ParamKind, ParamSet, ParamSpec, Range, parameter_error};
use crate::{
    Field, LobeInfo, Lobes, MIN_COS, ModelError, ModelInfo, Properties, Registered, Sample, ScatteringFunction,
};
use fiberlab_math::frame::{cos_theta, direction_from_sin_cos, phi, sin_theta};
use fiberlab_math::microfacet::{Ggx, reflect, refract};
use fiberlab_math::{DVec2, DVec3, FiberFrame, Rgb, fresnel};
use std::f64::consts::{PI, TAU};

/// Valid GGX roughness α.
pub const ROUGHNESS_RANGE: Range = Range::closed(0.01, 1.0);
/// Valid aspect ratio (minor/major).
pub const ASPECT_RANGE: Range = Range::closed(0.1, 1.0);
/// Valid lobe multipliers.
pub const MULTIPLIER_RANGE: Range = Range::closed(0.0, 10.0);

/// Side of the lattice of entry microfacets (TT and TRT paths per hit: its square).
pub const ENTRY_SIDE: usize = 3;
/// Side of the lattice of internal-reflection microfacets per entry path (TRT).
pub const INTERNAL_SIDE: usize = 1;
const TT_PATHS: usize = ENTRY_SIDE * ENTRY_SIDE;
const TRT_PATHS: usize = TT_PATHS * INTERNAL_SIDE * INTERNAL_SIDE;
/// Panels of the width average ([`ScatteringFunction::eval_far`], 4 nodes each).
const FAR_PANELS: usize = 256;
/// Least probability of the TRRT+/uniform sampling component.
pub const RESIDUAL_FLOOR: f64 = 0.02;
/// Share of the uniform sphere in the TRRT+ sampling component.
pub const UNIFORM_SHARE: f64 = 0.25;
/// Multipliers of h that make the lattice shifts (and the orientation of `average`)
/// equidistributed as h varies: large and mutually incommensurate (the shifts are
/// `((h + 2)·rate).fract()`: the entry lattice's two, the internal lattice's two, the
/// orientation's).
pub const SHIFT_RATES: [f64; 5] = [7_919.137_5, 6_451.371_3, 5_003.732_9, 3_571.939_1, 4_409.571_7];
/// The additive recurrence of the R2 low-discrepancy sequence in two dimensions, `(1/g, 1/g²)`
/// with g the plastic number (Roberts 2018).
pub const R2: [f64; 2] = [0.754_877_666_246_693, 0.569_840_290_998_053];

const ROUGHNESS: ParamSpec = ParamSpec {
    key: "roughness",
    kind: ParamKind::Number(ROUGHNESS_RANGE),
    unit: "",
    default: "0.3",
    doc: "GGX roughness α of the fiber surface (Blender's Roughness)",
};
const ASPECT: ParamSpec = ParamSpec {
    key: "aspect",
    kind: ParamKind::Number(ASPECT_RANGE),
    unit: "",
    default: "0.85",
    doc: "axis ratio minor/major of the elliptical cross-section (Blender's Aspect Ratio)",
};
const ORIENTATION: ParamSpec = ParamSpec {
    key: "orientation",
    kind: ParamKind::Text,
    unit: "degrees or `average`",
    default: "0",
    doc: "major axis from the frame's v toward w; `average`: a random orientation per hit",
};
const REFLECTION: ParamSpec = ParamSpec {
    key: "reflection",
    kind: ParamKind::Number(MULTIPLIER_RANGE),
    unit: "",
    default: "1",
    doc: "multiplier of R (≠ 1 breaks energy conservation)",
};
const TRANSMISSION: ParamSpec = ParamSpec {
    key: "transmission",
    kind: ParamKind::Number(MULTIPLIER_RANGE),
    unit: "",
    default: "1",
    doc: "multiplier of TT (≠ 1 breaks energy conservation)",
};
const SECONDARY_REFLECTION: ParamSpec = ParamSpec {
    key: "secondary_reflection",
    kind: ParamKind::Number(MULTIPLIER_RANGE),
    unit: "",
    default: "1",
    doc: "multiplier of TRT (≠ 1 breaks energy conservation)",
};

const PARAMS: [ParamSpec; 12] = [
    parameters::ETA,
    ROUGHNESS,
    ASPECT,
    ORIENTATION,
    parameters::ALPHA,
    parameters::SIGMA_A,
    parameters::EUMELANIN,
    parameters::PHEOMELANIN,
    parameters::COLOR,
    REFLECTION,
    TRANSMISSION,
    SECONDARY_REFLECTION,
];

/// Registry entry: `huang-2022`.
impl Registered for Huang {
    const INFO: ModelInfo = ModelInfo {
        name: "huang-2022",
        summary: "Huang 2022 microfacet hair (Cycles' default): GGX surface, elliptical section, near-field",
        citation: "Huang, Hullin & Hanika 2022; Walter et al. 2007; Heitz 2018",
        params: &PARAMS,
        data: None,
    };

    fn from_param_set(p: &ParamSet) -> Result<Self, ModelError> {
        Ok(Huang::new(HuangParams::from_param_set(p)?)?)
    }
}

/// How the elliptical cross-section is oriented about the axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Orientation {
    /// Major axis at this angle (radians) from the frame's `v` toward `w`.
    Fixed(f64),
    /// A fiber assembly of random orientations (a different one per offset h).
    Average,
}

/// Parameters of [`Huang`] (angles in **radians**; the registry takes degrees).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HuangParams {
    /// Index of refraction η ∈ (1, 4].
    pub eta: f64,
    /// GGX roughness α ∈ [0.01, 1].
    pub roughness: f64,
    /// Axis ratio minor/major ∈ [0.1, 1].
    pub aspect: f64,
    /// Orientation of the major axis.
    pub orientation: Orientation,
    /// Cuticle tilt (radians, [−20°, 20°]); > 0 leans the mesonormal toward the root.
    pub alpha: f64,
    /// Where σ_a comes from (a colour is inverted with β_n = `roughness`, as Cycles does).
    pub absorption: Absorption,
    /// Multiplier of R.
    pub reflection: f64,
    /// Multiplier of TT.
    pub transmission: f64,
    /// Multiplier of TRT.
    pub secondary_reflection: f64,
}

impl Default for HuangParams {
    /// Blender's defaults (η 1.55, roughness 0.3, aspect 0.85, tilt 2°, multipliers 1) with
    /// fiberlab's default absorption (eumelanin 1.3) and the major axis along `v`.
    fn default() -> Self {
        Self {
            eta: 1.55,
            roughness: 0.3,
            aspect: 0.85,
            orientation: Orientation::Fixed(0.0),
            alpha: 2f64.to_radians(),
            absorption: Absorption::default(),
            reflection: 1.0,
            transmission: 1.0,
            secondary_reflection: 1.0,
        }
    }
}

impl HuangParams {
    /// Blond: the defaults with eumelanin 0.3.
    #[must_use]
    pub fn blond() -> Self {
        Self { absorption: Absorption::BLOND, ..Self::default() }
    }
    /// Brown: the defaults (eumelanin 1.3).
    #[must_use]
    pub fn brown() -> Self {
        Self::default()
    }
    /// Black: the defaults with eumelanin 8.
    #[must_use]
    pub fn black() -> Self {
        Self { absorption: Absorption::BLACK, ..Self::default() }
    }

    /// Reads the registry parameters (`alpha` and a numeric `orientation` in degrees).
    pub fn from_param_set(p: &ParamSet) -> Result<Self, ModelError> {
        let text = p.text("orientation").unwrap_or("0");
        let orientation = if text.trim().eq_ignore_ascii_case("average") {
            Orientation::Average
        } else {
            let degrees = text.trim().parse::<f64>().map_err(|_| ModelError::BadValue {
                key: "orientation".into(),
                value: text.into(),
                expected: "degrees or `average`".into(),
            })?;
            Orientation::Fixed(degrees.to_radians())
        };
        Ok(Self {
            eta: p.number("eta")?,
            roughness: p.number("roughness")?,
            aspect: p.number("aspect")?,
            orientation,
            alpha: p.degrees("alpha")?,
            absorption: Absorption::from_param_set(p)?,
            reflection: p.number("reflection")?,
            transmission: p.number("transmission")?,
            secondary_reflection: p.number("secondary_reflection")?,
        })
    }

    /// Checks every value against its range (the error names the parameter; angles in
    /// degrees).
    pub fn validate(&self) -> Result<(), crate::params::ParameterError> {
        ETA_RANGE.check("eta", self.eta)?;
        ROUGHNESS_RANGE.check("roughness", self.roughness)?;
        ASPECT_RANGE.check("aspect", self.aspect)?;
        if let Orientation::Fixed(o) = self.orientation {
            Range::closed(f64::NEG_INFINITY, f64::INFINITY).check_degrees("orientation", o)?;
        }
        ALPHA_RANGE.check_degrees("alpha", self.alpha)?;
        self.absorption.validate()?;
        MULTIPLIER_RANGE.check("reflection", self.reflection)?;
        MULTIPLIER_RANGE.check("transmission", self.transmission)?;
        MULTIPLIER_RANGE.check("secondary_reflection", self.secondary_reflection).map(|_| ())
    }
}

parameter_error! {
    /// Why a [`Huang`] fiber cannot be built: a parameter outside its range (named, with the
    /// range; angles in degrees).
    HuangError
}

/// The Huang 2022 microfacet hair fiber.
#[derive(Clone, Debug)]
pub struct Huang {
    /// Identity for the per-thread vertex cache (shared by clones, which are equal).
    id: u64,
    params: HuangParams,
    /// σ_a per unit major semi-axis.
    sigma_a: Rgb,
    ggx: Ggx,
    /// `(sin α, cos α)` of the cuticle tilt.
    tilt: (f64, f64),
    /// d'Eon's longitudinal function of TRRT+ (`v = 4α²`).
    residual: Longitudinal,
    /// Reflected and transmitted fractions of the rough interface met from inside (boxed: a
    /// table of 66 numbers, which would make every [`crate::Model`] as large).
    inside: Box<InterfaceAlbedo>,
    /// Mean chord of the cross-section, `π·area/perimeter` (Cauchy), for the orders beyond TRT.
    mean_chord: f64,
    /// Mean projected half-width over orientations (`orientation = average`), `(2/π)·E(1 − b²)`.
    mean_half_width: f64,
}

impl Huang {
    /// A Huang fiber; the error names the parameter out of range.
    pub fn new(params: HuangParams) -> Result<Self, HuangError> {
        params.validate()?;
        let inside = Box::new(InterfaceAlbedo::new(&Ggx::new(params.roughness), 1.0 / params.eta));
        // Ramanujan's perimeter of the ellipse of semi-axes 1 and b.
        let b = params.aspect;
        let perimeter = PI * (3.0 * (1.0 + b) - ((3.0 + b) * (1.0 + 3.0 * b)).sqrt());
        let mean_chord = PI * PI * b / perimeter;
        let n = 4096;
        let mean_half_width = (0..n)
            .map(|k| {
                let psi = PI * (k as f64 + 0.5) / n as f64;
                Ellipse::new(b, psi).half_width(DVec2::X)
            })
            .sum::<f64>()
            / n as f64;
        Ok(Self {
            id: NEXT_FIBER_ID.fetch_add(1, std::sync::atomic::Ordering::Relaxed),
            params,
            sigma_a: params.absorption.sigma_a(params.roughness),
            ggx: Ggx::new(params.roughness),
            tilt: params.alpha.sin_cos(),
            residual: Longitudinal::new(4.0 * params.roughness * params.roughness),
            inside,
            mean_chord,
            mean_half_width,
        })
    }

    /// The parameters (radians).
    #[must_use]
    pub fn params(&self) -> &HuangParams {
        &self.params
    }

    /// σ_a per unit major semi-axis (resolved from the absorption).
    #[must_use]
    pub fn sigma_a(&self) -> Rgb {
        self.sigma_a
    }

    /// The albedos of the rough interface met from inside (TRRT+ and the sampling shares).
    #[must_use]
    pub fn inside_albedo(&self) -> &InterfaceAlbedo {
        &self.inside
    }

    /// Mean chord `π·area/perimeter` of the cross-section (TRRT+).
    #[must_use]
    pub fn mean_chord(&self) -> f64 {
        self.mean_chord
    }

    /// Mean projected half-width over orientations (`orientation = average`).
    #[must_use]
    pub fn mean_half_width(&self) -> f64 {
        self.mean_half_width
    }

    /// The far-field `f_s(ω_i, ω_o)`: `eval` averaged over `n_h` midpoint offsets (each with
    /// its own lattice shift; the paper's integral across the width as n_h grows).
    #[must_use]
    pub fn far_field(&self, wi: DVec3, wo: DVec3, n_h: usize) -> Rgb {
        let n_h = n_h.max(1);
        (0..n_h).map(|k| self.eval(wi, wo, -1.0 + (k as f64 + 0.5) * 2.0 / n_h as f64)).fold(Rgb::ZERO, |a, b| a + b)
            / n_h as f64
    }

    /// The mesonormal at a boundary point of outward normal `n` (normal-plane, 2D): the normal
    /// tilted toward the root (−u) by α.
    #[inline]
    fn mesonormal(&self, n: DVec2) -> (DVec3, DVec3) {
        let (s, c) = self.tilt;
        let macro_normal = DVec3::new(0.0, n.x, n.y);
        (macro_normal, DVec3::new(-s, c * n.x, c * n.y))
    }

    /// Everything of the fiber at one hit that depends on `ω_o` and `h` only: the entry point,
    /// the TT and TRT paths (with their weights and exit frames) and the TRRT+ power. A
    /// renderer can prepare it once per vertex and share it between its light samples and its
    /// bounce; `eval`, `pdf` and `sample` go through the same preparation (kept per thread for
    /// the last (ω_o, h), see [`Huang::with_vertex`]), so both give the same bits.
    #[must_use]
    pub fn at_vertex(&self, wo: DVec3, h: f64) -> HuangAtVertex<'_> {
        let mut vertex = Vertex::default();
        self.prepare(wo, h, &mut vertex);
        HuangAtVertex { fiber: self, vertex }
    }

    /// Runs `f` on the prepared vertex of (`wo`, `h`): the calling thread keeps the last
    /// preparation, keyed by this fiber's identity and the bits of `wo` and `h`, so the many
    /// evaluations and samples of one vertex (a renderer's light samples and bounce, the
    /// harness's quadratures at a fixed viewer) prepare it once. No allocation after a
    /// thread's first call.
    fn with_vertex<R>(&self, wo: DVec3, h: f64, f: impl FnOnce(&Vertex) -> R) -> R {
        let key = VertexKey { fiber: self.id, wo: [wo.x.to_bits(), wo.y.to_bits(), wo.z.to_bits()], h: h.to_bits() };
        LAST_VERTEX.with(|cell| {
            let mut slot = cell.borrow_mut();
            let (cached, vertex) = &mut *slot;
            if *cached != Some(key) {
                self.prepare(wo, h, vertex);
                *cached = Some(key);
            }
            f(vertex)
        })
    }

    /// Fills `v` with the vertex of (`wo`, `h`).
    fn prepare(&self, wo: DVec3, h: f64, v: &mut Vertex) {
        // On the fiber axis every offset's scale surface is seen edge-on: the vertex is that of
        // the nearest direction with cosθ_o = MIN_COS (at the same φ_o, as every model reads
        // the axis), so that f_s and the pdf approach the axis continuously.
        let wo = if cos_theta(wo) < MIN_COS {
            direction_from_sin_cos((1.0 - MIN_COS * MIN_COS).sqrt().copysign(sin_theta(wo)), MIN_COS, phi(wo))
        } else {
            wo
        };
        v.reset(wo);
        let h = if h.is_finite() { h.clamp(-1.0, 1.0) } else { 0.0 };
        let shift = |k: usize| ((h + 2.0) * SHIFT_RATES[k]).fract();
        let (ellipse, scale) = match self.params.orientation {
            Orientation::Fixed(psi) => (Ellipse::new(self.params.aspect, psi), 1.0),
            Orientation::Average => {
                let e = Ellipse::new(self.params.aspect, PI * shift(4));
                let t = DVec2::new(v.phi_o.cos(), v.phi_o.sin());
                (e, e.half_width(t) / self.mean_half_width)
            }
        };
        v.scale = scale;
        let t = DVec2::new(v.phi_o.cos(), v.phi_o.sin());
        let entry = ellipse.entry(t, h);
        let (n1, m1) = self.mesonormal(entry.n);
        let cos_o = wo.dot(m1);
        if cos_o <= 0.0 || wo.dot(n1) <= 0.0 {
            return; // the scale surface at this offset faces away from the camera
        }
        v.visible = true;
        (v.n_macro, v.n_meso, v.cos_o) = (n1, m1, cos_o);
        let g = &self.ggx;
        let lambda_o = g.lambda(cos_o);
        v.g1_o = 1.0 / (1.0 + lambda_o);
        let eta = self.params.eta;
        let inv_eta = 1.0 / eta;
        let sigma = self.sigma_a;
        let (s0, s1, s2, s3) = (shift(0), shift(1), shift(2), shift(3));
        let entry_weight = 1.0 / TT_PATHS as f64;
        let internal_weight = 1.0 / (INTERNAL_SIDE * INTERNAL_SIDE) as f64;
        for i in 0..ENTRY_SIDE {
            for j in 0..ENTRY_SIDE {
                let u1 = (i as f64 + s0) / ENTRY_SIDE as f64;
                let u2 = (j as f64 + s1) / ENTRY_SIDE as f64;
                let mh = g.sample_visible(m1, wo, u1, u2);
                let c1 = wo.dot(mh);
                if c1 <= 0.0 {
                    continue;
                }
                let Some(d1) = refract(-wo, mh, inv_eta) else { continue };
                let c1_in = d1.dot(m1);
                if c1_in >= 0.0 || d1.dot(n1) >= 0.0 {
                    continue; // refracted back out of the microsurface
                }
                let w1 = (1.0 - fresnel::dielectric(c1, eta)) * (1.0 + lambda_o) / (1.0 + lambda_o + g.lambda(c1_in))
                    * entry_weight;
                let Some((len1, p2)) = ellipse.exit(entry.p, DVec2::new(d1.y, d1.z)) else { continue };
                let a1 = (sigma * -len1).exp();
                let (n2, m2) = self.mesonormal(p2.n);
                let cos_v2 = d1.dot(m2);
                if cos_v2 <= 0.0 || d1.dot(n2) <= 0.0 {
                    continue;
                }
                let tt = ExitPath::new(self, -d1, m2, n2, a1 * w1);
                v.tt[v.n_tt] = tt;
                v.n_tt += 1;
                // TRT: one rough internal reflection at p₂.
                let lambda_v2 = tt.lambda_v;
                for k in 0..INTERNAL_SIDE {
                    for l in 0..INTERNAL_SIDE {
                        // Each entry path draws its own internal microfacets: the shift moves
                        // along the R2 sequence (Roberts 2018) with the path's index.
                        let e = (i * ENTRY_SIDE + j) as f64 + 0.5;
                        let u3 = (k as f64 + (s2 + e * R2[0]).fract()) / INTERNAL_SIDE as f64;
                        let u4 = (l as f64 + (s3 + e * R2[1]).fract()) / INTERNAL_SIDE as f64;
                        let mr = g.sample_visible(-m2, -d1, u3, u4);
                        let c2 = -d1.dot(mr);
                        if c2 <= 0.0 {
                            continue;
                        }
                        let d2 = reflect(d1, mr);
                        let c2_out = d2.dot(m2);
                        if c2_out >= 0.0 || d2.dot(n2) >= 0.0 {
                            continue; // reflected out of the microsurface
                        }
                        let w2 = fresnel::dielectric(c2, inv_eta) * (1.0 + lambda_v2)
                            / (1.0 + lambda_v2 + g.lambda(c2_out))
                            * internal_weight;
                        let Some((len2, p3)) = ellipse.exit(p2.p, DVec2::new(d2.y, d2.z)) else { continue };
                        let a2 = (sigma * -len2).exp();
                        let (n3, m3) = self.mesonormal(p3.n);
                        if d2.dot(m3) <= 0.0 || d2.dot(n3) <= 0.0 {
                            continue;
                        }
                        let trt = ExitPath::new(self, -d2, m3, n3, tt.weight * a2 * w2);
                        // TRRT+: what the rough interface at p₃ reflects, then at every further
                        // chord (transmittance A of the last one) a fraction E_T leaves and
                        // E_R goes on: E_R·A·E_T/(1 − A·E_R) in all.
                        let e_r = self.inside.reflected(trt.cos_v);
                        let cos_d2 = (d2.y * d2.y + d2.z * d2.z).sqrt();
                        let (next_r, next_t) = self.inside.across_chords(cos_d2);
                        let a = (sigma * (-self.mean_chord / cos_d2.max(MIN_COS))).exp();
                        let escapes = (a * next_t) / (Rgb::ONE - a * next_r).map(|x| x.max(1e-12));
                        v.residual += trt.weight * escapes * e_r;
                        v.trt[v.n_trt] = trt;
                        v.n_trt += 1;
                    }
                }
            }
        }
        v.prepare_sampling(&self.params);
    }
}

/// One internal path arriving at its exit point: the closed-form rough exit there.
#[derive(Clone, Copy, Debug, Default)]
struct ExitPath {
    /// Reversed travel direction (pointing back into the fiber), unit.
    v: DVec3,
    /// Inner mesonormal (−outward mesonormal).
    n_in: DVec3,
    /// Outward macro normal (in the normal plane).
    n_out: DVec3,
    /// `v·n_in > 0`.
    cos_v: f64,
    /// Smith Λ of `v`.
    lambda_v: f64,
    /// Throughput arriving (Fresnel, masking, absorption, lattice weight).
    weight: Rgb,
    /// Axis of the path's sampling lobe: the smooth exit direction (refraction through the
    /// mesonormal), or where none exists the grazing exit lifted by α.
    axis: DVec3,
    /// Luminance of the power the rough interface transmits (`weight·E_T(cos θ_v)`): the
    /// path's share of its lobe's sampling.
    share: f64,
}

impl ExitPath {
    fn new(fiber: &Huang, v: DVec3, meso_out: DVec3, n_out: DVec3, weight: Rgb) -> Self {
        let n_in = -meso_out;
        let cos_v = v.dot(n_in);
        let axis = refract(-v, n_in, fiber.params.eta).unwrap_or_else(|| {
            let along = -v + n_in * cos_v;
            (along.normalize_or_zero() + meso_out * fiber.params.roughness).normalize_or(meso_out)
        });
        let share = weight.luminance() * fiber.inside.transmitted(cos_v);
        Self { v, n_in, n_out, cos_v, lambda_v: fiber.ggx.lambda(cos_v), weight, axis, share }
    }

    /// Density over `ω_i` (per sr) of leaving through the rough interface, times nothing
    /// else: `(1 − F(v·m))·D(m)·G₂·(v·m)|ω_i·m|/((v·n)·|ηv + ω_i|²)`.
    #[inline]
    fn exit_density(&self, g: &Ggx, eta: f64, wi: DVec3) -> f64 {
        let cos_out = -wi.dot(self.n_in);
        if cos_out <= 0.0 || wi.dot(self.n_out) <= 0.0 {
            return 0.0;
        }
        let hv = self.v * eta + wi;
        let len = hv.length();
        if len <= 0.0 {
            return 0.0;
        }
        let m = hv / len;
        let (vm, im, cos_m) = (self.v.dot(m), wi.dot(m), m.dot(self.n_in));
        if vm <= 0.0 || im >= 0.0 || cos_m <= 0.0 {
            return 0.0;
        }
        let f = fresnel::dielectric(vm, 1.0 / eta);
        let g2 = 1.0 / (1.0 + self.lambda_v + g.lambda(cos_out));
        (1.0 - f) * g.d(cos_m) * g2 * vm * (-im) / (self.cos_v * len * len)
    }
}

/// What a [`Huang`] fiber needs at one hit (fixed `ω_o`, `h`): filled by the fiber's
/// preparation, then read by its evaluation and sampling.
#[derive(Clone, Debug)]
struct Vertex {
    wo: DVec3,
    phi_o: f64,
    sin_o: f64,
    cos_theta_o: f64,
    /// False when the camera cannot see the scale surface at this offset (everything is 0).
    visible: bool,
    n_macro: DVec3,
    n_meso: DVec3,
    /// `ω_o·m₁`.
    cos_o: f64,
    /// `G₁(ω_o)`.
    g1_o: f64,
    tt: [ExitPath; TT_PATHS],
    n_tt: usize,
    trt: [ExitPath; TRT_PATHS],
    n_trt: usize,
    /// Power of TRRT+.
    residual: Rgb,
    /// Orientation-average weight `W_ψ(ω_o)/W̄` (1 for a fixed orientation).
    scale: f64,
    /// Probabilities of the sampling components R, TT, TRT, TRRT+/uniform.
    lobe_prob: [f64; 4],
    /// Sums of the TT and TRT paths' shares.
    share_sum: [f64; 2],
}

impl Default for Vertex {
    fn default() -> Self {
        Self {
            wo: DVec3::ZERO,
            phi_o: 0.0,
            sin_o: 0.0,
            cos_theta_o: 1.0,
            visible: false,
            n_macro: DVec3::ZERO,
            n_meso: DVec3::ZERO,
            cos_o: 0.0,
            g1_o: 0.0,
            tt: [ExitPath::default(); TT_PATHS],
            n_tt: 0,
            trt: [ExitPath::default(); TRT_PATHS],
            n_trt: 0,
            residual: Rgb::ZERO,
            scale: 1.0,
            lobe_prob: [0.0; 4],
            share_sum: [0.0; 2],
        }
    }
}

impl Vertex {
    /// Back to an invisible vertex for the viewer `wo` (the path arrays are overwritten as they
    /// are filled; only their counts are reset).
    fn reset(&mut self, wo: DVec3) {
        (self.wo, self.phi_o, self.sin_o, self.cos_theta_o) = (wo, phi(wo), sin_theta(wo), cos_theta(wo));
        self.visible = false;
        (self.n_tt, self.n_trt) = (0, 0);
        self.residual = Rgb::ZERO;
        self.scale = 1.0;
        self.lobe_prob = [0.0; 4];
        self.share_sum = [0.0; 2];
    }

    fn prepare_sampling(&mut self, p: &HuangParams) {
        let f_r = fresnel::dielectric(self.cos_o, p.eta);
        self.share_sum =
            [self.tt[..self.n_tt].iter().map(|x| x.share).sum(), self.trt[..self.n_trt].iter().map(|x| x.share).sum()];
        let e = [
            p.reflection * f_r,
            p.transmission * self.share_sum[0],
            p.secondary_reflection * self.share_sum[1],
            self.residual.luminance(),
        ];
        let total: f64 = e.iter().sum();
        self.lobe_prob = if total > 0.0 {
            let mut q = e.map(|x| (1.0 - RESIDUAL_FLOOR) * x / total);
            q[3] += RESIDUAL_FLOOR;
            q
        } else {
            [0.0, 0.0, 0.0, 1.0]
        };
    }

    /// `g_h` lobe by lobe (R, TT, TRT, TRRT+), multipliers and orientation weight included.
    fn integrand_lobes(&self, f: &Huang, wi: DVec3) -> [Rgb; 4] {
        if !self.visible {
            return [Rgb::ZERO; 4];
        }
        let (g, eta) = (&f.ggx, f.params.eta);
        let mut out = [Rgb::ZERO; 4];
        // R
        let cos_i = wi.dot(self.n_meso);
        if cos_i > 0.0 && wi.dot(self.n_macro) > 0.0 {
            let hv = self.wo + wi;
            let len = hv.length();
            if len > 0.0 {
                let m = hv / len;
                let fr = fresnel::dielectric(self.wo.dot(m), eta);
                let g2 = g.g2(self.cos_o, cos_i);
                let r = fr * g.d(m.dot(self.n_meso)) * g2 / (4.0 * self.cos_o);
                out[0] = Rgb::splat(r * f.params.reflection);
            }
        }
        // TT, TRT
        for path in &self.tt[..self.n_tt] {
            out[1] += path.weight * path.exit_density(g, eta, wi);
        }
        for path in &self.trt[..self.n_trt] {
            out[2] += path.weight * path.exit_density(g, eta, wi);
        }
        out[1] *= f.params.transmission;
        out[2] *= f.params.secondary_reflection;
        // TRRT+
        let (si, ci) = (sin_theta(wi), cos_theta(wi));
        out[3] = self.residual * (f.residual.eval(si, ci, self.sin_o, self.cos_theta_o) / TAU);
        out.map(|x| x * self.scale)
    }

    /// The sampling density (per sr) of `wi`.
    fn density(&self, f: &Huang, wi: DVec3) -> f64 {
        if !self.visible {
            return 1.0 / (4.0 * PI); // nothing scatters: uniform samples of weight 0
        }
        let q = &self.lobe_prob;
        let mut pdf = 0.0;
        if q[0] > 0.0 {
            let hv = self.wo + wi;
            let len = hv.length();
            if len > 0.0 {
                let m = hv / len;
                pdf += q[0] * self.g1_o * f.ggx.d(m.dot(self.n_meso)) / (4.0 * self.cos_o);
            }
        }
        for (lobe, paths) in [(1, &self.tt[..self.n_tt]), (2, &self.trt[..self.n_trt])] {
            let sum = self.share_sum[lobe - 1];
            if q[lobe] > 0.0 && sum > 0.0 {
                let mut p = 0.0;
                for path in paths.iter().filter(|x| x.share > 0.0) {
                    let c = wi.dot(path.axis);
                    p += path.share * f.ggx.d(c) * c.max(0.0);
                }
                pdf += q[lobe] * p / sum;
            }
        }
        let (si, ci) = (sin_theta(wi), cos_theta(wi));
        let m = f.residual.eval(si, ci, self.sin_o, self.cos_theta_o) / TAU;
        pdf += q[3] * ((1.0 - UNIFORM_SHARE) * m + UNIFORM_SHARE / (4.0 * PI));
        pdf
    }

    /// `f_s(ω_i, ω_o; h)` and the density with which the sampler draws `ω_i`.
    fn eval_and_pdf(&self, f: &Huang, wi: DVec3) -> (Rgb, f64) {
        let lobes = self.integrand_lobes(f, wi);
        let g = lobes[0] + lobes[1] + lobes[2] + lobes[3];
        (g / cos_theta(wi).max(MIN_COS), self.density(f, wi))
    }

    /// Draws `ω_i` from four uniforms, as [`ScatteringFunction::sample`].
    fn sample(&self, f: &Huang, u: [f64; 4]) -> Option<Sample> {
        if !self.visible {
            // The camera sees no scale surface here: a direction of the uniform density the
            // pdf states, carrying nothing.
            let z = 2.0 * u[1] - 1.0;
            let wi = direction_from_sin_cos(z, (1.0 - z * z).max(0.0).sqrt(), TAU * u[2]);
            return Some(Sample { wi, weight: Rgb::ZERO, pdf: 1.0 / (4.0 * PI), delta: false, lobe: 3 });
        }
        let q = &self.lobe_prob;
        // The first component whose cumulative probability exceeds u[0] (the last one with a
        // positive probability at the top end), and u[0] rescaled within it.
        let (mut lobe, mut lo) = (3, 1.0 - q[3]);
        let mut acc = 0.0;
        for (k, &p) in q.iter().enumerate() {
            if p > 0.0 && u[0] < acc + p {
                (lobe, lo) = (k, acc);
                break;
            }
            acc += p;
        }
        let u0 = ((u[0] - lo) / q[lobe]).clamp(0.0, 1.0 - f64::EPSILON);
        let wi = match lobe {
            0 => {
                let m = f.ggx.sample_visible(self.n_meso, self.wo, u[1], u[2]);
                reflect(-self.wo, m)
            }
            1 | 2 => {
                let paths = if lobe == 1 { &self.tt[..self.n_tt] } else { &self.trt[..self.n_trt] };
                let target = u0 * self.share_sum[lobe - 1];
                let mut acc = 0.0;
                let mut chosen = None;
                for path in paths.iter().filter(|x| x.share > 0.0) {
                    acc += path.share;
                    chosen = Some(path);
                    if target < acc {
                        break;
                    }
                }
                let path = chosen?;
                // GGX lobe about the smooth exit direction: tan²θ = α²u/(1 − u).
                let a2 = f.ggx.alpha() * f.ggx.alpha();
                let cos2 = (1.0 - u[1]) / (1.0 + (a2 - 1.0) * u[1]);
                let (c, s) = (cos2.sqrt(), (1.0 - cos2).max(0.0).sqrt());
                let frame = FiberFrame::from_tangent(path.axis);
                let (sp, cp) = (TAU * u[2]).sin_cos();
                (path.axis * c + frame.v * (s * cp) + frame.w * (s * sp)).normalize()
            }
            _ => {
                if u0 < UNIFORM_SHARE {
                    let z = 2.0 * u[1] - 1.0;
                    direction_from_sin_cos(z, (1.0 - z * z).max(0.0).sqrt(), TAU * u[2])
                } else {
                    let si = f.residual.sample_sin_theta(self.sin_o, self.cos_theta_o, u[1], u[2]);
                    direction_from_sin_cos(si, (1.0 - si * si).max(0.0).sqrt(), TAU * u[3])
                }
            }
        };
        let (value, pdf) = self.eval_and_pdf(f, wi);
        if pdf.is_nan() || pdf <= 0.0 || !pdf.is_finite() {
            return None;
        }
        Some(Sample { wi, weight: value * (cos_theta(wi) / pdf), pdf, delta: false, lobe: lobe as u8 })
    }
}

/// A [`Huang`] fiber prepared at one hit by [`Huang::at_vertex`].
#[derive(Clone, Debug)]
pub struct HuangAtVertex<'a> {
    fiber: &'a Huang,
    vertex: Vertex,
}

impl HuangAtVertex<'_> {
    /// `f_s(ω_i, ω_o; h)` and the density with which [`Self::sample`] draws `ω_i`.
    #[must_use]
    pub fn eval_and_pdf(&self, wi: DVec3) -> (Rgb, f64) {
        self.vertex.eval_and_pdf(self.fiber, wi)
    }

    /// Draws `ω_i` from four uniforms, as [`ScatteringFunction::sample`].
    #[must_use]
    pub fn sample(&self, u: [f64; 4]) -> Option<Sample> {
        self.vertex.sample(self.fiber, u)
    }
}

/// Which vertex a thread's [`LAST_VERTEX`] holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct VertexKey {
    fiber: u64,
    wo: [u64; 3],
    h: u64,
}

thread_local! {
    /// The last vertex prepared on this thread ([`Huang::with_vertex`]).
    static LAST_VERTEX: std::cell::RefCell<(Option<VertexKey>, Vertex)> =
        std::cell::RefCell::new((None, Vertex::default()));
}

/// Identities of [`Huang`] fibers (a clone shares its original's: same parameters).
static NEXT_FIBER_ID: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);

impl ScatteringFunction for Huang {
    fn properties(&self) -> Properties {
        Properties { reciprocal: false, energy_conserving: false, field: Field::Near, lobes: Lobes::Smooth }
    }

    fn eval(&self, wi: DVec3, wo: DVec3, h: f64) -> Rgb {
        self.with_vertex(wo, h, |v| v.eval_and_pdf(self, wi).0)
    }

    fn pdf(&self, wi: DVec3, wo: DVec3, h: f64) -> f64 {
        self.with_vertex(wo, h, |v| v.density(self, wi))
    }

    fn eval_and_pdf(&self, wi: DVec3, wo: DVec3, h: f64) -> (Rgb, f64) {
        self.with_vertex(wo, h, |v| v.eval_and_pdf(self, wi))
    }

    fn sample(&self, wo: DVec3, h: f64, u: [f64; 4]) -> Option<Sample> {
        self.with_vertex(wo, h, |v| v.sample(self, u))
    }

    /// σ_a per unit major semi-axis: for a circle, the chord convention itself (for an ellipse,
    /// the one of its circumscribed circle).
    fn chord_absorption(&self) -> Option<Rgb> {
        Some(self.sigma_a)
    }

    /// The lattices of entry and internal microfacets are shifted by a function of h that
    /// turns over every ~1/5000 of the width, so no panel resolves `eval` across h: the width
    /// average integrates the microfacets as a quasi-Monte Carlo sum over its nodes. π/256
    /// gives 256 panels (1024 nodes), which agree with the 4096-node rule within 0.5% of the
    /// largest value where the lobes are wide (0.35% measured where 64 nodes are 0.65% off), and
    /// 1.2% where a narrow TT lobe gets few nodes (`crates/scatter/tests/width_average.rs`).
    fn width_feature(&self) -> f64 {
        PI / FAR_PANELS as f64
    }

    /// `R`, `TT`, `TRT` and `TRRT+` (the residual; its sampler also draws the uniform share).
    fn lobes(&self) -> Vec<LobeInfo> {
        ["R", "TT", "TRT", "TRRT+"].map(LobeInfo::smooth).to_vec()
    }

    fn eval_lobes(&self, wi: DVec3, wo: DVec3, h: f64, out: &mut [Rgb]) -> bool {
        let lobes = self.with_vertex(wo, h, |v| v.integrand_lobes(self, wi));
        let c = cos_theta(wi).max(MIN_COS);
        for (slot, g) in out.iter_mut().zip(lobes) {
            *slot = g / c;
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fiberlab_math::frame::direction;

    /// One vertex prepared once serves every evaluation and sample bit for bit, and a sample's
    /// weight is `f_s cosθ_i/pdf` of its direction.
    #[test]
    fn a_vertex_prepared_once_serves_every_evaluation_and_sample() {
        let fiber = Huang::new(HuangParams::default()).unwrap();
        let (wo, h) = (direction(0.3, 1.1), -0.37);
        let vertex = fiber.at_vertex(wo, h);
        let mut checked = 0;
        for k in 0..64 {
            let (a, b) = (k as f64 / 64.0, ((k * 37) % 64) as f64 / 64.0);
            let wi = direction(-1.4 + 2.8 * a, TAU * b);
            assert_eq!(vertex.eval_and_pdf(wi), fiber.eval_and_pdf(wi, wo, h));
            let u = [a, b, (a + 0.31) % 1.0, (b + 0.77) % 1.0];
            if let Some(s) = vertex.sample(u) {
                let (f, pdf) = fiber.eval_and_pdf(s.wi, wo, h);
                assert!((s.pdf - pdf).abs() <= 1e-12 * pdf);
                let want = f * (cos_theta(s.wi) / pdf);
                for c in 0..3 {
                    assert!((s.weight[c] - want[c]).abs() <= 1e-12 * want[c].abs().max(1e-300));
                }
                checked += 1;
            }
        }
        assert!(checked > 50);
    }

    #[test]
    fn parameters_parse_and_errors_name_the_key() {
        let p = |pairs: &[(&str, &str)]| crate::build("huang-2022", pairs);
        assert!(p(&[("orientation", "average")]).is_ok());
        assert!(p(&[("orientation", "30"), ("aspect", "0.7")]).is_ok());
        let e = p(&[("orientation", "sideways")]).unwrap_err().to_string();
        assert!(e.contains("`orientation`") && e.contains("average"), "{e}");
        let e = p(&[("roughness", "0")]).unwrap_err().to_string();
        assert!(e.contains("`roughness`") && e.contains("[0.01, 1]"), "{e}");
        let e = p(&[("aspect", "1.2")]).unwrap_err().to_string();
        assert!(e.contains("`aspect`"), "{e}");
        let e = p(&[("alpha", "25")]).unwrap_err().to_string();
        assert!(e.contains("`alpha`") && e.contains("degrees"), "{e}");
        let e = p(&[("orientation", "inf")]).unwrap_err().to_string();
        assert!(e.contains("`orientation`"), "{e}");
    }
}
