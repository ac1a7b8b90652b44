//! The hostile-input suite (issue 15): the `fiberlab` binary fed what a hostile user would
//! feed it. Every case asserts that the command fails (non-zero exit, and not a panic: no
//! "panicked", no exit code 101 or 134, no signal), that the message names the place (the
//! file, its line, the flag), and that no file is left behind or replaced: each command runs
//! in a temporary directory holding an earlier `out.exr`, `out.png` and `out.csv`, and the
//! directory's files and their bytes must be the same afterwards.
//!
//! The other categories of the issue have their suites beside this one: absurd sizes and
//! bad output places in `fail_fast.rs`, stopped and resumed renders in `render_cli.rs`,
//! error texts of `fit`, `check`, `measure` and scenes in `tool_messages.rs`.

use assert_cmd::Command;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// A tiny scene: 16×16 pixels, 1 spp, 30 generated strands on a sphere, a sky; every
/// section starts a line with `[`, so a line can be told to be inside a section.
const SCENE: &str = r#"[camera]
eye = [0.0, 0.0, 4.0]
target = [0.0, 0.0, 0.0]
fov = 40
width = 16
height = 16

[render]
spp = 1
seed = 3

[materials.hair]
model = "kajiya-kay"

[materials.skin]
lambert = [0.5, 0.4, 0.3]

[[hair]]
material = "hair"
generator = { strands = 30, segments = 4 }

[[sphere]]
center = [0.0, 0.0, 0.0]
radius = 1.0
material = "skin"

[[light]]
type = "environment"
radiance = [1.0, 1.0, 1.0]
"#;

/// [`SCENE`] without its `[[hair]]` entry.
fn scene_without_hair() -> String {
    SCENE.replace("[[hair]]\nmaterial = \"hair\"\ngenerator = { strands = 30, segments = 4 }\n", "")
}

/// The files a refused command must leave as they were.
const EARLIER_OUTPUTS: [&str; 3] = ["out.exr", "out.png", "out.csv"];

/// A temporary working directory for the commands.
struct Dir(tempfile::TempDir);

impl Dir {
    fn new() -> Self {
        let dir = Self(tempfile::tempdir().expect("a temporary directory"));
        for name in EARLIER_OUTPUTS {
            dir.write(name, format!("an earlier {name}, which a failed command must not replace"));
        }
        dir
    }

    fn path(&self, name: &str) -> PathBuf {
        self.0.path().join(name)
    }

    fn write(&self, name: &str, bytes: impl AsRef<[u8]>) {
        std::fs::write(self.path(name), bytes).expect("writes");
    }

    /// Every file below the directory with its bytes.
    fn files(&self) -> BTreeMap<PathBuf, Vec<u8>> {
        fn walk(dir: &Path, into: &mut BTreeMap<PathBuf, Vec<u8>>) {
            for entry in std::fs::read_dir(dir).expect("lists") {
                let path = entry.expect("lists").path();
                if path.is_dir() {
                    walk(&path, into);
                } else {
                    into.insert(path.clone(), std::fs::read(&path).expect("reads"));
                }
            }
        }
        let mut files = BTreeMap::new();
        walk(self.0.path(), &mut files);
        files
    }

    fn run(&self, args: &[&str], stdin: &str) -> std::process::Output {
        Command::cargo_bin("fiberlab")
            .expect("binary builds")
            .current_dir(self.0.path())
            .args(args)
            .write_stdin(stdin)
            .output()
            .expect("runs")
    }

    /// Runs a command that must succeed; its standard output.
    fn ok(&self, args: &[&str]) -> String {
        let out = self.run(args, "");
        assert!(out.status.success(), "{args:?} failed: {}", String::from_utf8_lossy(&out.stderr));
        String::from_utf8_lossy(&out.stdout).into_owned()
    }

    /// Runs a command that must be refused (see the module docs) with a message holding every
    /// one of `says`; the message.
    fn refused(&self, args: &[&str], says: &[&str]) -> String {
        self.refused_with_input(args, "", says)
    }

