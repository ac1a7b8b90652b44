//! End-to-end tests of the `fiberlab` binary's documented interfaces.

mod fiberlab_process;
use fiberlab_process::{fiberlab, stdout_of};

/// The value printed by `fiberlab fit` as `  key = value ± error`.
fn fitted(out: &str, key: &str) -> f64 {
    let line = out.lines().find(|l| l.trim_start().starts_with(key)).unwrap();
    line.split('=').nth(1).unwrap().split('±').next().unwrap().trim().parse().unwrap()
}

#[test]
fn models_lists_every_registered_model_with_parameters() {
    let out = stdout_of(fiberlab().arg("models"));
    for spec in fiberlab_scatter::MODELS {
        assert!(out.contains(spec.name), "{} missing", spec.name);
        for p in spec.params {
            assert!(out.contains(p.key), "{}: {} missing", spec.name, p.key);
        }
    }
}

#[test]
fn eval_reads_csv_and_appends_values() {
    let input = "wi_x,wi_y,wi_z,wo_x,wo_y,wo_z,h,tag\n0,1,0,0,0,1,0.5,a\n0.6,0.8,0,-0.6,0.8,0,-1,b\n";
    let out =
        stdout_of(fiberlab().args(["eval", "--model", "diffuse", "--param", "albedo=0.5,0.25,1"]).write_stdin(input));
    let lines: Vec<&str> = out.lines().collect();
    assert_eq!(lines[0], "wi_x,wi_y,wi_z,wo_x,wo_y,wo_z,h,tag,f_r,f_g,f_b,pdf");
    assert_eq!(lines.len(), 3);
    let f_r: f64 = lines[1].split(',').nth(8).unwrap().parse().unwrap();
    assert!((f_r - 0.5 / (std::f64::consts::PI.powi(2))).abs() < 1e-15);
    assert!(lines[2].contains(",b,"));
}

#[test]
fn eval_errors_name_line_and_column_and_write_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.csv");
    let input = "wi_x,wi_y,wi_z,wo_x,wo_y,wo_z\n0,1,0,0,0,1\n0,1,0,0,0,oops\n";
    let res = fiberlab()
        .args(["eval", "--model", "kajiya-kay", "--output", out.to_str().unwrap()])
        .write_stdin(input)
        .output()
        .unwrap();
    assert!(!res.status.success());
    let err = String::from_utf8_lossy(&res.stderr);
    assert!(err.contains("line 3, column 6 (`wo_z`)"), "{err}");
    assert!(!out.exists(), "partial output written");
}

#[test]
fn bad_parameters_name_the_key() {
    let res = fiberlab()
        .args(["sample", "--model", "kajiya-kay", "--param", "p=nan", "--wo", "0,1,0", "--count", "1"])
        .output()
        .unwrap();
    assert!(!res.status.success());
    assert!(String::from_utf8_lossy(&res.stderr).contains("`p`"));
    let res = fiberlab().args(["eval", "--model", "specular", "--param", "bogus=1"]).write_stdin("").output().unwrap();
    assert!(String::from_utf8_lossy(&res.stderr).contains("no parameter `bogus`"));
}

