//! What the tools tell: `fit`'s uncertainties, bounds and colour fits, its data checks,
//! `check --quiet`, `scene --default`, and error texts that name the place, once, in the
//! unit given.

mod fiberlab_process;
use assert_cmd::Command;
use fiberlab_process::{fiberlab, stdout_of};
use std::path::Path;

/// Stderr of a command that must fail (non-zero exit, no panic).
fn error_of(cmd: &mut Command) -> String {
    let out = cmd.output().expect("runs");
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(!out.status.success(), "expected a failure, got success: {}", String::from_utf8_lossy(&out.stdout));
    assert!(!err.contains("panicked"), "{err}");
    err
}

/// A CSV of the ideal diffuse fiber, `f_s = ρ/π²` per channel (closed form), on a grid of
/// directions in degrees, with 1 % standard errors.
fn diffuse_csv(albedo: [f64; 3]) -> String {
    let mut csv = String::from("theta_i,phi_i,theta_r,phi_r,f_r,f_g,f_b,std_r,std_g,std_b\n");
    let pi2 = std::f64::consts::PI.powi(2);
    for i in 0..6 {
        for j in 0..8 {
            let f = albedo.map(|a| a / pi2);
            csv.push_str(&format!(
                "{},0,{},{},{},{},{},{},{},{}\n",
                -60 + 20 * i,
                -70 + 20 * j,
                45 * j - 170,
                f[0],
                f[1],
                f[2],
                0.01 * f[0],
                0.01 * f[1],
                0.01 * f[2]
            ));
        }
    }
    csv
}

fn fit_diffuse(dir: &Path, csv: &str, init: &str) -> std::process::Output {
    let data = dir.join("data.csv");
    std::fs::write(&data, csv).unwrap();
    fiberlab()
        .args(["fit", "--model", "diffuse", "--data", data.to_str().unwrap(), "--init", init, "--out"])
        .arg(dir.join("fitted"))
        .output()
        .unwrap()
}

/// The value printed as `  key = value ± error`.
fn fitted(out: &str, key: &str) -> f64 {
    let line = out.lines().find(|l| l.trim_start().starts_with(&format!("{key} = "))).unwrap();
    line.split('=').nth(1).unwrap().split('±').next().unwrap().trim().parse().unwrap()
}

#[test]
fn fit_recovers_a_colour_per_channel_from_rgb_data() {
    let dir = tempfile::tempdir().unwrap();
    let out = fit_diffuse(dir.path(), &diffuse_csv([0.7, 0.4, 0.1]), "albedo=0.5");
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    for (key, want) in [("albedo[r]", 0.7), ("albedo[g]", 0.4), ("albedo[b]", 0.1)] {
        assert!((fitted(&text, key) - want).abs() < 1e-4, "{key}: {text}");
    }
    assert!(text.contains(" ± ") && !text.contains("NaN") && !text.contains("warning"), "{text}");
    // The parameters file holds the colour as an array, which other commands read.
    let toml = std::fs::read_to_string(dir.path().join("fitted.toml")).unwrap();
    let table: toml::Table = toml.parse().unwrap();
    let albedo = table["params"]["albedo"].as_array().unwrap();
    assert_eq!(albedo.len(), 3, "{toml}");
    assert!((albedo[0].as_float().unwrap() - 0.7).abs() < 1e-4, "{toml}");
    stdout_of(
        fiberlab()
            .args(["sample", "--model", "diffuse", "--wo", "0,1,0", "--count", "2", "--params-file"])
            .arg(dir.path().join("fitted.toml")),
    );
}

/// Data of ρ = 1.3, beyond albedo's range [0, 1]: the fit ends on the bound, warns, and says
/// why it gives no uncertainty instead of printing `± NaN`.
#[test]
fn fit_flags_a_parameter_on_its_bound_and_never_prints_nan() {
    let dir = tempfile::tempdir().unwrap();
    let out = fit_diffuse(dir.path(), &diffuse_csv([1.3, 1.3, 1.3]), "albedo=0.5");
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(!text.contains("NaN"), "{text}");
    assert!(text.contains("uncertainty undefined: the value is on its bound"), "{text}");
    assert!(text.contains("warning: `albedo[r]` ended on its upper bound 1.0 (valid range [0, 1])"), "{text}");
}

/// Angles outside θ ∈ [−90°, 90°], φ ∈ [−360°, 360°] are errors naming file, line and column.
#[test]
fn fit_data_outside_the_angle_ranges_is_refused_at_its_place() {
    let dir = tempfile::tempdir().unwrap();
    let csv = diffuse_csv([0.5; 3]);
    let mut lines: Vec<String> = csv.lines().map(String::from).collect();
    lines[3] = lines[3].replacen("-60,", "300,", 1);
    let out = fit_diffuse(dir.path(), &lines.join("\n"), "albedo=0.5");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{err}");
    assert!(err.contains("data.csv: line 4, column 1 (`theta_i`): 300.0 degrees is outside [-90, 90]"), "{err}");
    assert!(!dir.path().join("fitted.toml").exists(), "nothing is written on error");
    let csv = diffuse_csv([0.5; 3]).replacen("\n-60,0,-70,-170,", "\n-60,0,-70,-400,", 1);
    let out = fit_diffuse(dir.path(), &csv, "albedo=0.5");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("line 2, column 4 (`phi_r`): -400.0 degrees is outside [-360, 360]"), "{err}");
}

