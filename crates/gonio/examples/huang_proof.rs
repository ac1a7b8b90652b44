//! `huang-2022` against the explicit rough elliptical fiber, per lobe, over a grid of
//! roughnesses, aspect ratios, orientations and incidences (the table of the book's
//! `models/huang-2022.md`). Prints one Markdown row per case:
//! for R, TT, TRT, TRRT+ (`higher`) and all, the model's albedo relative to the measured one
//! and the relative L2 distance of the tables with, in parentheses, the one the measured
//! table's Monte Carlo error alone gives.
//!
//! `cargo run --release -p fiberlab-gonio --example huang_proof -- [RAYS] [OFFSETS] [SUB]`
//! (defaults 1 000 000 rays, 512 offsets per node, 4 × 4 nodes per 10° bin: the R lobe at
//! α = 0.1 needs the nodes, the microfacet lattices the offsets).

use fiberlab_gonio::model_comparison::{BinAverage, compare_lobes};
use fiberlab_gonio::{Fiber, Orientation, Setup, measure};
use fiberlab_math::Rgb;
use fiberlab_scatter::build;
use std::sync::atomic::AtomicBool;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let rays: usize = args.get(1).map_or(1_000_000, |a| a.parse().expect("RAYS"));
    let offsets: usize = args.get(2).map_or(512, |a| a.parse().expect("OFFSETS"));
    let sub: usize = args.get(3).map_or(4, |a| a.parse().expect("SUB"));
    // (aspect, orientation °, θ_i °, φ_i °, tilt °)
    let mut geometry = vec![(1.0, 0.0, 0.0, 0.0, 0.0), (1.0, 0.0, 30.0, 0.0, 0.0), (1.0, 0.0, 60.0, 0.0, 0.0)];
    for aspect in [0.85, 0.7] {
        geometry.extend([
            (aspect, 0.0, 30.0, 0.0, 0.0),
            (aspect, 45.0, 30.0, 10.0, 0.0),
            (aspect, 90.0, 60.0, 0.0, 0.0),
        ]);
    }
    geometry.push((1.0, 0.0, 30.0, 0.0, 3.0));
    println!(
        "rays {rays} per case, model far field over {sub} × {sub} nodes per bin and {offsets} offsets per node; \
         σ_a = 0.2, 0.4, 0.8 per radius, η = 1.55"
    );
    println!();
    println!("| α | a | ψ | θ_i | φ_i | tilt | R | TT | TRT | TRRT+ | all |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|");
    for roughness in [0.1, 0.3, 0.6] {
        for &(aspect, psi, theta_i, phi_i, tilt) in &geometry {
            let fiber = Fiber {
                roughness,
                aspect,
                orientation: Orientation::Fixed(f64::to_radians(psi)),
                sigma_a: Rgb::new(0.2, 0.4, 0.8),
                scale_angle: f64::to_radians(tilt),
                scale_length: 0.3,
                ..Fiber::default()
            };
            let setup = Setup {
                theta_i: f64::to_radians(theta_i),
                phi_i: f64::to_radians(phi_i),
                rays,
                bins_theta: 18,
                bins_phi: 36,
                seed: 1,
            };
            let m = measure(&fiber, &setup, &AtomicBool::new(false), |_| {}).expect("a valid setup");
            let model = build(
                "huang-2022",
                &[
                    ("roughness", roughness.to_string()),
                    ("aspect", aspect.to_string()),
                    ("orientation", psi.to_string()),
                    ("alpha", tilt.to_string()),
                    ("sigma_a", "0.2,0.4,0.8".into()),
                ],
            )
            .expect("valid parameters");
            let rows = compare_lobes(&m, &fiber, &model, BinAverage { sub, offsets });
            let cells: Vec<String> = rows
                .iter()
                .map(|r| format!("{:.3} · {:.2} ({:.2})", r.model_albedo / r.measured_albedo, r.rel_l2, r.mc_rel_l2))
                .collect();
            println!("| {roughness} | {aspect} | {psi}° | {theta_i}° | {phi_i}° | {tilt}° | {} |", cells.join(" | "));
        }
    }
}
