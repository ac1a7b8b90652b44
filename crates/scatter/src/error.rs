//! Errors raised when a model is constructed from invalid parameters.

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
    /// NaN or ±∞.
    #[error("parameter `{key}` = {value} is not finite; valid range {range}")]
    NotFinite {
        /// Parameter key.
        key: String,
        /// The offending value.
        value: f64,
        /// The valid range.
        range: String,
    },
    /// A finite value outside the valid range.
    #[error("parameter `{key}` = {value} is out of range; valid range {range}")]
    OutOfRange {
        /// Parameter key.
        key: String,
        /// The offending value.
        value: f64,
        /// The valid range.
        range: String,
    },
    /// The same key was given more than once.
    #[error("parameter `{key}` is given more than once")]
    Duplicate {
        /// Parameter key.
        key: String,
    },
    /// Parameters that are individually valid but inconsistent together.
    #[error("{0}")]
    Inconsistent(String),
}
