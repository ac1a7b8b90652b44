//! `fiberlab fit` and `compare-model` with surface models on surface tables: wood fitted to a
//! traced fiber slab, the residual report against a closed form, and the refusals of a table
//! of the wrong kind.

mod fiberlab_process;
use fiberlab_process::{fiberlab, refused, stdout_of};
use std::path::Path;

/// A fitted number from `fit`'s output line `  KEY = VALUE …`.
fn fitted(out: &str, key: &str) -> f64 {
    out.lines()
        .find_map(|l| l.trim().strip_prefix(&format!("{key} = ")))
        .and_then(|rest| rest.split_whitespace().next())
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("no `{key}` in:\n{out}"))
}

/// The slab of `bench/wood_proof` (smooth absorbing cylinders under a finish of index 1.5),
/// measured at θ_i = 30°, 60°.
fn slab(dir: &Path) -> String {
    let prefix = dir.join("slab");
    stdout_of(fiberlab().args([
        "measure",
        "--surface",
        "--eta",
        "1.5",
        "--fiber-eta",
        "2.3",
        "--sigma-a",
        "5",
        "--substrate",
        "0",
        "--theta-i",
        "30,60",
        "--bins",
        "30,60",
        "--rays",
        "300000",
        "--out",
        prefix.to_str().unwrap(),
    ]));
    format!("{}.csv", prefix.display())
}

/// Wood's fiber term fitted to the slab's `fiber` class: the width goes to the model's
/// narrowest (the cylinders are smooth), the strength agrees within a factor 4 with the
/// independent estimate of `compare-model` (the ratio of the measured and modelled albedos
/// of the class), and the fit explains the table to its noise (reduced χ² < 2) — far better
/// than no highlight at all (Δχ² > 100). (The least-squares strength is the lower one: the model's
/// highlight is narrower than a bin and its locus is off by up to a bin in some columns, and
/// a lobe in the wrong bin is fitted smaller; the albedo ratio does not see positions.)
#[test]
fn wood_is_fitted_to_a_fiber_slab_table() {
    let dir = tempfile::tempdir().unwrap();
    let table = slab(dir.path());
    let out = dir.path().join("wood");
    let fit = stdout_of(fiberlab().args([
        "fit",
        "--model",
        "wood",
        "--table",
        &table,
        "--lobe",
        "fiber",
        "--fix",
        "k_d=0",
        "--fix",
        "eta=1.5",
        "--init",
        "k_f=0.02",
        "--init",
        "beta=4",
        "--luminance",
        "-q",
        "--out",
        out.to_str().unwrap(),
    ]));
    let (k_f, beta) = (fitted(&fit, "k_f"), fitted(&fit, "beta"));
    assert!(beta < 0.6, "β = {beta}: {fit}");
    let reduced: f64 = fit.rsplit("reduced χ² = ").next().unwrap().lines().next().unwrap().trim().parse().unwrap();
    assert!(reduced < 2.0, "{fit}");
    let json = stdout_of(fiberlab().args([
        "compare-model",
        "--table",
        &table,
        "--model",
        "wood",
        "--json",
        "--param",
        "eta=1.5",
        "--param",
        "beta=0.5",
        "--param",
        "k_f=0.01",
    ]));
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    for row in v["fiber"].as_array().unwrap() {
        let ratio = k_f / row["k_f_fit"].as_f64().unwrap();
        assert!((0.25..4.0).contains(&ratio), "k_f {k_f} vs albedo ratio {row}");
    }
    // The same fit with the highlight switched off is far worse: the highlight lowers χ² by
    // more than 100 (a detection at more than 10σ).
    let none = stdout_of(fiberlab().args([
        "fit",
        "--model",
        "wood",
        "--table",
        &table,
        "--lobe",
        "fiber",
        "--fix",
        "k_d=0",
        "--fix",
        "k_f=0",
        "--init",
        "beta=4",
        "--luminance",
        "-q",
        "--out",
        out.to_str().unwrap(),
    ]));
    let chi2 = |s: &str| -> f64 { s.split("χ² = ").nth(1).unwrap().split(',').next().unwrap().parse().unwrap() };
    assert!(chi2(&none) - chi2(&fit) > 100.0, "{none}\n{fit}");
}

