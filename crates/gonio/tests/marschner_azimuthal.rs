//! The explicit smooth circular fiber against Marschner's azimuthal term: per-azimuth power
//! of the measured TT and TRT lobes equals `∫_bin N_p dφ` of `marschner` with exact roots
//! (glints off), and the measured TRT caustic sits where docs/theory/hair.md, "Caustics and
//! glints", puts it.

use fiberlab_gonio::{Fiber, Setup, measure};
use fiberlab_scatter::Model;
use fiberlab_scatter::marschner_2003::Lobe;
use std::f64::consts::{FRAC_PI_2, PI, TAU};
use std::sync::atomic::AtomicBool;

fn marschner() -> fiberlab_scatter::marschner_2003::Marschner {
    let m = fiberlab_scatter::build(
        "marschner",
        &[("roots", "exact"), ("glints", "off"), ("sigma_a", "0.3"), ("eccentricity", "1")],
    )
    .unwrap();
    match m {
        Model::Marschner(m) => m,
        _ => unreachable!(),
    }
}

/// Measured power per φ column of a lobe (all θ_r rows summed).
fn column_power(theta_i: f64, np: usize, rays: usize, lobe: &str) -> (Vec<f64>, Vec<f64>) {
    let fiber = Fiber { sigma_a: fiberlab_math::Rgb::splat(0.3), ..Fiber::default() };
    let nt = 90;
    let setup = Setup { theta_i, phi_i: 0.0, rays, bins_theta: nt, bins_phi: np, seed: 11 };
    let m = measure(&fiber, &setup, &AtomicBool::new(false), |_| {}).unwrap();
    let t = m.lobe(lobe).unwrap();
    let omega = |i: usize| {
        let a = -FRAC_PI_2 + i as f64 * PI / nt as f64;
        let b = a + PI / nt as f64;
        let prim = |x: f64| 0.5 * x + 0.25 * (2.0 * x).sin();
        (prim(b) - prim(a)) * TAU / np as f64
    };
    let mut power = vec![0.0; np];
    let mut var = vec![0.0; np];
    for i in 0..nt {
        for j in 0..np {
            power[j] += t.f[i * np + j][0] * omega(i);
            var[j] += (t.std[i * np + j][0] * omega(i)).powi(2);
        }
    }
    (power, var.into_iter().map(f64::sqrt).collect())
}

#[test]
fn tt_and_trt_azimuthal_power_matches_exact_root_n_p() {
    let theta_i = 0.35;
    let np = 90;
    let rays = 3_000_000;
    let model = marschner();
    for (name, lobe) in [("tt", Lobe::TT), ("trt", Lobe::TRT)] {
        let (power, se) = column_power(theta_i, np, rays, name);
        let mut worst: f64 = 0.0;
        for j in 0..np {
            let (a, b) = (-PI + j as f64 * TAU / np as f64, -PI + (j + 1) as f64 * TAU / np as f64);
            let k = 4000;
            let expected: f64 = (0..k)
                .map(|s| model.azimuthal(lobe, theta_i, a + (s as f64 + 0.5) * (b - a) / k as f64, 1.0)[0])
                .sum::<f64>()
                * (b - a)
                / k as f64;
            // Singular caustic bins: allow the midpoint error of the 1/sqrt peak.
            let slack = 0.02 * expected;
            let z = (power[j] - expected).abs() / (se[j] + 1e-12);
            if (power[j] - expected).abs() > 5.0 * se[j] + slack + 1e-6 {
                panic!("{name} column {j}: measured {} ± {} vs N_p {expected}", power[j], se[j]);
            }
            worst = worst.max(z);
        }
        eprintln!("{name}: worst |z| {worst:.2}");
    }
}

