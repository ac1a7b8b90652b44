//! The one way a scattering model is built from user input (scene files, `--model/--param`,
//! `--params-file`): any registered model from its name and `(key, value)` pairs, with the
//! external data its specification asks for ([`ModelSpec::data`]) loaded here — the I/O a
//! pure scattering crate cannot do.
//!
//! A measured table of **one incidence** is refused here ([`LoadError::OneIncidence`]):
//! the `measured` model interpolates between measured incidences, and a single slice says
//! nothing about light from any other inclination. Every use of a table as a scattering
//! function goes through this loader (scenes, `render`, `evaluate`, `eval`, `sample`,
//! `plot`, `fit`, the model side of `compare-model`), so the rule holds everywhere;
//! `compare-model --table` still reads such a table as measured data.

use crate::measured_table::{TableError, load_measured};
use fiberlab_io::weave_pattern::{WeavePatternError, read_weave_pattern};
use fiberlab_scatter::irawan_2012::Irawan2012;
use fiberlab_scatter::params::{ParamSet, RawValue};
use fiberlab_scatter::{ExternalData, Model, ModelError, ModelSpec, SurfaceModel};
use std::path::{Path, PathBuf};
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
    /// The weave-pattern file could not be read (the error names file, line and field).
    #[error(transparent)]
    Pattern(#[from] WeavePatternError),
    /// A measured table with a single incidence: nothing to interpolate between.
    #[error(
        "{}: the table holds one incidence (θ_i = {theta_deg}°); the `measured` model interpolates between \
         measured incidences and needs at least two: measure several, e.g. `fiberlab measure --theta-i \
         -60,-30,0,30,60`",
        path.display()
    )]
    OneIncidence {
        /// The table file.
        path: PathBuf,
        /// Its one incidence, degrees.
        theta_deg: f64,
    },
}

/// A model as a user asks for it: a registered name (fiber or surface) and `(key, value)`
/// pairs — from `--param` and `--params-file`, a scene's table, Python keywords or the
/// explorer's JSON — with the directory relative data paths are resolved against. The
/// command line, Python and the explorer build this one type and build models through it.
#[derive(Clone, Debug, PartialEq)]
pub struct ModelRequest {
    /// Registered name (`fiberlab models` lists them).
    pub name: String,
    /// Parameters, later pairs overriding earlier ones with the same key.
    pub params: Vec<(String, RawValue)>,
    /// Directory of relative data paths (a table, a weave pattern); empty: the working
    /// directory.
    pub base: PathBuf,
}

impl ModelRequest {
    /// Model `name` with `params`, data paths relative to the working directory.
    #[must_use]
    pub fn new(name: impl Into<String>, params: Vec<(String, RawValue)>) -> Self {
        Self { name: name.into(), params, base: PathBuf::new() }
    }

    /// The same request with `key` set to `value` (replacing a given value).
    #[must_use]
    pub fn with(&self, key: &str, value: RawValue) -> Self {
        let mut params: Vec<(String, RawValue)> = self.params.iter().filter(|(k, _)| k != key).cloned().collect();
        params.push((key.to_string(), value));
        Self { params, ..self.clone() }
    }

    /// The registry the name belongs to (an unknown name is an error listing both).
    pub fn kind(&self) -> Result<fiberlab_scatter::ModelKind, ModelError> {
        Ok(fiberlab_scatter::lookup(&self.name)?.kind())
    }

    /// The fiber model ([`load_model`]).
    pub fn build(&self) -> Result<Model, LoadError> {
        load_model(&self.name, &self.params, &self.base)
    }

    /// The surface model ([`load_surface_model`]).
    pub fn build_surface(&self) -> Result<SurfaceModel, LoadError> {
        load_surface_model(&self.name, &self.params, &self.base)
    }

