//! End-to-end tests of `fiberlab hair`, `fiberlab render` and `fiberlab merge`.

use assert_cmd::Command;
use std::path::Path;

fn fiberlab(dir: &Path) -> Command {
    let mut c = Command::cargo_bin("fiberlab").expect("binary builds");
    c.current_dir(dir);
    c
}

fn ok(cmd: &mut Command) -> String {
    let out = cmd.output().expect("runs");
    assert!(out.status.success(), "failed: {}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8_lossy(&out.stderr).into_owned()
}

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
    ok(fiberlab(d).args([
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
    let info = fiberlab(d).args(["hair", "info", "h.hair"]).output().unwrap();
    assert!(String::from_utf8_lossy(&info.stdout).contains("strands     300"));
    std::fs::write(d.join("s.toml"), SCENE).unwrap();
    ok(fiberlab(d).args(["render", "s.toml", "--quiet", "--threads", "2", "--out", "full"]));
    for i in 0..3 {
        let tile = format!("{i}/3");
        ok(fiberlab(d).args([
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
    ok(fiberlab(d).args(["merge", "p0.exr", "p1.exr", "p2.exr", "--out", "merged"]));
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
    let out = fiberlab(d).args(["render", "bad.toml", "--quiet"]).output().unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("bad.toml:11:1:") && err.contains("bogus"), "{err}");
    std::fs::write(d.join("s.toml"), SCENE.replace("file = \"h.hair\"", "generator = { strands = 10 }")).unwrap();
    // An output place that cannot be written is refused before the scene is even read.
    let out = fiberlab(d).args(["render", "s.toml", "--out", "/nonexistent/dir/r"]).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("/nonexistent/dir") && err.contains("does not exist"), "{err}");
    let out = fiberlab(d).args(["render", "s.toml", "--out", "."]).output().unwrap();
    assert!(String::from_utf8_lossy(&out.stderr).contains("is a directory"));
    let out = fiberlab(d).args(["render", "s.toml", "--tile", "3/3"]).output().unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("0 ≤ I < N"), "{}", String::from_utf8_lossy(&out.stderr));
}
