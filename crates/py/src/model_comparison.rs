//! `fiberlab._native.compare_model` and `evaluate`: a model against a measured table and
//! the colour-matched evaluation of hair models, each one call of `fiberlab_compare` — the
//! calls `fiberlab compare-model` and `fiberlab evaluate` make — returning the JSON those
//! print (`--json`, `metrics.json`).

use crate::PyModel;
use fiberlab_compare::evaluation::{EvaluationRequest, KajiyaKayColour, evaluate as evaluate_models};
use fiberlab_compare::model_table::{CompareOptions, compare_model as compare_with_table};
use fiberlab_io::table::{TableKind, read, read_kind};
use numpy::PyReadonlyArray3;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;

fn value_error(e: impl std::fmt::Display) -> PyErr {
    PyValueError::new_err(e.to_string())
}

/// `model` against the table at `table` (written by `fiberlab measure`, fiber or surface):
/// the JSON text of `fiberlab compare-model --json`.
#[pyfunction]
#[pyo3(signature = (model, table, subsamples = 3, viewer_first = false))]
pub(crate) fn compare_model(
    py: Python<'_>,
    model: &PyModel,
    table: PathBuf,
    subsamples: usize,
    viewer_first: bool,
) -> PyResult<String> {
    let kind = read_kind(&table).map_err(value_error)?;
    let data = read(&table).map_err(value_error)?;
    let options = CompareOptions { subsamples, viewer_first };
    let request = &model.request;
    let comparison = py.detach(|| compare_with_table(&data, kind, request, options)).map_err(|e| match kind {
        TableKind::Surface => value_error(format!("{}: {e}", table.display())),
        _ => value_error(e),
    })?;
    serde_json::to_value(&comparison).map(|v| v.to_string()).map_err(value_error)
}

/// The evaluation of `models` (name → dict of parameters, in order) in the scene (a path,
/// TOML text, or the default scene), against the render of the measured model of `table` or
/// against `reference` (`(H, W, 3)` linear RGB): `(metrics, images)`, `metrics` the JSON
/// text of `metrics.json`, `images` name → `(H, W, 3)` float32 (`reference` and each model).
#[pyfunction]
#[pyo3(signature = (path, text, models, table, reference, spp, reference_spp, kajiya_kay_colour))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn evaluate<'py>(
    py: Python<'py>,
    path: Option<PathBuf>,
    text: Option<String>,
    models: Vec<(String, Bound<'py, PyDict>)>,
    table: Option<PathBuf>,
    reference: Option<PyReadonlyArray3<'py, f64>>,
    spp: Option<u32>,
    reference_spp: u32,
    kajiya_kay_colour: &str,
) -> PyResult<(String, Bound<'py, PyDict>)> {
    let file = crate::scene_file(path.as_deref(), text.as_deref(), "evaluate")?;
    let mut entries = Vec::new();
    for (name, params) in &models {
        let mut pairs = Vec::new();
        for (k, v) in params.iter() {
            let key: String = k.extract().map_err(|_| value_error("parameter names must be strings"))?;
            pairs.push((key.clone(), crate::raw_value(&key, &v)?));
        }
        entries.push((name.clone(), pairs));
    }
    let request = EvaluationRequest {
        models: entries,
        table,
        reference_image: reference.as_ref().map(|r| crate::compare::image("reference", r)).transpose()?,
        spp,
        reference_spp,
        kajiya_kay_colour: KajiyaKayColour::parse(kajiya_kay_colour).map_err(value_error)?,
    };
    let (reference, results) = py.detach(|| {
        let (mut scene, settings) = file.build().map_err(value_error)?;
        evaluate_models(&mut scene, &settings, &request, |_| {}).map_err(value_error)
    })?;
    let rows: Vec<_> = results.iter().map(|r| r.row(reference.noise())).collect();
    let images = PyDict::new(py);
    images.set_item("reference", crate::image_array(py, &reference.linear_image()))?;
    for r in &results {
        images.set_item(&r.entry.name, crate::image_array(py, &r.render.linear_image()))?;
    }
    Ok((serde_json::to_string(&rows).map_err(value_error)?, images))
}
