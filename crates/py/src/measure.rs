//! `fiberlab._native.measure`: the virtual goniophotometer (`fiberlab_gonio`), with the fiber
//! built from its parameters by the same conversion as `fiberlab measure`
//! ([`fiberlab_gonio::Fiber::from_raw`]).

use crate::raw_value;
use fiberlab_gonio::{Fiber, Measurement, Setup};
use numpy::IntoPyArray;
use numpy::ndarray::{Array1, Array3};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

/// Measures `fiber` (a dict of `fiberlab measure --param` keys; angles in degrees, as in a
/// fiber TOML file) at each light inclination of `theta_i` (radians) and azimuth `phi_i`
/// (radians): one dict per inclination with `theta_i`, `phi_i`, `theta_r` `(nθ,)` and `phi`
/// `(nφ,)` bin centres (radians), `lobes` (name → `{f, std}` `(nθ, nφ, 3)` in sr⁻¹ and
/// `albedo` `(3,)`), and the `traced`, `missed`, `dropped` ray counts. Ctrl-C
/// (KeyboardInterrupt) stops the measurement and raises it.
#[pyfunction]
#[allow(clippy::too_many_arguments)]
pub(crate) fn measure<'py>(
    py: Python<'py>,
    fiber: &Bound<'py, PyDict>,
    theta_i: Vec<f64>,
    phi_i: f64,
    rays: usize,
    bins_theta: usize,
    bins_phi: usize,
    seed: u64,
) -> PyResult<Bound<'py, PyList>> {
    let mut pairs = Vec::new();
    for (k, v) in fiber.iter() {
        let key: String = k.extract().map_err(|_| PyValueError::new_err("fiber parameter names must be strings"))?;
        let raw = raw_value(&key, &v)?;
        pairs.push((key, raw));
    }
    let fiber = Fiber::from_raw(&pairs).map_err(|e| PyValueError::new_err(e.to_string()))?;
    if rays == 0 {
        return Err(PyValueError::new_err("measure: rays must be at least 1"));
    }
    if bins_theta == 0 || bins_phi == 0 {
        return Err(PyValueError::new_err(format!(
            "measure: bins must be two positive integers, got ({bins_theta}, {bins_phi})"
        )));
    }
    if theta_i.is_empty() {
        return Err(PyValueError::new_err("measure: theta_i needs at least one inclination"));
    }
    if !phi_i.is_finite() {
        return Err(PyValueError::new_err(format!("measure: phi_i = {phi_i} is not finite")));
    }
    let setups: Vec<Setup> =
        theta_i.iter().map(|&t| Setup { theta_i: t, phi_i, rays, bins_theta, bins_phi, seed }).collect();
    setups[0].check_bins().map_err(|e| PyValueError::new_err(e.to_string()))?;
    // The command line's check: one measurement in flight and the tables of every incidence.
    let kept = setups[0]
        .bin_count()
        .and_then(|b| b.checked_mul(fiberlab_gonio::RESULT_BYTES_PER_BIN))
        .and_then(|b| b.checked_mul(setups.len() as u64));
    crate::check_memory(&[
        fiberlab_io::memory_budget::Need::new(
            format!("goniophotometer bins {bins_theta}×{bins_phi}"),
            setups[0].estimated_bytes(rayon::current_num_threads()),
        ),
        fiberlab_io::memory_budget::Need::new(format!("tables of {} incidences", setups.len()), kept),
    ])?;
    let measurements = crate::interrupt::interruptible(
        py,
        |stop| {
            setups
                .iter()
                .map(|s| fiberlab_gonio::measure(&fiber, s, stop, |_| {}))
                .collect::<Result<Vec<Measurement>, _>>()
        },
        |_| Ok(()),
    )?;
    let measurements = measurements.map_err(|e| PyValueError::new_err(e.to_string()))?;
    let list = PyList::empty(py);
    for m in &measurements {
        list.append(measurement_dict(py, m)?)?;
    }
    Ok(list)
}

fn measurement_dict<'py>(py: Python<'py>, m: &Measurement) -> PyResult<Bound<'py, PyDict>> {
    let (nt, np) = (m.setup.bins_theta, m.setup.bins_phi);
    let d = PyDict::new(py);
    d.set_item("theta_i", m.setup.theta_i)?;
    d.set_item("phi_i", m.setup.phi_i)?;
    let theta_r: Vec<f64> = (0..nt).map(|i| m.bin_centre(i, 0).0).collect();
    let phi: Vec<f64> = (0..np).map(|j| m.bin_centre(0, j).1).collect();
    d.set_item("theta_r", Array1::from_vec(theta_r).into_pyarray(py))?;
    d.set_item("phi", Array1::from_vec(phi).into_pyarray(py))?;
    let table = |v: &[fiberlab_math::Rgb]| {
        let flat: Vec<f64> = v.iter().flat_map(|c| [c[0], c[1], c[2]]).collect();
        Array3::from_shape_vec((nt, np, 3), flat).expect("one RGB value per bin").into_pyarray(py)
    };
    let lobes = PyDict::new(py);
    for (name, lobe) in Measurement::LOBE_NAMES.iter().zip(&m.lobes) {
        let l = PyDict::new(py);
        l.set_item("f", table(&lobe.f))?;
        l.set_item("std", table(&lobe.std))?;
        l.set_item("albedo", Array1::from_vec(vec![lobe.albedo[0], lobe.albedo[1], lobe.albedo[2]]).into_pyarray(py))?;
        lobes.set_item(*name, l)?;
    }
    d.set_item("lobes", lobes)?;
    d.set_item("traced", m.traced)?;
    d.set_item("missed", m.missed)?;
    d.set_item("dropped", m.dropped)?;
    d.set_item("masked", m.masked)?;
    Ok(d)
}
