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
    /// A TOML file with a `[params]` table (e.g. written by `fiberlab fit`); --param overrides it.
    #[arg(long, value_name = "FILE.toml")]
    pub params_file: Option<std::path::PathBuf>,
}

impl ModelArgs {
    /// The `key=value` pairs: the params file's, then `--param` (which wins).
    pub fn pairs(&self) -> anyhow::Result<Vec<(String, String)>> {
        let mut pairs = match &self.params_file {
            Some(path) => read_params_file(path, &self.model)?,
            None => Vec::new(),
        };
        for p in &self.params {
            let (k, v) = split_key_value(p)?;
            pairs.retain(|(key, _)| *key != k);
            pairs.push((k, v));
        }
        Ok(pairs)
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
    let model = fiberlab_render::measured_table::load_measured(&path).map_err(anyhow::Error::msg)?;
    Ok(model.into())
}

/// `[params]` of a TOML file as strings; a `model` key, if present, must match `model`.
fn read_params_file(path: &std::path::Path, model: &str) -> anyhow::Result<Vec<(String, String)>> {
    let text = std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    let table: toml::Table = text.parse().map_err(|e: toml::de::Error| {
        let (line, col) = e.span().map_or((0, 0), |s| crate::measure::line_col(&text, s.start));
        anyhow::anyhow!("{}: line {line}, column {col}: {}", path.display(), e.message())
    })?;
    if let Some(m) = table.get("model").and_then(|v| v.as_str())
        && m != model
    {
        anyhow::bail!("{}: parameters are for model `{m}`, not `{model}`", path.display());
    }
    let Some(params) = table.get("params").and_then(|v| v.as_table()) else {
        anyhow::bail!("{}: expected a [params] table", path.display());
    };
    params
        .iter()
        .map(|(k, v)| {
            let value = match v {
                toml::Value::String(s) => s.clone(),
                toml::Value::Float(x) => x.to_string(),
                toml::Value::Integer(x) => x.to_string(),
                toml::Value::Array(a) => a.iter().map(|x| x.to_string()).collect::<Vec<_>>().join(","),
                _ => anyhow::bail!("{}: [params] `{k}`: expected a string, number or array", path.display()),
            };
            Ok((k.clone(), value))
        })
        .collect()
}