#[test]
fn sample_weights_match_eval() {
    let out = stdout_of(fiberlab().args([
        "sample",
        "--model",
        "lambertian-cylinder",
        "--wo",
        "0,0.6,0.8",
        "--count",
        "100",
        "--seed",
        "3",
    ]));
    let lines: Vec<&str> = out.lines().collect();
    assert_eq!(lines[0], "wi_x,wi_y,wi_z,weight_r,weight_g,weight_b,pdf");
    assert_eq!(lines.len(), 101);
    for l in &lines[1..] {
        let v: Vec<f64> = l.split(',').map(|x| x.parse().unwrap()).collect();
        assert!((v[3] - 0.8).abs() < 1e-12, "weight = albedo: {l}");
        assert!(((v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt() - 1.0).abs() < 1e-9);
        assert!(v[6] > 0.0);
    }
    // Same seed, same samples.
    let again = stdout_of(fiberlab().args([
        "sample",
        "--model",
        "lambertian-cylinder",
        "--wo",
        "0,0.6,0.8",
        "--count",
        "100",
        "--seed",
        "3",
    ]));
    assert_eq!(out, again);
}

#[test]
fn check_passes_and_prints_json() {
    let out = stdout_of(fiberlab().args(["check", "--model", "diffuse", "--json"]));
    let rows: serde_json::Value = serde_json::from_str(&out).unwrap();
    let rows = rows.as_array().unwrap();
    assert!(rows.len() > 20);
    for key in ["model", "test", "value", "expected", "tolerance", "pass"] {
        assert!(rows[0].get(key).is_some(), "missing {key}");
    }
    assert!(rows.iter().all(|r| r["pass"] == true));
}

#[test]
fn plot_writes_png_and_svg() {
    let dir = tempfile::tempdir().unwrap();
    for name in ["f.png", "f.svg"] {
        let path = dir.path().join(name);
        stdout_of(fiberlab().args(["plot", "--model", "goldman", "--theta-i", "20", "--out", path.to_str().unwrap()]));
        let bytes = std::fs::read(&path).unwrap();
        assert!(bytes.len() > 1000);
        if name.ends_with("png") {
            assert_eq!(&bytes[1..4], b"PNG");
        } else {
            assert!(String::from_utf8_lossy(&bytes).contains("<svg"));
        }
    }
    let res = fiberlab().args(["plot", "--model", "diffuse", "--theta-i", "20", "--out", "x.jpg"]).output().unwrap();
    assert!(!res.status.success());
}

#[test]
fn measure_writes_the_documented_csv_and_a_figure() {
    let dir = tempfile::tempdir().unwrap();
    let prefix = dir.path().join("m");
    let out = stdout_of(fiberlab().args([
        "measure",
        "--theta-i",
        "20",
        "--rays",
        "20000",
        "--bins",
        "6,12",
        "--param",
        "sigma_a=0.3",
        "--out",
        prefix.to_str().unwrap(),
    ]));
    assert!(out.contains("Mrays/s"), "{out}");
    let csv = std::fs::read_to_string(prefix.with_extension("csv")).unwrap();
    let mut lines = csv.lines();
    assert_eq!(lines.next().unwrap(), "lobe,theta_i,phi_i,theta_r,phi_r,f_r,f_g,f_b,std_r,std_g,std_b");
    assert_eq!(lines.count(), 6 * 6 * 12);
    assert!(std::fs::metadata(prefix.with_extension("png")).unwrap().len() > 1000);
    let exr = fiberlab_io::LinearImage::read_exr(&prefix.with_extension("exr")).unwrap();
    assert_eq!((exr.width(), exr.height()), (12, 6));
    // Fiber files: errors name file, line and column, or the bad key.
    let fiber = dir.path().join("f.toml");
    std::fs::write(&fiber, "eta = 1.5\naspect = = 2\n").unwrap();
    let res = fiberlab()
        .args(["measure", "--theta-i", "0", "--rays", "10", "--fiber", fiber.to_str().unwrap(), "--out", "x"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&res.stderr);
    assert!(!res.status.success() && err.contains("f.toml: line 2"), "{err}");
    std::fs::write(&fiber, "eta = 1.5\nradius = 2\n").unwrap();
    let res = fiberlab()
        .args(["measure", "--theta-i", "0", "--rays", "10", "--fiber", fiber.to_str().unwrap(), "--out", "x"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&res.stderr);
    assert!(err.contains("unknown fiber parameter `radius`") && err.contains("f.toml"), "{err}");
    // Arrays, numbers and booleans in a fiber file mean what the same --param text means.
    std::fs::write(&fiber, "sigma_a = [0.1, 0.2, 0.3]\norientation = 30\naspect = 0.8\n").unwrap();
    let toml = fiberlab()
        .args(["measure", "--theta-i", "10", "--rays", "2000", "--bins", "4,8", "--fiber", fiber.to_str().unwrap()])
        .args(["--out", dir.path().join("a").to_str().unwrap()])
        .output()
        .unwrap();
    assert!(toml.status.success(), "{}", String::from_utf8_lossy(&toml.stderr));
    let text = fiberlab()
        .args(["measure", "--theta-i", "10", "--rays", "2000", "--bins", "4,8"])
        .args(["--param", "sigma_a=0.1,0.2,0.3", "--param", "orientation=30", "--param", "aspect=0.8"])
        .args(["--out", dir.path().join("b").to_str().unwrap()])
        .output()
        .unwrap();
    assert!(text.status.success(), "{}", String::from_utf8_lossy(&text.stderr));
    let (a, b) = (dir.path().join("a.csv"), dir.path().join("b.csv"));
    assert_eq!(std::fs::read_to_string(a).unwrap(), std::fs::read_to_string(b).unwrap());
}

/// `--param lobes=r,tt --param glints=off` and a `--params-file` with `lobes = ["r", "tt"]`
/// and `glints = false` give the same model: `eval` prints the same values.
#[test]
fn params_file_arrays_and_booleans_match_param_text() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("p.toml");
    std::fs::write(&file, "[params]\nlobes = [\"r\", \"tt\"]\nglints = false\n").unwrap();
    let input =
        "wi_x,wi_y,wi_z,wo_x,wo_y,wo_z,h\n0,0.6,0.8,-0.6,0.8,0,0.2\n0,1,0,0,-1,0,0\n0.6,0.8,0,0,-0.6,0.8,-0.4\n";
    let eval =
        |extra: &[&str]| stdout_of(fiberlab().args(["eval", "--model", "marschner"]).args(extra).write_stdin(input));
    let text = eval(&["--param", "lobes=r,tt", "--param", "glints=off"]);
    let from_file = eval(&["--params-file", file.to_str().unwrap()]);
    assert_eq!(text, from_file);
    assert_ne!(text, eval(&["--param", "glints=off"]), "the lobes matter for these directions");
}

#[test]
fn measured_table_is_a_model_and_compares_with_models() {
    let dir = tempfile::tempdir().unwrap();
    let prefix = dir.path().join("t");
    stdout_of(fiberlab().args([
        "measure",
        "--theta-i",
        "-30,0,30",
        "--rays",
        "60000",
        "--bins",
        "18,36",
        "--param",
        "sigma_a=0.2",
        "--out",
        prefix.to_str().unwrap(),
    ]));
    let table = format!("table={}", prefix.with_extension("csv").display());
    // Tabulated model: eval and sample work, and sampling weights average to its albedo.
    let out = stdout_of(fiberlab().args([
        "sample",
        "--model",
        "measured",
        "--param",
        &table,
        "--wo",
        "0.2,0.9797959,0",
        "--count",
        "2000",
    ]));
    let weights: Vec<f64> = out.lines().skip(1).map(|l| l.split(',').nth(3).unwrap().parse().unwrap()).collect();
    let mean = weights.iter().sum::<f64>() / weights.len() as f64;
    assert!(mean > 0.3 && mean < 1.0, "mean weight {mean}");
    let out = stdout_of(
        fiberlab()
            .args(["eval", "--model", "measured", "--param", &table])
            .write_stdin("wi_x,wi_y,wi_z,wo_x,wo_y,wo_z\n0,1,0,0,0,1\n"),
    );
    assert!(out.lines().nth(1).unwrap().split(',').count() == 10);
    // compare-model prints one line per incidence and lobe.
    let out = stdout_of(fiberlab().args([
        "compare-model",
        "--table",
        prefix.with_extension("csv").to_str().unwrap(),
        "--model",
        "marschner",
    ]));
    assert_eq!(out.lines().filter(|l| l.contains(" all ")).count(), 3, "{out}");
    assert_eq!(out.lines().filter(|l| l.contains(" trt ")).count(), 3, "{out}");
    // A missing table is a clear error.
    let res = fiberlab().args(["sample", "--model", "measured", "--wo", "0,1,0", "--count", "1"]).output().unwrap();
    assert!(String::from_utf8_lossy(&res.stderr).contains("table=PATH"));
}

#[test]
fn fit_recovers_parameters_from_a_user_csv_and_writes_a_params_file() {
    use fiberlab_math::frame::direction;
    use fiberlab_scatter::ScatteringFunction;
    let truth = fiberlab_scatter::build("marschner", &[("alpha_r", "-6"), ("beta_r", "8"), ("glints", "off")]).unwrap();
    let mut csv = String::from("theta_i,phi_i,theta_r,phi_r,value,std\n");
    for i in 0..8 {
        for j in 0..24 {
            let (ti, tr, pr) = (-60.0 + 15.0 * i as f64, -80.0 + 7.0 * j as f64, 15.0 * j as f64 - 170.0);
            let f = truth.eval(
                direction(f64::to_radians(ti), 0.0),
                direction(f64::to_radians(tr), f64::to_radians(pr)),
                0.0,
            );
            let v = f.luminance();
            csv.push_str(&format!("{ti},0,{tr},{pr},{v},{}\n", 0.01 * v + 1e-6));
        }
    }
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("data.csv");
    std::fs::write(&data, csv).unwrap();
    let prefix = dir.path().join("fitted");
    let out = stdout_of(fiberlab().args([
        "fit",
        "--model",
        "marschner",
        "--data",
        data.to_str().unwrap(),
        "--fix",
        "glints=off",
        "--init",
        "alpha_r=-3",
        "--init",
        "beta_r=5",
        "--out",
        prefix.to_str().unwrap(),
    ]));
    let value = |key: &str| fitted(&out, key);
    assert!((value("alpha_r") + 6.0).abs() < 0.05, "{out}");
    assert!((value("beta_r") - 8.0).abs() < 0.05, "{out}");
    // The written file is accepted by other commands.
    let params = prefix.with_extension("toml");
    stdout_of(fiberlab().args([
        "sample",
        "--model",
        "marschner",
        "--params-file",
        params.to_str().unwrap(),
        "--wo",
        "0,1,0",
        "--count",
        "3",
    ]));
    let res = fiberlab()
        .args([
            "sample",
            "--model",
            "chiang",
            "--params-file",
            params.to_str().unwrap(),
            "--wo",
            "0,1,0",
            "--count",
            "3",
        ])
        .output()
        .unwrap();
    assert!(String::from_utf8_lossy(&res.stderr).contains("not `chiang`"));
}

#[test]
fn kajiya_kay_fitted_to_a_model_recovers_itself_and_fits_chiang() {
    let out = stdout_of(fiberlab().args([
        "fit",
        "--model",
        "kajiya-kay",
        "--target",
        "kajiya-kay",
        "--target-param",
        "k_d=0.04",
        "--target-param",
        "k_s=0.2",
        "--target-param",
        "p=20",
        "--init",
        "k_d=0.02",
        "--init",
        "k_s=0.1",
        "--init",
        "p=10",
        "--out",
        tempfile::tempdir().unwrap().path().join("kk").to_str().unwrap(),
    ]));
    let value = |key: &str| fitted(&out, key);
    assert!(
        (value("k_d") - 0.04).abs() < 1e-3 && (value("k_s") - 0.2).abs() < 1e-2 && (value("p") - 20.0).abs() < 0.5,
        "{out}"
    );
    let out = stdout_of(fiberlab().args([
        "fit",
        "--model",
        "kajiya-kay",
        "--target",
        "chiang",
        "--init",
        "k_d=0.02",
        "--init",
        "k_s=0.1",
        "--init",
        "p=10",
        "--out",
        tempfile::tempdir().unwrap().path().join("kk2").to_str().unwrap(),
    ]));
    assert!(out.contains("reduced χ²"), "{out}");
}

#[test]
fn scenes_can_render_hair_with_a_measured_table() {
    let dir = tempfile::tempdir().unwrap();
    stdout_of(fiberlab().current_dir(dir.path()).args([
        "measure",
        "--theta-i",
        "-40,-20,0,20,40",
        "--rays",
        "40000",
        "--bins",
        "18,36",
        "--param",
        "sigma_a=0.4",
        "--out",
        "fiber",
    ]));
    let scene = r#"
[camera]
eye = [0.0, 0.0, -4.0]
target = [0.0, 0.0, 0.0]
up = [0.0, 1.0, 0.0]
fov = 40.0
width = 24
height = 24

[render]
spp = 2

[materials.hair]
model = "measured"
params = { table = "fiber.csv" }

[[hair]]
material = "hair"
generator = { strands = 300, segments = 8, style = "straight", length = 1.0, seed = 1 }

[[light]]
type = "environment"
radiance = [1.0, 1.0, 1.0]
"#;
    std::fs::write(dir.path().join("s.toml"), scene).unwrap();
    let out = stdout_of(fiberlab().current_dir(dir.path()).args(["render", "s.toml", "--out", "img", "--quiet"]));
    assert!(dir.path().join("img.exr").exists(), "{out}");
    // evaluate: every model against the measured reference, metrics and a labelled grid.
    let out = stdout_of(fiberlab().current_dir(dir.path()).args([
        "evaluate",
        "--scene",
        "s.toml",
        "--table",
        "fiber.csv",
        "--models",
        "kajiya-kay,chiang,measured",
        "--spp",
        "1",
        "--reference-spp",
        "4",
        "--out",
        "ev",
    ]));
    let metrics: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("ev/metrics.json")).unwrap()).unwrap();
    assert_eq!(metrics.as_array().unwrap().len(), 3, "{out}");
    assert!(metrics[0]["flip"].as_f64().unwrap() >= 0.0);
    assert!(dir.path().join("ev/grid.png").exists() && dir.path().join("ev/reference.exr").exists());
    std::fs::write(dir.path().join("bad.toml"), scene.replace("fiber.csv", "nope.csv")).unwrap();
    let res =
        fiberlab().current_dir(dir.path()).args(["render", "bad.toml", "--out", "x", "--quiet"]).output().unwrap();
    let err = String::from_utf8_lossy(&res.stderr);
    assert!(!res.status.success() && err.contains("nope.csv"), "{err}");
}

