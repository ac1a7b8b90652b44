//! Fuzzes the USD BasisCurves reader: any text must give strands or an error naming the
//! file, never a panic or a stack overflow (prims nest at most `MAX_PRIM_DEPTH` deep, tuples
//! `MAX_TUPLE_DEPTH`); strands that are read are consistent and write back to text that reads
//! to the same strands. Runs under a memory budget of [`BUDGET`].
#![no_main]

use fiberlab_io::usda_curves;
use libfuzzer_sys::fuzz_target;
use std::path::Path;

/// The memory budget every fuzzed read runs under (`fiberlab_io::memory_budget`): a reader
/// allocates in proportion to its input only through checks against it, so an input that asks
/// for more is an error, not an out-of-memory kill of the fuzzer (whose own limit is 2 GiB).
const BUDGET: u64 = 256 << 20;

fuzz_target!(|data: &[u8]| {
    fiberlab_io::memory_budget::set_limit(Some(BUDGET));
    let Ok(text) = std::str::from_utf8(data) else { return };
    let path = Path::new("hair.usda");
    match usda_curves::parse_str(text, path) {
        Ok(strands) => {
            strands.validate().expect("read strands are consistent");
            let again = usda_curves::to_text(&strands).expect("consistent strands write");
            assert_eq!(usda_curves::parse_str(&again, path).expect("written text reads"), strands);
        }
        Err(e) => assert!(e.to_string().starts_with("hair.usda:"), "{e}"),
    }
});
