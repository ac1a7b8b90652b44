//! χ² goodness-of-fit of `sample()` against `pdf()` (Mitsuba's `chi2.py` approach).
//!
//! The sphere is binned uniformly in `(sinθ, φ)` (equal solid angle per cell). Expected
//! counts integrate `pdf` over each cell in the θ variable (`dω = cosθ dθ dφ`, a smooth
//! integrand even where the pdf has a `1/cosθ` factor), with `sub × sub` midpoint nodes.
//! Cells expecting fewer than [`CHI2_MIN_EXPECTED`] samples are pooled into one; a sample in
//! a cell with zero expected mass fails the test outright.

use crate::tolerance::CHI2_MIN_EXPECTED;
use fiberlab_math::DVec3;
use fiberlab_math::frame::{direction_from_sin_cos, phi, sin_theta};
use fiberlab_scatter::ScatteringFunction;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use statrs::distribution::{ChiSquared, ContinuousCDF};
use std::f64::consts::{PI, TAU};

/// Settings of one χ² test.
#[derive(Clone, Copy, Debug)]
pub struct Chi2Config {
    /// Cells in `sinθ`.
    pub bins_theta: usize,
    /// Cells in φ.
    pub bins_phi: usize,
    /// Midpoint nodes per cell side for the expected counts.
    pub sub: usize,
    /// Number of `sample()` calls.
    pub samples: usize,
    /// Seed of the sample stream.
    pub seed: u64,
}

impl Default for Chi2Config {
    fn default() -> Self {
        Self { bins_theta: 48, bins_phi: 96, sub: 6, samples: 1_000_000, seed: 1 }
    }
}

/// Outcome of one χ² test.
#[derive(Clone, Debug)]
pub struct Chi2Outcome {
    /// χ² statistic over the pooled cells.
    pub statistic: f64,
    /// Degrees of freedom (cells after pooling − 1).
    pub dof: usize,
    /// `P(X ≥ statistic)` under the null hypothesis.
    pub p_value: f64,
    /// Samples that fell in cells with zero expected mass.
    pub impossible: usize,
    /// `sample()` calls that returned `None`.
    pub failures: usize,
}

impl Chi2Outcome {
    /// True when the test does not reject at significance `alpha`.
    #[must_use]
    pub fn passes(&self, alpha: f64) -> bool {
        self.impossible == 0 && self.p_value >= alpha
    }
}

fn cell_of(cfg: &Chi2Config, w: DVec3) -> usize {
    let u = ((sin_theta(w) + 1.0) * 0.5 * cfg.bins_theta as f64) as usize;
    let p = ((phi(w) + PI) / TAU * cfg.bins_phi as f64) as usize;
    u.min(cfg.bins_theta - 1) * cfg.bins_phi + p.min(cfg.bins_phi - 1)
}

/// Expected probability of every cell: `∫_cell pdf dω`.
pub fn expected_masses(f: &impl ScatteringFunction, wo: DVec3, h: f64, cfg: &Chi2Config) -> Vec<f64> {
    let mut mass = vec![0.0; cfg.bins_theta * cfg.bins_phi];
    let dp = TAU / cfg.bins_phi as f64;
    for i in 0..cfg.bins_theta {
        let ua = -1.0 + 2.0 * i as f64 / cfg.bins_theta as f64;
        let ub = -1.0 + 2.0 * (i + 1) as f64 / cfg.bins_theta as f64;
        let (ta, tb) = (ua.clamp(-1.0, 1.0).asin(), ub.clamp(-1.0, 1.0).asin());
        // Cells near the poles are wide in θ: keep the θ spacing of the nodes that of the
        // equatorial cells.
        let equatorial = 2.0 / cfg.bins_theta as f64;
        let sub_theta = ((cfg.sub as f64 * (tb - ta) / equatorial).ceil() as usize).max(cfg.sub);
        let dt = (tb - ta) / sub_theta as f64;
        for j in 0..cfg.bins_phi {
            let mut m = 0.0;
            for a in 0..sub_theta {
                let t = ta + (a as f64 + 0.5) * dt;
                let (s, c) = t.sin_cos();
                for b in 0..cfg.sub {
                    let p = -PI + (j as f64 + (b as f64 + 0.5) / cfg.sub as f64) * dp;
                    m += f.pdf(direction_from_sin_cos(s, c, p), wo, h) * c;
                }
            }
            mass[i * cfg.bins_phi + j] = m * dt * dp / cfg.sub as f64;
        }
    }
    mass
}

