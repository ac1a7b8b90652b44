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
//!
//! Issue 36 (no input may crash, hang, exhaust memory or overwrite what is not ours) adds one
//! section per category at the end: panics, allocations outside the memory check, unbounded
//! reads (FIFOs and devices as inputs), outputs that are not regular files (links, FIFOs;
//! a link to a file outside the test's directory stands in for `/dev/full`: no test writes to
//! a real device), unbounded work, signals (one test per long verb), merge, and silent
//! nonsense. Every command runs under a generous timeout that kills it (a hang fails the
//! test, by a signal, without a timed assertion).

use assert_cmd::Command;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// How long a command may run before it is killed (a hang then fails its test).
const TIMEOUT: Duration = Duration::from_secs(300);

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

    /// Every file below the directory with its bytes; a symbolic link as `link → TARGET`, a
    /// FIFO or device as what it is (never read: reading a FIFO would block).
    fn files(&self) -> BTreeMap<PathBuf, Vec<u8>> {
        fn walk(dir: &Path, into: &mut BTreeMap<PathBuf, Vec<u8>>) {
            for entry in std::fs::read_dir(dir).expect("lists") {
                let path = entry.expect("lists").path();
                let kind = std::fs::symlink_metadata(&path).expect("exists").file_type();
                if kind.is_symlink() {
                    let to = std::fs::read_link(&path).expect("a link");
                    into.insert(path.clone(), format!("link → {}", to.display()).into_bytes());
                } else if kind.is_dir() {
                    walk(&path, into);
                } else if kind.is_file() {
                    into.insert(path.clone(), std::fs::read(&path).expect("reads"));
                } else {
                    into.insert(path.clone(), format!("not a regular file: {kind:?}").into_bytes());
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
            .timeout(TIMEOUT)
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

// =======================================================================================
// Issue 36: no input may crash, hang, exhaust memory or overwrite what is not ours.

/// Makes a FIFO at `path` (with `mkfifo`).
fn mkfifo(path: &Path) {
    let made = std::process::Command::new("mkfifo").arg(path).status().expect("mkfifo runs");
    assert!(made.success(), "mkfifo {}", path.display());
}

/// A symbolic link at `link` to `target`.
fn symlink(target: &Path, link: &Path) {
    std::os::unix::fs::symlink(target, link).expect("links");
}

/// Asserts that no hidden temporary file (`.NAME.XXXX.tmp`) is left in `dir`.
fn no_hidden_temporaries(dir: &Dir) {
    let hidden: Vec<String> = std::fs::read_dir(dir.0.path())
        .expect("lists")
        .map(|e| e.expect("lists").file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with('.'))
        .collect();
    assert!(hidden.is_empty(), "hidden temporaries left: {hidden:?}");
}

// ---------------------------------------------------------------------------------------
// 1. panics

/// `--time-limit 1e300` (beyond what a duration counts) is no limit, not a panic; an OBJ with
/// a line element among faces that use `vt` is refused at its line (it panicked in the mesh).
#[test]
fn a_huge_time_limit_and_an_obj_line_element_do_not_panic() {
    let dir = Dir::new();
    dir.write("s.toml", SCENE);
    dir.ok(&["render", "s.toml", "--time-limit", "1e300", "--quiet", "--out", "r"]);
    assert!(dir.path("r.exr").exists() && !dir.path("r.partial.exr").exists(), "rendered to the end");
    dir.write("l.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nf 1/1 2/2 3/3\nl 1 2\n");
    let text = format!("{SCENE}\n[[mesh]]\nfile = \"l.obj\"\nmaterial = \"skin\"\n");
    dir.write("bad.toml", &text);
    let err = dir.refused(
        &["render", "bad.toml", "--quiet", "--out", "out"],
        &["bad.toml:", "l.obj", "line 8: `l` (line) elements are not read"],
    );
    names_line_in_section(&err, "bad.toml", &text, "l.obj");
}

// ---------------------------------------------------------------------------------------
// 2. allocations outside the memory check

/// `--subsamples` sets the nodes of every bin of a surface table (`sub`² each): `fit` and
/// `compare-model` check them against the memory budget before making them (`compare-model
/// --subsamples 100000` asked for 320 GB for its first bin and aborted, exit 134).
#[test]
fn surface_bin_nodes_go_through_the_memory_check() {
    let dir = Dir::new();
    let mut table = String::from(fiberlab_io::table::SURFACE_HEADER);
    table.push_str("\nlobe,theta_i,phi_i,theta_r,phi_r,f_r,f_g,f_b,std_r,std_g,std_b\n");
    for i in 0..9 {
        for j in 0..12 {
            let (t, p) = (5.0 + 10.0 * f64::from(i), -165.0 + 30.0 * f64::from(j));
            table.push_str(&format!("all,40,0,{t},{p},0.15,0.15,0.15,0.01,0.01,0.01\n"));
        }
    }
    dir.write("lambert.csv", table);
    let huge = ["--subsamples", "100000"];
    let mut compare = vec!["compare-model", "--table", "lambert.csv", "--model", "lambertian"];
    compare.extend_from_slice(&huge);
    dir.refused(&compare, &["1080000000000 bin nodes (100000² per bin) needs ~"]);
    let mut fit =
        vec!["fit", "--model", "lambertian", "--table", "lambert.csv", "--init", "k_d=0.3", "-q", "--out", "f"];
    fit.extend_from_slice(&huge);
    dir.refused(&fit, &["1080000000000 bin nodes (100000² per bin) needs ~"]);
    // The same table with the default nodes is compared and fitted.
    dir.ok(&["compare-model", "--table", "lambert.csv", "--model", "lambertian"]);
}

/// Sizes that a command allocates in proportion to are checked before any work, naming the
/// quantity and its estimate (each of these aborted the process, or filled the machine).
#[test]
fn sizes_in_proportion_to_the_input_go_through_the_memory_check() {
    let dir = Dir::new();
    dir.write("s.toml", SCENE);
    for (args, says) in [
        (
            &[
                "render",
                "s.toml",
                "--integrator",
                "dual-scattering",
                "--fiber-count",
                "grid",
                "--dual",
                "grid=100000",
                "--quiet",
                "--out",
                "out",
            ][..],
            &["fiber density grid", "(--dual grid=100000) needs ~"][..],
        ),
        (
            &["texture", "wood", "--width", "1000000", "--height", "1000000", "--out", "tex"],
            &["texture 1000000×1000000 (three maps) needs ~"],
        ),
        (&["mesh", "cloth", "--resolution", "100000000", "--out", "cloth.obj"], &["(--resolution 100000000) needs ~"]),
        (&["mesh", "cloth-patch", "--periods", "10000", "--out", "p.usda"], &["10000 × 10000 periods", "needs ~"]),
        (
            &["dual-tables", "--model", "chiang", "--inclinations", "1000000000000", "--out", "t"],
            &["1000000000000 table rows (--inclinations) needs ~"],
        ),
        (&["render", "s.toml", "--memory-limit", "1K", "--quiet", "--out", "out"], &["above --memory-limit 1.00 KiB"]),
    ] {
        dir.refused(args, says);
    }
    // The memory limit bounds the input files too: a scene larger than it is not read.
    let err = dir.refused(&["render", "s.toml", "--memory-limit", "100", "--quiet", "--out", "out"], &["s.toml"]);
    assert!(err.contains("more than the memory budget (--memory-limit 100 B)"), "{err}");
}

// ---------------------------------------------------------------------------------------
// 3. unbounded reads: FIFOs and devices as inputs

/// A FIFO at every input path is refused at once, naming the path (each blocked forever);
/// `/dev/zero` as an input is refused as a device (each grew until the kernel killed the
/// process); `/dev/zero` as the standard input of `eval` ends at the first over-long line.
#[test]
fn fifos_and_devices_given_as_inputs_are_refused_at_once() {
    let dir = Dir::new();
    dir.write("s.toml", SCENE);
    mkfifo(&dir.path("fifo"));
    for name in ["f.hair", "f.toml", "f.obj", "f.exr", "f.png", "f.csv", "f.weave", "f.pbrt", "f.usda"] {
        symlink(Path::new("fifo"), &dir.path(name));
    }
    for name in ["z.usda", "z.pbrt.gz", "z.pbrt", "z.obj", "z.csv", "z.hair"] {
        symlink(Path::new("/dev/zero"), &dir.path(name));
    }
    dir.write("inc.pbrt", "WorldBegin\nInclude \"f.pbrt\"\n");
    let scene_with = |section: &str| format!("{SCENE}\n{section}");
    dir.write("obj.toml", scene_with("[[mesh]]\nfile = \"f.obj\"\nmaterial = \"skin\"\n"));
    dir.write("env.toml", scene_with("[[light]]\ntype = \"envmap\"\nfile = \"f.exr\"\n"));
    dir.write(
        "tex.toml",
        scene_with("[materials.tex]\nmodel = \"lambertian\"\nparams = { k_d = \"f.png\" }\n[[sphere]]\ncenter = [0, 3, 0]\nradius = 1\nmaterial = \"tex\"\n"),
    );
    dir.write("zusd.toml", SCENE.replace("generator = { strands = 30, segments = 4 }", "file = \"z.usda\""));
    dir.write("zgz.toml", SCENE.replace("generator = { strands = 30, segments = 4 }", "file = \"z.pbrt.gz\""));
    dir.write("zobj.toml", scene_with("[[mesh]]\nfile = \"z.obj\"\nmaterial = \"skin\"\n"));
    let fifo = "a FIFO (named pipe), not a regular file";
    let device = "a character device, not a regular file";
    let cases: Vec<(Vec<&str>, Vec<&str>)> = vec![
        (vec!["hair", "info", "f.hair"], vec!["f.hair", fifo]),
        (vec!["hair", "info", "f.usda"], vec!["f.usda", fifo]),
        (vec!["hair", "info", "inc.pbrt"], vec!["inc.pbrt:2:9: cannot read the included file", "f.pbrt", fifo]),
        (vec!["render", "f.toml", "--quiet", "--out", "out"], vec!["f.toml", fifo]),
        (vec!["render", "obj.toml", "--quiet", "--out", "out"], vec!["obj.toml:", "f.obj", fifo]),
        (vec!["render", "env.toml", "--quiet", "--out", "out"], vec!["env.toml:", "f.exr", fifo]),
        (vec!["render", "tex.toml", "--quiet", "--out", "out"], vec!["tex.toml:", "f.png", fifo]),
        (vec!["render", "s.toml", "--resume", "f.exr", "--quiet", "--out", "out"], vec!["f.exr", fifo]),
        (vec!["merge", "f.exr", "--out", "m"], vec!["f.exr", fifo]),
        (vec!["eval", "--model", "diffuse", "--input", "f.csv"], vec!["f.csv", fifo]),
        (vec!["eval", "--model", "measured", "--param", "table=f.csv"], vec!["f.csv", fifo]),
        (vec!["eval", "--model", "irawan-2012", "--param", "pattern=f.weave"], vec!["f.weave", fifo]),
        (vec!["eval", "--model", "chiang", "--params-file", "f.toml"], vec!["f.toml", fifo]),
        (
            vec!["fit", "--model", "kajiya-kay", "--data", "f.csv", "--init", "k_d=0.2", "--out", "fo"],
            vec!["f.csv", fifo],
        ),
        (
            vec!["fit", "--model", "kajiya-kay", "--table", "f.csv", "--init", "k_d=0.2", "--out", "fo"],
            vec!["f.csv", fifo],
        ),
        (vec!["measure", "--fiber", "f.toml", "--theta-i", "0", "--rays", "10", "--out", "mo"], vec!["f.toml", fifo]),
        (vec!["compare", "f.png", "f.png"], vec!["f.png", fifo]),
        (vec!["montage", "f.png", "--out", "mont.png"], vec!["f.png", fifo]),
        (vec!["hair", "info", "z.usda"], vec!["z.usda", device]),
        (vec!["hair", "info", "z.hair"], vec!["z.hair", device]),
        (vec!["hair", "info", "z.pbrt"], vec!["z.pbrt", device]),
        (vec!["render", "zusd.toml", "--quiet", "--out", "out"], vec!["z.usda", device]),
        (vec!["render", "zgz.toml", "--quiet", "--out", "out"], vec!["z.pbrt.gz", device]),
        (vec!["render", "zobj.toml", "--quiet", "--out", "out"], vec!["z.obj", device]),
        (vec!["eval", "--model", "diffuse", "--input", "/dev/zero"], vec!["/dev/zero", device]),
        (vec!["eval", "--model", "measured", "--param", "table=z.csv"], vec!["z.csv", device]),
    ];
    for (args, says) in &cases {
        dir.refused(args, says);
    }
    // Standard input is the verb's one stream input: a stream without line breaks ends in an
    // error at its first over-long line, not in exhausted memory.
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_fiberlab"))
        .current_dir(dir.0.path())
        .args(["eval", "--model", "diffuse"])
        .stdin(std::fs::File::open("/dev/zero").expect("opens"))
        .output()
        .expect("runs");
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("<stdin>: line 1: longer than 1.00 MiB without a line break"), "{err}");
}

// ---------------------------------------------------------------------------------------
// 4. outputs that are not regular files

/// No writer replaces a symbolic link (here to a file outside the test's directory, standing
/// in for `/dev/full`), a FIFO or a directory: each is refused, naming what it is, and the
/// link, its target and every other file are as they were. `/dev/stdout` is written through.
#[test]
fn outputs_never_replace_links_fifos_or_devices() {
    let dir = Dir::new();
    let elsewhere = tempfile::tempdir().expect("a temporary directory");
    let precious = elsewhere.path().join("precious");
    std::fs::write(&precious, "not ours").expect("writes");
    dir.write("s.toml", SCENE);
    dir.write("in.csv", "wi_x,wi_y,wi_z,wo_x,wo_y,wo_z\n0,0,1,0,0,1\n");
    dir.write("good.hair", generated_hair(&dir));
    dir.ok(&["render", "s.toml", "--quiet", "--tile", "0/2", "--out", "p0"]);
    dir.ok(&["render", "s.toml", "--quiet", "--tile", "1/2", "--out", "p1"]);
    for name in [
        "link.hair",
        "link.usda",
        "link.csv",
        "link.toml",
        "link.png",
        "link.obj",
        "lk.exr",
        "lk.csv",
        "lk.toml",
        "lk.png",
    ] {
        symlink(&precious, &dir.path(name));
    }
    mkfifo(&dir.path("fifo.hair"));
    mkfifo(&dir.path("fifo.csv"));
    let link = "a symbolic link to ";
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (vec!["hair", "generate", "--strands", "3", "--segments", "2", "--out", "link.hair"], link),
        (vec!["hair", "generate", "--strands", "3", "--segments", "2", "--out", "fifo.hair"], "a FIFO (named pipe)"),
        (vec!["hair", "convert", "good.hair", "link.usda"], link),
        (vec!["eval", "--model", "diffuse", "--input", "in.csv", "--output", "link.csv"], link),
        (vec!["sample", "--model", "diffuse", "--wo", "0,0,1", "--count", "3", "--output", "link.csv"], link),
        (
            vec!["sample", "--model", "diffuse", "--wo", "0,0,1", "--count", "3", "--output", "fifo.csv"],
            "a FIFO (named pipe)",
        ),
        (vec!["scene", "--default", "--out", "link.toml"], link),
        (vec!["plot", "--model", "diffuse", "--theta-i", "30", "--out", "link.png"], link),
        (vec!["mesh", "cloth", "--resolution", "32", "--out", "link.obj"], link),
        (vec!["render", "s.toml", "--quiet", "--out", "lk"], link),
        (vec!["merge", "p0.exr", "p1.exr", "--out", "lk"], link),
        (vec!["measure", "--theta-i", "0", "--rays", "100", "--bins", "4,8", "--out", "lk"], link),
        (
            vec![
                "fit",
                "--model",
                "kajiya-kay",
                "--target",
                "kajiya-kay",
                "--init",
                "k_d=0.2",
                "--quiet",
                "--out",
                "lk",
            ],
            link,
        ),
        (
            vec![
                "dual-tables",
                "--model",
                "chiang",
                "--inclinations",
                "4",
                "--outgoing",
                "8",
                "--incident",
                "2",
                "--offsets",
                "2",
                "--out",
                "lk",
            ],
            link,
        ),
        (vec!["compare", "p0.png", "p0.png", "--out", "lk"], link),
        (vec!["montage", "p0.png", "--out", "link.png"], link),
    ];
    for (args, says) in &cases {
        dir.refused(args, &[says]);
        assert_eq!(std::fs::read_to_string(&precious).expect("reads"), "not ours", "{args:?}");
    }
    no_hidden_temporaries(&dir);
    // The documented streams are written through, not renamed.
    let template = dir.ok(&["scene", "--default", "--out", "/dev/stdout"]);
    assert!(template.starts_with("[camera]"), "{template}");
    let rows = dir.ok(&["sample", "--model", "diffuse", "--wo", "0,0,1", "--count", "2", "--output", "/dev/stdout"]);
    assert!(rows.starts_with("wi_x,wi_y,wi_z,") && rows.lines().count() == 3, "{rows}");
}

// ---------------------------------------------------------------------------------------
// 5. unbounded work

/// `--threads 100000` runs as many threads as the machine has (it took 90 s for a 1-spp
/// 32² image); pbrt files that include the next twice, 25 deep, are refused after a bounded
/// number of reads (they ran for minutes); 8,000 nested USD prims are an error at the prim
/// past the limit (they overflowed the stack).
#[test]
fn thread_counts_include_fan_out_and_usd_nesting_are_bounded() {
    let dir = Dir::new();
    dir.write("s.toml", SCENE);
    let out = dir.run(&["render", "s.toml", "--threads", "100000", "--spp", "1", "--quiet", "--out", "r"], "");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(err.contains("--threads 100000: rendering with"), "{err}");
    for i in 0..25 {
        dir.write(&format!("f{i}.pbrt"), format!("Include \"f{n}.pbrt\"\nInclude \"f{n}.pbrt\"\n", n = i + 1));
    }
    dir.write("f25.pbrt", "Shape \"curve\" \"point3 P\" [0 0 0 0 0.3 0 0 0.6 0 0 1 0] \"float width\" 0.01\n");
    let text = SCENE.replace("generator = { strands = 30, segments = 4 }", "file = \"f0.pbrt\"");
    dir.write("fan.toml", &text);
    let err = dir.refused(
        &["render", "fan.toml", "--quiet", "--out", "out"],
        &["fan.toml:", "more than 4096 files read in all"],
    );
    names_line_in_section(&err, "fan.toml", &text, "f0.pbrt");
    let depth = 8000;
    let mut usd = String::from("#usda 1.0\n");
    for i in 0..depth {
        usd.push_str(&format!("def Xform \"p{i}\" {{\n"));
    }
    usd.push_str(&"}\n".repeat(depth));
    dir.write("deep.usda", usd);
    dir.refused(&["hair", "info", "deep.usda"], &["deep.usda:258:1: prims nest more than 256 deep"]);
    dir.write("deep.toml", SCENE.replace("generator = { strands = 30, segments = 4 }", "file = \"deep.usda\""));
    dir.refused(&["render", "deep.toml", "--quiet", "--out", "out"], &["deep.toml:", "deep.usda:258:1: prims nest"]);
}

// ---------------------------------------------------------------------------------------
// 6. signals

/// Starts `args` in `dir`, waits until it says that it listens for signals, sends `signal`
/// (with `kill`) and waits for the end (killing it after [`TIMEOUT`]): its exit status and
/// standard error.
fn signalled(dir: &Dir, args: &[&str], signal: &str) -> (Option<i32>, String) {
    use std::io::{BufRead, BufReader};
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_fiberlab"))
        .current_dir(dir.0.path())
        .args(args)
        .stdin(std::process::Stdio::null())
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("starts");
    let stderr = child.stderr.take().expect("piped");
    let (lines, received) = std::sync::mpsc::channel();
    let reader = std::thread::spawn(move || {
        for line in BufReader::new(stderr).lines().map_while(Result::ok) {
            if lines.send(line).is_err() {
                break;
            }
        }
    });
    let start = Instant::now();
    let mut text = String::new();
    loop {
        let left = TIMEOUT.saturating_sub(start.elapsed());
        match received.recv_timeout(left) {
            Ok(line) => {
                text += &line;
                text.push('\n');
                if line.contains("Ctrl-C stops and keeps") {
                    break;
                }
            }
            Err(_) => {
                let _ = child.kill();
                panic!("{args:?} never said that it listens for signals: {text}");
            }
        }
    }
    // Let it get into its work, then signal.
    std::thread::sleep(Duration::from_millis(500));
    let sent = std::process::Command::new("kill").arg(format!("-{signal}")).arg(child.id().to_string()).status();
    assert!(sent.expect("kill runs").success(), "kill -{signal}");
    let status = loop {
        if let Some(status) = child.try_wait().expect("waits") {
            break status;
        }
        if start.elapsed() > TIMEOUT {
            let _ = child.kill();
            panic!("{args:?} did not end after SIG{signal}: {text}");
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    reader.join().expect("the reader ends with the process");
    text.extend(received.try_iter().map(|l| l + "\n"));
    (status.code(), text)
}

/// Runs a long verb, signals it, and checks what every stopped verb must do: exit with 130
/// (not killed by the signal, no panic), say what it wrote, write `partial`, leave no hidden
/// temporary file and every earlier output as it was.
fn stops_and_keeps_what_is_done(dir: &Dir, args: &[&str], signal: &str, partial: &[&str]) -> String {
    let before = dir.files();
    let (code, err) = signalled(dir, args, signal);
    assert_eq!(code, Some(130), "{args:?} after SIG{signal}: {err}");
    assert!(err.contains("interrupted: ") && !err.contains("panicked"), "{err}");
    for p in partial {
        assert!(dir.path(p).is_file(), "{args:?}: no {p} after SIG{signal}: {err}");
    }
    no_hidden_temporaries(dir);
    let after = dir.files();
    for (path, bytes) in &before {
        assert_eq!(after.get(path), Some(bytes), "{args:?} changed {}", path.display());
    }
    err
}

#[test]
fn render_stopped_by_sigterm_keeps_its_samples() {
    let dir = Dir::new();
    dir.write("s.toml", SCENE.replace("spp = 1", "spp = 100000"));
    stops_and_keeps_what_is_done(
        &dir,
        &["render", "s.toml", "--quiet", "--out", "r"],
        "TERM",
        &["r.partial.exr", "r.partial.png"],
    );
    assert!(!dir.path("r.exr").exists());
}

/// The same on the GPU (Mesa's software Vulkan in CI; `FIBERLAB_GPU_TESTS=skip` skips it on
/// a machine without any Vulkan driver): SIGINT during a GPU render keeps the finished chunks'
/// samples in a partial image.
#[test]
fn gpu_render_stopped_by_sigint_keeps_its_samples() {
    if std::env::var("FIBERLAB_GPU_TESTS").as_deref() == Ok("skip") {
        eprintln!("skipping the GPU render (FIBERLAB_GPU_TESTS=skip)");
        return;
    }
    let dir = Dir::new();
    // The GPU renders chiang (not kajiya-kay).
    dir.write("s.toml", SCENE.replace("spp = 1", "spp = 100000").replace("\"kajiya-kay\"", "\"chiang\""));
    let err = stops_and_keeps_what_is_done(
        &dir,
        &["render", "s.toml", "--device", "gpu", "--quiet", "--out", "r"],
        "INT",
        &["r.partial.exr", "r.partial.png"],
    );
    assert!(!dir.path("r.exr").exists(), "{err}");
}

#[test]
fn measure_stopped_by_sigint_writes_a_partial_table() {
    let dir = Dir::new();
    let args = ["measure", "--theta-i", "0,30", "--rays", "2000000000", "--bins", "6,12", "--out", "m"];
    stops_and_keeps_what_is_done(&dir, &args, "INT", &["m.partial.csv", "m.partial.png", "m.partial.exr"]);
    assert!(!dir.path("m.csv").exists());
    let table = std::fs::read_to_string(dir.path("m.partial.csv")).expect("reads");
    assert!(table.starts_with("lobe,theta_i,") && table.lines().count() > 1, "{table}");
}

#[test]
fn fit_stopped_by_sighup_writes_its_best_point_so_far() {
    let dir = Dir::new();
    let args = [
        "fit",
        "--model",
        "chiang",
        "--target",
        "marschner",
        "--init",
        "beta_m=0.5",
        "--init",
        "beta_n=0.5",
        "--init",
        "alpha=0",
        "--iterations",
        "1000000",
        "--quiet",
        "--out",
        "f",
    ];
    stops_and_keeps_what_is_done(&dir, &args, "HUP", &["f.partial.toml"]);
    let toml = std::fs::read_to_string(dir.path("f.partial.toml")).expect("reads");
    assert!(toml.contains("model = \"chiang\"") && toml.contains("beta_m = "), "{toml}");
}

#[test]
fn check_stopped_by_sigterm_prints_the_rows_done() {
    let dir = Dir::new();
    let err = stops_and_keeps_what_is_done(&dir, &["check", "--quiet"], "TERM", &[]);
    assert!(err.contains("configurations") && err.contains("the table above is partial"), "{err}");
}

#[test]
fn sample_stopped_by_sigint_keeps_the_rows_written_and_no_temporary() {
    let dir = Dir::new();
    let args = ["sample", "--model", "chiang", "--wo", "0,1,0", "--count", "100000000", "--output", "s.csv"];
    stops_and_keeps_what_is_done(&dir, &args, "INT", &["s.partial.csv"]);
    assert!(!dir.path("s.csv").exists());
    let rows = std::fs::read_to_string(dir.path("s.partial.csv")).expect("reads");
    assert!(rows.starts_with("wi_x,") && rows.lines().count() > 1, "{} rows", rows.lines().count());
}

#[test]
fn dual_tables_stopped_by_sighup_write_the_rows_done() {
    let dir = Dir::new();
    let args = ["dual-tables", "--model", "chiang", "--inclinations", "100000", "--outgoing", "32", "--out", "t"];
    stops_and_keeps_what_is_done(&dir, &args, "HUP", &["t.partial.csv", "t.partial.png"]);
    assert!(!dir.path("t.csv").exists());
}

/// A streamed output larger than the free space of its file system is refused before the
/// first row (`sample --count 1e11` filled the disk).
#[test]
fn a_streamed_output_larger_than_the_free_disk_is_refused_up_front() {
    let dir = Dir::new();
    dir.refused(
        &["sample", "--model", "diffuse", "--wo", "0,0,1", "--count", "18000000000000000000", "--output", "s.csv"],
        &["s.csv: the output needs ~", "free on its file system"],
    );
}

// ---------------------------------------------------------------------------------------
// 7. merge

/// `merge … --out q0` would overwrite the part `q0.exr`; one crop of an image is not the
/// image (75 % of it was left black with exit 0).
#[test]
fn merge_refuses_to_overwrite_a_part_and_crops_that_do_not_cover_the_image() {
    let dir = Dir::new();
    render_part(&dir, SCENE, "q0", &["--tile", "0/2"]);
    render_part(&dir, SCENE, "q1", &["--tile", "1/2"]);
    render_part(&dir, SCENE, "left", &["--crop", "0,0,10,16"]);
    render_part(&dir, SCENE, "rest", &["--crop", "10,0,16,16"]);
    dir.refused(&["merge", "q0.exr", "q1.exr", "--out", "q0"], &["--out q0: q0.exr is the part q0.exr", "overwrite"]);
    dir.refused(
        &["merge", "left.exr", "--out", "m"],
        &["left.exr", "cover 160 of the 16×16 image's 256 pixels", "x = 10, y = 0"],
    );
    dir.ok(&["merge", "left.exr", "rest.exr", "--out", "whole"]);
}

// ---------------------------------------------------------------------------------------
// 8. silent nonsense

/// Values that gave NaN, dropped numbers or an empty answer with exit 0 are refused where
/// they enter, naming the place.
#[test]
fn model_parameters_arrays_and_flags_that_made_nonsense_are_refused() {
    let dir = Dir::new();
    let pair = "wi_x,wi_y,wi_z,wo_x,wo_y,wo_z\n0,1,0,0,0,1\n";
    dir.refused_with_input(&["eval", "--model", "chiang", "--param", "beta_m=1e-200"], pair, &["beta_m", "[0.01, 1]"]);
    dir.refused_with_input(&["eval", "--model", "deon", "--param", "beta_m=1e-200"], pair, &["beta_m", "[0.01, 1]"]);
    dir.refused_with_input(&["eval", "--model", "chiang", "--param", "beta_n=1e-320"], pair, &["beta_n", "[0.01, 1]"]);
    dir.refused(
        &["sample", "--model", "wood", "--wo", "0,0,-1", "--count", "10", "--output", "s.csv"],
        &["--wo 0,0,-1", "drew no sample in 10 tries", "below the surface"],
    );
    dir.write("s.toml", SCENE);
    dir.refused(
        &[
            "render",
            "s.toml",
            "--integrator",
            "dual-scattering",
            "--fiber-count",
            "grid",
            "--dual",
            "grid=0",
            "--quiet",
            "--out",
            "out",
        ],
        &["--dual grid = 0: expected a whole number of cells ≥ 1"],
    );
    // A fourth number where three are meant, in each array of three.
    for (from, to) in [
        ("center = [0.0, 0.0, 0.0]", "center = [0.0, 0.0, 0.0, 9.0]"),
        ("eye = [0.0, 0.0, 4.0]", "eye = [0.0, 0.0, 4.0, 1.0]"),
        ("target = [0.0, 0.0, 0.0]", "target = [0.0, 0.0, 0.0]\nup = [0.0, 1.0, 0.0, 0.0]"),
        ("lambert = [0.5, 0.4, 0.3]", "lambert = [0.5, 0.4, 0.3, 0.2]"),
    ] {
        let text = SCENE.replace(from, to);
        dir.write("bad.toml", &text);
        let err = dir.refused(&["render", "bad.toml", "--quiet", "--out", "out"], &["bad.toml:", "invalid length 4"]);
        names_line_in_section(&err, "bad.toml", &text, to.lines().last().unwrap());
    }
    // Camera values: each error at its own key's line; a far eye is not "the same as target".
    for (from, to, says) in [
        ("fov = 40", "fov = 400", "fov = 400.0 must be in (0, 180)"),
        ("eye = [0.0, 0.0, 4.0]", "eye = [1e300, 1e300, 4.0]", "too far apart"),
    ] {
        let text = SCENE.replace(from, to);
        dir.write("cam.toml", &text);
        let err = dir.refused(&["render", "cam.toml", "--quiet", "--out", "out"], &["cam.toml:", says]);
        let line = text.lines().position(|l| l == to).unwrap() + 1;
        assert!(err.contains(&format!("cam.toml:{line}:1: camera: ")), "{err}");
        assert!(!err.contains("must differ"), "{err}");
    }
}

/// Data a fit cannot use, USD composition, weave-file ranges, OBJ reader errors and a zero
/// pbrt scale: refused with the place, never a silent answer.
#[test]
fn files_that_made_silent_nonsense_are_refused_at_their_place() {
    let dir = Dir::new();
    let row = |v: &str| format!("0,0,10,180,{v}\n");
    dir.write(
        "huge.csv",
        format!("theta_i,phi_i,theta_r,phi_r,value\n{}", (0..20).map(|_| row("1e300")).collect::<String>()),
    );
    dir.write(
        "zero.csv",
        format!("theta_i,phi_i,theta_r,phi_r,value\n{}", (0..20).map(|_| row("0")).collect::<String>()),
    );
    let fit = |data: &'static str| {
        vec!["fit", "--model", "kajiya-kay", "--data", data, "--init", "k_d=0.2", "--quiet", "--out", "f"]
    };
    dir.refused(&fit("huge.csv"), &["no free parameter changes χ²"]);
    dir.refused(&fit("zero.csv"), &["every observed value is 0"]);
    // USD references are refused, not left out (an empty groom rendered).
    dir.write("refs.usda", "#usda 1.0\ndef Xform \"groom\" (\n    references = @hair.usda@\n)\n{\n}\n");
    dir.refused(&["hair", "info", "refs.usda"], &["refs.usda:3:5: `references`", "flatten"]);
    // Weave files: a range error at the line that gives the value, said once; `tile` once.
    let weave = "tile 2 2\nalpha 50\nbeta 4\nss 0.5\nhwidth 0.5\nwarp_area 1\nweft_area 1\n\
                 yarn 1 warp psi=0 umax=22 kappa=-0.7 width=1 length=1 center=0.5,0.5 kd=0.25 ks=0.075\n\
                 yarn 2 weft psi=0 umax=16 kappa=-0.7 width=1 length=1 center=1.5,0.5 kd=0.25 ks=0.075\n\
                 pattern\n1 2\n2 1\n";
    dir.write("a.weave", weave);
    let pair = "wi_x,wi_y,wi_z,wo_x,wo_y,wo_z\n0,0,1,0,0,1\n";
    let err = dir.refused_with_input(
        &["eval", "--model", "irawan-2012", "--param", "pattern=a.weave"],
        pair,
        &["a.weave:2:", "alpha"],
    );
    assert_eq!(err.matches("is not valid").count(), 1, "said once: {err}");
    dir.write("t.weave", weave.replace("alpha 50\n", "alpha 0.015\ntile 2 2\n"));
    dir.refused_with_input(
        &["eval", "--model", "irawan-2012", "--param", "pattern=t.weave"],
        pair,
        &["t.weave:3:", "given twice"],
    );
    // The OBJ reader's own errors name their line.
    dir.write("u.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 3\nusemtl\n");
    dir.write("u.toml", format!("{SCENE}\n[[mesh]]\nfile = \"u.obj\"\nmaterial = \"skin\"\n"));
    dir.refused(&["render", "u.toml", "--quiet", "--out", "out"], &["u.obj", "line 5"]);
    // A pbrt `Scale 0 0 0` makes every width 0 (a width of 0 is refused).
    dir.write(
        "z.pbrt",
        "Scale 0 0 0\nShape \"curve\" \"point3 P\" [0 0 0 0 0.3 0 0 0.6 0 0 1 0] \"float width\" 0.01\n",
    );
    dir.write("z.toml", SCENE.replace("generator = { strands = 30, segments = 4 }", "file = \"z.pbrt\""));
    dir.refused(&["render", "z.toml", "--quiet", "--out", "out"], &["z.pbrt:2:", "singular"]);
}
