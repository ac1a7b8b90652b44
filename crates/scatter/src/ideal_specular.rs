//! The ideal specular fiber: all light leaves on the specular cone θ_r = −θ_i
//! (`docs/theory/radiometry.md`, "Ideal specular fiber").
//!
//! Parameters: the registry entry (the `params` of `Registered::INFO` below) is the one table of
//! keys, units, defaults and valid ranges; `fiberlab models --model specular` prints it and the
//! book's page `docs/book/src/models/specular.md` shows it. The formulas below write `eta` as η.
//!
//! # Formula
//! `f_s(ω_i, ω_r) = δ(θ_i + θ_r)·n(φ)·F / cos²θ_i`, with `∫ n dφ = 1`:
//! * `uniform`: `n = 1/(2π)`;
//! * `mirror` (a perfectly reflecting circular cross-section, R path): a ray at offset h
//!   leaves at φ = −2γ_i, γ_i = asin h, so `n(φ) = cos(φ/2)/4`.
//!
//! With `fresnel=on` the lobe is weighted by the dielectric reflectance `F(η, cos ι)`:
//! for `mirror` `cos ι = cosθ_i·cos(φ/2)` (the true incidence angle on the cylinder); for
//! `uniform`, which has no cross-section geometry, `cos ι = cosθ_i` (a facet whose normal
//! lies in the plane of incidence). Reciprocal (the lobe is symmetric), far-field, delta.
//! Sampling is exact: `φ = 2·asin(2ξ − 1)` (mirror) or `φ = π(2ξ − 1)` (uniform).

use crate::params::{ParamKind, ParamSet, ParamSpec, Range, parameter_error};
use crate::{
    ConeValue, Field, LobeInfo, Lobes, ModelError, ModelInfo, Properties, Registered, Sample, ScatteringFunction,
};
use fiberlab_math::frame::{cos_theta, direction_from_sin_cos, phi, sin_theta};
use fiberlab_math::{DVec3, Rgb, fresnel};
use std::f64::consts::{PI, TAU};

/// Registry entry: `specular`.
impl Registered for IdealSpecular {
    const INFO: ModelInfo = ModelInfo {
        name: "specular",
        summary: "ideal specular fiber: a delta lobe on the cone θ_r = −θ_i",
        citation: "Marschner, Scattering from fibers (course notes); docs/theory/radiometry.md",
        params: &[
            ParamSpec {
                key: "azimuth",
                kind: ParamKind::Choice(&["uniform", "mirror"]),
                unit: "",
                default: "mirror",
                doc: "azimuthal distribution on the cone",
            },
            ParamSpec {
                key: "fresnel",
                kind: ParamKind::Choice(&["on", "off"]),
                unit: "",
                default: "off",
                doc: "weight by dielectric Fresnel reflectance",
            },
            ParamSpec {
                key: "eta",
                kind: ParamKind::Number(ETA_RANGE),
                unit: "",
                default: "1.55",
                doc: "index of refraction (used with fresnel=on)",
            },
        ],
        data: None,
    };

    fn from_param_set(p: &ParamSet) -> Result<Self, ModelError> {
        Ok(IdealSpecular::new(IdealSpecularParams::from_param_set(p)?)?)
    }
}

/// Parameters of [`IdealSpecular`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IdealSpecularParams {
    /// The azimuthal distribution on the cone.
    pub azimuth: Azimuth,
    /// `Some(η)`: the lobe is weighted by the dielectric reflectance of index η ∈ (1, 4];
    /// `None`: a perfect reflector.
    pub fresnel_eta: Option<f64>,
}

impl Default for IdealSpecularParams {
    /// A perfect mirror cylinder (`azimuth = mirror`, no Fresnel).
    fn default() -> Self {
        Self { azimuth: Azimuth::Mirror, fresnel_eta: None }
    }
}

impl IdealSpecularParams {
    /// A smooth dielectric cylinder of index 1.55 (hair keratin), R path only.
    #[must_use]
    pub fn keratin() -> Self {
        Self { azimuth: Azimuth::Mirror, fresnel_eta: Some(1.55) }
    }

    /// Reads the registry parameters.
    pub fn from_param_set(p: &ParamSet) -> Result<Self, ModelError> {
        let azimuth = if p.choice("azimuth")? == "uniform" { Azimuth::Uniform } else { Azimuth::Mirror };
        let fresnel_eta = if p.switch("fresnel")? { Some(p.number("eta")?) } else { None };
        Ok(Self { azimuth, fresnel_eta })
    }
}

