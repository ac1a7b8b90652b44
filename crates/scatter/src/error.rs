//! Errors raised when a model is constructed from invalid parameters.

use crate::params::ParameterError;
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
