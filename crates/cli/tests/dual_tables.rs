//! `fiberlab dual-tables`: the CSV it writes (header, size, ā_f + ā_b against the model's
//! albedo) and refusals.

mod fiberlab_process;
use fiberlab_process::fiberlab;

fn rows(path: &std::path::Path) -> (String, Vec<Vec<f64>>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap().to_string();
    (header, lines.map(|l| l.split(',').map(|x| x.parse().unwrap()).collect()).collect())
}

#[test]
fn lossless_diffuse_table_splits_evenly_and_sums_to_one() {
    let dir = tempfile::tempdir().unwrap();
    let prefix = dir.path().join("d");
    let out = fiberlab()
        .args(["dual-tables", "--model", "diffuse", "--param", "albedo=1", "--inclinations", "10"])
        .args(["--outgoing", "64", "--incident", "2", "--out", prefix.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let (header, table) = rows(&dir.path().join("d.csv"));
    let columns: Vec<&str> = header.split(',').collect();
    assert_eq!(columns[0], "theta_deg");
    assert!(header.contains("af_r,af_g,af_b,ab_r,ab_g,ab_b"), "{header}");
    let col = |name: &str| columns.iter().position(|c| *c == name).unwrap();
    assert_eq!(table.len(), 10);
    assert!(std::fs::metadata(dir.path().join("d.png")).unwrap().len() > 1000);
    for (k, row) in table.iter().enumerate() {
        assert_eq!(row.len(), columns.len());
        // Cell midpoints of (−90°, 90°).
        assert!((row[0] - (-90.0 + 18.0 * (k as f64 + 0.5))).abs() < 1e-4, "{row:?}");
        for c in ["r", "g", "b"] {
            let (af, ab) = (row[col(&format!("af_{c}"))], row[col(&format!("ab_{c}"))]);
            // A constant f_s with albedo 1: half the light into each half-sphere.
            assert!((af + ab - 1.0).abs() < 1e-3 && (af - 0.5).abs() < 1e-3, "{row:?}");
            // Ā_b = ā_b ā_f²/(1 − ā_f²) + ā_b³ ā_f²/(1 − ā_f²)³ at ā_f = ā_b = ½.
            let want = 0.5 * 0.25 / 0.75 + 0.125 * 0.25 / 0.75_f64.powi(3);
            assert!((row[col(&format!("abar_b_{c}"))] - want).abs() < 5e-3, "{row:?}");
            // Constant f_s: the mean of θ_h = (θ + θ_r)/2 under the weight cos²θ_r is θ/2.
            assert!((row[col(&format!("alpha_f_{c}"))] - 0.5 * row[0].to_radians()).abs() < 1e-6, "{row:?}");
            assert!(
                (row[col(&format!("all_ng_{c}"))] - row[col(&format!("af_{c}"))] / std::f64::consts::PI).abs() < 1e-9
            );
        }
    }
}

#[test]
fn delta_models_and_unknown_models_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let prefix = dir.path().join("s");
    for (model, message) in [("specular", "delta lobes"), ("nosuchmodel", "unknown model")] {
        let out = fiberlab()
            .args(["dual-tables", "--model", model, "--inclinations", "4", "--out", prefix.to_str().unwrap()])
            .output()
            .unwrap();
        assert!(!out.status.success());
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(stderr.contains(message), "{model}: {stderr}");
        assert!(!dir.path().join("s.csv").exists());
    }
}
