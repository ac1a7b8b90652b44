//! Fuzzes the scene reader: any text must parse or give an error naming the file, never a
//! panic. Runs under a memory budget of [`BUDGET`] (the scene's own estimate is checked against
//! it before a scene is built). A scene that parses is also built when building it reads no file and generates
//! little hair (so that the fuzzer measures the reader, not the generator's running time).
//!
//! The first byte picks the input: odd (as `[` and `#` are), the input is the scene text;
//! even, the rest edits a valid scene (pairs of bytes: which number, which hostile value),
//! so that many inputs stay valid TOML and reach the checks of `build`.
#![no_main]

use fiberlab_render::scene_file::SceneFile;
use libfuzzer_sys::fuzz_target;
use std::path::Path;

/// The memory budget every fuzzed read runs under (`fiberlab_io::memory_budget`): a reader
/// allocates in proportion to its input only through checks against it, so an input that asks
/// for more is an error, not an out-of-memory kill of the fuzzer (whose own limit is 2 GiB).
const BUDGET: u64 = 256 << 20;

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

/// The valid scene the edits start from.
const SCENE: &str = include_str!("../seeds/scene/tiny.toml");

/// Values put in place of the scene's numbers.
const HOSTILE: [&str; 14] =
    ["nan", "inf", "-inf", "-1", "0", "-0.0", "1e39", "1e308", "-1e308", "1e-320", "3", "65535", "\"x\"", "[]"];

/// [`SCENE`] with numbers replaced as `edits` say.
fn edited(edits: &[u8]) -> String {
    let mut spans = Vec::new();
    let bytes = SCENE.as_bytes();
    let mut i = 0;
    while i < bytes.len() {
        let starts =
            bytes[i].is_ascii_digit() || (bytes[i] == b'-' && bytes.get(i + 1).is_some_and(u8::is_ascii_digit));
        if starts && (i == 0 || !bytes[i - 1].is_ascii_alphanumeric() && bytes[i - 1] != b'_') {
            let start = i;
            i += 1;
            while i < bytes.len() && (bytes[i].is_ascii_digit() || b".eE+-".contains(&bytes[i])) {
                i += 1;
            }
            spans.push(start..i);
        } else {
            i += 1;
        }
    }
    let mut replace: Vec<(std::ops::Range<usize>, &str)> = edits
        .chunks_exact(2)
        .map(|e| (spans[usize::from(e[0]) % spans.len()].clone(), HOSTILE[usize::from(e[1]) % HOSTILE.len()]))
        .collect();
    replace.sort_by_key(|(s, _)| std::cmp::Reverse(s.start));
    replace.dedup_by_key(|(s, _)| s.start);
    let mut text = SCENE.to_string();
    for (span, value) in replace {
        text.replace_range(span, value);
    }
    text
}

fuzz_target!(|data: &[u8]| {
    fiberlab_io::memory_budget::set_limit(Some(BUDGET));
    let Some((&mode, edits)) = data.split_first() else { return };
    let owned;
    let text = if mode % 2 == 1 {
        // The file reader refuses non-UTF-8 bytes (naming line and column) before parsing.
        let Ok(text) = std::str::from_utf8(data) else { return };
        text
    } else {
        owned = edited(edits);
        &owned
    };
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
    // What the command line and Python check before they build: a scene whose estimate is
    // above the budget (a 10⁵ × 10⁵ camera) is refused, not built.
    match file.memory_estimate() {
        Ok(estimate) if fiberlab_io::memory_budget::check_needs(&estimate.needs()).is_ok() => {}
        Ok(_) => return,
        Err(e) => {
            assert!(e.to_string().starts_with("fuzz.toml"), "error without the file: {e}");
            return;
        }
    }
    if let Err(e) = file.build() {
        assert!(e.to_string().starts_with("fuzz.toml"), "error without the file: {e}");
    }
});
