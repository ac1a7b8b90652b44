//! The scene and OBJ readers under hostile input, on stable Rust (the `fuzz/` targets
//! `scene_reader` and `obj_reader` run the same entry points under cargo-fuzz): random bytes,
//! mutated valid scenes and OBJ-like text never panic, every error names its file, and
//! every non-finite number written into a scene is refused at a line of the file.

use fiberlab_geometry::Ray;
use fiberlab_math::DVec3;
use fiberlab_render::scene_file::{SceneError, SceneFile};
use proptest::prelude::*;
use proptest::sample::Index;
use std::path::Path;

/// A small scene with every section but the ones that read a `.hair` or EXR file: a fiber,
/// a lambert and a mirror material, a little generated hair, an emitting sphere, a floor, an
/// OBJ mesh (the file [`OBJ`] beside the scene) and three kinds of light.
const SCENE: &str = r#"[camera]
eye = [0.0, 0.5, 4.0]
target = [0.0, 0.0, 0.0]
up = [0.0, 1.0, 0.0]
fov = 40.0
width = 8
height = 6

[render]
spp = 1
max_depth = 4
seed = 3
exposure = 0.5

[materials.hair]
model = "kajiya-kay"
params = { k_d = [0.03, 0.014, 0.006], k_s = 0.025, p = 60.0 }

[materials.skin]
lambert = [0.62, 0.45, 0.36]

[materials.glass]
mirror = [0.9, 0.9, 0.9]

[[hair]]
material = "hair"
generator = { strands = 12, segments = 4, style = "wavy", length = 1.2, amplitude = 0.03, wavelength = 0.35, clumps = 3, clumping = 0.3, gravity = 2.0, noise = 0.04, root_diameter = 0.002, tip_ratio = 0.5, head_center = [0.0, 0.0, 0.0], head_radius = 1.0, scalp_angle_deg = 100.0, seed = 1 }

[[sphere]]
center = [0.0, 0.0, 0.0]
radius = 1.0
material = "skin"

[[sphere]]
center = [0.0, 5.0, 0.0]
radius = 0.5
material = "glass"
emission = [2.0, 2.0, 2.0]

[[mesh]]
floor = -2.0
material = "skin"

[[mesh]]
file = "quad.obj"
material = "glass"
scale = 1.0
translate = [0.0, -1.5, 0.0]

[[light]]
type = "environment"
radiance = [0.35, 0.45, 0.6]

[[light]]
type = "sun"
direction = [1.0, 1.3, -0.5]
angular_radius_deg = 2.0
irradiance = [4.0, 3.7, 3.2]

[[light]]
type = "distant"
direction = [0.0, 1.0, 0.0]
irradiance = [1.0, 1.0, 1.0]
"#;

/// The mesh of [`SCENE`]: a quad whose corners are 2 away from the origin (so that a huge
/// `scale` overflows).
const OBJ: &str = "v -2 0 -2\nv 2 0 -2\nv 2 0 2\nv -2 0 2\nf 1 2 3 4\n";

/// The scene's path, in a directory (made once) that holds `quad.obj`.
fn scene_path() -> &'static Path {
    static DIR: std::sync::OnceLock<(tempfile::TempDir, std::path::PathBuf)> = std::sync::OnceLock::new();
    let (_, path) = DIR.get_or_init(|| {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("quad.obj"), OBJ).unwrap();
        let path = dir.path().join("hostile.toml");
        (dir, path)
    });
    path
}

/// Parses and, when that succeeds, builds `text`; panics only if the reader does, or if an
/// error does not name the file.
fn parse_and_build(text: &str) -> Result<(), SceneError> {
    let path = scene_path();
    let result = SceneFile::parse(text, path).and_then(|f| f.build().map(|_| ()));
    if let Err(e) = &result {
        assert!(e.to_string().starts_with(&path.display().to_string()), "error without the file: {e}");
    }
    result
}

/// Byte ranges of the numbers written in `text` (maximal runs of number characters holding
/// a digit; the scene above has no digits in keys or strings).
fn number_spans(text: &str) -> Vec<std::ops::Range<usize>> {
    let is_number_char = |c: u8| c.is_ascii_digit() || b".-+eE".contains(&c);
    let bytes = text.as_bytes();
    let mut spans = Vec::new();
    let mut i = 0;
    while i < bytes.len() {
        if is_number_char(bytes[i]) && (i == 0 || !bytes[i - 1].is_ascii_alphabetic() && bytes[i - 1] != b'_') {
            let start = i;
            while i < bytes.len() && is_number_char(bytes[i]) {
                i += 1;
            }
            if bytes[start..i].iter().any(u8::is_ascii_digit) {
                spans.push(start..i);
            }
        } else {
            i += 1;
        }
    }
    spans
}

/// The 1-based line of byte `at`.
fn line_of(text: &str, at: usize) -> usize {
    text[..at].matches('\n').count() + 1
}

#[test]
fn the_base_scene_builds_and_has_numbers_to_mutate() {
    parse_and_build(SCENE).unwrap();
    let spans = number_spans(SCENE);
    assert!(spans.len() > 60, "{} numbers", spans.len());
    assert!(spans.iter().all(|s| SCENE[s.clone()].parse::<f64>().is_ok()), "every span is a number");
}

