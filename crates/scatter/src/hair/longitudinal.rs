//! Longitudinal scattering: how a lobe spreads in inclination around the specular cone
//! (`docs/theory/hair.md`, "Longitudinal scattering").
//!
//! # d'Eon's normalized lobe ([`Longitudinal`], used by `chiang` and `deon`)
//! d'Eon et al. 2011 replace Marschner's Gaussian by the θ-marginal of a von Mises–Fisher lobe
//! of concentration 1/v centred on the mirror direction:
//! `M_p(θ_i, θ_o) = exp(−sinθ_i sinθ_o/v)·I₀(cosθ_i cosθ_o/v) / (2v·sinh(1/v))`, normalized,
//! `∫ M_p cosθ_i dθ_i = 1` for every θ_o. Evaluated in the overflow- and cancellation-free form
//! `M_p = i0e(a)·exp(−(1 − cos(θ_i + θ_o))/v) / (v(1 − e^{−2/v}))`, `a = cosθ_i cosθ_o/v`,
//! `i0e(x) = e^{−x}I₀(x)`, `1 − cos(θ_i + θ_o)` from the sines and cosines without cancellation and
//! `1 − e^{−2/v}` by `expm1` (valid for every v > 0; tested from v = 10⁻⁵ to 30). Sampled
//! exactly: the cosine to the mirror direction is `c = 1 + v·ln(u₁ + (1 − u₁)e^{−2/v})`, the
//! azimuth about it `2πu₂` (the stable form pbrt-v4 and Tungsten use; the inversion written as
//! `v·ln(e^{1/v} − 2u sinh(1/v))` overflows for small v).
//!
//! # Marschner's Gaussian lobes ([`GaussianLobes`], used by `marschner`)
//! Marschner et al. 2003: `M_p(θ_h) = k_M·g(β_p; θ_h − α_p)`, g the unit-area Gaussian in the
//! half angle θ_h = (θ_i + θ_r)/2, with the ratios of their Table 1: `α_TT = −α_R/2`,
//! `α_TRT = −3α_R/2`, `β_TT = β_R/2`, `β_TRT = 2β_R`. The constant k_M is the model's choice
//! (`docs/theory/peer-discrepancies.md`, "Marschner longitudinal normalization").

use fiberlab_math::special::{gaussian, i0e, safe_sqrt};
use std::f64::consts::TAU;

/// d'Eon 2011's longitudinal scattering function `M_p` for one lobe (variance-like `v > 0`),
/// with its constants precomputed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Longitudinal {
    v: f64,
    /// `1/(v·(1 − e^{−2/v}))`.
    inv_norm: f64,
    /// `e^{−2/v} − 1` (for the sampler).
    expm1_neg_2_over_v: f64,
}

impl Longitudinal {
    /// The lobe of variance-like roughness `v` (must be finite and > 0; callers validate).
    #[must_use]
    pub fn new(v: f64) -> Self {
        debug_assert!(v > 0.0 && v.is_finite());
        let expm1_neg_2_over_v = (-2.0 / v).exp_m1();
        Self { v, inv_norm: 1.0 / (v * -expm1_neg_2_over_v), expm1_neg_2_over_v }
    }

    /// The roughness `v`.
    #[must_use]
    pub fn v(&self) -> f64 {
        self.v
    }

    /// `M_p(θ_i, θ_o)` (density over `cosθ_i dθ_i`, i.e. per unit `sinθ_i`) from the sines
    /// and cosines of the two inclinations; both cosines must be ≥ 0 (d'Eon 2011, in the stable
    /// form of the module docs).
    #[must_use]
    #[inline]
    pub fn eval(&self, sin_i: f64, cos_i: f64, sin_o: f64, cos_o: f64) -> f64 {
        let a = cos_i * cos_o / self.v;
        // 1 − cos(θ_i + θ_o), cancellation-free.
        let one_minus_cos = 0.5 * ((cos_i - cos_o).powi(2) + (sin_i + sin_o).powi(2));
        let e = (-one_minus_cos / self.v).exp();
        if e == 0.0 {
            return 0.0; // far outside a narrow lobe: skip the Bessel function
        }
        let m = i0e(a) * e * self.inv_norm;
        debug_assert!(m.is_finite() && m >= 0.0);
        m
    }

