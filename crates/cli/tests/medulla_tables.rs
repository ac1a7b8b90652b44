//! `fiberlab medulla-tables`: the files it writes and their consistency, and bad input.

mod fiberlab_process;
use fiberlab_process::fiberlab;

fn rows(path: &std::path::Path) -> (String, Vec<Vec<f64>>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap().to_string();
    (header, lines.map(|l| l.split(',').map(|x| x.parse().unwrap()).collect()).collect())
}

#[test]
fn writes_slices_that_integrate_to_the_escaping_fraction() {
    let dir = tempfile::tempdir().unwrap();
    let prefix = dir.path().join("m");
    let out = fiberlab()
        .args(["medulla-tables", "--sigma-s", "1.2", "--sigma-a", "0.1,0.2,0.3", "--g", "-0.2", "--walks", "64"])
        .args(["--out", prefix.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let (h_az, az) = rows(&dir.path().join("m_azimuthal.csv"));
    let (h_fr, fr) = rows(&dir.path().join("m_fractions.csv"));
    let (h_lo, lo) = rows(&dir.path().join("m_longitudinal.csv"));
    assert_eq!(h_az, "theta_t_deg,h,phi_q_deg,n_r,n_g,n_b,mean_path_length");
    assert_eq!(h_fr, "theta_t_deg,h,scattered,escaping_r,escaping_g,escaping_b,mean_path_length");
    assert_eq!(h_lo, "theta_t_deg,phi_q_deg,theta_o_deg,m_r,m_g,m_b");
    assert!(std::fs::metadata(dir.path().join("m.png")).unwrap().len() > 1000);
    // Every (θ_t, h') slice: Σ N·Δφ over its nodes (the periodic piecewise-linear integral)
    // equals the escaping fraction of that node, per channel; escaping ≤ scattered.
    let per_slice = az.len() / fr.len();
    let dphi = std::f64::consts::TAU / per_slice as f64;
    for (k, f) in fr.iter().enumerate() {
        let slice = &az[k * per_slice..(k + 1) * per_slice];
        assert!(slice.iter().all(|r| r[0] == f[0] && r[1] == f[1]));
        for c in 0..3 {
            let integral: f64 = slice.iter().map(|r| r[3 + c] * dphi).sum();
            assert!((integral - f[3 + c]).abs() <= 1e-6 * f[3 + c].max(1e-9), "{f:?}: {integral}");
            assert!(f[3 + c] <= f[2] + 1e-12);
        }
        // The closed form of the scattered fraction, σ_s = 1.2.
        let s = 1.0 - (-1.2 * 2.0 * (1.0 - f[1] * f[1]).max(0.0).sqrt() / f[0].to_radians().cos()).exp();
        assert!((f[2] - s).abs() < 1e-6, "{f:?} {s}");
    }
    assert!(lo.iter().all(|r| r[3..].iter().all(|&m| m >= 0.0 && m.is_finite())));
}

#[test]
fn bad_parameters_are_refused_by_name_and_nothing_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let prefix = dir.path().join("m");
    for (sigma_s, sigma_a, g, name) in
        [("1", "0", "1", "`g`"), ("-1", "0", "0", "`sigma_s`"), ("1", "0,-1,0", "0", "`sigma_a`")]
    {
        let out = fiberlab()
            .args(["medulla-tables", "--sigma-s", sigma_s, "--sigma-a", sigma_a, "--g", g])
            .args(["--out", prefix.to_str().unwrap()])
            .output()
            .unwrap();
        assert!(!out.status.success());
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(name), "{err}");
    }
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}
