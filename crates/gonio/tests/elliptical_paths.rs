//! The hair core's exact smooth paths through an elliptical cross-section
//! (`fiberlab_scatter::hair::ellipse::smooth_path`, a 2D trace with Bravais' index) against the
//! explicit 3D elliptical fiber of the goniophotometer at zero roughness: per azimuth column,
//! the measured TT and TRT power equals `½∫ A_p(h) dh` over the offsets whose path leaves into
//! that column.

use fiberlab_gonio::{Fiber, Orientation, Setup, measure};
use fiberlab_math::{Rgb, wrap_pi};
use fiberlab_scatter::hair::ellipse::{Ellipse, smooth_path};
use std::f64::consts::{FRAC_PI_2, PI, TAU};
use std::sync::atomic::AtomicBool;

#[test]
fn exact_elliptical_paths_match_the_explicit_ellipse() {
    let (theta_i, phi_i, sigma) = (0.3, 0.4, 0.3);
    let (nt, np) = (30, 72);
    for &(aspect, psi_deg) in &[(0.85, 30.0), (0.7, -60.0)] {
        let psi = f64::to_radians(psi_deg);
        let fiber =
            Fiber { sigma_a: Rgb::splat(sigma), aspect, orientation: Orientation::Fixed(psi), ..Fiber::default() };
        let setup = Setup { theta_i, phi_i, rays: 1_500_000, bins_theta: nt, bins_phi: np, seed: 9 };
        let m = measure(&fiber, &setup, &AtomicBool::new(false), |_| {}).unwrap();
        let prim = |x: f64| 0.5 * x + 0.25 * (2.0 * x).sin();
        let omega = |i: usize| {
            let a = -FRAC_PI_2 + i as f64 * PI / nt as f64;
            (prim(a + PI / nt as f64) - prim(a)) * TAU / np as f64
        };
        let ellipse = Ellipse::new(aspect, psi);
        for (name, p) in [("tt", 1), ("trt", 2)] {
            let t = m.lobe(name).unwrap();
            let (mut power, mut var) = (vec![0.0; np], vec![0.0; np]);
            for i in 0..nt {
                for j in 0..np {
                    power[j] += t.f[i * np + j][0] * omega(i);
                    var[j] += (t.std[i * np + j][0] * omega(i)).powi(2);
                }
            }
            let mut exact = vec![0.0; np];
            let n_h = 200_000;
            for k in 0..n_h {
                let h = -1.0 + (k as f64 + 0.5) * 2.0 / n_h as f64;
                if let Some(path) = smooth_path(&ellipse, 1.55, Rgb::splat(sigma), theta_i.sin_cos(), phi_i, h, p) {
                    let rel = wrap_pi(path.exit_azimuth - phi_i);
                    let j = (((rel + PI) / TAU * np as f64) as usize).min(np - 1);
                    exact[j] += path.attenuation[0] / n_h as f64;
                }
            }
            let mut worst = 0.0f64;
            for j in 0..np {
                let se = var[j].sqrt();
                worst = worst.max((power[j] - exact[j]).abs() / se.max(1e-9));
                assert!(
                    (power[j] - exact[j]).abs() <= 5.0 * se + 1e-4,
                    "a {aspect} ψ {psi_deg}° {name} column {j}: measured {} ± {se}, exact paths {}",
                    power[j],
                    exact[j]
                );
            }
            let (sum_m, sum_e): (f64, f64) = (power.iter().sum(), exact.iter().sum());
            eprintln!(
                "a {aspect} ψ {psi_deg}° {name}: albedo measured {sum_m:.5} exact {sum_e:.5}, worst |z| {worst:.2}"
            );
        }
    }
}
