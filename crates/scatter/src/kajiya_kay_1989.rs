//! Kajiya & Kay 1989, *Rendering fur with three dimensional textures*, written as a fiber
//! scattering function (`docs/theory/radiometry.md`, "Kajiya–Kay as a scattering function").
//!
//! Parameters: the registry entry (the `params` of `Registered::INFO` below) is the one table of
//! keys, units, defaults and valid ranges; `fiberlab models --model kajiya-kay` prints it and the
//! book's page `docs/book/src/models/kajiya-kay.md` shows it.
//!
//! # Formula
//! `f_s(ω_i, ω_r) = k_d + k_s·max(0, cos(θ_i + θ_r))^p / cosθ_i` (clamped before the power).
//! No φ dependence. The `1/cosθ_i` cancels the scattering integral's cosine: KK's specular
//! radiance is not weighted by the fiber's projected width toward the light.
//!
//! Caveats (tested by the harness against closed forms, not claimed away):
//! * **not reciprocal**: `f(i, r)/f(r, i) = cosθ_r/cosθ_i` for the specular part;
//! * **not energy bounded**: `ρ(θ_i) = π²k_d + k_s·E_p(θ_i)` and `E_p → ∞` as θ_i → ±π/2.
//!   At exactly grazing light the `1/cosθ_i` is evaluated with `cosθ_i ≥ 1e−8`.
//!
//! Sampling: a mixture of the exact diffuse-fiber lobe (density `cosθ_i/π²`) and the
//! specular lobe, whose longitudinal variable `x = θ_i + θ_o` is drawn from a 4096-cell
//! tabulation of `cos^p x`; φ is uniform. The drawn θ_i goes through the pole taper
//! ([`crate::hair::pole_taper`]: at a grazing viewer the specular lobe is centred on the fiber
//! axis, and a density in θ_i that is not zero there is infinite per steradian). The pdf is
//! exactly the density of the samples.

use crate::function::MIN_COS;
use crate::hair::pole_taper::{taper, taper_derivative, untaper};
use crate::params::{ParamKind, ParamSet, ParamSpec, Range, parameter_error};
use crate::sampling::Tabulated1D;
use crate::{Field, LobeInfo, Lobes, ModelError, ModelInfo, Properties, Registered, Sample, ScatteringFunction};
use fiberlab_math::frame::{cos_theta, direction_from_sin_cos, phi, sin_theta};
use fiberlab_math::{DVec3, Rgb};
use std::f64::consts::{FRAC_PI_2, PI, TAU};
use std::sync::Arc;

/// Cells of the tabulated `cos^p x` on [−π/2, π/2].
const LOBE_CELLS: usize = 4096;

const K_RANGE: Range = Range::closed(0.0, 10.0);
const P_RANGE: Range = Range::closed(0.5, 1e4);

/// Index of `k_d` in [`PARAMS`].
pub(crate) const K_D: usize = 0;
/// Index of `k_s` in [`PARAMS`].
pub(crate) const K_S: usize = 1;
/// Index of `p` in [`PARAMS`].
pub(crate) const P: usize = 2;

/// Parameter table shared with [`crate::goldman_1997`] (which names the entries by
/// [`K_D`], [`K_S`], [`P`]; a test checks that they match the keys).
pub(crate) const PARAMS: [ParamSpec; 3] = [
    ParamSpec {
        key: "k_d",
        kind: ParamKind::Color(K_RANGE),
        unit: "1/sr",
        default: "0.05",
        doc: "diffuse coefficient",
    },
    ParamSpec {
        key: "k_s",
        kind: ParamKind::Color(K_RANGE),
        unit: "1/sr",
        default: "0.1",
        doc: "specular coefficient",
    },
    ParamSpec { key: "p", kind: ParamKind::Number(P_RANGE), unit: "", default: "30", doc: "specular exponent" },
];

/// Registry entry: `kajiya-kay`.
impl Registered for KajiyaKay {
    const INFO: ModelInfo = ModelInfo {
        name: "kajiya-kay",
        summary: "Kajiya–Kay diffuse + specular cone, as a scattering function",
        citation: "Kajiya & Kay 1989; docs/theory/radiometry.md",
        params: &PARAMS,
        data: None,
    };

    fn from_param_set(p: &ParamSet) -> Result<Self, ModelError> {
        Ok(KajiyaKay::new(KajiyaKayParams::from_param_set(p)?)?)
    }
}

/// Parameters of [`KajiyaKay`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KajiyaKayParams {
    /// Diffuse coefficient `k_d` ∈ [0, 10] sr⁻¹ per channel.
    pub k_d: Rgb,
    /// Specular coefficient `k_s` ∈ [0, 10] sr⁻¹ per channel.
    pub k_s: Rgb,
    /// Specular exponent `p` ∈ [0.5, 10⁴].
    pub p: f64,
}