    fn refused_with_input(&self, args: &[&str], stdin: &str, says: &[&str]) -> String {
        let before = self.files();
        let out = self.run(args, stdin);
        let err = String::from_utf8_lossy(&out.stderr).into_owned();
        let code = out.status.code();
        assert!(code.is_some(), "{args:?}: killed by a signal ({:?}): {err}", out.status);
        assert!(!matches!(code, Some(0 | 101 | 134)), "{args:?}: exit code {code:?}: {err}");
        assert!(!err.contains("panicked"), "{args:?}: panicked: {err}");
        for s in says {
            assert!(err.contains(s), "{args:?}: the message does not say `{s}`: {err}");
        }
        let after = self.files();
        let changed: Vec<_> = before
            .keys()
            .chain(after.keys())
            .filter(|k| before.get(*k) != after.get(*k))
            .map(|k| k.strip_prefix(self.0.path()).unwrap_or(k).display().to_string())
            .collect();
        assert!(changed.is_empty(), "{args:?}: files written, replaced or removed: {changed:?}; {err}");
        err
    }
}

/// The `(line, column)` of the first `NAME:LINE:COLUMN:` in `message`, `NAME` a file name.
fn position(message: &str, name: &str) -> Option<(usize, usize)> {
    let at = message.find(&format!("{name}:"))? + name.len() + 1;
    let mut numbers = message[at..].splitn(3, ':').map(|n| n.parse::<usize>().ok());
    Some((numbers.next()??, numbers.next()??))
}

/// Asserts that the error names `file` at a line inside the section (`[…]` header and what
/// follows) that holds the first line of `text` containing `marker`, and not later than it.
fn names_line_in_section(err: &str, file: &str, text: &str, marker: &str) {
    let (line, column) = position(err, file).unwrap_or_else(|| panic!("no {file}:LINE:COLUMN: in {err}"));
    let lines: Vec<&str> = text.lines().collect();
    let bad = lines.iter().position(|l| l.contains(marker)).expect("the marker is in the text") + 1;
    let section = lines[..bad].iter().rposition(|l| l.starts_with('[')).expect("inside a section") + 1;
    assert!(
        (section..=bad).contains(&line) && column >= 1,
        "{file}:{line}:{column} is not in the section of lines {section}..={bad}: {err}"
    );
}

/// A `.hair` file written by `fiberlab hair generate`, for patching.
fn generated_hair(dir: &Dir) -> Vec<u8> {
    dir.ok(&["hair", "generate", "--strands", "3", "--segments", "2", "--out", "good.hair"]);
    let bytes = std::fs::read(dir.path("good.hair")).expect("reads");
    std::fs::remove_file(dir.path("good.hair")).expect("removes");
    bytes
}

// ---------------------------------------------------------------------------------------
// merge

/// Renders `scene` (written as `name.toml`) with `flags` to the prefix `name`.
fn render_part(dir: &Dir, scene: &str, name: &str, flags: &[&str]) {
    dir.write(&format!("{name}.toml"), scene);
    let toml = format!("{name}.toml");
    let mut args = vec!["render", toml.as_str(), "--quiet", "--out", name];
    args.extend_from_slice(flags);
    dir.ok(&args);
}

