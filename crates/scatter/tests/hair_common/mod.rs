//! Shared helpers of the hair-model tests: a PCG generator, uniform sphere directions and a
//! 2D χ² goodness-of-fit test of `sample` against `pdf` in (sinθ_i, φ_i − φ_o).
#![allow(dead_code)]

use fiberlab_math::frame::{direction_from_sin_cos, phi, sin_theta, wrap_pi};
use fiberlab_math::{DVec3, special::safe_sqrt};
use fiberlab_scatter::ScatteringFunction;
use std::f64::consts::{PI, TAU};

/// PCG32 (O'Neill), returning f64 in [0, 1).
pub struct Pcg(u64);

impl Pcg {
    pub fn new(seed: u64) -> Self {
        let mut p = Pcg(seed.wrapping_mul(0x5851_F42D_4C95_7F2D).wrapping_add(0x1405_7B7E_F767_814F));
        p.next_u32();
        p
    }
    fn next_u32(&mut self) -> u32 {
        let old = self.0;
        self.0 = old.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        let rot = (old >> 59) as u32;
        xorshifted.rotate_right(rot)
    }
    pub fn uniform(&mut self) -> f64 {
        let hi = (self.next_u32() as u64) << 21;
        let lo = (self.next_u32() >> 11) as u64;
        (hi | lo) as f64 / (1u64 << 53) as f64
    }
    pub fn u4(&mut self) -> [f64; 4] {
        [self.uniform(), self.uniform(), self.uniform(), self.uniform()]
    }
    /// Uniform direction on the sphere.
    pub fn sphere(&mut self) -> DVec3 {
        let s = 2.0 * self.uniform() - 1.0;
        direction_from_sin_cos(s, safe_sqrt(1.0 - s * s), TAU * self.uniform())
    }
}

/// Result of [`chi2`].
#[derive(Debug)]
pub struct Chi2 {
    pub statistic: f64,
    pub dof: usize,
    /// Wilson–Hilferty normal deviate of the statistic (≈ N(0, 1) under the null).
    pub z: f64,
    /// `∫ pdf dω` over the sphere by the same cell quadrature.
    pub pdf_integral: f64,
}

/// χ² test of `f.sample(wo, h, ·)` against `f.pdf` on an `n_s × n_phi` grid in
/// (sinθ_i ∈ [−1, 1], φ_i − φ_o ∈ [−π, π)); expected counts integrate the pdf over each cell
/// with `sub × sub` midpoint sub-samples; cells expecting < 5 are pooled.
pub fn chi2(
    f: &impl ScatteringFunction,
    wo: DVec3,
    h: f64,
    n_samples: usize,
    n_s: usize,
    n_phi: usize,
    seed: u64,
) -> Chi2 {
    let sub = 3;
    let (ds, dp) = (2.0 / n_s as f64, TAU / n_phi as f64);
    let cell = |wi: DVec3| -> usize {
        let i = (((sin_theta(wi) + 1.0) / ds) as usize).min(n_s - 1);
        let j = (((wrap_pi(phi(wi) - phi(wo)) + PI) / dp) as usize).min(n_phi - 1);
        i * n_phi + j
    };
    let mut observed = vec![0.0f64; n_s * n_phi];
    let mut rng = Pcg::new(seed);
    for _ in 0..n_samples {
        if let Some(s) = f.sample(wo, h, rng.u4()) {
            observed[cell(s.wi)] += 1.0;
        }
    }
    let mut expected = vec![0.0f64; n_s * n_phi];
    let (dss, dps) = (ds / sub as f64, dp / sub as f64);
    let mut total = 0.0;
    for i in 0..n_s {
        for a in 0..sub {
            let s = -1.0 + i as f64 * ds + (a as f64 + 0.5) * dss;
            let c = safe_sqrt(1.0 - s * s);
            for j in 0..n_phi {
                let mut acc = 0.0;
                for b in 0..sub {
                    let rel = -PI + j as f64 * dp + (b as f64 + 0.5) * dps;
                    acc += f.pdf(direction_from_sin_cos(s, c, phi(wo) + rel), wo, h);
                }
                expected[i * n_phi + j] += acc * dss * dps;
            }
        }
    }
    for e in expected.iter_mut() {
        total += *e;
        *e *= n_samples as f64;
    }
    let (mut stat, mut bins) = (0.0, 0usize);
    let (mut pooled_o, mut pooled_e) = (0.0, 0.0);
    for (o, e) in observed.iter().zip(&expected) {
        if *e < 5.0 {
            pooled_o += o;
            pooled_e += e;
        } else {
            stat += (o - e).powi(2) / e;
            bins += 1;
        }
    }
    if pooled_e > 0.0 {
        stat += (pooled_o - pooled_e).powi(2) / pooled_e.max(1.0);
        bins += 1;
    }
    let k = (bins - 1) as f64;
    let z = ((stat / k).cbrt() - (1.0 - 2.0 / (9.0 * k))) / (2.0 / (9.0 * k)).sqrt();
    Chi2 { statistic: stat, dof: bins - 1, z, pdf_integral: total }
}
