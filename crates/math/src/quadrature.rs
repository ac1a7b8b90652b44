//! Quadrature rules shared by the models, the harness and the comparisons: Gauss–Legendre
//! nodes, and the one rule by which a near-field quantity is averaged over the fiber's width.
//!
//! # Formula
//! Width average: `ḡ = ½ ∫_{−1}^{1} g(h) dh = ½ ∫_{−π/2}^{π/2} g(sin γ) cos γ dγ`,
//! where `h = sin γ` is the offset across the fiber and γ the angle of incidence on its
//! surface. In γ the integrand is smooth up to the edges (path lengths inside a fiber go as
//! `cos γ = √(1 − h²)`, which rules in `h` resolve slowly), so the rule works in γ: equal
//! panels over [−π/2, π/2] with 4 Gauss–Legendre nodes each. Equal panels, not one
//! high-order rule, because a narrow azimuthal lobe can sit anywhere across the width
//! (a reflection lobe of roughness β_n is about β_n/4 wide in γ); a model says how narrow
//! its features are (`ScatteringFunction::width_feature` in `fiberlab-scatter`) and gets one
//! panel per feature width.

use crate::Rgb;
use std::f64::consts::{FRAC_PI_2, PI};

/// Panels of the default width average: a feature of width π/16 in γ resolved by one panel.
pub const WIDTH_PANELS: usize = 16;

/// Most panels any width average uses (4096 nodes).
pub const MAX_WIDTH_PANELS: usize = 1024;

/// 4-point Gauss–Legendre nodes and weights on [−1, 1].
const GAUSS_LEGENDRE_4: [(f64, f64); 4] = [
    (-0.861_136_311_594_052_6, 0.347_854_845_137_453_8),
    (-0.339_981_043_584_856_3, 0.652_145_154_862_546_1),
    (0.339_981_043_584_856_3, 0.652_145_154_862_546_1),
    (0.861_136_311_594_052_6, 0.347_854_845_137_453_8),
];

/// Gauss–Legendre nodes and weights `(x_k, w_k)` on [−1, 1] (`n` nodes, exact for
/// polynomials of degree 2n − 1): Newton's method on the Legendre polynomial `P_n` from the
/// asymptotic guesses `cos(π(k + 3/4)/(n + 1/2))`, weights `2/((1 − x²)P_n′(x)²)`.
#[must_use]
pub fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    let nf = n as f64;
    (0..n)
        .map(|i| {
            let mut x = (PI * (i as f64 + 0.75) / (nf + 0.5)).cos();
            let mut dp = 1.0;
            for _ in 0..100 {
                let (mut p0, mut p1) = (1.0, x);
                for k in 2..=n {
                    let kf = k as f64;
                    let p2 = ((2.0 * kf - 1.0) * x * p1 - (kf - 1.0) * p0) / kf;
                    p0 = p1;
                    p1 = p2;
                }
                dp = nf * (x * p1 - p0) / (x * x - 1.0);
                let dx = p1 / dp;
                x -= dx;
                if dx.abs() < 1e-15 {
                    break;
                }
            }
            (x, 2.0 / ((1.0 - x * x) * dp * dp))
        })
        .collect()
}

/// Panels that resolve a feature `feature` radians wide in γ (one panel per feature width):
/// `⌈π/feature⌉`, at least [`WIDTH_PANELS`] and at most [`MAX_WIDTH_PANELS`].
#[must_use]
pub fn width_panels(feature: f64) -> usize {
    let panels = (PI / feature).ceil();
    if panels.is_nan() { MAX_WIDTH_PANELS } else { (panels as usize).clamp(WIDTH_PANELS, MAX_WIDTH_PANELS) }
}