/// `--quiet` hides the progress bar; without a terminal it is hidden anyway, and stdout (table
/// or JSON) is the same either way.
#[test]
fn check_quiet_changes_nothing_on_stdout() {
    for json in [false, true] {
        let run = |quiet: bool| {
            let mut cmd = fiberlab();
            cmd.args(["check", "--model", "diffuse"]);
            if json {
                cmd.arg("--json");
            }
            if quiet {
                cmd.arg("--quiet");
            }
            let out = cmd.output().unwrap();
            assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
            // Standard error holds only the line that says Ctrl-C keeps the rows done.
            let err: String = String::from_utf8(out.stderr)
                .unwrap()
                .lines()
                .filter(|l| !l.contains("(Ctrl-C stops and keeps the rows done)"))
                .collect();
            (String::from_utf8(out.stdout).unwrap(), err)
        };
        let ((loud, loud_err), (quiet, quiet_err)) = (run(false), run(true));
        assert_eq!(loud, quiet);
        assert!(loud_err.is_empty() && quiet_err.is_empty(), "{loud_err}{quiet_err}");
        if json {
            let rows: serde_json::Value = serde_json::from_str(&loud).unwrap();
            assert!(!rows.as_array().unwrap().is_empty());
        } else {
            assert!(loud.contains("passed, 0 failed"), "{loud}");
        }
    }
}

/// The template is the default scene: written to a file, it renders the same pixels as
/// `fiberlab render` without a scene (one sample per pixel, a small crop).
#[test]
fn scene_default_prints_the_scene_render_uses() {
    let dir = tempfile::tempdir().unwrap();
    let printed = stdout_of(fiberlab().args(["scene", "--default"]));
    assert!(printed.starts_with("[camera]") && printed.contains("[[hair]]"), "{printed}");
    stdout_of(fiberlab().current_dir(dir.path()).args(["scene", "--default", "--out", "s.toml"]));
    assert_eq!(std::fs::read_to_string(dir.path().join("s.toml")).unwrap(), printed);
    let crop = ["--spp", "1", "--crop", "240,240,256,256", "--quiet"];
    stdout_of(fiberlab().current_dir(dir.path()).args(["render", "s.toml", "--out", "from_file"]).args(crop));
    stdout_of(fiberlab().current_dir(dir.path()).args(["render", "--out", "builtin"]).args(crop));
    let read = |name: &str| fiberlab_io::LinearImage::read_exr(&dir.path().join(name)).unwrap();
    let (a, b) = (read("from_file.exr"), read("builtin.exr"));
    assert_eq!(a.pixels(), b.pixels());
    assert!(a.pixels().iter().any(|p| p.iter().any(|c| *c > 0.0)), "the crop shows something");
    let err = error_of(fiberlab().args(["scene"]));
    assert!(err.contains("--default"), "{err}");
}

/// `--fiber` errors name the file; a parameter error is printed once; angles are shown in
/// the degrees given, huge numbers in exponent form.
#[test]
fn fiber_errors_name_the_file_once_in_the_unit_given() {
    let dir = tempfile::tempdir().unwrap();
    let fiber = dir.path().join("f.toml");
    std::fs::write(&fiber, "eta = 7\n").unwrap();
    let measure = |extra: &[&str]| {
        let mut cmd = fiberlab();
        cmd.args(["measure", "--theta-i", "0", "--rays", "10", "--out"]).arg(dir.path().join("m")).args(extra);
        error_of(&mut cmd)
    };
    let err = measure(&["--fiber", fiber.to_str().unwrap()]);
    assert!(err.contains("f.toml") && err.contains("`eta` = 7 is out of range"), "{err}");
    assert_eq!(err.matches("out of range").count(), 1, "printed once: {err}");
    let err = measure(&["--param", "scale_angle=25"]);
    assert!(err.contains("`scale_angle` = 25 is out of range; valid range (-20, 20) degrees"), "{err}");
    assert_eq!(err.matches("out of range").count(), 1, "{err}");
    let err = measure(&["--param", "scale_angle=1e308"]);
    assert!(err.contains("= 1e308 ") && !err.contains("00000000"), "{err}");
    let err = measure(&["--param", "scale_angle=10", "--param", "scale_length=1e300"]);
    assert!(err.contains("`scale_length` = 1e300 is invalid") && !err.contains("00000000"), "{err}");
}

/// A camera error names the one rule that failed.
#[test]
fn camera_error_names_only_the_failed_rule() {
    let dir = tempfile::tempdir().unwrap();
    let scene = "[camera]\neye = [0, 0, 5]\ntarget = [0, 0, 0]\nfov = 0\nwidth = 8\nheight = 8\n";
    std::fs::write(dir.path().join("s.toml"), scene).unwrap();
    let err = error_of(fiberlab().current_dir(dir.path()).args(["render", "s.toml", "--out", "x", "--quiet"]));
    assert!(err.contains("s.toml:4:1: camera: fov = 0.0 must be in (0, 180) degrees"), "{err}");
    assert!(!err.contains("width") && !err.contains("up "), "{err}");
}
