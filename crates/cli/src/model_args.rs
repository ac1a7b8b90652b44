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

    /// Builds the model, with an error naming the model on failure. `measured` loads its
    /// table (`table=PATH`, rows with lobe `all`).
    pub fn build(&self) -> anyhow::Result<Model> {
        let pairs = self.pairs()?;
        if self.model == "measured" {
            return build_measured(&pairs);
        }
        fiberlab_scatter::build(&self.model, &pairs).with_context(|| format!("model `{}`", self.model))
    }

    /// `name key=value …` for titles.
    pub fn label(&self) -> String {
        std::iter::once(self.model.clone()).chain(self.params.iter().cloned()).collect::<Vec<_>>().join(" ")
    }
}

/// `measured` from its `table=PATH` parameter.
fn build_measured(pairs: &[(String, String)]) -> anyhow::Result<Model> {
    let mut path = None;
    for (k, v) in pairs {
        match k.as_str() {
            "table" => path = Some(std::path::PathBuf::from(v)),
            _ => anyhow::bail!("model `measured` has no parameter `{k}`; its parameters are: table"),
        }
    }
    let path = path.context("model `measured`: give the table as --param table=PATH")?;
    let lobes = crate::table::read(&path)?;
    let all = lobes.get("all").with_context(|| format!("{}: no rows with lobe `all`", path.display()))?;
    let model =
        fiberlab_scatter::measured::Measured::new(all.to_table()).with_context(|| path.display().to_string())?;
    Ok(model.into())
}
