//! Fuzzes the pbrt-v4 curve reader: any text must give strands or an error naming the file,
//! never a panic; strands that are read are consistent. `Include`s resolve against a
//! directory that does not exist, so they are errors too.
#![no_main]

use fiberlab_io::pbrt_curves;
use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    let path = Path::new("/nonexistent-fuzz-dir/scene.pbrt");
    match pbrt_curves::parse_str(text, path) {
        Ok(strands) => strands.validate().expect("read strands are consistent"),
        Err(e) => assert!(e.to_string().contains("scene.pbrt"), "{e}"),
    }
});
