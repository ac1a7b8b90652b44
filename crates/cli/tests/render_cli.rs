//! End-to-end tests of `fiberlab hair`, `fiberlab render` and `fiberlab merge`.

mod fiberlab_process;
use fiberlab_process::{fiberlab_in, stderr_of};

const SCENE: &str = r#"
[camera]
eye = [0.0, 0.5, 4.0]
target = [0.0, 0.0, 0.0]
fov = 40
width = 20
height = 14

[render]
spp = 2
seed = 3

[materials.hair]
model = "kajiya-kay"

[materials.skin]
lambert = [0.5, 0.4, 0.3]

[[hair]]
material = "hair"
file = "h.hair"

[[sphere]]
center = [0, 0, 0]
radius = 1
material = "skin"

[[light]]
type = "environment"
radiance = [1, 1, 1]

[[light]]
type = "sun"
direction = [1, 1, 1]
angular_radius_deg = 1
irradiance = [2, 2, 2]
"#;

#[test]
fn generate_render_in_parts_and_merge_bit_for_bit() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    stderr_of(fiberlab_in(d).args([
        "hair",
        "generate",
        "--style",
        "curly",
        "--strands",
        "300",
        "--seed",
        "4",
        "--out",
        "h.hair",
    ]));
    let info = fiberlab_in(d).args(["hair", "info", "h.hair"]).output().unwrap();
    assert!(String::from_utf8_lossy(&info.stdout).contains("strands     300"));
    std::fs::write(d.join("s.toml"), SCENE).unwrap();
    stderr_of(fiberlab_in(d).args(["render", "s.toml", "--quiet", "--threads", "2", "--out", "full"]));
    for i in 0..3 {
        let tile = format!("{i}/3");
        stderr_of(fiberlab_in(d).args([
            "render",
            "s.toml",
            "--quiet",
            "--threads",
            "1",
            "--tile",
            &tile,
            "--out",
            &format!("p{i}"),
        ]));
    }
    stderr_of(fiberlab_in(d).args(["merge", "p0.exr", "p1.exr", "p2.exr", "--out", "merged"]));
    let full = fiberlab_io::LinearImage::read_exr(&d.join("full.exr")).unwrap();
    let merged = fiberlab_io::LinearImage::read_exr(&d.join("merged.exr")).unwrap();
    assert_eq!(full, merged);
    assert!(d.join("full.png").exists() && d.join("merged.png").exists());
}

#[test]
fn scene_errors_name_file_line_and_key() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("bad.toml"), SCENE.replace("spp = 2", "spp = 2\nbogus = 1")).unwrap();
    let out = fiberlab_in(d).args(["render", "bad.toml", "--quiet"]).output().unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("bad.toml:11:1:") && err.contains("bogus"), "{err}");
    std::fs::write(d.join("s.toml"), SCENE.replace("file = \"h.hair\"", "generator = { strands = 10 }")).unwrap();
    // An output place that cannot be written is refused before the scene is even read.
    let out = fiberlab_in(d).args(["render", "s.toml", "--out", "/nonexistent/dir/r"]).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("/nonexistent/dir") && err.contains("does not exist"), "{err}");
    let out = fiberlab_in(d).args(["render", "s.toml", "--out", "."]).output().unwrap();
    assert!(String::from_utf8_lossy(&out.stderr).contains("is a directory"));
    let out = fiberlab_in(d).args(["render", "s.toml", "--tile", "3/3"]).output().unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("0 ≤ I < N"), "{}", String::from_utf8_lossy(&out.stderr));
}

/// Renders the test scene (with a generated `h.hair`) in a new directory.
fn scene_dir() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    stderr_of(fiberlab_in(d).args(["hair", "generate", "--strands", "200", "--seed", "4", "--out", "h.hair"]));
    std::fs::write(d.join("s.toml"), SCENE).unwrap();
    dir
}

