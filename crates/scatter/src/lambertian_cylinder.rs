//! An opaque cylinder with a Lambertian surface, as a fiber scattering function
//! (`docs/theory/radiometry.md`, "Lambertian cylinder"; equal to Tungsten's
//! `LambertianFiberBcsdf`).
//!
//! Parameters: the registry entry (the `params` of `Registered::INFO` below) is the one table of
//! keys, units, defaults and valid ranges; `fiberlab models --model lambertian-cylinder` prints it
//! and the book's page `docs/book/src/models/lambertian-cylinder.md` shows it. The formulas below
//! write `albedo` as ρ.
//!
//! # Formula
//! `f_s = (ρ/(4π))·[(π − |φ|)·cosφ + sin|φ|]`, `|φ| ≤ π`, φ = φ_r − φ_i (0 = backscatter),
//! independent of θ_i and θ_r; `∫ g dφ = 8` so the albedo is ρ. Reciprocal, far-field.
//! Exact sampling: the offset h uniform over the visible width, the surface normal `n(h)`
//! in the normal plane, then a cosine-weighted hemisphere about `n`; weight ρ.

use crate::params::{AlbedoParams, ParamKind, ParamSet, ParamSpec, Range, parameter_error};
use crate::sampling::cosine_hemisphere;
use crate::{Field, LobeInfo, Lobes, ModelError, ModelInfo, Properties, Registered, Sample, ScatteringFunction};
use fiberlab_math::frame::{cos_theta, phi, relative_phi};
use fiberlab_math::{DVec3, Rgb};
use std::f64::consts::PI;

/// Registry entry: `lambertian-cylinder`.
impl Registered for LambertianCylinder {
    const INFO: ModelInfo = ModelInfo {
        name: "lambertian-cylinder",
        summary: "opaque cylinder with a Lambertian surface",
        citation: "docs/theory/radiometry.md (Tungsten LambertianFiberBcsdf)",
        params: &[ParamSpec {
            key: "albedo",
            kind: ParamKind::Color(Range::UNIT),
            unit: "",
            default: "0.8",
            doc: "surface albedo ρ",
        }],
        data: None,
    };

    fn from_param_set(p: &ParamSet) -> Result<Self, ModelError> {
        Ok(LambertianCylinder::new(LambertianCylinderParams::from_param_set(p)?)?)
    }
}

/// Parameters of [`LambertianCylinder`]: its surface albedo.
pub type LambertianCylinderParams = AlbedoParams;

parameter_error! {
    /// Why a [`LambertianCylinder`] cannot be built.
    LambertianCylinderError
}

/// Opaque Lambertian cylinder.
///
/// Seen from the light (backscatter, φ = 0, θ = 0) under irradiance E the visible
/// half-circle has normals at γ ∈ [−π/2, π/2]; each point reflects radiance `(ρ/π)·E·cosγ`,
/// and its share of the projected width is `cosγ dγ/2`, so the width-averaged radiance is
/// `(ρE/2π)∫cos²γ dγ = ρE/4`, i.e. `f_s = ρ/4`:
/// ```
/// use fiberlab_scatter::ScatteringFunction;
/// use fiberlab_scatter::lambertian_cylinder::{LambertianCylinder, LambertianCylinderParams};
/// use fiberlab_math::{Rgb, frame::direction};
/// let f = LambertianCylinder::new(LambertianCylinderParams { albedo: Rgb::splat(0.8) }).unwrap();
/// let w = direction(0.0, 0.7);
/// assert!((f.eval(w, w, 0.0)[0] - 0.8 / 4.0).abs() < 1e-15);
/// ```
#[derive(Clone, Debug)]
pub struct LambertianCylinder {
    albedo: Rgb,
}

/// The azimuthal shape `g(φ) = (π − |φ|)cosφ + sin|φ|`, with `∫_{−π}^{π} g dφ = 8`.
#[must_use]
pub fn azimuthal(phi: f64) -> f64 {
    let a = phi.abs().min(PI);
    ((PI - a) * a.cos() + a.sin()).max(0.0)
}

impl LambertianCylinder {
    /// A Lambertian cylinder of surface albedo ∈ [0, 1] per channel.
    pub fn new(params: LambertianCylinderParams) -> Result<Self, LambertianCylinderError> {
        Ok(Self { albedo: Range::UNIT.check_rgb("albedo", params.albedo)? })
    }

    /// The surface albedo ρ.
    #[must_use]
    pub fn albedo(&self) -> Rgb {
        self.albedo
    }

    fn density(wi: DVec3, wo: DVec3) -> f64 {
        cos_theta(wi) * azimuthal(relative_phi(wi, wo)) / (4.0 * PI)
    }
}

impl ScatteringFunction for LambertianCylinder {
    fn properties(&self) -> Properties {
        Properties { reciprocal: true, energy_conserving: true, field: Field::Far, lobes: Lobes::Smooth }
    }

    fn eval(&self, wi: DVec3, wo: DVec3, _h: f64) -> Rgb {
        self.albedo * (azimuthal(relative_phi(wi, wo)) / (4.0 * PI))
    }

    fn pdf(&self, wi: DVec3, wo: DVec3, _h: f64) -> f64 {
        Self::density(wi, wo)
    }

    fn lobes(&self) -> Vec<LobeInfo> {
        vec![LobeInfo::smooth("diffuse")]
    }

    fn sample(&self, wo: DVec3, _h: f64, u: [f64; 4]) -> Option<Sample> {
        // Offset across the visible width, and the surface normal it hits.
        let gamma = (2.0 * u[0] - 1.0).clamp(-1.0, 1.0).asin();
        let phi_n = phi(wo) + gamma;
        let n = DVec3::new(0.0, phi_n.cos(), phi_n.sin());
        let wi = cosine_hemisphere(n, DVec3::X, u[1], u[2]);
        Some(Sample { wi, weight: self.albedo, pdf: Self::density(wi, wo), delta: false, lobe: 0 })
    }
}
