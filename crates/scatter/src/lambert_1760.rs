//! The Lambertian surface (Lambert, *Photometria*, 1760): a constant BRDF, the simplest
//! surface model and the reference the surface pipeline is tested with.
//!
//! Parameters: the registry entry (the `params` of `Registered::INFO` below) is the one table of
//! keys, units, defaults and valid ranges; `fiberlab models --model lambertian` prints it and the
//! book's page `docs/book/src/models/lambertian.md` shows it.
//!
//! # Formula
//! `f_r(ω_i, ω_o) = k_d/π` for `ω_i`, `ω_o` above the surface (`z > 0`), else 0; the albedo
//! is `∫ f_r cosθ_o dω_o = k_d` since `∫_{H²} cosθ dω = π`. Reciprocal, energy conserving.
//! Sampling is exact: cosine-weighted hemisphere, density `cosθ_i/π`, weight `k_d`.

use crate::params::{ParamKind, ParamSet, ParamSpec, Range, parameter_error};
use crate::sampling::cosine_hemisphere;
use crate::{LobeInfo, ModelError, ModelInfo, Registered, Sample, SurfaceProperties, SurfaceScattering};
use fiberlab_math::{DVec3, Rgb};
use std::f64::consts::FRAC_1_PI;

/// Registry entry: `lambertian`.
impl Registered for Lambertian {
    const INFO: ModelInfo = ModelInfo {
        name: "lambertian",
        summary: "Lambertian surface, f_r = k_d/π",
        citation: "Lambert, Photometria (1760)",
        params: &[ParamSpec {
            key: "k_d",
            kind: ParamKind::Color(Range::UNIT),
            unit: "",
            default: "0.8",
            doc: "diffuse albedo k_d = π·f_r (texturable)",
        }],
        data: None,
    };

    fn from_param_set(p: &ParamSet) -> Result<Self, ModelError> {
        Ok(Lambertian::new(LambertianParams::from_param_set(p)?)?)
    }
}

/// Parameters of [`Lambertian`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LambertianParams {
    /// Diffuse albedo per channel, in [0, 1].
    pub k_d: Rgb,
}

impl Default for LambertianParams {
    /// `k_d = 0.8`.
    fn default() -> Self {
        Self { k_d: Rgb::splat(0.8) }
    }
}

impl LambertianParams {
    /// Reads the registry parameters.
    pub fn from_param_set(p: &ParamSet) -> Result<Self, ModelError> {
        Ok(Self { k_d: p.color("k_d")? })
    }
}

parameter_error! {
    /// Why a [`Lambertian`] surface cannot be built.
    LambertianError
}

/// A Lambertian surface of albedo `k_d`.
///
/// ```
/// use fiberlab_scatter::SurfaceScattering;
/// use fiberlab_scatter::lambert_1760::{Lambertian, LambertianParams};
/// use fiberlab_math::{DVec3, Rgb};
/// let f = Lambertian::new(LambertianParams { k_d: Rgb::splat(0.5) }).unwrap();
/// let v = f.eval(DVec3::new(0.6, 0.0, 0.8), DVec3::Z);
/// assert!((v[0] - 0.5 / std::f64::consts::PI).abs() < 1e-15);
/// assert_eq!(f.eval(DVec3::new(0.6, 0.0, -0.8), DVec3::Z), Rgb::ZERO);
/// ```
#[derive(Clone, Copy, Debug)]
pub struct Lambertian {
    k_d: Rgb,
}

impl Lambertian {
    /// A Lambertian surface; `k_d` ∈ [0, 1] per channel.
    pub fn new(params: LambertianParams) -> Result<Self, LambertianError> {
        Ok(Self { k_d: Range::UNIT.check_rgb("k_d", params.k_d)? })
    }

    /// The albedo.
    #[must_use]
    pub fn k_d(&self) -> Rgb {
        self.k_d
    }
}

impl SurfaceScattering for Lambertian {
    fn properties(&self) -> SurfaceProperties {
        SurfaceProperties { reciprocal: true, energy_conserving: true, has_delta: false, transmits: false }
    }

    fn eval(&self, wi: DVec3, wo: DVec3) -> Rgb {
        if wi.z > 0.0 && wo.z > 0.0 { self.k_d * FRAC_1_PI } else { Rgb::ZERO }
    }

    fn pdf(&self, wi: DVec3, wo: DVec3) -> f64 {
        if wi.z > 0.0 && wo.z > 0.0 { wi.z * FRAC_1_PI } else { 0.0 }
    }

    fn sample(&self, wo: DVec3, u: [f64; 4]) -> Option<Sample> {
        if wo.z <= 0.0 {
            return None;
        }
        let wi = cosine_hemisphere(DVec3::Z, DVec3::X, u[0], u[1]);
        if wi.z <= 0.0 {
            return None;
        }
        Some(Sample { wi, weight: self.k_d, pdf: wi.z * FRAC_1_PI, delta: false, lobe: 0 })
    }

    fn lobes(&self) -> Vec<LobeInfo> {
        vec![LobeInfo::smooth("diffuse")]
    }

    fn texturable_keys(&self) -> &'static [&'static str] {
        &["k_d"]
    }

    fn set_parameter(&mut self, key: &str, value: Rgb) -> Result<(), ModelError> {
        match key {
            "k_d" => self.k_d = Range::UNIT.check_rgb("k_d", value)?,
            _ => return Err(crate::surface::not_texturable(&Self::INFO, key)),
        }
        Ok(())
    }
}