#[test]
fn merge_refuses_duplicate_missing_mixed_overlapping_and_non_finite_parts() {
    let dir = Dir::new();
    render_part(&dir, SCENE, "p0", &["--tile", "0/2"]);
    render_part(&dir, SCENE, "p1", &["--tile", "1/2"]);
    render_part(&dir, SCENE, "whole", &[]);
    render_part(&dir, SCENE, "seed9", &["--tile", "1/2", "--seed", "9"]);
    render_part(
        &dir,
        &SCENE.replace("radiance = [1.0, 1.0, 1.0]", "radiance = [2.0, 1.0, 1.0]"),
        "other",
        &["--tile", "1/2"],
    );
    render_part(&dir, SCENE, "thirds", &["--tile", "1/3"]);
    render_part(&dir, SCENE, "spp2", &["--tile", "1/2", "--spp", "2"]);
    render_part(&dir, SCENE, "left", &["--crop", "0,0,10,16"]);
    render_part(&dir, SCENE, "right", &["--crop", "8,0,16,16"]);
    // A part whose pixel (3, 5) became NaN, header kept.
    let mut image = fiberlab_io::LinearImage::read_exr(&dir.path("p1.exr")).expect("reads");
    image.set(3, 5, [0.1, f32::NAN, 0.2]);
    image.write_exr(&dir.path("nan.exr")).expect("writes");
    for name in ["p0", "p1", "whole", "seed9", "other", "thirds", "spp2", "left", "right"] {
        std::fs::remove_file(dir.path(&format!("{name}.png"))).expect("removes");
    }
    let merge = |parts: &[&str], says: &[&str]| {
        let mut args = vec!["merge"];
        args.extend_from_slice(parts);
        args.extend_from_slice(&["--out", "out"]);
        dir.refused(&args, says);
    };
    merge(&["p0.exr", "p0.exr", "p1.exr"], &["p0.exr", "both are part 0/2"]);
    merge(&["p0.exr"], &["missing part(s) 1/2", "p0.exr"]);
    merge(&["p0.exr", "whole.exr"], &["whole.exr: not a part"]);
    merge(&["p0.exr", "seed9.exr"], &["p0.exr and seed9.exr", "seed 3 against 9"]);
    merge(&["p0.exr", "other.exr"], &["p0.exr and other.exr", "scene hash"]);
    merge(&["p0.exr", "thirds.exr"], &["p0.exr and thirds.exr", "split into 2 against 3"]);
    merge(&["left.exr", "right.exr"], &["left.exr and right.exr", "crops overlap"]);
    merge(&["p0.exr", "nan.exr"], &["nan.exr", "1 non-finite pixel(s), the first at x = 3, y = 5"]);
    merge(&["p0.exr", "spp2.exr"], &["p0.exr and spp2.exr", "spp 1 against 2"]);
    merge(&["p0.exr", "missing.exr"], &["missing.exr"]);
    // The parts themselves are fine: each refused set differs from this one by its bad part.
    dir.ok(&["merge", "p0.exr", "p1.exr", "--out", "good"]);
    dir.ok(&["merge", "left.exr", "--out", "good"]);
}

// ---------------------------------------------------------------------------------------
// scene numbers

/// Every number of a scene is checked, at its section's place in the file: the lights, the
/// sphere, the floor, a mesh's scale and translation.
#[test]
fn non_finite_and_negative_scene_numbers_are_refused_at_their_place() {
    let dir = Dir::new();
    dir.write("q.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 3\n");
    let base = SCENE.replace("[[light]]\ntype = \"environment\"\nradiance = [1.0, 1.0, 1.0]\n", "");
    dir.write("base.toml", &base);
    dir.ok(&["render", "base.toml", "--quiet", "--out", "base"]);
    // (section, text of its bad line, what the message names)
    let sections = [
        ("[[light]]\ntype = \"environment\"\nradiance = [0.1, nan, 0.3]\n", "nan", "environment: radiance"),
        ("[[light]]\ntype = \"environment\"\nradiance = [0.1, -0.2, 0.3]\n", "-0.2", "environment: radiance"),
        (
            "[[light]]\ntype = \"sun\"\ndirection = [0, 1, 0]\nangular_radius_deg = 1\nirradiance = [-1, 1, 1]\n",
            "[-1,",
            "sun: irradiance",
        ),
        (
            "[[light]]\ntype = \"distant\"\ndirection = [0, 1, 0]\nirradiance = [1, inf, 1]\n",
            "inf",
            "distant: irradiance",
        ),
        (
            "[[light]]\ntype = \"distant\"\ndirection = [nan, 1, 0]\nirradiance = [1, 1, 1]\n",
            "nan",
            "distant: direction",
        ),
        ("[[light]]\ntype = \"envmap\"\nfile = \"sky.exr\"\nscale = nan\n", "nan", "envmap: scale"),
        ("[[sphere]]\ncenter = [0, nan, 0]\nradius = 1\nmaterial = \"skin\"\n", "nan", "sphere: center"),
        ("[[sphere]]\ncenter = [0, 0, 0]\nradius = -1\nmaterial = \"skin\"\n", "-1", "sphere: radius"),
        (
            "[[sphere]]\ncenter = [0, 3, 0]\nradius = 1\nmaterial = \"skin\"\nemission = [1, inf, 1]\n",
            "inf",
            "sphere: emission",
        ),
        ("[[mesh]]\nfloor = nan\nmaterial = \"skin\"\n", "nan", "mesh: floor"),
        ("[[mesh]]\nfile = \"q.obj\"\nmaterial = \"skin\"\nscale = nan\n", "nan", "mesh: scale"),
        ("[[mesh]]\nfile = \"q.obj\"\nmaterial = \"skin\"\nscale = -2\n", "-2", "mesh: scale"),
        ("[[mesh]]\nfile = \"q.obj\"\nmaterial = \"skin\"\ntranslate = [0, 0, inf]\n", "inf", "mesh: translate"),
    ];
    for (section, bad, says) in sections {
        let text = format!("{base}\n{section}");
        dir.write("bad.toml", &text);
        let err = dir.refused(&["render", "bad.toml", "--quiet", "--out", "out"], &["bad.toml:", says]);
        names_line_in_section(&err, "bad.toml", &text, bad);
    }
}

