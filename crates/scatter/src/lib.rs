//! The fiber scattering-function interface ([`ScatteringFunction`]), the surface one
//! ([`SurfaceScattering`]), one file per model
//! (named after its paper), the shared hair core ([`hair`]), the [`Model`] enum and registry,
//! and curve radiometry.
//!
//! Pure: no I/O. Conventions (frame, angles, units) are those of [`fiberlab_math`]; every
//! `f_s` is in sr⁻¹ with `L_r = ∫ f_s L_i cosθ_i dω_i`, θ from the fiber's normal plane.
#![forbid(unsafe_code)]

mod error;
mod function;
pub mod hair;
mod model;
pub mod params;
pub mod radiometry;
pub mod sampling;
mod spec;
mod surface;
mod surface_model;

pub mod chiang_2016;
pub mod deon_2011;
pub mod dual_scattering_tables;
pub mod goldman_1997;
pub mod ideal_diffuse;
pub mod ideal_specular;
pub mod irawan_2012;
pub mod kajiya_kay_1989;
pub mod lambert_1760;
pub mod lambertian_cylinder;
pub mod marschner_2003;
pub mod marschner_2005;
pub mod measured;
pub mod sadeghi_2013;
pub mod yan_2017;

pub use error::ModelError;
pub use function::{ConeValue, Field, LobeInfo, Lobes, MIN_COS, Properties, Sample, ScatteringFunction};
pub use model::{ALL_MODELS, MODELS, Model, ModelSpec, build, build_raw, find};
pub use spec::{ExternalData, MARKDOWN_BEGIN, MARKDOWN_END, ModelInfo, Registered};
pub use surface::{FiberHighlight, SurfaceProperties, SurfaceScattering, not_texturable};
pub use surface_model::{
    ModelKind, RegistryEntry, SURFACE_MODELS, SurfaceModel, SurfaceModelSpec, build_surface, build_surface_raw,
    find_surface, lookup, registry,
};