parameter_error! {
    /// Why an [`IdealSpecular`] fiber cannot be built.
    IdealSpecularError
}

const ETA_RANGE: Range = Range::open_closed(1.0, 4.0);

/// Azimuthal distribution on the specular cone.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Azimuth {
    /// `n(φ) = 1/(2π)`.
    Uniform,
    /// `n(φ) = cos(φ/2)/4`, the mirror circular cross-section.
    Mirror,
}

/// Ideal specular fiber.
///
/// A mirror cylinder hit uniformly across its width reflects the ray at offset h into
/// φ = −2 asin h, so the azimuthal density is `|dh/dφ|/2 = cos(φ/2)/4`: 1/4 at backscatter.
/// ```
/// use fiberlab_scatter::ScatteringFunction;
/// use fiberlab_scatter::ideal_specular::{IdealSpecular, IdealSpecularParams};
/// let f = IdealSpecular::new(IdealSpecularParams::default()).unwrap();
/// assert!((f.cone(0.2, 0.0).value[0] - 0.25).abs() < 1e-15);
/// assert!((f.cone(0.2, 2.0).value[0] - (1.0f64).cos() / 4.0).abs() < 1e-15);
/// ```
#[derive(Clone, Debug)]
pub struct IdealSpecular {
    azimuth: Azimuth,
    /// `Some(η)` when the lobe is Fresnel-weighted.
    eta: Option<f64>,
}

impl IdealSpecular {
    /// A specular fiber; `fresnel_eta = Some(η)` weights the lobe by Fresnel reflectance.
    pub fn new(params: IdealSpecularParams) -> Result<Self, IdealSpecularError> {
        if let Some(e) = params.fresnel_eta {
            ETA_RANGE.check("eta", e)?;
        }
        Ok(Self { azimuth: params.azimuth, eta: params.fresnel_eta })
    }

    /// The azimuthal distribution.
    #[must_use]
    pub fn azimuth(&self) -> Azimuth {
        self.azimuth
    }

    /// `Some(η)` when the lobe is Fresnel-weighted.
    #[must_use]
    pub fn fresnel_eta(&self) -> Option<f64> {
        self.eta
    }

    /// `n(φ)`, density of the relative azimuth (rad⁻¹).
    fn azimuthal_pdf(&self, phi: f64) -> f64 {
        match self.azimuth {
            Azimuth::Uniform => 1.0 / TAU,
            Azimuth::Mirror => (0.5 * phi).cos().max(0.0) / 4.0,
        }
    }

    /// Fresnel weight of the lobe at relative azimuth φ for a ray with `cos θ`.
    fn attenuation(&self, cos_theta: f64, phi: f64) -> f64 {
        match (self.eta, self.azimuth) {
            (None, _) => 1.0,
            (Some(eta), Azimuth::Uniform) => fresnel::dielectric(cos_theta, eta),
            (Some(eta), Azimuth::Mirror) => fresnel::dielectric(cos_theta * (0.5 * phi).cos().max(0.0), eta),
        }
    }
}

impl ScatteringFunction for IdealSpecular {
    fn properties(&self) -> Properties {
        Properties { reciprocal: true, energy_conserving: true, field: Field::Far, lobes: Lobes::Delta }
    }

    fn eval(&self, _wi: DVec3, _wo: DVec3, _h: f64) -> Rgb {
        Rgb::ZERO
    }

    fn pdf(&self, _wi: DVec3, _wo: DVec3, _h: f64) -> f64 {
        0.0
    }

    fn lobes(&self) -> Vec<LobeInfo> {
        vec![LobeInfo { name: "specular", delta: true }]
    }

    fn sample(&self, wo: DVec3, _h: f64, u: [f64; 4]) -> Option<Sample> {
        let phi_rel = match self.azimuth {
            Azimuth::Uniform => PI * (2.0 * u[0] - 1.0),
            Azimuth::Mirror => 2.0 * (2.0 * u[0] - 1.0).clamp(-1.0, 1.0).asin(),
        };
        let cos_o = cos_theta(wo);
        let wi = direction_from_sin_cos(-sin_theta(wo), cos_o, phi(wo) - phi_rel);
        let weight = Rgb::splat(self.attenuation(cos_o, phi_rel));
        Some(Sample { wi, weight, pdf: 0.0, delta: true, lobe: 0 })
    }

    fn cone(&self, theta_o: f64, phi: f64) -> ConeValue {
        let n = self.azimuthal_pdf(phi);
        ConeValue { value: Rgb::splat(n * self.attenuation(theta_o.cos(), phi)), pdf: n }
    }
}