/// Numbers each finite but nonsense together: a mesh scale that takes the vertices to
/// infinity, and a floor's `scale`/`translate`, which a floor does not use.
#[test]
fn mesh_numbers_that_overflow_or_are_unused_are_refused() {
    let dir = Dir::new();
    dir.write("q.obj", "v -2 0 -2\nv 2 0 -2\nv 2 0 2\nf 1 2 3\n");
    for (section, bad) in [
        ("[[mesh]]\nfile = \"q.obj\"\nmaterial = \"skin\"\nscale = 1e308\n", "1e308"),
        ("[[mesh]]\nfloor = 0.0\nmaterial = \"skin\"\nscale = nan\n", "nan"),
        ("[[mesh]]\nfloor = 0.0\nmaterial = \"skin\"\ntranslate = [0, 1, 0]\n", "translate"),
    ] {
        let text = format!("{SCENE}\n{section}");
        dir.write("bad.toml", &text);
        let err = dir.refused(&["render", "bad.toml", "--quiet", "--out", "out"], &["bad.toml:", "mesh"]);
        names_line_in_section(&err, "bad.toml", &text, bad);
    }
}

#[test]
fn envmap_pixels_must_be_finite_and_non_negative() {
    let dir = Dir::new();
    let mut pixels = vec![[0.5_f32, 0.5, 0.5]; 8 * 4];
    pixels[8 + 2] = [0.5, f32::NAN, 0.5];
    fiberlab_io::LinearImage::from_pixels(8, 4, pixels).unwrap().write_exr(&dir.path("sky.exr")).unwrap();
    let mut pixels = vec![[0.5_f32, 0.5, 0.5]; 8 * 4];
    pixels[3 * 8 + 7] = [0.5, 0.5, -1.0];
    fiberlab_io::LinearImage::from_pixels(8, 4, pixels).unwrap().write_exr(&dir.path("dark.exr")).unwrap();
    for (file, pixel) in [("sky.exr", "pixel x = 2, y = 1"), ("dark.exr", "pixel x = 7, y = 3")] {
        let text = format!("{SCENE}\n[[light]]\ntype = \"envmap\"\nfile = \"{file}\"\n");
        dir.write("bad.toml", &text);
        let err = dir.refused(&["render", "bad.toml", "--quiet", "--out", "out"], &["bad.toml:", file, pixel]);
        names_line_in_section(&err, "bad.toml", &text, file);
    }
}