/// "Every number in a scene validated": each float of the scene replaced by `nan`, `inf` or
/// `-inf` is refused, at a line no later than the number's own (a whole-section error points
/// at the section's header), never built.
#[test]
fn every_non_finite_scene_number_is_refused_at_its_line() {
    let mut accepted = Vec::new();
    for span in number_spans(SCENE) {
        let written = &SCENE[span.clone()];
        if !written.contains('.') {
            continue; // integers (sizes, counts, seeds): a float there is a type error
        }
        let line = line_of(SCENE, span.start);
        for bad in ["nan", "inf", "-inf"] {
            let text = format!("{}{bad}{}", &SCENE[..span.start], &SCENE[span.end..]);
            match parse_and_build(&text) {
                Ok(()) => accepted.push(format!("line {line}: `{}` with {bad}", SCENE.lines().nth(line - 1).unwrap())),
                Err(e) => assert!(e.line >= 1 && e.line <= line, "line {line} → {bad}: error at line {}: {e}", e.line),
            }
        }
    }
    assert!(accepted.is_empty(), "accepted non-finite numbers:\n{}", accepted.join("\n"));
}

/// A coordinate finite in double but not in the single precision the OBJ reader stores
/// (`v 1e39 0 0` loaded as an infinite vertex before).
#[test]
fn obj_coordinates_beyond_single_precision_name_their_line() {
    let text = "v 0 0 0\nv 1e39 0 0\nv 1 1 0\nf 1 2 3\n";
    let e = fiberlab_io::obj::parse_obj(text, Path::new("big.obj"), 1.0, DVec3::ZERO).unwrap_err().to_string();
    assert!(e.starts_with("big.obj: line 2:") && e.contains("`v 1e39 0 0`"), "{e}");
    assert!(fiberlab_io::obj::parse_obj(&text.replace("1e39", "3e38"), Path::new("big.obj"), 1.0, DVec3::ZERO).is_ok());
}

/// Values a hostile user might put in place of any number of the scene.
const HOSTILE: [&str; 17] = [
    "nan", "inf", "-inf", "-1", "0", "-0.0", "1e39", "1e308", "-1e308", "1e-320", "3", "65536", "1e30", "\"x\"",
    "[1, 2]", "true", "{}",
];

proptest! {
    #![proptest_config(ProptestConfig { cases: 512, ..ProptestConfig::default() })]

    #[test]
    fn random_bytes_never_panic_the_scene_reader(bytes in proptest::collection::vec(any::<u8>(), 0..400)) {
        let _ = parse_and_build(&String::from_utf8_lossy(&bytes));
    }

    /// Numbers replaced by hostile values, lines dropped or doubled, the text cut short:
    /// parsed and built, never a panic, every error naming the file.
    #[test]
    fn mutated_scenes_never_panic(
        numbers in proptest::collection::vec((any::<Index>(), 0..HOSTILE.len()), 0..4),
        drop_line in proptest::option::of(any::<Index>()),
        double_line in proptest::option::of(any::<Index>()),
        cut in proptest::option::of(any::<Index>()),
    ) {
        let spans = number_spans(SCENE);
        let mut replace: Vec<(std::ops::Range<usize>, &str)> =
            numbers.iter().map(|(i, v)| (spans[i.index(spans.len())].clone(), HOSTILE[*v])).collect();
        replace.sort_by_key(|(s, _)| std::cmp::Reverse(s.start));
        replace.dedup_by_key(|(s, _)| s.start);
        let mut text = SCENE.to_string();
        for (span, value) in replace {
            text.replace_range(span, value);
        }
        let mut lines: Vec<&str> = text.lines().collect();
        if let Some(i) = double_line {
            let i = i.index(lines.len());
            lines.insert(i, lines[i]);
        }
        if let Some(i) = drop_line {
            lines.remove(i.index(lines.len()));
        }
        let mut text = lines.join("\n");
        if let Some(i) = cut {
            let mut at = i.index(text.len() + 1);
            while !text.is_char_boundary(at) {
                at -= 1;
            }
            text.truncate(at);
        }
        let _ = parse_and_build(&text);
    }

    /// OBJ-like text from its record kinds with hostile numbers and indices: a mesh or an
    /// error naming the file, never a panic; a loaded mesh can be intersected.
    #[test]
    fn obj_like_text_never_panics_the_obj_reader(
        records in proptest::collection::vec((0..8usize, proptest::collection::vec(0..HOSTILE.len() + 6, 0..5)), 0..12),
    ) {
        let word = |k: usize| match k {
            k if k < HOSTILE.len() => HOSTILE[k].to_string(),
            k => ["1", "2", "3", "-1", "1/1/1", "2//2"][k - HOSTILE.len()].to_string(),
        };
        let kinds = ["v", "vn", "vt", "f", "l", "o x", "mtllib /dev/zero", "usemtl m"];
        let text: String = records
            .iter()
            .map(|(kind, words)| {
                let rest: Vec<String> = words.iter().map(|&k| word(k)).collect();
                format!("{} {}\n", kinds[*kind], rest.join(" "))
            })
            .collect();
        match fiberlab_io::obj::parse_obj(&text, Path::new("hostile.obj"), 1.0, DVec3::ZERO) {
            Ok(mesh) => {
                prop_assert!(!mesh.is_empty());
                let _ = mesh.intersect(&Ray::new(DVec3::new(0.2, 0.3, 5.0), -DVec3::Z));
            }
            Err(e) => prop_assert!(e.to_string().starts_with("hostile.obj: "), "{}", e),
        }
    }

    #[test]
    fn random_bytes_never_panic_the_obj_reader(bytes in proptest::collection::vec(any::<u8>(), 0..400)) {
        if let Err(e) = fiberlab_io::obj::parse_obj(&String::from_utf8_lossy(&bytes), Path::new("hostile.obj"), 1.0, DVec3::ZERO) {
            prop_assert!(e.to_string().starts_with("hostile.obj: "), "{}", e);
        }
    }
}
