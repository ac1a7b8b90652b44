//! Fuzzes the pbrt-v4 curve reader: any text must give strands or an error naming the file,
//! never a panic; strands that are read are consistent. `Include`s resolve against a
//! directory that does not exist, so they are errors too. Runs under a memory budget of
//! [`BUDGET`]: object instances of instances are refused before their copies exceed it.
#![no_main]

use fiberlab_io::pbrt_curves;
use libfuzzer_sys::fuzz_target;
use std::path::Path;

/// The memory budget every fuzzed read runs under (`fiberlab_io::memory_budget`): a reader
/// allocates in proportion to its input only through checks against it, so an input that asks
/// for more is an error, not an out-of-memory kill of the fuzzer (whose own limit is 2 GiB).
const BUDGET: u64 = 256 << 20;

fuzz_target!(|data: &[u8]| {
    fiberlab_io::memory_budget::set_limit(Some(BUDGET));
    let Ok(text) = std::str::from_utf8(data) else { return };
    let path = Path::new("/nonexistent-fuzz-dir/scene.pbrt");
    match pbrt_curves::parse_str(text, path) {
        Ok(strands) => strands.validate().expect("read strands are consistent"),
        Err(e) => assert!(e.to_string().contains("scene.pbrt"), "{e}"),
    }
});