/// Calls `node(h, w)` for the width-average rule of `panels` panels (module docs): γ over
/// [−π/2, π/2] in equal panels with 4 Gauss–Legendre nodes each, `h = sin γ`, raw weights
/// `cos γ dγ` (normalized by the caller).
fn for_each_width_node(panels: usize, mut node: impl FnMut(f64, f64)) {
    let panels = panels.max(1);
    let half = 0.5 * PI / panels as f64;
    for p in 0..panels {
        let mid = -FRAC_PI_2 + (2 * p + 1) as f64 * half;
        for &(x, w) in &GAUSS_LEGENDRE_4 {
            let (sin, cos) = (mid + half * x).sin_cos();
            node(sin, w * half * cos);
        }
    }
}

/// The width-average rule of `panels` panels as offsets `h_k` with weights summing to 1, so
/// that `Σ w_k g(h_k) ≈ ½∫_{−1}^{1} g(h) dh` (a constant is averaged to rounding error).
#[must_use]
pub fn width_nodes(panels: usize) -> Vec<(f64, f64)> {
    let mut nodes = Vec::with_capacity(4 * panels.max(1));
    for_each_width_node(panels, |h, w| nodes.push((h, w)));
    let total: f64 = nodes.iter().map(|&(_, w)| w).sum();
    nodes.into_iter().map(|(h, w)| (h, w / total)).collect()
}

/// `½∫_{−1}^{1} g(h) dh` by the width-average rule of `panels` panels (nodes computed on the
/// fly: no allocation).
pub fn width_average(panels: usize, mut g: impl FnMut(f64) -> Rgb) -> Rgb {
    let (mut sum, mut total) = (Rgb::ZERO, 0.0);
    for_each_width_node(panels, |h, w| {
        sum += g(h) * w;
        total += w;
    });
    sum / total
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gauss_legendre_integrates_polynomials_of_degree_2n_minus_1_exactly() {
        for n in [1, 2, 5, 48, 300] {
            let nodes = gauss_legendre(n);
            let total: f64 = nodes.iter().map(|&(_, w)| w).sum();
            assert!((total - 2.0).abs() < 1e-12, "n {n}: Σw = {total}");
            let d = 2 * n - 2; // even degree 2n − 2: ∫ x^d = 2/(d + 1)
            let got: f64 = nodes.iter().map(|&(x, w)| w * x.powi(d as i32)).sum();
            assert!((got - 2.0 / (d as f64 + 1.0)).abs() < 1e-11, "n {n}: {got}");
        }
    }

    /// Closed forms: ½∫ h² dh = 1/3, ½∫ √(1 − h²) dh = π/4 (the chord, smooth in γ), a
    /// constant exactly, and a narrow Gaussian bump at h = 0.3 (σ = 0.02) once the panels
    /// resolve it.
    #[test]
    fn width_average_matches_closed_forms() {
        let avg = |panels: usize, g: fn(f64) -> f64| width_average(panels, |h| Rgb::splat(g(h)))[0];
        assert!((avg(WIDTH_PANELS, |h| h * h) - 1.0 / 3.0).abs() < 1e-12);
        assert!((avg(WIDTH_PANELS, |h| (1.0 - h * h).sqrt()) - PI / 4.0).abs() < 1e-12);
        assert!((avg(WIDTH_PANELS, |_| 0.7) - 0.7).abs() < 1e-15);
        // ½∫ exp(−(h − 0.3)²/(2σ²)) dh = σ√(2π)/2 (the tails beyond ±1 are nil).
        let sigma = 0.02;
        let want = sigma * (2.0 * PI).sqrt() / 2.0;
        let got = avg(width_panels(sigma), |h| (-(h - 0.3) * (h - 0.3) / (2.0 * 0.02 * 0.02)).exp());
        assert!((got - want).abs() < 1e-4 * want, "{got} vs {want}");
        let nodes = width_nodes(7);
        assert_eq!(nodes.len(), 28);
        assert!(nodes.iter().all(|&(h, w)| h.abs() < 1.0 && w > 0.0));
        assert!((nodes.iter().map(|&(_, w)| w).sum::<f64>() - 1.0).abs() < 1e-15);
        assert_eq!(width_panels(0.0), MAX_WIDTH_PANELS);
        assert_eq!(width_panels(10.0), WIDTH_PANELS);
    }
}