#[test]
fn obj_vertices_with_nan_or_missing_coordinates_name_their_line() {
    let dir = Dir::new();
    dir.write("q.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nvn 0 0 1\nf 1 2 3\n");
    let text = format!("{SCENE}\n[[mesh]]\nfile = \"q.obj\"\nmaterial = \"skin\"\n");
    dir.write("good.toml", &text);
    dir.ok(&["render", "good.toml", "--quiet", "--out", "good"]);
    for (obj, line) in [
        ("v 0 0 0\nv 1 nan 0\nv 1 1 0\nf 1 2 3\n", "line 2: expected three finite coordinates, got `v 1 nan 0`"),
        ("# a quad\nv 0 0 0\nv 1 0 0\nv 1 1\nf 1 2 3\n", "line 4: expected three finite coordinates, got `v 1 1`"),
        ("v 0 0 0\nv 1 0 0\nv 1 1 0\nvn 0 inf 1\nf 1 2 3\n", "line 4"),
    ] {
        dir.write("q.obj", obj);
        let text = format!("{SCENE}\n[[mesh]]\nfile = \"q.obj\"\nmaterial = \"skin\"\n");
        dir.write("bad.toml", &text);
        let err = dir.refused(&["render", "bad.toml", "--quiet", "--out", "out"], &["bad.toml:", "q.obj", line]);
        names_line_in_section(&err, "bad.toml", &text, "q.obj");
    }
}

// ---------------------------------------------------------------------------------------
// scene files: --hair, text that is not UTF-8

#[test]
fn hair_flag_needs_a_hair_entry_in_the_scene() {
    let dir = Dir::new();
    dir.write("h.hair", generated_hair(&dir));
    dir.write("bare.toml", scene_without_hair());
    dir.ok(&["render", "bare.toml", "--quiet", "--out", "bare"]);
    dir.refused(
        &["render", "bare.toml", "--hair", "h.hair", "--quiet", "--out", "out"],
        &["bare.toml", "--hair h.hair", "no [[hair]]"],
    );
}

#[test]
fn a_scene_that_is_not_utf8_names_line_column_and_byte() {
    let dir = Dir::new();
    dir.write("bad.toml", b"[camera]\nfov = \xff30\n");
    let err = dir.refused(&["render", "bad.toml", "--quiet", "--out", "out"], &["bad.toml:2:7:", "byte 15", "UTF-8"]);
    assert!(!err.contains(":0:0"), "{err}");
    // An unreadable scene is an error of the whole file: no position at all.
    let err = dir.refused(&["render", "none.toml", "--quiet", "--out", "out"], &["none.toml"]);
    assert!(!err.contains(":0:0") && position(&err, "none.toml").is_none(), "{err}");
}

// ---------------------------------------------------------------------------------------
// .hair files

/// Header fields that make a `.hair` file unreadable, named by byte offset and in words:
/// the default thickness (not "header[0]"), the magic as text (not as a byte list).
#[test]
fn bad_hair_files_name_the_file_the_byte_and_the_field() {
    let dir = Dir::new();
    let good = generated_hair(&dir);
    let patched = |at: usize, bytes: &[u8]| {
        let mut b = good.clone();
        b[at..at + bytes.len()].copy_from_slice(bytes);
        b
    };
    dir.write("nan.hair", patched(20, &f32::NAN.to_le_bytes()));
    dir.write("negative.hair", patched(20, &(-1.0_f32).to_le_bytes()));
    dir.write("magic.hair", patched(0, b"XAIR"));
    dir.write("short.hair", &good[..100]);
    dir.write("good.hair", &good);
    dir.write("s.toml", SCENE);
    dir.ok(&["render", "s.toml", "--hair", "good.hair", "--quiet", "--out", "good"]);
    for (file, says) in [
        ("nan.hair", "byte 20: the header's default thickness is not finite (NaN)"),
        ("negative.hair", "byte 20: the header's default thickness -1 is negative"),
        ("magic.hair", "byte 0: expected the magic \"HAIR\", found \"XAIR\""),
        ("short.hair", "128-byte header"),
    ] {
        let err = dir.refused(&["render", "s.toml", "--hair", file, "--quiet", "--out", "out"], &[file, says]);
        assert!(!err.contains("header[") && !err.contains("[88, 65"), "{err}");
        dir.refused(&["hair", "info", file], &[file, says]);
    }
    // The same file named by the scene: the scene's line too.
    let text = SCENE.replace("generator = { strands = 30, segments = 4 }", "file = \"magic.hair\"");
    dir.write("m.toml", &text);
    let err = dir.refused(&["render", "m.toml", "--quiet", "--out", "out"], &["m.toml:", "magic.hair", "\"XAIR\""]);
    names_line_in_section(&err, "m.toml", &text, "magic.hair");
}

// ---------------------------------------------------------------------------------------
// flags

