//! `fiberlab._native.compare`: the image metrics of `fiberlab compare`
//! ([`fiberlab_io::image_metrics`]) on arrays.

use fiberlab_io::image_metrics::{Image, compare as image_compare};
use numpy::{PyReadonlyArray3, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

pub(crate) fn image(name: &str, a: &PyReadonlyArray3<'_, f64>) -> PyResult<Image> {
    let shape = a.shape();
    if shape[2] != 3 {
        return Err(PyValueError::new_err(format!("{name}: expected shape (H, W, 3), got {shape:?}")));
    }
    let v = crate::slice(name, a)?;
    Ok(Image { width: shape[1], height: shape[0], pixels: v.chunks_exact(3).map(|p| [p[0], p[1], p[2]]).collect() })
}

/// Metrics of `b` against the reference `a` (`(H, W, 3)` linear RGB float64): a dict with
/// `rmse`, `relmse`, `ssim`, `flip` (and `scale`, the per-channel factors, with `align`);
/// `mask` `(H, W, 3)` selects the pixels whose mean is above one half.
#[pyfunction]
#[pyo3(signature = (a, b, mask = None, align = false))]
pub(crate) fn compare<'py>(
    py: Python<'py>,
    a: PyReadonlyArray3<'py, f64>,
    b: PyReadonlyArray3<'py, f64>,
    mask: Option<PyReadonlyArray3<'py, f64>>,
    align: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let (a, b) = (image("a", &a)?, image("b", &b)?);
    let mask = mask.as_ref().map(|m| image("mask", m)).transpose()?;
    let (m, _) =
        py.detach(|| image_compare(&a, &b, mask.as_ref(), align)).map_err(|e| PyValueError::new_err(e.to_string()))?;
    let d = PyDict::new(py);
    d.set_item("rmse", m.rmse)?;
    d.set_item("relmse", m.relmse)?;
    d.set_item("ssim", m.ssim)?;
    d.set_item("flip", m.flip)?;
    if let Some(s) = m.scale {
        d.set_item("scale", s.to_vec())?;
    }
    Ok(d)
}
