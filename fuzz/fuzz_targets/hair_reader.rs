//! Fuzzes the `.hair` reader: any byte string must parse or return an error, never panic;
//! whatever parses must write back to the same bytes.
#![no_main]

use fiberlab_io::HairFile;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(hair) = HairFile::parse(data) {
        let bytes = hair.to_bytes().expect("a parsed file is consistent");
        assert_eq!(bytes, data, "parse → write must reproduce the input");
    }
});
