//! `huang-2022` against the explicit rough fiber (the goniophotometer with GGX interfaces and
//! the same single-scattering microfacet rule), lobe by lobe, on two cases: a circular fiber
//! (α = 0.3, θ_i = 30°) and an elliptical one (α = 0.5, aspect 0.7 at 30°, θ_i = 60°), 200 000
//! rays each in 20° bins. The model's far field is its near field averaged over 4 × 4 nodes per
//! bin and 128 offsets h per node; each offset shifts the lattices of entry and internal
//! microfacets, so the average integrates them, with a quasi-Monte Carlo error on top of the
//! table's. Tolerances, per lobe (rel L2 = ‖model − measured‖/‖measured‖ over the bins; "MC"
//! the same for the table's standard errors; measured values as circular/elliptical):
//! * R and TT, the paper's exact terms: albedo within 3% (measured −0.4%/+2.3% for R,
//!   −0.2%/+1.1% for TT), rel L2 within MC + 0.04 (R 0.072/0.085 against MC 0.076/0.069; TT
//!   0.023/0.031 against 0.011/0.018).
//! * TRT: albedo within 6% (+1.3%/−2.4%), rel L2 within MC + 0.2 (0.21/0.24 against
//!   0.064/0.053: the quasi-Monte Carlo noise of the microfacet lattices, which falls with more
//!   offsets; the `huang_proof` example takes the count as an argument).
//! * TRRT+, an approximation (a geometric series over the chords with the interface albedos
//!   averaged over offsets, and a uniform azimuth): its albedo within 0.01 of the measured one
//!   (measured +0.0016/+0.0076: 0.0089 → 0.0105, 0.0072 → 0.0148), rel L2 below 1.5
//!   (0.43/0.78).
//! * `all`: albedo within 2% plus TRRT+'s 0.01 (measured +0.2%/+5.2%, the latter TRRT+'s
//!   excess), rel L2 within MC + 0.05 (0.027/0.056 against 0.013/0.027).

use fiberlab_gonio::model_comparison::{BinAverage, compare_lobes};
use fiberlab_gonio::{Fiber, Orientation, Setup, measure};
use fiberlab_math::Rgb;
use fiberlab_scatter::build;
use std::sync::atomic::AtomicBool;

/// Rays per case (20° bins: the test is sized to seconds; the `huang_proof` example runs the
/// full grid with more).
const RAYS: usize = 200_000;
/// Offsets h per model node.
const OFFSETS: usize = 128;

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
            rays: RAYS,
            bins_theta: 9,
            bins_phi: 18,
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
        let rows = compare_lobes(&m, &fiber, &model, BinAverage { sub: 4, offsets: OFFSETS });
        for r in &rows {
            eprintln!(
                "α {roughness} a {aspect} θ_i {theta_i}: {:<6} albedo measured {:.4} model {:.4}, rel L2 {:.3} (MC {:.3})",
                r.lobe, r.measured_albedo, r.model_albedo, r.rel_l2, r.mc_rel_l2
            );
            let error = (r.model_albedo - r.measured_albedo).abs();
            let (albedo_ok, shape_tol) = match r.lobe {
                "r" | "tt" => (error < 0.03 * r.measured_albedo, 0.04),
                "trt" => (error < 0.06 * r.measured_albedo, 0.2),
                "higher" => (error < 0.01, 1.5),
                _ => (error < 0.02 * r.measured_albedo + 0.01, 0.05),
            };
            assert!(albedo_ok, "{}: albedo {} vs {}", r.lobe, r.model_albedo, r.measured_albedo);
            assert!(r.rel_l2 < r.mc_rel_l2 + shape_tol, "{}: rel L2 {} (MC {})", r.lobe, r.rel_l2, r.mc_rel_l2);
        }
    }
}
