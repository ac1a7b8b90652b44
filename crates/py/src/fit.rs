//! `fiberlab._native.fit`: `fiberlab fit`'s weighted least squares ([`fiberlab_fit`]) on
//! arrays of observations.

use crate::{direction, raw_value, slice};
use fiberlab_fit::{Channel, FitOptions, FreeParam, Observation, Uncertainty, fit_with};
use fiberlab_scatter::params::ParamSet;
use numpy::{PyReadonlyArray1, PyReadonlyArray2};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// Fits the parameters `init` (key → starting number, or `[r, g, b]` for a colour fitted per
/// channel) of model `model` with the others `fixed`, to observations: directions `wi`, `wo`
/// `(N, 3)`, measured f_s `value` `(N,)` (sr⁻¹) with standard errors `sigma` `(N,)`, each of
/// `channel` `(N,)` (−1 luminance, 0, 1, 2 red, green, blue). Returns a dict: `params`
/// (key → number or `[r, g, b]`), `uncertainty` (fitted number → σ, or the reason none can be
/// given), `at_bound` (fitted number → the bound it ended on), `chi2`, `dof`, `iterations`.
#[pyfunction]
#[pyo3(signature = (model, fixed, init, wi, wo, value, sigma, channel, max_iters = 400))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn fit<'py>(
    py: Python<'py>,
    model: &str,
    fixed: &Bound<'py, PyDict>,
    init: &Bound<'py, PyDict>,
    wi: PyReadonlyArray2<'py, f64>,
    wo: PyReadonlyArray2<'py, f64>,
    value: PyReadonlyArray1<'py, f64>,
    sigma: PyReadonlyArray1<'py, f64>,
    channel: PyReadonlyArray1<'py, i64>,
    max_iters: u64,
) -> PyResult<Bound<'py, PyDict>> {
    let value_error = |e: &dyn std::fmt::Display| PyValueError::new_err(e.to_string());
    let spec = fiberlab_scatter::find(model).map_err(|e| value_error(&e))?;
    let mut pairs = Vec::new();
    for (k, v) in fixed.iter() {
        let key: String = k.extract()?;
        pairs.push((key.clone(), raw_value(&key, &v)?));
    }
    let base = ParamSet::from_raw(spec.name, spec.params, &pairs).map_err(|e| value_error(&e))?;
    let mut free = Vec::new();
    for (k, v) in init.iter() {
        let key: String = k.extract()?;
        let start = match v.extract::<f64>() {
            Ok(x) => vec![x],
            Err(_) => v
                .extract::<Vec<f64>>()
                .map_err(|_| PyValueError::new_err(format!("init `{key}`: expected a starting number or [r, g, b]")))?,
        };
        free.push(FreeParam { key, start });
    }
    let (wi, wo, value, sigma) =
        (slice("wi", &wi)?, slice("wo", &wo)?, slice("value", &value)?, slice("sigma", &sigma)?);
    let channel =
        channel.as_slice().map_err(|_| PyValueError::new_err("channel: expected a C-contiguous int array"))?;
    let n = value.len();
    if wi.len() != 3 * n || wo.len() != 3 * n || sigma.len() != n || channel.len() != n {
        return Err(PyValueError::new_err(format!(
            "expected {n} observations in wi, wo (N, 3), sigma and channel (N,)"
        )));
    }
    let mut data = Vec::with_capacity(n);
    for k in 0..n {
        let (Some(a), Some(b)) = (direction(wi, k), direction(wo, k)) else {
            return Err(PyValueError::new_err(format!("observation {k}: wi and wo must be finite unit vectors")));
        };
        let channel = match channel[k] {
            -1 => Channel::Luminance,
            c @ 0..=2 => Channel::Rgb(c as usize),
            c => return Err(PyValueError::new_err(format!("channel[{k}] = {c}: expected -1 (luminance), 0, 1 or 2"))),
        };
        data.push(Observation { wi: a, wo: b, value: value[k], sigma: sigma[k], channel });
    }
    let options = FitOptions { max_iters, ..FitOptions::default() };
    let r = py.detach(|| fit_with(&base, &free, &data, &options)).map_err(|e| value_error(&e))?;
    let out = PyDict::new(py);
    let params = PyDict::new(py);
    for (key, v) in &r.values {
        if v.len() == 1 {
            params.set_item(key, v[0])?;
        } else {
            params.set_item(key, v.clone())?;
        }
    }
    let uncertainty = PyDict::new(py);
    let at_bound = PyDict::new(py);
    for (((name, _), u), b) in r.params.iter().zip(&r.uncertainties).zip(&r.at_bound) {
        match u {
            Uncertainty::Sigma(s) => uncertainty.set_item(name, *s)?,
            Uncertainty::Undefined(why) => uncertainty.set_item(name, why.to_string())?,
        }
        if let Some(b) = b {
            at_bound.set_item(name, b.bound)?;
        }
    }
    out.set_item("params", params)?;
    out.set_item("uncertainty", uncertainty)?;
    out.set_item("at_bound", at_bound)?;
    out.set_item("chi2", r.chi2)?;
    out.set_item("dof", r.dof)?;
    out.set_item("iterations", r.iterations)?;
    Ok(out)
}
