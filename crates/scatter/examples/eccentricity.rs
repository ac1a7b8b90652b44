//! How far Marschner 2003's first-order eccentricity correction holds, and Khungurn & Marschner
//! 2017's qualitative findings, from the hair core's exact smooth paths through elliptical
//! cross-sections (`hair::ellipse::smooth_path`, tested against the goniophotometer's explicit
//! ellipse in `crates/gonio/tests/elliptical_paths.rs`).
//!
//! For light in the normal plane (θ = 0) at azimuth `φ_i` from the major axis, for each aspect
//! ratio a it prints the TRT caustics (the azimuths where the exit azimuth Φ(h) is stationary)
//! of the exact ellipse, those of `marschner` with `eccentricity = a` (the peaks of its exact-
//! root N_TRT, glints off) and of the circle, and the relative L2 distance of the binned TRT
//! azimuthal distributions (2° bins) of the η* correction and of the circle from the exact one.
//!
//! Run: `cargo run --release -p fiberlab-scatter --example eccentricity`

use fiberlab_math::{Rgb, wrap_pi};
use fiberlab_scatter::hair::ellipse::{Ellipse, smooth_path};
use fiberlab_scatter::marschner_2003::Lobe;
use fiberlab_scatter::{Model, build};
use std::f64::consts::{PI, TAU};

const ETA: f64 = 1.55;
const SIGMA: f64 = 0.3;
const BINS: usize = 180;

/// Exact TRT: (caustic azimuths in degrees, binned distribution of the exit azimuth relative to
/// the light, ½∫A dh per bin).
fn exact(aspect: f64, phi_i: f64) -> (Vec<f64>, Vec<f64>) {
    let e = Ellipse::new(aspect, 0.0);
    let n = 400_000;
    let mut hist = vec![0.0; BINS];
    let mut prev: Option<(f64, f64)> = None; // (Φ, dΦ sign)
    let mut caustics = Vec::new();
    let mut last_phi = None;
    for k in 0..n {
        let h = -1.0 + (k as f64 + 0.5) * 2.0 / n as f64;
        let Some(path) = smooth_path(&e, ETA, Rgb::splat(SIGMA), (0.0, 1.0), phi_i, h, 2) else {
            (prev, last_phi) = (None, None);
            continue;
        };
        let rel = wrap_pi(path.exit_azimuth - phi_i);
        let j = (((rel + PI) / TAU * BINS as f64) as usize).min(BINS - 1);
        hist[j] += path.attenuation[0] / n as f64;
        if let Some(lp) = last_phi {
            let d = wrap_pi(rel - lp);
            if let Some((pphi, pd)) = prev
                && d * pd < 0.0
            {
                caustics.push(f64::to_degrees(pphi));
            }
            prev = Some((rel, d));
        }
        last_phi = Some(rel);
    }
    (caustics, hist)
}

/// Marschner's TRT N(φ) with eccentricity `a` for light at `phi_i` from the major axis: peaks
/// (degrees) and the binned distribution.
fn marschner(a: f64, phi_i: f64) -> (Vec<f64>, Vec<f64>) {
    let m = build(
        "marschner",
        &[("roots", "exact"), ("glints", "off"), ("sigma_a", &SIGMA.to_string()), ("eccentricity", &a.to_string())],
    )
    .unwrap();
    let Model::Marschner(m) = m else { unreachable!() };
    let n = |phi: f64| m.azimuthal(Lobe::TRT, 0.0, phi, (2.0 * phi_i + phi).cos())[0];
    let fine = 36_000;
    let values: Vec<f64> = (0..fine).map(|k| n(-PI + (k as f64 + 0.5) * TAU / fine as f64)).collect();
    let mut peaks = Vec::new();
    for k in 1..fine - 1 {
        if values[k] > values[k - 1]
            && values[k] >= values[k + 1]
            && values[k] > 3.0 * values.iter().sum::<f64>() / fine as f64
        {
            peaks.push(-180.0 + (k as f64 + 0.5) * 360.0 / fine as f64);
        }
    }
    let per = fine / BINS;
    let hist = (0..BINS).map(|b| values[b * per..(b + 1) * per].iter().sum::<f64>() * TAU / fine as f64).collect();
    (peaks, hist)
}

fn rel_l2(a: &[f64], b: &[f64]) -> f64 {
    let d: f64 = a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum();
    (d / a.iter().map(|x| x * x).sum::<f64>()).sqrt()
}

fn list(v: &[f64]) -> String {
    v.iter().map(|x| format!("{x:.1}")).collect::<Vec<_>>().join(", ")
}

fn main() {
    println!(
        "TRT caustics (degrees, φ_r − φ_i) for light in the normal plane at φ_i from the major axis; η = {ETA}, σ_a = {SIGMA}"
    );
    println!();
    println!(
        "| a | φ_i | exact ellipse | η* (Marschner 2003) | circle | rel L2 η* | rel L2 circle | TRT albedo exact / η* |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    let (circle_caustics, _) = exact(1.0, 0.0);
    for &a in &[1.0, 0.95, 0.9, 0.85, 0.75] {
        for &phi_deg in &[0.0, 30.0, 60.0, 90.0] {
            let phi_i = f64::to_radians(phi_deg);
            let (c_exact, h_exact) = exact(a, phi_i);
            let (c_star, h_star) = marschner(a, phi_i);
            let (_, h_circle) = exact(1.0, phi_i);
            let (s_exact, s_star): (f64, f64) = (h_exact.iter().sum(), h_star.iter().sum());
            println!(
                "| {a} | {phi_deg}° | {} | {} | {} | {:.2} | {:.2} | {s_exact:.4} / {s_star:.4} |",
                list(&c_exact),
                list(&c_star),
                list(&circle_caustics),
                rel_l2(&h_exact, &h_star),
                rel_l2(&h_exact, &h_circle)
            );
        }
    }
}
