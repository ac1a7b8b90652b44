//! The one way a scattering model is built from user input (scene files, `--model/--param`,
//! `--params-file`): any registered model from its name and `(key, value)` pairs, with the
//! external data its specification asks for ([`ModelSpec::data`]) loaded here — the I/O a
//! pure scattering crate cannot do.

use crate::measured_table::{TableError, load_measured};
use fiberlab_scatter::params::{ParamSet, RawValue};
use fiberlab_scatter::{ExternalData, Model, ModelError, ModelSpec};
use std::path::Path;
use thiserror::Error;

/// Why a model could not be loaded.
#[non_exhaustive]
#[derive(Debug, Error)]
pub enum LoadError {
    /// Unknown model, unknown key, bad or out-of-range value, missing data parameter.
    #[error(transparent)]
    Model(#[from] ModelError),
    /// The model's data file could not be read or used.
    #[error(transparent)]
    Table(#[from] TableError),
}

/// Builds model `name` from `pairs` (converted and validated against its specification);
/// a model built from data reads it, relative paths resolved against `base` (the scene
/// file's directory; an empty path for the working directory).
pub fn load_model<K: AsRef<str>>(name: &str, pairs: &[(K, RawValue)], base: &Path) -> Result<Model, LoadError> {
    let spec: &ModelSpec = fiberlab_scatter::find(name)?;
    let params = ParamSet::from_raw(spec.name, spec.params, pairs)?;
    match spec.data {
        None => Ok((spec.build)(&params)?),
        Some(ExternalData::Table { key }) => {
            let path = params.text(key).ok_or(ModelError::NeedsData { model: spec.name, key })?;
            Ok(load_measured(&base.join(path))?.into())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn models_without_data_build_like_the_registry() {
        let pairs = [("lobes", RawValue::List(vec!["r".into(), "tt".into()])), ("glints", RawValue::Bool(false))];
        let loaded = load_model("marschner", &pairs, Path::new("")).unwrap();
        let built = fiberlab_scatter::build("marschner", &[("lobes", "r,tt"), ("glints", "off")]).unwrap();
        assert_eq!(format!("{loaded:?}"), format!("{built:?}"));
        let e = load_model("marschner", &[("nope", RawValue::Number(1.0))], Path::new("")).unwrap_err();
        assert!(matches!(e, LoadError::Model(ModelError::UnknownParameter { .. })), "{e}");
    }

    #[test]
    fn a_model_built_from_a_table_reads_it_relative_to_the_base() {
        let e = load_model::<&str>("measured", &[], Path::new("")).unwrap_err();
        assert!(matches!(e, LoadError::Model(ModelError::NeedsData { key: "table", .. })), "{e}");
        let dir = tempfile::tempdir().unwrap();
        let e = load_model("measured", &[("table", RawValue::from("t.csv"))], dir.path()).unwrap_err();
        assert!(
            matches!(e, LoadError::Table(_)) && e.to_string().contains(&dir.path().join("t.csv").display().to_string()),
            "{e}"
        );
    }
}