impl Default for KajiyaKayParams {
    /// `k_d = 0.05`, `k_s = 0.1`, `p = 30`.
    fn default() -> Self {
        Self { k_d: Rgb::splat(0.05), k_s: Rgb::splat(0.1), p: 30.0 }
    }
}

impl KajiyaKayParams {
    /// A dark, glossy look: little diffuse, a sharp highlight (`k_d = 0.01`, `k_s = 0.2`, `p = 80`).
    #[must_use]
    pub fn dark_glossy() -> Self {
        Self { k_d: Rgb::splat(0.01), k_s: Rgb::splat(0.2), p: 80.0 }
    }

    /// Reads the registry parameters.
    pub fn from_param_set(p: &ParamSet) -> Result<Self, ModelError> {
        Ok(Self { k_d: p.color("k_d")?, k_s: p.color("k_s")?, p: p.number("p")? })
    }
}

parameter_error! {
    /// Why a [`KajiyaKay`] fiber cannot be built.
    KajiyaKayError
}

/// Kajiya–Kay fiber.
///
/// At θ_i = θ_r = 0 the viewer sits on the specular cone (`cos(θ_i + θ_r) = 1`) and
/// `cosθ_i = 1`, so `f_s = k_d + k_s`, whatever the azimuth:
/// ```
/// use fiberlab_scatter::ScatteringFunction;
/// use fiberlab_scatter::kajiya_kay_1989::{KajiyaKay, KajiyaKayParams};
/// use fiberlab_math::{Rgb, frame::direction};
/// let f = KajiyaKay::new(KajiyaKayParams { k_d: Rgb::splat(0.05), k_s: Rgb::splat(0.1), p: 30.0 }).unwrap();
/// let value = f.eval(direction(0.0, 0.0), direction(0.0, 2.5), 0.0);
/// assert!((value[0] - 0.15).abs() < 1e-15);
/// ```
#[derive(Clone, Debug)]
pub struct KajiyaKay {
    k_d: Rgb,
    k_s: Rgb,
    p: f64,
    /// `cos^p x` tabulated on [−π/2, π/2] (shared between clones).
    lobe: Arc<Tabulated1D>,
}

impl KajiyaKay {
    /// A Kajiya–Kay fiber with diffuse `k_d`, specular `k_s` (sr⁻¹) and exponent `p`.
    pub fn new(params: KajiyaKayParams) -> Result<Self, KajiyaKayError> {
        let KajiyaKayParams { k_d, k_s, p } = params;
        K_RANGE.check_rgb("k_d", k_d)?;
        K_RANGE.check_rgb("k_s", k_s)?;
        P_RANGE.check("p", p)?;
        let lobe = Tabulated1D::new(-FRAC_PI_2, FRAC_PI_2, LOBE_CELLS, 8, |x| x.cos().max(0.0).powf(p));
        Ok(Self { k_d, k_s, p, lobe: Arc::new(lobe) })
    }

    /// Diffuse coefficient `k_d` (sr⁻¹).
    #[must_use]
    pub fn k_d(&self) -> Rgb {
        self.k_d
    }
    /// Specular coefficient `k_s` (sr⁻¹).
    #[must_use]
    pub fn k_s(&self) -> Rgb {
        self.k_s
    }
    /// Specular exponent `p`.
    #[must_use]
    pub fn p(&self) -> f64 {
        self.p
    }

    /// The tabulated `cos^p x` on [−π/2, π/2] that the specular lobe samples (for a copy
    /// elsewhere, e.g. the GPU's).
    #[must_use]
    pub fn lobe_table(&self) -> &Tabulated1D {
        &self.lobe
    }

    /// `f_s` from the inclinations alone (it has no φ dependence).
    pub(crate) fn eval_theta(&self, sin_i: f64, cos_i: f64, sin_o: f64, cos_o: f64) -> Rgb {
        let cone = (cos_i * cos_o - sin_i * sin_o).max(0.0);
        self.k_d + self.k_s * (cone.powf(self.p) / cos_i.max(MIN_COS))
    }

    /// Range of `x = θ_i + θ_o` for which θ_i ∈ [−π/2, π/2] and the lobe is non-zero.
    fn lobe_range(theta_o: f64) -> (f64, f64) {
        ((theta_o - FRAC_PI_2).max(-FRAC_PI_2), (theta_o + FRAC_PI_2).min(FRAC_PI_2))
    }

    /// Probability of choosing the diffuse lobe given θ_o.
    fn diffuse_weight(&self, theta_o: f64) -> f64 {
        let (a, b) = Self::lobe_range(theta_o);
        let w_d = PI * PI * self.k_d.luminance();
        let w_s = TAU * self.k_s.luminance() * (self.lobe.cdf(b) - self.lobe.cdf(a));
        if w_d + w_s > 0.0 { w_d / (w_d + w_s) } else { 1.0 }
    }