#[test]
fn a_stopped_render_is_partial_and_resume_is_bit_identical_to_one_render() {
    let dir = scene_dir();
    let d = dir.path();
    stderr_of(fiberlab_in(d).args(["render", "s.toml", "--quiet", "--spp", "6", "--out", "long"]));
    // A 0-second time limit stops at once: the finished image of that name is not replaced,
    // the partial one goes beside it, and the exit status is 0 (the limit was asked for).
    std::fs::copy(d.join("long.exr"), d.join("r.exr")).unwrap();
    let before = std::fs::read(d.join("r.exr")).unwrap();
    let err = stderr_of(fiberlab_in(d).args([
        "render",
        "s.toml",
        "--quiet",
        "--spp",
        "6",
        "--time-limit",
        "0",
        "--out",
        "r",
    ]));
    assert!(err.contains("stopped by --time-limit") && err.contains("--resume r.partial.exr"), "{err}");
    assert_eq!(std::fs::read(d.join("r.exr")).unwrap(), before);
    let partial = fiberlab_io::LinearImage::read_exr(&d.join("r.partial.exr")).unwrap();
    assert_eq!(partial.attribute("spp"), Some("0"));
    // Continue it in two steps, to 2 spp and then to 6 (the prefix comes from the file): the
    // finished image is the one-render image bit for bit, and the partial files are gone.
    stderr_of(fiberlab_in(d).args([
        "render",
        "s.toml",
        "--quiet",
        "--spp",
        "2",
        "--resume",
        "r.partial.exr",
        "--out",
        "r2",
    ]));
    stderr_of(fiberlab_in(d).args(["render", "s.toml", "--quiet", "--spp", "6", "--resume", "r2.exr", "--out", "r"]));
    let long = fiberlab_io::LinearImage::read_exr(&d.join("long.exr")).unwrap();
    let resumed = fiberlab_io::LinearImage::read_exr(&d.join("r.exr")).unwrap();
    assert_eq!(resumed, long);
    let err = stderr_of(fiberlab_in(d).args([
        "render",
        "s.toml",
        "--quiet",
        "--spp",
        "7",
        "--time-limit",
        "0",
        "--out",
        "q",
    ]));
    assert!(err.contains("q.partial.exr"), "{err}");
    stderr_of(fiberlab_in(d).args(["render", "s.toml", "--quiet", "--spp", "6", "--resume", "q.partial.exr"]));
    assert_eq!(fiberlab_io::LinearImage::read_exr(&d.join("q.exr")).unwrap(), long);
    assert!(!d.join("q.partial.exr").exists() && !d.join("q.partial.png").exists());
    // What cannot be continued is refused before any work, naming the file and the reason.
    std::fs::write(d.join("other.toml"), SCENE.replace("seed = 3", "seed = 3\nmax_depth = 5")).unwrap();
    for (args, says) in [
        (&["s.toml", "--spp", "2", "--resume", "long.exr"][..], "already has 6 spp"),
        (&["other.toml", "--resume", "long.exr"][..], "another scene"),
        (&["s.toml", "--seed", "9", "--resume", "long.exr"][..], "seed 3, not --seed 9"),
        (&["s.toml", "--tile", "0/2", "--resume", "long.exr"][..], "it renders the whole image"),
        (&["s.toml", "--resume", "missing.exr"][..], "missing.exr"),
    ] {
        let out = fiberlab_in(d).arg("render").args(args).args(["--quiet", "--out", "bad"]).output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.code() == Some(1) && err.contains(says), "{args:?}: {err}");
        assert!(!d.join("bad.exr").exists() && !d.join("bad.partial.exr").exists(), "{args:?}");
    }
}

#[test]
#[cfg(unix)]
fn ctrl_c_stops_a_billion_spp_render_with_status_130_and_a_partial_image() {
    use std::io::{BufRead, BufReader};
    let dir = scene_dir();
    let d = dir.path();
    std::fs::write(d.join("r.exr"), b"a finished image").unwrap();
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_fiberlab"))
        .current_dir(d)
        .args(["render", "s.toml", "--quiet", "--spp", "1000000000", "--out", "r"])
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let mut stderr = BufReader::new(child.stderr.take().unwrap());
    let mut line = String::new();
    // The handler is installed before this line is printed.
    while !line.contains("rendering") {
        line.clear();
        assert!(stderr.read_line(&mut line).unwrap() > 0, "render ended before it started");
    }
    let kill = std::process::Command::new("kill").args(["-INT", &child.id().to_string()]).status().unwrap();
    assert!(kill.success());
    let mut rest = String::new();
    std::io::Read::read_to_string(&mut stderr, &mut rest).unwrap();
    let status = child.wait().unwrap();
    assert_eq!(status.code(), Some(130), "{rest}");
    assert!(rest.contains("interrupted: wrote r.partial.exr"), "{rest}");
    assert_eq!(std::fs::read(d.join("r.exr")).unwrap(), b"a finished image");
    let partial = fiberlab_io::LinearImage::read_exr(&d.join("r.partial.exr")).unwrap();
    assert_eq!(partial.attribute("target_spp"), Some("1000000000"));
    assert!(d.join("r.partial.png").exists());
}

/// `--size WxH` renders that many pixels instead of the camera's (a quick preview): the scene's
/// own size gives the scene's image, another size another image of that size; a render at one
/// size is not continued at another, and a malformed size is refused when the command line is
/// read.
#[test]
fn size_overrides_the_camera_image_size() {
    let dir = scene_dir();
    let d = dir.path();
    let read = |name: &str| fiberlab_io::LinearImage::read_exr(&d.join(name)).unwrap();
    stderr_of(fiberlab_in(d).args(["render", "s.toml", "--quiet", "--spp", "1", "--out", "own"]));
    stderr_of(fiberlab_in(d).args(["render", "s.toml", "--quiet", "--spp", "1", "--size", "20x14", "--out", "same"]));
    assert_eq!(read("same.exr").pixels(), read("own.exr").pixels());
    let err = stderr_of(
        fiberlab_in(d).args(["render", "s.toml", "--quiet", "--spp", "1", "--size", "9×5", "--out", "small"]),
    );
    assert!(err.contains("9×5"), "{err}");
    let small = read("small.exr");
    assert_eq!((small.width(), small.height()), (9, 5));
    assert!(small.pixels().iter().flatten().any(|&v| v > 0.0));
    let png = image::open(d.join("small.png")).unwrap();
    assert_eq!((png.width(), png.height()), (9, 5));
    let out = fiberlab_in(d)
        .args(["render", "s.toml", "--quiet", "--spp", "2", "--resume", "small.exr", "--size", "20x14", "--out", "x"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.code() == Some(1) && err.contains("another scene"), "{err}");
    for (bad, says) in [("0x5", "at least 1"), ("12", "WxH"), ("12x", "WxH"), ("3x4.5", "WxH")] {
        let out = fiberlab_in(d).args(["render", "s.toml", "--quiet", "--size", bad]).output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.code() == Some(2) && err.contains("--size") && err.contains(says), "{bad}: {err}");
    }
    assert!(!d.join("render.exr").exists() && !d.join("x.exr").exists());
}
