//! The surface-scattering interface: a BRDF (possibly with delta lobes) in a local shading
//! frame, beside the fiber interface of [`crate::ScatteringFunction`].
//!
//! # Frame and units
//! Directions are unit vectors in the local frame of the surface point: `z` is the shading
//! normal, `x` the tangent (the direction of increasing texture coordinate `u`), `y = z × x`.
//! Both directions point away from the surface (`ω_i` toward the light, `ω_o` toward the
//! viewer). `f_r(ω_i, ω_o)` is in sr⁻¹ with
//! `L_r(ω_o) = ∫ f_r(ω_i, ω_o) L_i(ω_i) cosθ_i dω_i`, θ measured from the normal — the usual
//! BRDF, unlike the fiber convention where θ is measured from the normal plane
//! (`docs/theory/conventions.md`). Densities are per steradian.
//!
//! # Textured parameters
//! A surface model is a small value (no heap data): the renderer copies the material's model
//! at every hit and overwrites its textured parameters with [`SurfaceScattering::set_parameter`],
//! so that function must not allocate and must recompute whatever the model derives from the
//! parameter. Texel values are validated once, when the texture is loaded, against the
//! parameter's range in the model's parameter table.

use crate::{LobeInfo, ModelError, ModelInfo, Sample};
use fiberlab_math::{DVec3, Rgb};

/// What a surface model claims about itself; the validation harness tests exactly these.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SurfaceProperties {
    /// `f_r(ω_i, ω_o) = f_r(ω_o, ω_i)`.
    pub reciprocal: bool,
    /// Albedo `∫ f_r cosθ_o dω_o ≤ 1` (plus the delta lobes' throughput) for every `ω_i`.
    pub energy_conserving: bool,
    /// Some lobe is a Dirac delta (e.g. a smooth finish): `eval`/`pdf` leave it out and
    /// `sample` returns it with `pdf = 0` and [`Sample::delta`] set.
    pub has_delta: bool,
    /// Light may leave below the surface (`ω_i` and `ω_o` on opposite sides); when false,
    /// `eval` is 0 unless both directions have `z > 0`.
    pub transmits: bool,
}

/// A surface scattering function: evaluation, importance sampling and its density, in the
/// local frame (`z` = normal, `x` = tangent along `u`).
pub trait SurfaceScattering: Send + Sync {
    /// What the model claims.
    fn properties(&self) -> SurfaceProperties;

    /// `f_r(ω_i, ω_o)` in sr⁻¹ per colour channel (delta lobes left out).
    fn eval(&self, wi: DVec3, wo: DVec3) -> Rgb;

    /// Density (sr⁻¹) with which [`SurfaceScattering::sample`] draws `wi` given `wo`
    /// (delta lobes left out).
    fn pdf(&self, wi: DVec3, wo: DVec3) -> f64;

    /// `eval` and `pdf` together (models that share work between them override this).
    fn eval_and_pdf(&self, wi: DVec3, wo: DVec3) -> (Rgb, f64) {
        (self.eval(wi, wo), self.pdf(wi, wo))
    }

    /// Draws `ω_i` given `ω_o` from four independent uniforms in [0, 1); the weight is
    /// `f_r·|cosθ_i|/pdf` (for a delta lobe its throughput). `None` when no direction can be
    /// produced.
    fn sample(&self, wo: DVec3, u: [f64; 4]) -> Option<Sample>;

    /// The lobes `sample` chooses among, in the order of [`Sample::lobe`].
    fn lobes(&self) -> Vec<LobeInfo>;

    /// The keys [`SurfaceScattering::set_parameter`] accepts (a subset of the model's
    /// parameter table), so that a renderer can reject a texture bound to any other key when
    /// it loads the scene.
    fn texturable_keys(&self) -> &'static [&'static str];

    /// Replaces the parameter `key` (a key of the model's parameter table, in the units the
    /// library uses: radians for angles) by a texel value; scalar parameters read `value.r`.
    /// Must not allocate. An unknown or non-texturable key is an error.
    fn set_parameter(&mut self, key: &str, value: Rgb) -> Result<(), ModelError>;

    /// The fiber highlight of a surface whose shine comes from fibers under a finish
    /// (Marschner et al. 2005's wood), for comparisons with the single-fiber paths of a
    /// measured surface table; `None` for other surfaces (the default).
    fn fiber_highlight(&self) -> Option<&dyn FiberHighlight> {
        None
    }
}

/// A surface whose highlight comes from fibers below a dielectric finish: what a comparison
/// of its fiber term with a goniophotometer's single-fiber class needs.
pub trait FiberHighlight: Send + Sync {
    /// The unit fiber axis in the local frame.
    fn axis(&self) -> DVec3;
    /// A direction outside refracted through the finish (pointing back up).
    fn refract_in(&self, w: DVec3) -> DVec3;
    /// The fiber term's strength `k_f` (sr⁻¹ scale of its lobe).
    fn fiber_strength(&self) -> Rgb;
    /// `f_r` of the fiber term alone (through the finish, without the diffuse term and the
    /// finish's own reflection): what light scattered once by the fibers contributes.
    fn fiber_term(&self, wi: DVec3, wo: DVec3) -> Rgb;
}

/// The error [`SurfaceScattering::set_parameter`] returns for a key the model `info` cannot
/// texture (unknown, or not texturable), naming the model and its parameters.
#[must_use]
pub fn not_texturable(info: &ModelInfo, key: &str) -> ModelError {
    ModelError::UnknownParameter {
        model: info.name.into(),
        key: format!("{key} (as a textured parameter)"),
        known: info.params.iter().map(|s| s.key).collect::<Vec<_>>().join(", "),
    }
}