/// Runs the χ² test of `f.sample(wo, h, ·)` against `f.pdf(·, wo, h)`.
pub fn chi2_test(f: &impl ScatteringFunction, wo: DVec3, h: f64, cfg: &Chi2Config) -> Chi2Outcome {
    let mass = expected_masses(f, wo, h, cfg);
    let mut observed = vec![0u64; mass.len()];
    let mut rng = Pcg64::seed_from_u64(cfg.seed);
    let mut failures = 0;
    for _ in 0..cfg.samples {
        let u = [rng.random(), rng.random(), rng.random(), rng.random()];
        match f.sample(wo, h, u) {
            Some(s) => observed[cell_of(cfg, s.wi)] += 1,
            None => failures += 1,
        }
    }
    let n = cfg.samples as f64;
    let (mut stat, mut cells, mut impossible) = (0.0, 0usize, 0usize);
    let (mut pooled_obs, mut pooled_exp) = (0.0, 0.0);
    for (&m, &o) in mass.iter().zip(&observed) {
        let e = m * n;
        if e <= 0.0 {
            impossible += o as usize;
        } else if e < CHI2_MIN_EXPECTED {
            pooled_obs += o as f64;
            pooled_exp += e;
        } else {
            stat += (o as f64 - e).powi(2) / e;
            cells += 1;
        }
    }
    if pooled_exp > 0.0 {
        stat += (pooled_obs - pooled_exp).powi(2) / pooled_exp;
        cells += 1;
    }
    // Samples the sampler failed to produce are a cell of their own: expected n·(1 − Σm).
    let missing = (1.0 - mass.iter().sum::<f64>()).max(0.0) * n;
    if failures > 0 || missing >= CHI2_MIN_EXPECTED {
        let e = missing.max(1e-300);
        stat += (failures as f64 - e).powi(2) / e;
        cells += 1;
    }
    let dof = cells.saturating_sub(1).max(1);
    let p_value = ChiSquared::new(dof as f64).map(|d| 1.0 - d.cdf(stat)).unwrap_or(0.0);
    Chi2Outcome { statistic: stat, dof, p_value, impossible, failures }
}

/// 1D χ² of a delta model's sampled relative azimuth against its cone density
/// ([`ScatteringFunction::cone`]). Also counts samples off the cone (θ_i ≠ −θ_o).
pub fn chi2_cone(f: &impl ScatteringFunction, wo: DVec3, bins: usize, samples: usize, seed: u64) -> Chi2Outcome {
    let theta_o = fiberlab_math::frame::theta(wo);
    let sub = 16;
    let dp = TAU / bins as f64;
    let mass: Vec<f64> = (0..bins)
        .map(|j| {
            (0..sub).map(|b| f.cone(theta_o, -PI + (j as f64 + (b as f64 + 0.5) / sub as f64) * dp).pdf).sum::<f64>()
                * dp
                / sub as f64
        })
        .collect();
    let mut observed = vec![0u64; bins];
    let mut rng = Pcg64::seed_from_u64(seed);
    let (mut failures, mut off_cone) = (0, 0);
    for _ in 0..samples {
        let u = [rng.random(), rng.random(), rng.random(), rng.random()];
        match f.sample(wo, 0.0, u) {
            Some(s) => {
                if (s.wi.x + wo.x).abs() > 1e-9 {
                    off_cone += 1;
                }
                let rel = fiberlab_math::relative_phi(s.wi, wo);
                observed[(((rel + PI) / TAU * bins as f64) as usize).min(bins - 1)] += 1;
            }
            None => failures += 1,
        }
    }
    let n = samples as f64;
    let (mut stat, mut cells, mut impossible) = (0.0, 0usize, off_cone);
    for (&m, &o) in mass.iter().zip(&observed) {
        let e = m * n;
        if e <= 0.0 {
            impossible += o as usize;
        } else {
            stat += (o as f64 - e).powi(2) / e;
            cells += 1;
        }
    }
    let dof = cells.saturating_sub(1).max(1);
    let p_value = ChiSquared::new(dof as f64).map(|d| 1.0 - d.cdf(stat)).unwrap_or(0.0);
    Chi2Outcome { statistic: stat, dof, p_value, impossible, failures }
}
