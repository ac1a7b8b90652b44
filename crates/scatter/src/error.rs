//! Errors raised when a model is constructed from invalid parameters.

use std::fmt;
use thiserror::Error;

/// Why a model could not be built. Every message names the parameter and what is valid.
#[non_exhaustive]
#[derive(Clone, Debug, Error, PartialEq)]
pub enum ModelError {
    /// No model has this name.
    #[error("unknown model `{name}`; known models: {known}")]
    UnknownModel {
        /// The name given.
        name: String,
        /// Comma-separated list of registered names.
        known: String,
    },
    /// The model has no parameter with this key.
    #[error("model `{model}` has no parameter `{key}`; its parameters are: {known}")]
    UnknownParameter {
        /// Model name.
        model: String,
        /// The key given.
        key: String,
        /// Comma-separated list of valid keys.
        known: String,
    },
    /// The value could not be parsed.
    #[error("parameter `{key}`: cannot read `{value}` as {expected}")]
    BadValue {
        /// Parameter key.
        key: String,
        /// The text given.
        value: String,
        /// What was expected, e.g. "a number" or "one of r, tt, trt".
        expected: String,
    },
    /// A value outside its valid range (NaN, ±∞ or finite but out of range).
    #[error(transparent)]
    Parameter(#[from] ParameterError),
    /// The same key was given more than once.
    #[error("parameter `{key}` is given more than once")]
    Duplicate {
        /// Parameter key.
        key: String,
    },
    /// Parameters that are individually valid but inconsistent together.
    #[error("{0}")]
    Inconsistent(String),
    /// The model is built from external data (see [`crate::ExternalData`]) that the caller
    /// must load; its parameters alone cannot build it.
    #[error("model `{model}` is built from a table file: give its path as `{key}=PATH`")]
    NeedsData {
        /// Model name.
        model: &'static str,
        /// The parameter that names the data file.
        key: &'static str,
    },
    /// A model's reader asked for a parameter its specification does not define with that
    /// kind: a programming error in the model, reported instead of panicking.
    #[error("model `{model}`: its specification has no {kind} parameter `{key}`")]
    Specification {
        /// Model name.
        model: &'static str,
        /// The key asked for.
        key: String,
        /// The kind asked for.
        kind: &'static str,
    },
}

/// A value outside its parameter's valid range, named by the parameter's key. Shared by
/// every model's error type (each model's `XError` wraps it).
#[non_exhaustive]
#[derive(Clone, Debug, Error, PartialEq)]
pub enum ParameterError {
    /// NaN or ±∞.
    #[error("parameter `{key}` = {} is not finite; valid range {range}", Shown(*.value))]
    NotFinite {
        /// Parameter key.
        key: &'static str,
        /// The offending value.
        value: f64,
        /// The valid range, with its unit.
        range: String,
    },
    /// A finite value outside the valid range.
    #[error("parameter `{key}` = {} is out of range; valid range {range}", Shown(*.value))]
    OutOfRange {
        /// Parameter key.
        key: &'static str,
        /// The offending value (in the range's unit).
        value: f64,
        /// The valid range, with its unit.
        range: String,
    },
}

impl ParameterError {
    /// The key of the parameter at fault.
    #[must_use]
    pub fn key(&self) -> &'static str {
        match self {
            ParameterError::NotFinite { key, .. } | ParameterError::OutOfRange { key, .. } => key,
        }
    }
}

/// A number as a person reads it: twelve significant digits, plain for ordinary magnitudes,
/// in exponent form for huge or tiny ones (so 1e308 is not printed with 309 digits).
pub(crate) struct Shown(pub(crate) f64);

impl fmt::Display for Shown {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        // Twelve significant digits: hides the rounding of unit conversions (29.999999999999996°).
        let x = if self.0.is_finite() { format!("{:.11e}", self.0).parse().unwrap_or(self.0) } else { self.0 };
        if x.is_finite() && x != 0.0 && !(1e-4..1e7).contains(&x.abs()) { write!(f, "{x:e}") } else { write!(f, "{x}") }
    }
}
