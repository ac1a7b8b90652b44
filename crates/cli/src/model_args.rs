//! `--model NAME --param key=value …`, shared by every verb that builds a model.

use anyhow::Context;
use fiberlab_scatter::{Model, params::split_key_value};

/// Selects a registered model and its parameters.
#[derive(clap::Args, Clone, Debug)]
pub struct ModelArgs {
    /// Model name (`fiberlab models` lists them).
    #[arg(long)]
    pub model: String,
    /// Parameter as KEY=VALUE (repeatable); colours as one number or r,g,b.
    #[arg(long = "param", value_name = "KEY=VALUE")]
    pub params: Vec<String>,
}

impl ModelArgs {
    /// The `key=value` pairs.
    pub fn pairs(&self) -> anyhow::Result<Vec<(String, String)>> {
        self.params.iter().map(|p| split_key_value(p).map_err(anyhow::Error::from)).collect()
    }

    /// Builds the model, with an error naming the model on failure.
    pub fn build(&self) -> anyhow::Result<Model> {
        fiberlab_scatter::build(&self.model, &self.pairs()?).with_context(|| format!("model `{}`", self.model))
    }

    /// `name key=value …` for titles.
    pub fn label(&self) -> String {
        std::iter::once(self.model.clone()).chain(self.params.iter().cloned()).collect::<Vec<_>>().join(" ")
    }
}
