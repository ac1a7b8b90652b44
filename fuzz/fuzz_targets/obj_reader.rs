//! Fuzzes the OBJ reader: any text must give a mesh or an error naming the file, never a
//! panic; a mesh that loads has triangles and can be intersected. Runs under a memory budget
//! of [`BUDGET`].
#![no_main]

use fiberlab_geometry::Ray;
use fiberlab_math::DVec3;
use libfuzzer_sys::fuzz_target;
use std::path::Path;

/// The memory budget every fuzzed read runs under (`fiberlab_io::memory_budget`): a reader
/// allocates in proportion to its input only through checks against it, so an input that asks
/// for more is an error, not an out-of-memory kill of the fuzzer (whose own limit is 2 GiB).
const BUDGET: u64 = 256 << 20;

fuzz_target!(|data: &[u8]| {
    fiberlab_io::memory_budget::set_limit(Some(BUDGET));
    // The file reader refuses non-UTF-8 text before parsing; so does this target.
    let Ok(text) = std::str::from_utf8(data) else { return };
    match fiberlab_io::obj::parse_obj(text, Path::new("fuzz.obj"), 1.0, DVec3::ZERO) {
        Ok(mesh) => {
            assert!(!mesh.is_empty(), "a loaded mesh has triangles");
            let _ = mesh.intersect(&Ray::new(DVec3::new(0.1, 0.2, 5.0), -DVec3::Z));
        }
        Err(e) => assert!(e.to_string().starts_with("fuzz.obj: "), "error without the file: {e}"),
    }
});
