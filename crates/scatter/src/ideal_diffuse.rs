//! The ideal diffuse fiber (Marschner, *Scattering from fibers*, course notes; theory in
//! `docs/theory/radiometry.md`, "Ideal diffuse fiber").
//!
//! Parameters: the registry entry (the `params` of `Registered::INFO` below) is the one table of
//! keys, units, defaults and valid ranges; `fiberlab models --model diffuse` prints it and the
//! book's page `docs/book/src/models/diffuse.md` shows it. The formulas below write `albedo` as ρ.
//!
//! # Formula
//! `f_s(ω_i, ω_r) = ρ/π²` (constant), so `ρ(ω_i) = ∫ f_s cosθ_r dω_r = ρ` because
//! `∫_{S²} cosθ dω = π²`. Reciprocal, far-field, energy conserving.
//! Sampling is exact: density `cosθ_i/π²` per sr, weight ρ.

use crate::params::{AlbedoParams, ParamKind, ParamSet, ParamSpec, Range, parameter_error};
use crate::sampling::{cos_theta_direction, cos_theta_pdf};
use crate::{Field, LobeInfo, Lobes, ModelError, ModelInfo, Properties, Registered, Sample, ScatteringFunction};
use fiberlab_math::frame::cos_theta;
use fiberlab_math::{DVec3, Rgb};
use std::f64::consts::{PI, TAU};

/// Registry entry: `diffuse`.
impl Registered for IdealDiffuse {
    const INFO: ModelInfo = ModelInfo {
        name: "diffuse",
        summary: "ideal diffuse fiber, f_s = albedo/π²",
        citation: "Marschner, Scattering from fibers (course notes); docs/theory/radiometry.md",
        params: &[ParamSpec {
            key: "albedo",
            kind: ParamKind::Color(Range::UNIT),
            unit: "",
            default: "0.8",
            doc: "albedo ρ = π²·f_s",
        }],
        data: None,
    };

    fn from_param_set(p: &ParamSet) -> Result<Self, ModelError> {
        Ok(IdealDiffuse::new(IdealDiffuseParams::from_param_set(p)?)?)
    }
}

/// Parameters of [`IdealDiffuse`]: its albedo.
pub type IdealDiffuseParams = AlbedoParams;

parameter_error! {
    /// Why an [`IdealDiffuse`] fiber cannot be built.
    IdealDiffuseError
}

/// Ideal diffuse fiber: constant `f_s = ρ/π²`.
///
/// The value follows from the albedo alone: `∫ f_s cosθ_r dω_r = f_s·π²` must equal ρ, since
/// `∫_{S²} cosθ dω = 2π·∫cos²θ dθ = π²`:
/// ```
/// use fiberlab_scatter::ScatteringFunction;
/// use fiberlab_scatter::ideal_diffuse::{IdealDiffuse, IdealDiffuseParams};
/// use fiberlab_math::{Rgb, frame::direction};
/// let f = IdealDiffuse::new(IdealDiffuseParams { albedo: Rgb::splat(0.5) }).unwrap();
/// let value = f.eval(direction(0.3, 0.0), direction(-1.1, 2.0), 0.0);
/// assert!((value[0] - 0.5 / (std::f64::consts::PI * std::f64::consts::PI)).abs() < 1e-15);
/// ```
#[derive(Clone, Debug)]
pub struct IdealDiffuse {
    albedo: Rgb,
}

impl IdealDiffuse {
    /// A diffuse fiber of albedo ∈ [0, 1] per channel.
    pub fn new(params: IdealDiffuseParams) -> Result<Self, IdealDiffuseError> {
        Ok(Self { albedo: Range::UNIT.check_rgb("albedo", params.albedo)? })
    }

    /// The albedo ρ.
    #[must_use]
    pub fn albedo(&self) -> Rgb {
        self.albedo
    }
}

impl ScatteringFunction for IdealDiffuse {
    fn properties(&self) -> Properties {
        Properties { reciprocal: true, energy_conserving: true, field: Field::Far, lobes: Lobes::Smooth }
    }

    fn eval(&self, _wi: DVec3, _wo: DVec3, _h: f64) -> Rgb {
        self.albedo / (PI * PI)
    }

    fn pdf(&self, wi: DVec3, _wo: DVec3, _h: f64) -> f64 {
        cos_theta_pdf(cos_theta(wi))
    }

    fn lobes(&self) -> Vec<LobeInfo> {
        vec![LobeInfo::smooth("diffuse")]
    }

    fn sample(&self, _wo: DVec3, _h: f64, u: [f64; 4]) -> Option<Sample> {
        let wi = cos_theta_direction(u[0], u[1], TAU * u[2]);
        Some(Sample { wi, weight: self.albedo, pdf: cos_theta_pdf(cos_theta(wi)), delta: false, lobe: 0 })
    }
}