/// Flag values are validated while the command line is parsed, before any file is read: a
/// bad `--bins`, `--theta-i`, `--tile`, `--crop`, … is reported even when the scene or fiber
/// file does not exist (moved from `cli.rs`).
#[test]
fn bad_flag_values_are_reported_before_any_file_is_read() {
    let dir = Dir::new();
    for (args, expected) in [
        (
            &["measure", "--theta-i", "0", "--rays", "10", "--bins", "0,4", "--fiber", "missing.toml", "--out", "x"][..],
            "NT,NP",
        ),
        (&["measure", "--theta-i", "95", "--rays", "10", "--fiber", "missing.toml", "--out", "x"], "(-89.9, 89.9)"),
        (&["measure", "--theta-i", "0", "--rays", "0", "--fiber", "missing.toml", "--out", "x"], "positive integer"),
        (&["render", "missing.toml", "--tile", "3/3"], "0 ≤ I < N"),
        (&["render", "missing.toml", "--crop", "4,0,2,2"], "x0 < x1"),
        (&["render", "missing.toml", "--time-limit=-1"], "seconds ≥ 0"),
        (&["render", "missing.toml", "--exposure", "nan"], "finite"),
        (&["render", "missing.toml", "--spp", "0"], "--spp"),
        (&["render", "missing.toml", "--out", "/nonexistent/dir/r"], "does not exist"),
        (&["merge", "missing.exr", "--exposure", "inf"], "finite"),
        (&["bench", "--calls", "0", "--params-file", "missing.toml"], "--calls"),
        (
            &["plot", "--model", "diffuse", "--theta-i", "90", "--out", "x.png", "--params-file", "missing.toml"],
            "(-90, 90)",
        ),
    ] {
        let err = dir.refused(args, &[expected]);
        assert!(!err.contains("missing.toml"), "{args:?}: {err}");
    }
}

/// `--exposure nan` and `--spp 0` on a scene that renders: refused, naming the flag, and an
/// earlier image of the same name is kept.
#[test]
fn exposure_nan_and_spp_zero_are_refused() {
    let dir = Dir::new();
    dir.write("s.toml", SCENE);
    for exposure in ["nan", "inf", "-inf"] {
        dir.refused(
            &["render", "s.toml", "--exposure", exposure, "--quiet", "--out", "out"],
            &["--exposure", exposure, "finite"],
        );
    }
    dir.ok(&["render", "s.toml", "--quiet", "--tile", "0/2", "--out", "p0"]);
    dir.ok(&["render", "s.toml", "--quiet", "--tile", "1/2", "--out", "p1"]);
    dir.refused(&["merge", "p0.exr", "p1.exr", "--exposure", "nan", "--out", "out"], &["--exposure", "finite"]);
    dir.refused(&["render", "s.toml", "--spp", "0", "--quiet", "--out", "out"], &["--spp", "0"]);
    dir.refused(&["render", "s.toml", "--spp=-1", "--quiet", "--out", "out"], &["--spp"]);
}

/// The scene's own `[render]` numbers follow the rules of the flags: `spp = 0` is not
/// silently rendered at 1 spp, `exposure = nan` does not give a black PNG.
#[test]
fn scene_spp_zero_and_non_finite_exposure_are_refused() {
    let dir = Dir::new();
    for (from, to) in [("spp = 1", "spp = 0"), ("seed = 3", "seed = 3\nexposure = nan")] {
        let text = SCENE.replace(from, to);
        dir.write("bad.toml", &text);
        let key = to.lines().last().unwrap().split(' ').next().unwrap();
        let err = dir.refused(&["render", "bad.toml", "--quiet", "--out", "out"], &["bad.toml:", key]);
        names_line_in_section(&err, "bad.toml", &text, to.lines().last().unwrap());
    }
}

/// `--tile I/N` with more bands than the image has rows would render an empty part.
#[test]
fn tile_count_above_the_image_rows_is_refused() {
    let dir = Dir::new();
    dir.write("s.toml", SCENE);
    dir.refused(&["render", "s.toml", "--tile", "0/100", "--quiet", "--out", "out"], &["--tile", "0/100", "16"]);
    dir.refused(&["render", "s.toml", "--tile", "16/17", "--quiet", "--out", "out"], &["--tile", "16/17"]);
}

