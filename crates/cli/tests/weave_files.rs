//! Weave-pattern files on the command line (`--param pattern=FILE` of `irawan-2012`): a file
//! that spells out a preset evaluates bit-identically to the preset; a different weave does
//! not; bad files are refused naming file, line and field; `check --param` checks a file.

mod fiberlab_process;
use fiberlab_process::fiberlab;
use std::path::{Path, PathBuf};

fn weave(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/weaves").join(name)
}

/// Direction pairs on the upper hemisphere with UV positions over two tiles (a fixed
/// low-discrepancy-like grid, no random generator needed).
fn directions() -> String {
    let mut text = String::from("wi_x,wi_y,wi_z,wo_x,wo_y,wo_z,u,v\n");
    let dir = |t: f64, p: f64| [t.sin() * p.cos(), t.sin() * p.sin(), t.cos()];
    for k in 0..400 {
        let k = f64::from(k);
        let wi = dir(1.4 * (0.618_034 * k).fract(), std::f64::consts::TAU * (0.754_877 * k).fract());
        let wo = dir(1.4 * (0.569_840 * k).fract(), std::f64::consts::TAU * (0.414_213 * k).fract());
        let (u, v) = (2.0 * (0.324_718 * k).fract(), 2.0 * (0.267_949 * k).fract());
        text.push_str(&format!("{},{},{},{},{},{},{u},{v}\n", wi[0], wi[1], wi[2], wo[0], wo[1], wo[2]));
    }
    text
}

fn eval(params: &[String]) -> Result<String, String> {
    let mut cmd = fiberlab();
    cmd.args(["eval", "--model", "irawan-2012"]);
    for p in params {
        cmd.args(["--param", p]);
    }
    let out = cmd.write_stdin(directions()).output().unwrap();
    if out.status.success() {
        Ok(String::from_utf8(out.stdout).unwrap())
    } else {
        Err(String::from_utf8(out.stderr).unwrap())
    }
}

/// The file of the polyester-lining preset gives the preset's output byte for byte, with
/// highlights in it (f_r above the diffuse k_d/π somewhere); the satin file differs.
#[test]
fn a_pattern_file_of_a_preset_evaluates_like_the_preset() {
    let preset = eval(&["preset=polyester-lining".into()]).unwrap();
    let file = eval(&[format!("pattern={}", weave("polyester-lining.weave").display())]).unwrap();
    assert_eq!(preset, file);
    let diffuse_r = 0.25 / std::f64::consts::PI;
    let lit = preset
        .lines()
        .skip(1)
        .filter(|l| l.split(',').nth(8).unwrap().parse::<f64>().unwrap() > diffuse_r * 1.01)
        .count();
    assert!(lit > 0, "some rows see a highlight");
    let satin = eval(&[format!("pattern={}", weave("satin.weave").display())]).unwrap();
    assert_ne!(satin, preset);
    // The variations change the output of the same file.
    let fine = eval(&[format!("pattern={}", weave("satin.weave").display()), "fineness=30".into()]).unwrap();
    assert_ne!(fine, satin);
}

/// NaN, an id out of range, a missing row, a missing yarn field: `FILE:LINE: field …`.
#[test]
fn bad_pattern_files_are_refused_naming_file_line_and_field() {
    let dir = tempfile::tempdir().unwrap();
    let good = std::fs::read_to_string(weave("polyester-lining.weave")).unwrap();
    let cases = [
        (
            good.replace(
                "umax=16 kappa=-0.7 width=1 length=1 center=1.5",
                "umax=NaN kappa=-0.7 width=1 length=1 center=1.5",
            ),
            12,
            "umax",
        ),
        (good.replace("\n3 4\n", "\n3 5\n"), 17, "pattern"),
        (good.replace("\n3 4\n", "\n"), 15, "pattern"),
        (good.replace("yarn 3 weft psi=0 ", "yarn 3 weft "), 13, "psi"),
    ];
    for (k, (text, line, field)) in cases.iter().enumerate() {
        let path = dir.path().join(format!("bad{k}.weave"));
        std::fs::write(&path, text).unwrap();
        let e = eval(&[format!("pattern={}", path.display())]).unwrap_err();
        let at = format!("{}:{line}:", path.display());
        assert!(e.contains(&at) && e.contains(&format!("`{field}`")), "case {k}: expected {at} {field}: {e}");
    }
    let e = eval(&["pattern=none.weave".into()]).unwrap_err();
    assert!(e.contains("none.weave"), "{e}");
    let e = eval(&[format!("pattern={}", weave("satin.weave").display()), "preset=cotton-denim".into()]).unwrap_err();
    assert!(e.contains("not both"), "{e}");
}

/// `scenes/cloth-satin.toml` builds, its fabric read from `weaves/satin.weave` next to it.
#[test]
fn the_satin_scene_reads_its_weave_file() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/cloth-satin.toml");
    let file = fiberlab_render::scene_file::SceneFile::read(&path).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    assert!(text.contains("pattern = \"weaves/satin.weave\""));
    file.build().map_err(|e| e.to_string()).unwrap();
}