    /// The fiber model reduced to the lobes `lobes` (a `lobes=` value such as `r` or
    /// `tts,trts`), or `None` when the model has no `lobes` parameter or does not know those
    /// names (a hair model without a medulla has no `tts`).
    pub fn build_lobes(&self, lobes: &str) -> Result<Option<Model>, LoadError> {
        let spec = fiberlab_scatter::find(&self.name)?;
        let Some(param) = spec.params.iter().find(|p| p.key == "lobes") else { return Ok(None) };
        if let fiberlab_scatter::params::ParamKind::Subset(names) = param.kind
            && !lobes.split(',').all(|l| names.contains(&l))
        {
            return Ok(None);
        }
        self.with("lobes", RawValue::from(lobes)).build().map(Some)
    }

    /// `name key=value …`, for titles and labels.
    #[must_use]
    pub fn label(&self) -> String {
        std::iter::once(self.name.clone())
            .chain(self.params.iter().map(|(k, v)| format!("{k}={v}")))
            .collect::<Vec<_>>()
            .join(" ")
    }
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
            let path = base.join(params.text(key).ok_or(ModelError::NeedsData { model: spec.name, key })?);
            let table = load_measured(&path)?;
            if let [theta] = table.incidences() {
                let theta_deg = (theta.to_degrees() * 1e6).round() / 1e6;
                return Err(LoadError::OneIncidence { path, theta_deg });
            }
            Ok(table.into())
        }
        Some(ExternalData::WeavePattern { .. }) => Ok((spec.build)(&params)?),
    }
}

/// Builds surface model `name` from `pairs`, like [`load_model`] for fiber models: a model
/// with a weave-pattern parameter (`irawan-2012`'s `pattern=FILE`) reads the file, a
/// relative path resolved against `base`.
pub fn load_surface_model<K: AsRef<str>>(
    name: &str,
    pairs: &[(K, RawValue)],
    base: &Path,
) -> Result<SurfaceModel, LoadError> {
    let spec = fiberlab_scatter::find_surface(name)?;
    let params = ParamSet::from_raw(spec.name, spec.params, pairs)?;
    match spec.data {
        Some(ExternalData::WeavePattern { key }) if params.text(key).is_some() => {
            let path = base.join(params.text(key).unwrap_or_default());
            let pattern = read_weave_pattern(&path)?;
            Ok(Irawan2012::from_param_set_with(&params, Some(pattern))?.into())
        }
        _ => Ok((spec.build)(&params)?),
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

    /// A table of `incidences` (degrees), 2×2 bins of 0.1 sr⁻¹, in `fiberlab measure`'s CSV.
    fn table_csv(incidences: &[f64]) -> String {
        let mut text = String::from("lobe,theta_i,phi_i,theta_r,phi_r,f_r,f_g,f_b,std_r,std_g,std_b\n");
        for ti in incidences {
            for tr in [-45.0, 45.0] {
                for p in [-90.0, 90.0] {
                    text.push_str(&format!("all,{ti},0,{tr},{p},0.1,0.1,0.1,0.01,0.01,0.01\n"));
                }
            }
        }
        text
    }

    /// One incidence is refused with a message naming the file, its incidence and the fix;
    /// two incidences load.
    #[test]
    fn a_table_of_one_incidence_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("one.csv"), table_csv(&[30.0])).unwrap();
        std::fs::write(dir.path().join("two.csv"), table_csv(&[0.0, 30.0])).unwrap();
        let e = load_model("measured", &[("table", RawValue::from("one.csv"))], dir.path()).unwrap_err();
        let text = e.to_string();
        assert!(matches!(e, LoadError::OneIncidence { theta_deg: 30.0, .. }), "{e}");
        assert!(text.contains("one.csv") && text.contains("θ_i = 30°") && text.contains("at least two"), "{text}");
        let two = load_model("measured", &[("table", RawValue::from("two.csv"))], dir.path()).unwrap();
        assert!(matches!(two, Model::Measured(ref m) if m.incidences().len() == 2));
    }
}