/// A surface table whose `all` class is the constant `c/π` in every bin (a Lambertian BRDF
/// of albedo c), 5 % standard errors.
fn constant_table(path: &Path, c: f64) {
    let mut text = String::from(fiberlab_io::table::SURFACE_HEADER);
    text.push_str("\nlobe,theta_i,phi_i,theta_r,phi_r,f_r,f_g,f_b,std_r,std_g,std_b\n");
    let f = c / std::f64::consts::PI;
    for i in 0..9 {
        for j in 0..12 {
            let (t, p) = (5.0 + 10.0 * i as f64, -165.0 + 30.0 * j as f64);
            text.push_str(&format!("all,40,0,{t},{p},{f},{f},{f},{},{},{}\n", 0.05 * f, 0.05 * f, 0.05 * f));
        }
    }
    std::fs::write(path, text).unwrap();
}

/// `compare-model` with a non-wood surface model reports the residual: for a Lambertian
/// model of albedo k against a Lambertian table of albedo c, the per-bin RMS is |k − c|/π and
/// the relative L2 error |k − c|/c (closed forms); `fit` recovers c from the same table.
#[test]
fn the_surface_residual_matches_its_closed_form_and_fit_recovers_the_albedo() {
    let dir = tempfile::tempdir().unwrap();
    let table = dir.path().join("lambert.csv");
    constant_table(&table, 0.5);
    let t = table.to_str().unwrap();
    let json = stdout_of(fiberlab().args([
        "compare-model",
        "--table",
        t,
        "--model",
        "lambertian",
        "--param",
        "k_d=0.4",
        "--json",
    ]));
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    let row = &v["all"][0];
    assert!((row["rms"].as_f64().unwrap() - 0.1 / std::f64::consts::PI).abs() < 1e-9, "{row}");
    assert!((row["rel_l2"].as_f64().unwrap() - 0.2).abs() < 1e-9, "{row}");
    assert!((row["mc_rel_l2"].as_f64().unwrap() - 0.05).abs() < 1e-9, "{row}");
    assert_eq!(row["worst"].as_array().unwrap().len(), 5, "{row}");
    let out = dir.path().join("fit");
    let fit = stdout_of(fiberlab().args([
        "fit",
        "--model",
        "lambertian",
        "--table",
        t,
        "--init",
        "k_d=0.3,0.2,0.7",
        "-q",
        "--out",
        out.to_str().unwrap(),
    ]));
    for c in ["r", "g", "b"] {
        assert!((fitted(&fit, &format!("k_d[{c}]")) - 0.5).abs() < 1e-4, "{fit}");
    }
}

/// A surface table given to a fiber model, a fiber table given to a surface model, and a
/// surface model without a table are refused, each saying what it is and what is needed.
#[test]
fn tables_of_the_wrong_kind_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let surface = dir.path().join("surface.csv");
    constant_table(&surface, 0.5);
    let s = surface.to_str().unwrap();
    let e = refused(fiberlab().args(["fit", "--model", "chiang", "--table", s, "--init", "beta_m=0.3", "-q"]));
    assert!(e.contains("is a surface table") && e.contains("fiber model") && e.contains("sadeghi-2013"), "{e}");
    let fiber = dir.path().join("fiber.csv");
    std::fs::write(
        &fiber,
        "lobe,theta_i,phi_i,theta_r,phi_r,f_r,f_g,f_b,std_r,std_g,std_b\nall,0,0,0,0,0.1,0.1,0.1,0.01,0.01,0.01\n",
    )
    .unwrap();
    let f = fiber.to_str().unwrap();
    let e = refused(fiberlab().args(["fit", "--model", "sadeghi-2013", "--table", f, "--init", "k_d_1=0.3", "-q"]));
    assert!(e.contains("is a fiber table") && e.contains("surface model"), "{e}");
    let e =
        refused(fiberlab().args(["fit", "--model", "sadeghi-2013", "--target", "chiang", "--init", "k_d_1=0.3", "-q"]));
    assert!(e.contains("is a surface model") && e.contains("--table"), "{e}");
}
