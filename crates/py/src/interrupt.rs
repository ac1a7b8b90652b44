//! Long work (a render, a measurement) on a thread of its own while the calling thread —
//! the one Python delivers Ctrl-C to — watches for signals and reports progress: the one
//! Ctrl-C loop of the package.

use pyo3::prelude::*;
use std::sync::atomic::{AtomicBool, Ordering};

/// How often the calling thread checks for signals and calls `tick`.
const POLL: std::time::Duration = std::time::Duration::from_millis(50);

/// Runs `work(stop)` on a worker thread with the GIL released; about every 50 ms the calling
/// thread takes the GIL, checks for signals (KeyboardInterrupt) and calls `tick`. The first
/// error either raises sets `stop` (which `work` must honour) and is returned once `work`
/// has returned; otherwise `work`'s result.
pub(crate) fn interruptible<T: Send>(
    py: Python<'_>,
    work: impl FnOnce(&AtomicBool) -> T + Send,
    mut tick: impl FnMut(Python<'_>) -> PyResult<()> + Send,
) -> PyResult<T> {
    let (stop, finished) = (AtomicBool::new(false), AtomicBool::new(false));
    let mut interrupt: Option<PyErr> = None;
    let out = py.detach(|| {
        std::thread::scope(|threads| {
            let worker = threads.spawn(|| {
                let out = work(&stop);
                finished.store(true, Ordering::Release);
                out
            });
            while !finished.load(Ordering::Acquire) {
                std::thread::sleep(POLL);
                Python::attach(|py| {
                    if let Err(e) = py.check_signals().and_then(|()| tick(py))
                        && interrupt.is_none()
                    {
                        stop.store(true, Ordering::Relaxed);
                        interrupt = Some(e);
                    }
                });
            }
            worker.join().expect("the worker thread does not panic")
        })
    });
    match interrupt {
        Some(e) => Err(e),
        None => Ok(out),
    }
}
