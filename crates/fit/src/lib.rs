//! Fitting scattering-model parameters to measured values by weighted least squares:
//! Nelder–Mead (the `argmin` crate) on `χ² = Σ ((f_s(ω_i, ω_o) − value)/σ)²`, polished by
//! Levenberg–Marquardt steps, then uncertainties from the Gauss–Newton covariance
//! `(JᵀJ)⁻¹·χ²/dof` at the optimum.
//!
//! Each observation is one number: the luminance of `f_s` in sr⁻¹, or one of its channels
//! ([`Channel`]); near-field models are averaged over h. A colour parameter is fitted **per
//! channel** (three free numbers) when the data has channels, since then the three channels
//! are three independent measurements and the colour (e.g. the absorption `sigma_a` of a
//! hair) is what one wants to know — one scale for a fixed colour would need its hue known in
//! advance. From luminance-only data the channels cannot be told apart, and a colour is fitted
//! as one grey value (all channels equal).
//!
//! A surface model is fitted to the bins of a surface table ([`fit_surface`]): each bin's
//! value is compared with the model's average over the bin ([`surface_bins`], midpoint nodes
//! in the table's `cosθ dω` measure), the table's fixed direction taken as the light's or
//! the viewer's ([`SurfaceBin::fixed_is_viewer`]).
//!
//! An uncertainty that the covariance cannot give is an [`Uncertainty::Undefined`] with the
//! reason, and a parameter that ends on (within [`BOUND_TOLERANCE`] of) an end of its valid
//! range is reported with that end ([`AtBound`]). Pure.
#![forbid(unsafe_code)]

pub mod observation;
pub mod outcome;
mod problem;
pub mod solve;
pub mod surface;
mod uncertainty;

pub use observation::{Channel, Observation, model_grid};
pub use outcome::{
    AtBound, BOUND_TOLERANCE, FitError, FitOptions, FitResult, FreeParam, MAX_CONDITION, Step, Stop, Trace,
    Uncertainty, Undefined,
};
pub use solve::{Constraint, POLISH_ITERATIONS, fit, fit_constrained, fit_with};
pub use surface::{BinObservation, SurfaceBin, SurfaceData, bin_averages, fit_surface, surface_bins};
