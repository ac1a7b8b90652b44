//! `fiberlab._native.check`: the validation harness of `fiberlab check` (`fiberlab_check`)
//! for one model.

use crate::{AnyModel, PyModel};
use fiberlab_check::{Effort, check_model};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

/// Runs every check of the harness on `model` (what `fiberlab check` runs per
/// configuration): a list of dicts `{model, test, value, expected, tolerance, pass,
/// report}`; `report` rows are measurements without a pass/fail claim. The effort defaults
/// to the command line's.
#[pyfunction]
#[pyo3(signature = (model, label, chi2_samples = None, samples = None, pairs = None))]
pub(crate) fn check<'py>(
    py: Python<'py>,
    model: &PyModel,
    label: &str,
    chi2_samples: Option<usize>,
    samples: Option<usize>,
    pairs: Option<usize>,
) -> PyResult<Bound<'py, PyList>> {
    let d = Effort::default();
    let effort = Effort {
        chi2_samples: chi2_samples.unwrap_or(d.chi2_samples),
        samples: samples.unwrap_or(d.samples),
        pairs: pairs.unwrap_or(d.pairs),
    };
    let rows = py.detach(|| match &model.model {
        AnyModel::Fiber(m) => check_model(label, m, &effort),
        AnyModel::Surface(m) => fiberlab_check::surface::check_surface_model(label, m, &effort),
    });
    let list = PyList::empty(py);
    for r in rows {
        let d = PyDict::new(py);
        d.set_item("model", r.model)?;
        d.set_item("test", r.test)?;
        d.set_item("value", r.value)?;
        d.set_item("expected", r.expected)?;
        d.set_item("tolerance", r.tolerance)?;
        d.set_item("pass", r.pass)?;
        d.set_item("report", r.report)?;
        list.append(d)?;
    }
    Ok(list)
}
