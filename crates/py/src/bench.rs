//! `fiberlab._native._bench_rust`: the reference times of the throughput benchmark
//! (`crates/py/bench/eval_throughput.py`).

use crate::{AnyModel, PyModel, Quantity, SampleOutputs, check_inputs, eval_loop, sample_loop, slice};
use numpy::PyReadonlyArray1;
use numpy::PyReadonlyArray2;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

/// Seconds the parallel loop behind a `Model` method takes in Rust over flat arrays checked
/// beforehand: `what` is `"fs"` (`eval_fs`), `"fs_cos"` (`eval`), `"pdf"` (`pdf`) or
/// `"sample"` (`sample(wo, u, h)`; `wi` is not read). The loops, as in the methods, still
/// test each element as they read it. The output allocation is included, Python and the
/// array conversion are not (the methods allocate the same outputs through NumPy).
#[pyfunction]
#[allow(clippy::too_many_arguments)]
pub(crate) fn _bench_rust(
    py: Python<'_>,
    model: &PyModel,
    what: &str,
    wi: PyReadonlyArray2<'_, f64>,
    wo: PyReadonlyArray2<'_, f64>,
    h: PyReadonlyArray1<'_, f64>,
    u: PyReadonlyArray2<'_, f64>,
) -> PyResult<f64> {
    let (wi, wo, h, u) = (slice("wi", &wi)?, slice("wo", &wo)?, slice("h", &h)?, slice("u", &u)?);
    check_inputs(&[("wi", wi), ("wo", wo)], h, h.len())?;
    if u.len() != 4 * h.len() || u.iter().any(|x| !(0.0..1.0).contains(x)) {
        return Err(PyValueError::new_err("u: expected (N, 4) uniforms in [0, 1)"));
    }
    let quantity = match what {
        "fs" => Some(Quantity::Fs),
        "fs_cos" => Some(Quantity::FsCos),
        "pdf" => Some(Quantity::Pdf),
        "sample" => None,
        _ => return Err(PyValueError::new_err(format!("_bench_rust: unknown loop {what:?}"))),
    };
    Ok(py.detach(|| {
        let start = std::time::Instant::now();
        let n = h.len();
        match quantity {
            Some(q) => {
                let mut out = vec![0.0; q.width() * n];
                let valid = match &model.model {
                    AnyModel::Fiber(m) => eval_loop(m, wi, wo, h, q, &mut out),
                    AnyModel::Surface(m) => eval_loop(m, wi, wo, h, q, &mut out),
                };
                assert!(valid, "checked");
                std::hint::black_box(out);
            }
            None => {
                let (mut wi, mut weight, mut pdf, mut lobe) =
                    (vec![0.0; 3 * n], vec![0.0; 3 * n], vec![0.0; n], vec![0; n]);
                let out = SampleOutputs { wi: &mut wi, weight: &mut weight, pdf: &mut pdf, lobe: &mut lobe };
                let valid = match &model.model {
                    AnyModel::Fiber(m) => sample_loop(m, wo, u, h, out),
                    AnyModel::Surface(m) => sample_loop(m, wo, u, h, out),
                };
                assert!(valid, "checked");
                std::hint::black_box((wi, weight, pdf, lobe));
            }
        }
        start.elapsed().as_secs_f64()
    }))
}
