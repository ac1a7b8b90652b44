//! Fuzzes the scene reader: any text must parse or give an error naming the file, never a
//! panic. A scene that parses is also built when building it reads no file and generates
//! little hair (so that the fuzzer measures the reader, not the generator's running time).
#![no_main]

use fiberlab_render::scene_file::SceneFile;
use libfuzzer_sys::fuzz_target;
use std::path::Path;

/// True when `value` holds a key that names a file (`file`, a measured model's `table`).
fn names_a_file(value: &toml::Value) -> bool {
    match value {
        toml::Value::Table(t) => t.iter().any(|(k, v)| k == "file" || k == "table" || names_a_file(v)),
        toml::Value::Array(a) => a.iter().any(names_a_file),
        _ => false,
    }
}

/// True when every `[[hair]]` generator asks for little work (the defaults, 20 000 strands,
/// are too many here).
fn small_hair(scene: &toml::Table) -> bool {
    let Some(hair) = scene.get("hair").and_then(toml::Value::as_array) else { return true };
    hair.iter().all(|h| {
        let Some(g) = h.get("generator") else { return true };
        let int = |key: &str, default: i64| g.get(key).and_then(toml::Value::as_integer).unwrap_or(default);
        int("strands", 20_000) <= 200 && int("segments", 24) <= 64
    })
}

fuzz_target!(|data: &[u8]| {
    // The file reader refuses non-UTF-8 bytes (naming line and column) before parsing.
    let Ok(text) = std::str::from_utf8(data) else { return };
    let path = Path::new("fuzz.toml");
    let file = match SceneFile::parse(text, path) {
        Ok(file) => file,
        Err(e) => {
            assert!(e.to_string().starts_with("fuzz.toml"), "error without the file: {e}");
            return;
        }
    };
    let _ = (file.image_size(), file.render_settings());
    let Ok(table) = text.parse::<toml::Table>() else { return };
    if names_a_file(&toml::Value::Table(table.clone())) || !small_hair(&table) {
        return;
    }
    if let Err(e) = file.build() {
        assert!(e.to_string().starts_with("fuzz.toml"), "error without the file: {e}");
    }
});
