//! The surface-model interfaces of the `fiberlab` binary: `models` prints each model's kind,
//! `eval`/`sample`/`plot`/`check` take surface models with the local-frame CSV contract.

mod fiberlab_process;
use fiberlab_process::{fiberlab, stdout_of};
use std::f64::consts::PI;

#[test]
fn models_prints_the_kind_under_every_title_line() {
    let out = stdout_of(fiberlab().arg("models"));
    let lines: Vec<&str> = out.lines().collect();
    let mut kinds = Vec::new();
    for (k, l) in lines.iter().enumerate() {
        if !l.starts_with(' ') && l.contains(" — ") {
            let name = l.split(" — ").next().unwrap();
            let kind = lines[k + 1].strip_prefix("  kind: ").unwrap_or_else(|| panic!("{name}: no kind line"));
            kinds.push((name.to_string(), kind.to_string()));
        }
    }
    let kind_of = |n: &str| kinds.iter().find(|(m, _)| m == n).map(|(_, k)| k.as_str());
    assert_eq!(kind_of("chiang"), Some("fiber"));
    assert_eq!(kind_of("measured"), Some("fiber"));
    assert_eq!(kind_of("wood"), Some("surface"));
    assert_eq!(kind_of("lambertian"), Some("surface"));
    assert_eq!(kinds.len(), fiberlab_scatter::registry().count());
    let one = stdout_of(fiberlab().args(["models", "--model", "wood"]));
    assert!(one.contains("kind: surface") && one.contains("fiber_dip") && one.contains("tigers-eye"), "{one}");
}

#[test]
fn eval_of_a_surface_model_follows_the_contract() {
    let input = "wi_x,wi_y,wi_z,wo_x,wo_y,wo_z,u,v,tag\n0,0,1,0.6,0,0.8,0.25,0.75,a\n0,0,1,0.6,0,0.8,0.9,0.1,b\n";
    let out = stdout_of(fiberlab().args(["eval", "--model", "lambertian", "--param", "k_d=0.5"]).write_stdin(input));
    let lines: Vec<&str> = out.lines().collect();
    assert_eq!(lines[0], "wi_x,wi_y,wi_z,wo_x,wo_y,wo_z,u,v,tag,f_r,f_g,f_b,pdf");
    let values = |l: &str| l.split(',').skip(9).map(|x| x.parse::<f64>().unwrap()).collect::<Vec<_>>();
    let a = values(lines[1]);
    assert!((a[0] - 0.5 / PI).abs() < 1e-15 && (a[3] - 1.0 / PI).abs() < 1e-15, "{a:?}");
    assert_eq!(a, values(lines[2]), "u,v change nothing without a texture");
    // wood at normal incidence and exit, diffuse only: T²·k_d/(π η²), T = 1 − ((η−1)/(η+1))².
    let out = stdout_of(
        fiberlab()
            .args(["eval", "--model", "wood", "--param", "k_d=0.5", "--param", "k_f=0", "--param", "eta=1.5"])
            .write_stdin("wi_x,wi_y,wi_z,wo_x,wo_y,wo_z\n0,0,1,0,0,1\n"),
    );
    let f: f64 = out.lines().nth(1).unwrap().split(',').nth(6).unwrap().parse().unwrap();
    assert!((f - 0.96 * 0.96 * 0.5 / (PI * 2.25)).abs() < 1e-15, "{f}");
    let bad = fiberlab()
        .args(["eval", "--model", "wood"])
        .write_stdin("wi_x,wi_y,wi_z,wo_x,wo_y,wo_z,u,v\n0,0,1,0,0,1,x,0\n")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&bad.stderr);
    assert!(!bad.status.success() && err.contains("column 7 (`u`)"), "{err}");
}

#[test]
fn sample_of_a_smooth_finish_returns_the_delta_lobe_with_pdf_zero() {
    let out = stdout_of(fiberlab().args([
        "sample",
        "--model",
        "wood",
        "--param",
        "k_d=0",
        "--param",
        "k_f=0",
        "--wo",
        "0.6,0,0.8",
        "--count",
        "20",
    ]));
    let rows: Vec<Vec<f64>> = out.lines().skip(1).map(|l| l.split(',').map(|x| x.parse().unwrap()).collect()).collect();
    assert_eq!(rows.len(), 20);
    for r in rows {
        assert_eq!((r[0], r[1], r[2], r[6]), (-0.6, 0.0, 0.8, 0.0), "the mirror direction, pdf 0: {r:?}");
    }
}

#[test]
fn plot_and_check_take_surface_models() {
    let dir = tempfile::tempdir().unwrap();
    let png = dir.path().join("wood.png");
    stdout_of(fiberlab().args(["plot", "--model", "wood", "--theta-i", "30", "--out"]).arg(&png));
    assert!(std::fs::metadata(&png).unwrap().len() > 1000);
    let out = stdout_of(fiberlab().args(["check", "--model", "lambertian", "-q"]));
    assert!(out.contains("lambertian k_d=1") && out.contains(" 0 failed"), "{out}");
}

/// The contract below the surface: for a transmitting model (`leaf`) a pair on opposite sides
/// is its BTDF, the same for the pair swapped (reciprocity) and for the mirrored pair (two-sided);
/// `sample` returns directions below the surface with their pdf; a non-transmitting model gives
/// 0 there.
#[test]
fn transmission_rows_follow_the_contract() {
    let input = "wi_x,wi_y,wi_z,wo_x,wo_y,wo_z\n0,0.6,-0.8,0.6,0,0.8\n0.6,0,0.8,0,0.6,-0.8\n0,0.6,0.8,0.6,0,-0.8\n";
    let values = |out: &str| -> Vec<Vec<f64>> {
        out.lines().skip(1).map(|l| l.split(',').skip(6).map(|x| x.parse::<f64>().unwrap()).collect()).collect()
    };
    let leaf = values(&stdout_of(fiberlab().args(["eval", "--model", "leaf"]).write_stdin(input)));
    assert!(leaf[0][1] > 0.0 && leaf[0][1] > leaf[0][0] && leaf[0][3] > 0.0, "green transmission {:?}", leaf[0]);
    for c in 0..3 {
        assert!((leaf[0][c] - leaf[1][c]).abs() < 1e-12 && (leaf[0][c] - leaf[2][c]).abs() < 1e-12, "{leaf:?}");
    }
    let wood = values(&stdout_of(fiberlab().args(["eval", "--model", "wood"]).write_stdin(input)));
    assert_eq!(wood[0], vec![0.0; 4]);
    let out = stdout_of(fiberlab().args(["sample", "--model", "leaf", "--wo", "0,0.6,0.8", "--count", "2000"]));
    let below = out.lines().skip(1).filter(|l| l.split(',').nth(2).unwrap().parse::<f64>().unwrap() < 0.0).count();
    assert!(below > 100 && below < 1900, "{below} of 2000 below the surface");
}
