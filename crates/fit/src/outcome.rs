//! What a fit returns and how it fails: fitted values with their one-σ uncertainties (or why
//! an uncertainty cannot be given), the bounds a value ended on, χ² and the residuals.

use fiberlab_scatter::ModelError;
use fiberlab_scatter::params::Range;
use std::fmt;
use std::sync::Arc;
use thiserror::Error;

/// Why a fit could not be made.
#[non_exhaustive]
#[derive(Debug, Error)]
pub enum FitError {
    /// The starting parameters do not build a model.
    #[error("starting point: {0}")]
    Model(#[from] ModelError),
    /// Nothing to fit.
    #[error("{0}")]
    Setup(String),
    /// Observation data that cannot be used (the message names the file, line and column).
    #[error("{0}")]
    Data(String),
    /// The optimizer failed.
    #[error("optimizer: {0}")]
    Optimizer(String),
}

/// A free parameter and its starting value: one number, or three (r, g, b) for a colour
/// fitted per channel.
#[derive(Clone, Debug, PartialEq)]
pub struct FreeParam {
    /// The parameter's key.
    pub key: String,
    /// Starting value(s).
    pub start: Vec<f64>,
}

/// How to run a fit.
#[derive(Clone, Default)]
pub struct FitOptions {
    /// Largest number of optimizer iterations.
    pub max_iters: u64,
    /// Called with the iteration number after each optimizer iteration, then with
    /// `max_iters + k` before the k-th of at most [`crate::POLISH_ITERATIONS`] polishing steps.
    pub progress: Option<Arc<dyn Fn(u64) + Send + Sync>>,
    /// Called with the best point so far after each optimizer iteration and each polishing
    /// step that lowered χ² (for a live view of the convergence).
    pub trace: Option<Trace>,
    /// When set and answering true, the fit stops after the iteration in flight and returns
    /// the best point so far, with [`FitResult::interrupted`] (a signal handler's flag, a
    /// server request's cancellation).
    pub stop: Option<Stop>,
}

/// A question of [`FitOptions::stop`]: should the fit stop now?
pub type Stop = Arc<dyn Fn() -> bool + Send + Sync>;

/// A callback of [`FitOptions::trace`].
pub type Trace = Arc<dyn Fn(&Step) + Send + Sync>;

/// The best point of a fit in progress ([`FitOptions::trace`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Step {
    /// Optimizer iterations so far (polishing steps count on from `max_iters`).
    pub iteration: u64,
    /// The free numbers, named as in [`FitResult::params`].
    pub params: Vec<(String, f64)>,
    /// χ² there.
    pub chi2: f64,
}

/// Why a parameter's uncertainty is undefined.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Undefined {
    /// The parameter ended on its bound: χ² is not a parabola around an optimum there.
    AtBound,
    /// The residuals do not depend on the parameter (its Jacobian column is zero).
    NoEffect,
    /// The Jacobian's columns are (nearly) dependent: the data cannot separate this
    /// parameter from the others; the condition number of the scaled `JᵀJ`.
    IllConditioned(f64),
    /// The model cannot be built on either side of the value (no difference quotient).
    NoDerivative,
}

/// A one-σ uncertainty, or why there is none.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Uncertainty {
    /// One standard deviation.
    Sigma(f64),
    /// No uncertainty can be given, for this reason.
    Undefined(Undefined),
}

impl Uncertainty {
    /// The σ, if defined.
    #[must_use]
    pub fn sigma(self) -> Option<f64> {
        match self {
            Uncertainty::Sigma(s) => Some(s),
            Uncertainty::Undefined(_) => None,
        }
    }
}

impl fmt::Display for Undefined {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Undefined::AtBound => {
                f.write_str("the value is on its bound, where χ² has no minimum to measure a curvature at")
            }
            Undefined::NoEffect => f.write_str("the data do not depend on it (its column of the Jacobian is zero)"),
            Undefined::IllConditioned(c) => write!(
                f,
                "the Jacobian is ill-conditioned (condition number {c:.1e}): the data cannot tell it apart \
                 from the other free parameters"
            ),
            Undefined::NoDerivative => f.write_str("the model cannot be evaluated on either side of the value"),
        }
    }
}

/// A fitted value within [`BOUND_TOLERANCE`] of an end of its valid range.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AtBound {
    /// The end it is on.
    pub bound: f64,
    /// True for the lower end.
    pub lower: bool,
    /// The parameter's valid range.
    pub range: Range,
}

impl fmt::Display for AtBound {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let side = if self.lower { "lower" } else { "upper" };
        write!(f, "ended on its {side} bound {:?} (valid range {})", self.bound, self.range)
    }
}

/// A value ends on its bound when it is within this fraction of the range's width (or, for
/// a range open on one side, of `max(1, |bound|)`) of the bound.
pub const BOUND_TOLERANCE: f64 = 1e-3;

/// Condition number of the scaled `JᵀJ` above which the uncertainties are not given: the
/// central differences are good to about 1e-8 relative, so beyond 1e8 the inverse is noise.
pub const MAX_CONDITION: f64 = 1e8;

/// A fitted model.
#[derive(Clone, Debug)]
pub struct FitResult {
    /// Fitted numbers: `key` for a number or a grey colour, `key[r]`, `key[g]`, `key[b]` for
    /// a colour fitted per channel.
    pub params: Vec<(String, f64)>,
    /// One-σ uncertainty of each of `params`, or why it is undefined.
    pub uncertainties: Vec<Uncertainty>,
    /// For each of `params`, the bound it ended on, if any.
    pub at_bound: Vec<Option<AtBound>>,
    /// Fitted values per parameter key: one number, or r, g, b.
    pub values: Vec<(String, Vec<f64>)>,
    /// χ² at the optimum.
    pub chi2: f64,
    /// Degrees of freedom (observations − free numbers).
    pub dof: usize,
    /// Normalized residuals `(f − value)/σ` per observation.
    pub residuals: Vec<f64>,
    /// Optimizer iterations.
    pub iterations: u64,
    /// Stopped by [`FitOptions::stop`] before it converged: the best point so far (not
    /// polished).
    pub interrupted: bool,
}