    /// Density of the sampled θ_i (per radian of θ_i) given θ_o: the mixture's density at the
    /// tapered `W(θ_i)` times `W′(θ_i)` ([`crate::hair::pole_taper`]; the specular lobe of a
    /// grazing viewer is centred on the pole, where an untapered density in θ_i would be
    /// infinite per steradian).
    pub(crate) fn theta_pdf(&self, theta_i: f64, _cos_i: f64, theta_o: f64) -> f64 {
        let slope = taper_derivative(theta_i);
        if slope <= 0.0 {
            return 0.0;
        }
        let t = taper(theta_i);
        let cos_t = t.cos();
        let w_d = self.diffuse_weight(theta_o);
        let (a, b) = Self::lobe_range(theta_o);
        let diffuse = 2.0 * cos_t * cos_t / PI;
        let specular = if w_d < 1.0 { self.lobe.density_in(a, b, t + theta_o) } else { 0.0 };
        (w_d * diffuse + (1.0 - w_d) * specular) * slope
    }

    /// Draws θ_i given θ_o: `u_lobe` picks the lobe (0 diffuse, 1 specular, see
    /// [`KAJIYA_KAY_LOBES`]), `(u1, u2)` place θ_i in it; returns θ_i and the lobe.
    pub(crate) fn sample_theta(&self, theta_o: f64, u_lobe: f64, u1: f64, u2: f64) -> Option<(f64, u8)> {
        if u_lobe < self.diffuse_weight(theta_o) {
            Some((untaper((u1.sqrt() * (TAU * u2).cos()).clamp(-1.0, 1.0).asin()), 0))
        } else {
            let (a, b) = Self::lobe_range(theta_o);
            let (x, _) = self.lobe.sample_in(a, b, u1)?;
            Some((untaper((x - theta_o).clamp(-FRAC_PI_2, FRAC_PI_2)), 1))
        }
    }

    /// Shared sampling skeleton: θ_i from the KK mixture, φ from `sample_phi` (relative
    /// azimuth, with its density); weight from `eval`/`pdf`.
    pub(crate) fn sample_with(
        &self,
        wo: DVec3,
        u: [f64; 4],
        phi_rel: f64,
        eval: impl Fn(DVec3) -> Rgb,
        pdf: impl Fn(DVec3) -> f64,
    ) -> Option<Sample> {
        let theta_o = sin_theta(wo).atan2(cos_theta(wo));
        let (theta_i, lobe) = self.sample_theta(theta_o, u[0], u[1], u[2])?;
        let (s, c) = theta_i.sin_cos();
        let wi = direction_from_sin_cos(s, c, phi(wo) - phi_rel);
        let pdf = pdf(wi);
        if pdf.is_nan() || pdf <= 0.0 {
            return None;
        }
        let weight = eval(wi) * (cos_theta(wi) / pdf);
        Some(Sample { wi, weight, pdf, delta: false, lobe })
    }
}

/// The lobes of [`KajiyaKay::sample`] (and of the models that sample like it): the diffuse
/// term and the specular cone.
pub(crate) const KAJIYA_KAY_LOBES: [LobeInfo; 2] = [LobeInfo::smooth("diffuse"), LobeInfo::smooth("specular")];

/// θ of a direction from its components (accurate at grazing angles).
pub(crate) fn theta_of(w: DVec3) -> (f64, f64, f64) {
    let (s, c) = (sin_theta(w), cos_theta(w));
    (s.atan2(c), s, c)
}

impl ScatteringFunction for KajiyaKay {
    fn properties(&self) -> Properties {
        Properties { reciprocal: false, energy_conserving: false, field: Field::Far, lobes: Lobes::Smooth }
    }

    fn eval(&self, wi: DVec3, wo: DVec3, _h: f64) -> Rgb {
        self.eval_theta(sin_theta(wi), cos_theta(wi), sin_theta(wo), cos_theta(wo))
    }

    fn pdf(&self, wi: DVec3, wo: DVec3, _h: f64) -> f64 {
        let (ti, _, ci) = theta_of(wi);
        let (to, _, _) = theta_of(wo);
        self.theta_pdf(ti, ci, to) / (TAU * ci.max(MIN_COS))
    }

    fn lobes(&self) -> Vec<LobeInfo> {
        KAJIYA_KAY_LOBES.to_vec()
    }

    fn sample(&self, wo: DVec3, h: f64, u: [f64; 4]) -> Option<Sample> {
        self.sample_with(wo, u, PI * (2.0 * u[3] - 1.0), |wi| self.eval(wi, wo, h), |wi| self.pdf(wi, wo, h))
    }
}