    /// Draws `sinθ_i` with density `M_p(·, θ_o)` per unit `sinθ_i` from two independent
    /// uniforms (exact inversion): the cosine `c` of the angle to the mirror
    /// direction is `1 + v·ln(u₁ + (1 − u₁)e^{−2/v})`, written as `ln1p((1 − u₁)(e^{−2/v} − 1))`
    /// and clamped to `c ≥ −1` (no tail truncation), and the azimuth about the mirror
    /// direction is `2πu₂`.
    #[must_use]
    #[inline]
    pub fn sample_sin_theta(&self, sin_o: f64, cos_o: f64, u1: f64, u2: f64) -> f64 {
        let c = (1.0 + self.v * ((1.0 - u1) * self.expm1_neg_2_over_v).ln_1p()).max(-1.0);
        let s = safe_sqrt(1.0 - c * c);
        (-c * sin_o + s * (TAU * u2).cos() * cos_o).clamp(-1.0, 1.0)
    }
}

/// Marschner 2003's three Gaussian lobes (R, TT, TRT) from the R lobe's shift α_R and width
/// β_R (radians) with Table 1's ratios, and the constant k_M.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GaussianLobes {
    /// Shifts α_p (radians): `[α_R, −α_R/2, −3α_R/2]`.
    pub alpha: [f64; 3],
    /// Widths β_p (radians, standard deviations in θ_h): `[β_R, β_R/2, 2β_R]`.
    pub beta: [f64; 3],
    /// The constant k_M of `M_p = k_M·g(β_p; θ_h − α_p)`.
    pub k_m: f64,
}

impl GaussianLobes {
    /// The lobes for shift `alpha_r`, width `beta_r > 0` (radians) and constant `k_m`.
    #[must_use]
    pub fn new(alpha_r: f64, beta_r: f64, k_m: f64) -> Self {
        Self { alpha: [alpha_r, -0.5 * alpha_r, -1.5 * alpha_r], beta: [beta_r, 0.5 * beta_r, 2.0 * beta_r], k_m }
    }

