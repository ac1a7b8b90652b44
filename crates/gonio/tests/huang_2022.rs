//! `huang-2022` against the explicit rough fiber (the goniophotometer with GGX interfaces and
//! the same single-scattering microfacet rule), lobe by lobe, on two cases: a circular fiber
//! and an elliptical one under oblique light. The model's far field is its near field averaged
//! over 256 offsets h; each offset shifts the lattices of entry and internal microfacets, so
//! the average integrates them, with a quasi-Monte Carlo error on top of the table's.
//! Tolerances, per lobe (rel L2 = ‖model − measured‖/‖measured‖ over the bins; "MC" the same
//! for the table's standard errors):
//! * R and TT, the paper's exact terms: albedo within 2%, rel L2 within MC + 0.04 (the 2 × 2
//!   bin averaging of 10° bins; measured 0.065/0.064 and 0.012/0.009 in the circular case).
//! * TRT: albedo within 6%, rel L2 within MC + 0.2: with 256 offsets its quasi-Monte Carlo
//!   noise is 0.16 in the circular case, and falls to 0.055 with 1024 and 0.037 with 4096
//!   offsets against the table's 0.029 (the `huang_proof` example takes the count as an argument).
//! * TRRT+, an approximation (a geometric series over the chords with the interface albedos
//!   averaged over offsets, and a uniform azimuth): its albedo within 0.01 of the measured one
//!   (it is 0.3%–8% of the light; measured errors −0.004 to +0.006, relatively −5% lossless to
//!   +120% at σ_a = 0.4 and θ_i = 60°), rel L2 below 1.5.
//! * `all`: albedo within 5%, rel L2 within MC + 0.05.

use fiberlab_gonio::model_comparison::{BinAverage, compare_lobes};
use fiberlab_gonio::{Fiber, Orientation, Setup, measure};
use fiberlab_math::Rgb;
use fiberlab_scatter::build;
use std::sync::atomic::AtomicBool;

#[test]
fn huang_2022_matches_the_explicit_rough_fiber_lobe_by_lobe() {
    for &(roughness, aspect, psi, theta_i, phi_i) in &[(0.3, 1.0, 0.0, 30.0, 0.0), (0.5, 0.7, 30.0, 60.0, 20.0)] {
        let fiber = Fiber {
            roughness,
            aspect,
            orientation: Orientation::Fixed(f64::to_radians(psi)),
            sigma_a: Rgb::new(0.2, 0.4, 0.8),
            ..Fiber::default()
        };
        let setup = Setup {
            theta_i: f64::to_radians(theta_i),
            phi_i: f64::to_radians(phi_i),
            rays: 1_000_000,
            bins_theta: 18,
            bins_phi: 36,
            seed: 5,
        };
        let m = measure(&fiber, &setup, &AtomicBool::new(false), |_| {}).unwrap();
        let model = build(
            "huang-2022",
            &[
                ("roughness", roughness.to_string()),
                ("aspect", aspect.to_string()),
                ("orientation", psi.to_string()),
                ("alpha", "0".into()),
                ("sigma_a", "0.2,0.4,0.8".into()),
            ],
        )
        .unwrap();
        let rows = compare_lobes(&m, &fiber, &model, BinAverage { sub: 2, offsets: 256 });
        for r in &rows {
            eprintln!(
                "α {roughness} a {aspect} θ_i {theta_i}: {:<6} albedo measured {:.4} model {:.4}, rel L2 {:.3} (MC {:.3})",
                r.lobe, r.measured_albedo, r.model_albedo, r.rel_l2, r.mc_rel_l2
            );
            let error = (r.model_albedo - r.measured_albedo).abs();
            let (albedo_ok, shape_tol) = match r.lobe {
                "r" | "tt" => (error < 0.02 * r.measured_albedo, 0.04),
                "trt" => (error < 0.06 * r.measured_albedo, 0.2),
                "higher" => (error < 0.01, 1.5),
                _ => (error < 0.05 * r.measured_albedo, 0.05),
            };
            assert!(albedo_ok, "{}: albedo {} vs {}", r.lobe, r.model_albedo, r.measured_albedo);
            assert!(r.rel_l2 < r.mc_rel_l2 + shape_tol, "{}: rel L2 {} (MC {})", r.lobe, r.rel_l2, r.mc_rel_l2);
        }
    }
}