#[test]
fn bench_calls_zero_is_refused() {
    let dir = Dir::new();
    dir.refused(&["bench", "--calls", "0", "--model", "diffuse"], &["--calls", "0"]);
    dir.refused(&["bench", "--calls=-3", "--model", "diffuse"], &["--calls"]);
}

#[test]
fn phi_i_nan_is_refused() {
    let dir = Dir::new();
    for phi in ["nan", "inf"] {
        dir.refused(&["measure", "--theta-i", "0", "--phi-i", phi, "--rays", "10", "--out", "out"], &["--phi-i", phi]);
    }
}

/// Error texts: a missing file named once, a huge number in a few digits, the camera rule
/// that failed (not every rule), the generator value that cannot be written.
#[test]
fn error_texts_say_each_thing_once_and_briefly() {
    let dir = Dir::new();
    let err = dir.refused(&["hair", "info", "none.hair"], &["none.hair"]);
    assert_eq!(err.matches("none.hair").count(), 1, "{err}");
    dir.write("r.toml", SCENE.replace("radius = 1.0", "radius = -1e308"));
    let err = dir.refused(&["render", "r.toml", "--quiet", "--out", "out"], &["r.toml:", "radius"]);
    assert!(!err.contains("0000000000"), "{err}");
    dir.write("c.toml", SCENE.replace("fov = 40", "fov = 400"));
    let err = dir.refused(&["render", "c.toml", "--quiet", "--out", "out"], &["c.toml:", "fov"]);
    assert!(!err.contains("eye and target"), "{err}");
    dir.refused(&["hair", "generate", "--strands", "3", "--length", "1e308", "--out", "out"], &["length"]);
}

// ---------------------------------------------------------------------------------------
// poles

/// `marschner` evaluated with ω_i, ω_o or both exactly along the fiber axis (θ = ±90°):
/// `eval` succeeds and every f_s and pdf is finite and ≥ 0, and on the axis no larger than
/// a thousand times its largest value 1e-6 rad away (the issue found 2.2e297 against 2.2e4).
#[test]
fn marschner_at_the_poles_is_finite_through_eval() {
    use fiberlab_math::frame::direction;
    use std::f64::consts::FRAC_PI_2;
    let dir = Dir::new();
    let other = direction(0.3, 1.1);
    let mut rows = vec![];
    for pole in [FRAC_PI_2, -FRAC_PI_2] {
        for toward in [0.0, 1e-6] {
            let theta = pole - pole.signum() * toward;
            let axis = direction(theta, 0.4);
            rows.push((axis, other));
            rows.push((other, axis));
            rows.push((axis, direction(-theta, 2.0)));
        }
    }
    let mut csv = String::from("wi_x,wi_y,wi_z,wo_x,wo_y,wo_z,h\n");
    for (wi, wo) in &rows {
        csv.push_str(&format!("{},{},{},{},{},{},0.3\n", wi.x, wi.y, wi.z, wo.x, wo.y, wo.z));
    }
    let out = dir.run(&["eval", "--model", "marschner"], &csv);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let values: Vec<Vec<f64>> = String::from_utf8_lossy(&out.stdout)
        .lines()
        .skip(1)
        .map(|l| l.split(',').skip(7).map(|x| x.parse().expect("a number")).collect())
        .collect();
    assert_eq!(values.len(), rows.len());
    for (row, v) in values.iter().enumerate() {
        assert!(v.len() == 4 && v.iter().all(|x| x.is_finite() && *x >= 0.0), "row {row}: {v:?}");
    }
    // Rows 6k..6k+2 are on the axis, 6k+3..6k+5 the same pairs 1e-6 rad away.
    for pole in 0..2 {
        for pair in 0..3 {
            let (on, near) = (&values[6 * pole + pair], &values[6 * pole + 3 + pair]);
            for k in 0..4 {
                assert!(on[k] <= 1e3 * near[k].max(1e-12), "pole {pole}, pair {pair}, column {k}: {on:?} vs {near:?}");
            }
        }
    }
}