    /// `M_p(θ_h) = k_M·g(β_p; θ_h − α_p)` for lobe p ∈ {0, 1, 2} (per radian of θ_h).
    #[must_use]
    #[inline]
    pub fn eval(&self, p: usize, theta_h: f64) -> f64 {
        self.k_m * gaussian(self.beta[p], theta_h - self.alpha[p])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::FRAC_PI_2;

    /// Independent evaluation of `M_p` as the azimuthal integral of the vMF density:
    /// `M = κ/(2π(1 − e^{−2κ}))·∫_0^{2π} exp(κ(μ·ω − 1)) dψ`, κ = 1/v, by the periodic
    /// trapezoid rule (exponentially convergent). No Bessel function involved.
    fn m_by_vmf_quadrature(v: f64, theta_i: f64, theta_o: f64) -> f64 {
        let k = 1.0 / v;
        let (si, ci) = theta_i.sin_cos();
        let (so, co) = theta_o.sin_cos();
        let n = 200_000;
        let mut sum = 0.0;
        for j in 0..n {
            let psi = TAU * j as f64 / n as f64;
            let dot = -si * so + ci * co * psi.cos();
            sum += (k * (dot - 1.0)).exp();
        }
        k / (TAU * -(-2.0 * k).exp_m1()) * sum * TAU / n as f64
    }

    /// Direct form with the I₀ power series, in f64 (only for moderate arguments).
    fn m_direct_series(v: f64, theta_i: f64, theta_o: f64) -> f64 {
        let (si, ci) = theta_i.sin_cos();
        let (so, co) = theta_o.sin_cos();
        let x = ci * co / v;
        let q = 0.25 * x * x;
        let (mut term, mut sum, mut k) = (1.0f64, 1.0f64, 1.0f64);
        while term > 1e-18 * sum {
            term *= q / (k * k);
            sum += term;
            k += 1.0;
        }
        (-si * so / v).exp() * sum / (2.0 * v * (1.0 / v).sinh())
    }

    #[test]
    fn m_p_matches_independent_evaluations_for_v_from_1e_5_to_30() {
        let mut worst: f64 = 0.0;
        for &v in &[1e-5, 1e-4, 1e-3, 0.00652, 0.0846, 0.32, 1.0, 5.0, 27.44, 30.0] {
            for &(ti, to) in &[(0.1, -0.12), (-0.4, 0.38), (0.8, -0.75), (1.2, -1.2), (0.0, 0.0), (1.5, -1.49)] {
                let m = Longitudinal::new(v);
                let got = m.eval(f64::sin(ti), f64::cos(ti), f64::sin(to), f64::cos(to));
                let want = m_by_vmf_quadrature(v, ti, to);
                let rel = (got - want).abs() / want.max(1e-300);
                // Values below 1e-250 are underflow territory for the quadrature.
                if want > 1e-250 {
                    worst = worst.max(rel);
                    assert!(rel < 1e-9, "v={v} θi={ti} θo={to}: {got} vs {want}");
                }
                if v >= 0.05 {
                    let direct = m_direct_series(v, ti, to);
                    assert!((got - direct).abs() <= 1e-12 * direct, "v={v}: {got} vs series {direct}");
                }
            }
        }
        assert!(worst < 1e-9);
    }

    #[test]
    fn m_p_is_normalized_to_1e_6_for_every_v() {
        for &v in &[1e-5, 1e-4, 1e-3, 0.00652, 0.0846, 0.32, 1.0, 27.44, 30.0] {
            let m = Longitudinal::new(v);
            for &to in &[0.0, 0.3, -0.9, 1.4, FRAC_PI_2] {
                let (so, co) = f64::sin_cos(to);
                // ∫ M cosθ_i dθ_i = ∫ M d(sinθ_i): composite Simpson on panels growing
                // geometrically (×1.5) away from the peak at sinθ_i = −sinθ_o, the first of
                // width v (the lobe is v wide in sinθ_i at grazing, √v elsewhere).
                let peak = -so;
                let mut edges = vec![peak];
                let mut w = v;
                while peak - w > -1.0 || peak + w < 1.0 {
                    edges.push((peak - w).max(-1.0));
                    edges.push((peak + w).min(1.0));
                    w *= 1.5;
                }
                edges.push(-1.0);
                edges.push(1.0);
                edges.sort_by(f64::total_cmp);
                edges.dedup();
                let f = |s: f64| m.eval(s, safe_sqrt(1.0 - s * s), so, co.abs());
                let mut total = 0.0;
                for pair in edges.windows(2) {
                    let (a, b) = (pair[0], pair[1]);
                    let n = 64;
                    let hh = (b - a) / n as f64;
                    let mut acc = f(a) + f(b);
                    for k in 1..n {
                        acc += f(a + k as f64 * hh) * if k % 2 == 1 { 4.0 } else { 2.0 };
                    }
                    total += acc * hh / 3.0;
                }
                assert!((total - 1.0).abs() < 1e-6, "v={v} θo={to}: {total}");
            }
        }
    }

    #[test]
    fn sampler_inverts_the_marginal_cdf() {
        // The sampled sinθ_i has density M: compare its histogram-free CDF, i.e. the fraction
        // of stratified samples below x, with ∫_{−1}^{x} M d(sinθ_i).
        for &v in &[1e-3, 0.0846, 2.0] {
            let m = Longitudinal::new(v);
            let (so, co) = f64::sin_cos(0.5);
            let n = 400;
            let mut samples = Vec::with_capacity(n * n);
            for a in 0..n {
                for b in 0..n {
                    let (u1, u2) = ((a as f64 + 0.5) / n as f64, (b as f64 + 0.5) / n as f64);
                    samples.push(m.sample_sin_theta(so, co, u1, u2));
                }
            }
            samples.sort_by(f64::total_cmp);
            for &x in &[-0.6, -0.5, -0.45, -0.3, 0.0, 0.5] {
                let k = 20_000;
                let d = (x + 1.0) / k as f64;
                let cdf: f64 = (0..k)
                    .map(|j| {
                        let s = -1.0 + (j as f64 + 0.5) * d;
                        m.eval(s, safe_sqrt(1.0 - s * s), so, co) * d
                    })
                    .sum();
                let frac = samples.partition_point(|&s| s < x) as f64 / samples.len() as f64;
                assert!((frac - cdf).abs() < 2e-3, "v={v} x={x}: {frac} vs {cdf}");
            }
        }
        // Extreme uniforms never give NaN.
        let m = Longitudinal::new(1e-4);
        for &u1 in &[0.0, 1.0, 1e-300] {
            assert!(m.sample_sin_theta(1.0, 0.0, u1, 0.3).is_finite());
        }
    }
}
