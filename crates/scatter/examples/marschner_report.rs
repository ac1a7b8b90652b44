//! Marschner 2003's report tables: TRT caustic positions (exact and the paper's cubic), the
//! cubic's azimuth error, and the light-side albedo under both normalizations.
//!
//! `cargo run -p fiberlab-scatter --release --example marschner_report`

use fiberlab_math::Rgb;
use fiberlab_scatter::marschner_2003::{MarschnerParams, albedo_table, caustic_table, cubic_azimuth_error_table};
use fiberlab_scatter::radiometry::Quadrature;

fn main() -> Result<(), fiberlab_scatter::ModelError> {
    println!("caustics, η = 1.55 (θ_d deg, η′, exact h_c, φ_c deg, Φ'', cubic h_c, φ_c deg, Φ'', t):");
    let tds: Vec<f64> = [0.0, 10.0, 20.0, 30.0, 40.0, 45.0, 46.9, 50.0].iter().map(|d: &f64| d.to_radians()).collect();
    for r in caustic_table(1.55, 0.3, &tds) {
        println!(
            "  {:5.1} {:6.4} | {:6.4} {:7.3} {:7.3} | {:6.4} {:7.3} {:7.3} | t {:.3}",
            r.theta_d.to_degrees(),
            r.eta_prime,
            r.exact.h_c,
            r.exact.phi_c.to_degrees(),
            r.exact.d2phi_dh2,
            r.cubic.h_c,
            r.cubic.phi_c.to_degrees(),
            r.cubic.d2phi_dh2,
            r.exact.t
        );
    }
    let eps = [1.55, 1.7, 1.9, 2.2, 3.0, 10.0];
    let hs: Vec<f64> = (0..=10).map(|k| 0.1 * k as f64).collect();
    let table = cubic_azimuth_error_table(&eps, &hs);
    for p in 1..=2 {
        println!("cubic − exact azimuth (deg), p = {p}; rows η′, columns h = 0, 0.1, …, 1:");
        for &ep in &eps {
            let row: Vec<String> = table
                .iter()
                .filter(|r| r.p == p && r.eta_prime == ep)
                .map(|r| format!("{:6.2}", r.error.to_degrees()))
                .collect();
            println!("  {ep:5.2}: {}", row.join(" "));
        }
    }
    let q = Quadrature { theta: 360, phi: 720, h: 1 };
    let thetas = [0.0, 0.3, 0.6, 0.9, 1.2, 1.45, 1.55];
    for (name, base) in [
        ("σ_a = 0, glints off", MarschnerParams { sigma_a: Rgb::ZERO, glints: false, ..Default::default() }),
        ("σ_a = 0, glints on", MarschnerParams { sigma_a: Rgb::ZERO, ..Default::default() }),
        ("defaults (σ_a = 0.2,0.3,0.5)", MarschnerParams::default()),
    ] {
        println!("albedo ρ(θ_i), {name} (θ_i rad: energy | paper, red channel):");
        for r in albedo_table(&base, &thetas, &q)? {
            println!("  {:4.2}: {:.4} | {:.4}", r.theta_i, r.energy[0], r.paper[0]);
        }
    }
    Ok(())
}