#[test]
fn measured_trt_caustic_matches_the_exact_position() {
    // θ_i = 0: θ_d = 0, φ_c = 18.62° (docs/theory/hair.md, "Caustics and glints"); histogram in
    // 0.25° bins.
    let np = 1440;
    let (power, _) = column_power(0.0, np, 4_000_000, "trt");
    let bin = |deg: f64| ((deg + 180.0) / 360.0 * np as f64) as usize;
    let (lo, hi) = (bin(10.0), bin(30.0));
    let peak = (lo..hi).max_by(|&a, &b| power[a].total_cmp(&power[b])).unwrap();
    let centre = -180.0 + (peak as f64 + 0.5) * 360.0 / np as f64;
    eprintln!("measured TRT caustic at φ = {centre:.3}°");
    assert!((centre - 18.62).abs() < 0.3, "caustic at {centre}°");
    let model = marschner();
    // The exact-root N_p is singular there: its value rises without bound toward 18.62°.
    let n = |deg: f64| model.azimuthal(Lobe::TRT, 0.0, f64::to_radians(deg), 1.0)[0];
    assert!(n(18.5) > 3.0 * n(16.0));
}

/// Relative L2 distance between two azimuthal distributions.
fn rel_l2(a: &[f64], b: &[f64]) -> f64 {
    let d: f64 = a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum();
    (d / a.iter().map(|x| x * x).sum::<f64>()).sqrt()
}

#[test]
fn eccentricity_correction_against_the_exact_ellipse() {
    // Light along the major axis (φ_i = 0), axis ratio 0.85: measured TRT per φ column vs
    // Marschner's first-order η*(φ_h) correction and vs the circular model.
    let (theta_i, np, aspect) = (0.2, 90, 0.85);
    let fiber = Fiber {
        sigma_a: fiberlab_math::Rgb::splat(0.3),
        aspect,
        orientation: fiberlab_gonio::Orientation::Fixed(0.0),
        ..Fiber::default()
    };
    let nt = 90;
    let setup = Setup { theta_i, phi_i: 0.0, rays: 3_000_000, bins_theta: nt, bins_phi: np, seed: 5 };
    let m = measure(&fiber, &setup, &AtomicBool::new(false), |_| {}).unwrap();
    let t = m.lobe("trt").unwrap();
    let prim = |x: f64| 0.5 * x + 0.25 * (2.0 * x).sin();
    let measured: Vec<f64> = (0..np)
        .map(|j| {
            (0..nt)
                .map(|i| {
                    let a = -FRAC_PI_2 + i as f64 * PI / nt as f64;
                    t.f[i * np + j][0] * (prim(a + PI / nt as f64) - prim(a)) * TAU / np as f64
                })
                .sum()
        })
        .collect();
    let model = |e: &str| {
        let m = fiberlab_scatter::build(
            "marschner",
            &[("roots", "exact"), ("glints", "off"), ("sigma_a", "0.3"), ("eccentricity", e)],
        )
        .unwrap();
        let Model::Marschner(m) = m else { unreachable!() };
        (0..np)
            .map(|j| {
                let (a, b) = (-PI + j as f64 * TAU / np as f64, -PI + (j + 1) as f64 * TAU / np as f64);
                let k = 2000;
                (0..k)
                    .map(|s| {
                        let phi = a + (s as f64 + 0.5) * (b - a) / k as f64;
                        m.azimuthal(Lobe::TRT, theta_i, phi, phi.cos())[0]
                    })
                    .sum::<f64>()
                    * (b - a)
                    / k as f64
            })
            .collect::<Vec<f64>>()
    };
    let corrected = rel_l2(&measured, &model("0.85"));
    let circular = rel_l2(&measured, &model("1"));
    eprintln!(
        "TRT azimuthal relative L2 vs exact ellipse a=0.85: first-order η* {corrected:.3}, circular {circular:.3}"
    );
    // Reported, not claimed: both approximations are far from the exact ellipse.
    assert!(corrected.is_finite() && circular.is_finite());
    assert!(corrected > 0.05 && circular > 0.05, "an approximation matched the ellipse unexpectedly well");
}
