//! `fiberlab._native._bench_eval_rust`: the reference time of the evaluation benchmark
//! (`crates/py/bench/eval_throughput.py`).

use crate::{PyModel, Quantity, check_inputs, eval_loop, slice};
use numpy::PyReadonlyArray1;
use numpy::PyReadonlyArray2;
use pyo3::prelude::*;

/// Seconds the parallel f_s loop behind `Model.eval_fs` takes in Rust over flat arrays checked
/// beforehand (the loop itself, as in `eval_fs`, still tests each element as it reads it; the
/// output allocation is included, Python and the array conversion are not).
#[pyfunction]
pub(crate) fn _bench_eval_rust(
    py: Python<'_>,
    model: &PyModel,
    wi: PyReadonlyArray2<'_, f64>,
    wo: PyReadonlyArray2<'_, f64>,
    h: PyReadonlyArray1<'_, f64>,
) -> PyResult<f64> {
    let (wi, wo, h) = (slice("wi", &wi)?, slice("wo", &wo)?, slice("h", &h)?);
    check_inputs(&[("wi", wi), ("wo", wo)], h, h.len())?;
    Ok(py.detach(|| {
        let start = std::time::Instant::now();
        let out = eval_loop(&model.model, wi, wo, h, Quantity::Fs).expect("checked");
        let seconds = start.elapsed().as_secs_f64();
        std::hint::black_box(out);
        seconds
    }))
}
