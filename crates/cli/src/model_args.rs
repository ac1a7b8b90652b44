//! `--model NAME --param key=value … --params-file FILE`, shared by every verb that builds a
//! model: the values become [`RawValue`]s (`--param` text as text, the file's TOML through
//! the renderer's shared conversion) and the model is built by the one model loader, which
//! also reads the data a model is built from (`measured`'s `table=PATH`).

use anyhow::Context;
use fiberlab_render::model_loader::ModelRequest;
use fiberlab_render::toml_params::raw_pairs;
use fiberlab_scatter::params::{RawValue, split_key_value};
use fiberlab_scatter::{Model, ModelKind, SurfaceModel, lookup};
use std::path::Path;

/// Selects a registered model and its parameters.
#[derive(clap::Args, Clone, Debug)]
pub struct ModelArgs {
    /// Model name (`fiberlab models` lists them).
    #[arg(long)]
    pub model: String,
    /// Parameter as KEY=VALUE (repeatable); colours as one number or r,g,b, lists as a,b.
    #[arg(long = "param", value_name = "KEY=VALUE")]
    pub params: Vec<String>,
    /// A TOML file with a `[params]` table (e.g. written by `fiberlab fit`); --param overrides it.
    #[arg(long, value_name = "FILE.toml")]
    pub params_file: Option<std::path::PathBuf>,
}

impl ModelArgs {
    /// The `(key, value)` pairs: the params file's, then `--param` (which wins).
    pub fn pairs(&self) -> anyhow::Result<Vec<(String, RawValue)>> {
        let mut pairs = match &self.params_file {
            Some(path) => read_params_file(path, &self.model)?,
            None => Vec::new(),
        };
        for p in &self.params {
            let (k, v) = split_key_value(p)?;
            pairs.retain(|(key, _)| *key != k);
            pairs.push((k, RawValue::Text(v)));
        }
        Ok(pairs)
    }

    /// The one validated request the libraries take (relative data paths relative to the
    /// working directory).
    pub fn request(&self) -> anyhow::Result<ModelRequest> {
        Ok(ModelRequest::new(self.model.clone(), self.pairs()?))
    }

    /// Builds the model, with an error naming the model on failure.
    pub fn build(&self) -> anyhow::Result<Model> {
        self.request()?.build().with_context(|| format!("model `{}`", self.model))
    }

    /// Which registry the model belongs to (an unknown name is an error listing both).
    pub fn kind(&self) -> anyhow::Result<ModelKind> {
        Ok(lookup(&self.model)?.kind())
    }

    /// Builds a surface model (a fiber model's name is an error saying so) through the one
    /// model loader: a weave-pattern file (`pattern=FILE`) relative to the working directory.
    pub fn build_surface(&self) -> anyhow::Result<SurfaceModel> {
        self.request()?.build_surface().with_context(|| format!("model `{}`", self.model))
    }

    /// Builds the model from whichever registry holds its name.
    pub fn build_any(&self) -> anyhow::Result<AnyModel> {
        Ok(match self.kind()? {
            ModelKind::Surface => AnyModel::Surface(self.build_surface()?),
            ModelKind::Fiber => AnyModel::Fiber(self.build()?),
        })
    }

    /// `name key=value …` for titles.
    pub fn label(&self) -> String {
        std::iter::once(self.model.clone()).chain(self.params.iter().cloned()).collect::<Vec<_>>().join(" ")
    }
}

/// A model of either registry, as the verbs that take both build it.
#[derive(Clone, Debug)]
pub enum AnyModel {
    /// A fiber scattering function.
    Fiber(Model),
    /// A surface BRDF.
    Surface(SurfaceModel),
}

/// `[params]` of a TOML file; a `model` key, if present, must match `model`.
fn read_params_file(path: &Path, model: &str) -> anyhow::Result<Vec<(String, RawValue)>> {
    let table = crate::files::read_toml(path)?;
    if let Some(m) = table.get("model").and_then(|v| v.as_str())
        && m != model
    {
        anyhow::bail!("{}: parameters are for model `{m}`, not `{model}`", path.display());
    }
    let Some(params) = table.get("params").and_then(|v| v.as_table()) else {
        anyhow::bail!("{}: expected a [params] table", path.display());
    };
    raw_pairs(params).with_context(|| format!("{}: [params]", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args(params: &[&str], file: Option<&Path>) -> ModelArgs {
        ModelArgs {
            model: "marschner".into(),
            params: params.iter().map(ToString::to_string).collect(),
            params_file: file.map(Path::to_path_buf),
        }
    }

    /// `lobes = ["r", "tt"]` and `glints = false` in a `--params-file` build the model that
    /// `--param lobes=r,tt --param glints=off` builds; `--param` overrides the file.
    #[test]
    fn params_file_arrays_and_booleans_mean_what_param_text_means() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("p.toml");
        std::fs::write(&file, "model = \"marschner\"\n[params]\nlobes = [\"r\", \"tt\"]\nglints = false\nbeta_r = 6\n")
            .unwrap();
        let text = args(&["lobes=r,tt", "glints=off", "beta_r=6"], None).build().unwrap();
        let from_file = args(&[], Some(&file)).build().unwrap();
        assert_eq!(format!("{from_file:?}"), format!("{text:?}"));
        let all_lobes = fiberlab_scatter::build("marschner", &[("glints", "off"), ("beta_r", "6")]).unwrap();
        assert_ne!(format!("{from_file:?}"), format!("{all_lobes:?}"), "the lobes were read");
        let overridden = args(&["lobes=r,tt,trt"], Some(&file)).build().unwrap();
        assert_eq!(format!("{overridden:?}"), format!("{all_lobes:?}"));
        std::fs::write(&file, "[params]\nlobes = [\"r\", \"x\"]\n").unwrap();
        let e = format!("{:#}", args(&[], Some(&file)).build().unwrap_err());
        assert!(e.contains("lobes") && e.contains("marschner"), "{e}");
        std::fs::write(&file, "model = \"chiang\"\n[params]\n").unwrap();
        let e = format!("{:#}", args(&[], Some(&file)).build().unwrap_err());
        assert!(e.contains("not `marschner`"), "{e}");
    }

    #[test]
    fn a_model_built_from_a_table_needs_its_path() {
        let m = ModelArgs { model: "measured".into(), params: vec![], params_file: None };
        let e = format!("{:#}", m.build().unwrap_err());
        assert!(e.contains("table=PATH"), "{e}");
    }
}
