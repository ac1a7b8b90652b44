//! What the registry knows of a model without depending on the [`crate::Model`] enum: its
//! [`ModelInfo`] (name, summary, citation, parameter table, external data) and the
//! [`Registered`] trait by which it is built from validated parameters. Model files
//! implement [`Registered`]; the registry (`model.rs`) lists the models, so dependencies
//! point one way: registry → models → this module.

use crate::ModelError;
use crate::params::{ParamSet, ParamSpec};

/// How a model appears on the command line and in scene files.
#[derive(Clone, Copy, Debug)]
pub struct ModelInfo {
    /// Name used on the command line (`--model NAME`) and in scene files.
    pub name: &'static str,
    /// One-line description.
    pub summary: &'static str,
    /// Paper or section the model implements.
    pub citation: &'static str,
    /// Parameters with units, defaults and valid ranges.
    pub params: &'static [ParamSpec],
    /// External data the model is built from, loaded by the caller (`None`: parameters
    /// alone build it).
    pub data: Option<ExternalData>,
}

/// External data a model is built from, which a pure crate cannot read: the caller (the
/// renderer's model loader) reads it and constructs the model.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ExternalData {
    /// A measured table file (`fiberlab measure` CSV), whose path is the text parameter `key`.
    Table {
        /// The parameter holding the path.
        key: &'static str,
    },
    /// An optional weave-pattern file (`fiberlab_io::weave_pattern` text) named by the text
    /// parameter `key`; without it the model builds from its parameters alone (a preset).
    WeavePattern {
        /// The parameter holding the path.
        key: &'static str,
    },
}

/// A model of the registry: its description and its construction from validated
/// parameters (each model's `XParams::from_param_set`, then `X::new`).
pub trait Registered: Sized {
    /// The model's registry entry.
    const INFO: ModelInfo;

    /// Builds the model from validated parameters ([`ModelError::NeedsData`] for a model
    /// with [`ModelInfo::data`]: the caller loads the data and builds it itself).
    fn from_param_set(p: &ParamSet) -> Result<Self, ModelError>;
}