/// Every model `fiberlab models` lists has a row in the book's table of models (a line
/// `| [`name`](models/name.md) | …` of `docs/book/src/models.md`), linking to its page.
#[test]
fn the_books_model_table_lists_every_model() {
    let out = stdout_of(fiberlab().arg("models"));
    let names: Vec<&str> = out
        .lines()
        .filter(|l| !l.starts_with(' ') && l.contains(" — "))
        .map(|l| l.split(" — ").next().unwrap().trim())
        .collect();
    assert!(names.len() >= 9 && names.contains(&"marschner"), "{names:?}");
    let book = concat!(env!("CARGO_MANIFEST_DIR"), "/../../docs/book/src/models.md");
    let table = std::fs::read_to_string(book).unwrap();
    for name in names {
        let row = format!("| [`{name}`](models/{name}.md) |");
        assert!(table.lines().any(|l| l.starts_with(&row)), "docs/book/src/models.md has no row {row}");
    }
}

/// `fiberlab --version` names the package version and the commit the binary was built from
/// (`build.rs`; "unknown commit" where git or `.git` is absent).
#[test]
fn version_names_the_commit() {
    let out = stdout_of(fiberlab().arg("--version"));
    let version = env!("CARGO_PKG_VERSION");
    let head = std::process::Command::new("git")
        .args(["rev-parse", "--short=9", "HEAD"])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string());
    let commit = match std::env::var("FIBERLAB_COMMIT") {
        Ok(c) if !c.trim().is_empty() => c.trim().to_string(),
        _ => head.unwrap_or_else(|| "unknown commit".into()),
    };
    assert_eq!(out.trim(), format!("fiberlab {version} ({commit})"));
}

/// `fiberlab models --markdown --model NAME` prints exactly the generated block of the book's
/// page of that model (the pages are checked against the registry in
/// `crates/scatter/tests/registry_is_the_one_table.rs`).
#[test]
fn models_markdown_prints_the_books_table() {
    for name in ["chiang", "wood", "irawan-2012"] {
        let out = stdout_of(fiberlab().args(["models", "--markdown", "--model", name]));
        assert!(out.starts_with(&format!("**`{name}`**")), "{out}");
        assert!(out.lines().any(|l| l.starts_with("| parameter |")), "{out}");
        let page = concat!(env!("CARGO_MANIFEST_DIR"), "/../../docs/book/src/models/");
        let page = std::fs::read_to_string(format!("{page}{name}.md")).unwrap();
        assert!(page.contains(&out), "docs/book/src/models/{name}.md does not hold the output of models --markdown");
    }
    let all = stdout_of(fiberlab().args(["models", "--markdown"]));
    assert!(all.matches("| parameter |").count() >= 15, "{all}");
}
