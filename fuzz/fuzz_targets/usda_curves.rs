//! Fuzzes the USD BasisCurves reader: any text must give strands or an error naming the
//! file, never a panic; strands that are read are consistent and write back to text that
//! reads to the same strands.
#![no_main]

use fiberlab_io::usda_curves;
use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
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
