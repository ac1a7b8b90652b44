//! Opening the GPU for the tests: every test needs an adapter. CI installs Mesa's lavapipe, so
//! there a missing adapter fails the test; `FIBERLAB_GPU_TESTS=skip` lets a machine without
//! any Vulkan driver skip them with a printed reason. The tests of one file share one device
//! (compiling the kernels takes seconds on lavapipe).

use fiberlab_gpu::{AdapterChoice, Gpu};
use std::sync::OnceLock;

/// The GPU (software emulations included), or `None` with the reason printed when the
/// environment asks to skip; panics when there is none otherwise.
pub fn gpu() -> Option<&'static Gpu> {
    static GPU: OnceLock<Result<Gpu, String>> = OnceLock::new();
    match GPU.get_or_init(|| Gpu::open(AdapterChoice::Any).map_err(|e| e.to_string())) {
        Ok(g) => {
            eprintln!("GPU tests on {}", g.adapter());
            Some(g)
        }
        Err(e) if std::env::var("FIBERLAB_GPU_TESTS").as_deref() == Ok("skip") => {
            eprintln!("skipping a GPU test (FIBERLAB_GPU_TESTS=skip): {e}");
            None
        }
        Err(e) => panic!("{e} (set FIBERLAB_GPU_TESTS=skip to skip the GPU tests on a machine without one)"),
    }
}
