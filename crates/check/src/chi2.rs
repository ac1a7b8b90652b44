//! χ² goodness-of-fit of `sample()` against `pdf()` (Mitsuba's `chi2.py` approach).
//!
//! The sphere is binned uniformly in the cosine of a polar angle and in the azimuth about
//! that pole (equal solid angle per cell). Two grids ([`Pole`]):
//! * [`Pole::FiberAxis`] (the default): the pole is the fiber axis, cells are uniform in
//!   `(sinθ, φ)`, and expected counts integrate `pdf` over each cell in the θ variable
//!   (`dω = cosθ dθ dφ`, a smooth integrand even where the pdf has a `1/cosθ` factor), with
//!   `sub × sub` midpoint nodes (more in θ near the poles).
//! * [`Pole::Normal`]: the pole is the fiber's normal `w` (local z), as in a renderer's
//!   shading frame (Mitsuba's `SphericalDomain` over its hair frame), so the fiber axis lies
//!   on the grid's equator inside a cell; expected counts are the plain `sub × sub` midpoint
//!   rule in that cell's own coordinates. A pdf that grows like `1/cosθ` toward the fiber
//!   axis is integrable but not resolved by such a rule: this grid is how a peer's harness
//!   sees it, and how the check finds it.
//!
//! Cells expecting fewer than [`CHI2_MIN_EXPECTED`] samples are pooled into one; a sample in
//! a cell with zero expected mass fails the test outright.

use crate::rng::TestRng;
use crate::tolerance::{CHI2_MIN_EXPECTED, CHI2_QUADRATURE_SIGMAS, ROUNDING_REL};
use fiberlab_math::DVec3;
use fiberlab_math::frame::{direction_from_sin_cos, phi, sin_theta};
use fiberlab_scatter::ScatteringFunction;
use statrs::distribution::{ChiSquared, ContinuousCDF};
use std::f64::consts::{PI, TAU};

/// The pole of a χ² grid (module documentation).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Pole {
    /// Cells uniform in `(sinθ, φ)` about the fiber axis, integrated in θ.
    #[default]
    FiberAxis,
    /// Cells uniform in `(ω·w, atan2(ω·v, ω·u))` about the fiber normal `w`, integrated by the
    /// plain midpoint rule in those coordinates.
    Normal,
}

/// Settings of one χ² test.
#[derive(Clone, Copy, Debug)]
pub struct Chi2Config {
    /// Cells in the cosine of the polar angle (`sinθ` for [`Pole::FiberAxis`]).
    pub bins_theta: usize,
    /// Cells in the azimuth about the pole.
    pub bins_phi: usize,
    /// Midpoint nodes per cell side for the expected counts (and twice as many for the
    /// estimate of their error).
    pub sub: usize,
    /// Number of `sample()` calls.
    pub samples: usize,
    /// Seed of the sample stream.
    pub seed: u64,
    /// The grid's pole.
    pub pole: Pole,
}

impl Default for Chi2Config {
    fn default() -> Self {
        Self { bins_theta: 48, bins_phi: 96, sub: 6, samples: 1_000_000, seed: 1, pole: Pole::FiberAxis }
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
    /// Cells whose expected mass could not be resolved and went to the remainder cell.
    pub untrusted: usize,
    /// Expected mass of those cells (the fraction of the distribution the χ² cannot see
    /// cell by cell).
    pub untrusted_mass: f64,
    /// `∫ pdf dω` over the sphere by the cell quadrature (the finer of the two rules); the
    /// remainder cell tests `1 − Σ` trusted masses, so this should be 1.
    pub pdf_integral: f64,
}

impl Chi2Outcome {
    /// True when the test does not reject at significance `alpha`.
    #[must_use]
    pub fn passes(&self, alpha: f64) -> bool {
        self.impossible == 0 && self.p_value >= alpha
    }
}

/// The grid coordinates of `w`: the cosine of its polar angle and its azimuth about the pole.
fn grid_coordinates(pole: Pole, w: DVec3) -> (f64, f64) {
    match pole {
        Pole::FiberAxis => (sin_theta(w), phi(w)),
        Pole::Normal => (w.z.clamp(-1.0, 1.0), w.y.atan2(w.x)),
    }
}

/// The direction at grid coordinates `(z, φ)` with `sin` of the polar angle `s = √(1 − z²)`.
fn grid_direction(pole: Pole, z: f64, s: f64, p: f64) -> DVec3 {
    match pole {
        Pole::FiberAxis => direction_from_sin_cos(z, s, p),
        Pole::Normal => {
            let (sp, cp) = p.sin_cos();
            DVec3::new(s * cp, s * sp, z)
        }
    }
}

fn cell_of(cfg: &Chi2Config, w: DVec3) -> usize {
    let (z, p) = grid_coordinates(cfg.pole, w);
    let u = ((z + 1.0) * 0.5 * cfg.bins_theta as f64) as usize;
    let p = ((p + PI) / TAU * cfg.bins_phi as f64) as usize;
    u.min(cfg.bins_theta - 1) * cfg.bins_phi + p.min(cfg.bins_phi - 1)
}

/// Expected probability of every cell: `∫_cell pdf dω`.
pub fn expected_masses(f: &impl ScatteringFunction, wo: DVec3, h: f64, cfg: &Chi2Config) -> Vec<f64> {
    masses_with(f, wo, h, cfg, cfg.sub)
}

/// [`expected_masses`] with `sub` midpoint nodes per cell side.
fn masses_with(f: &impl ScatteringFunction, wo: DVec3, h: f64, cfg: &Chi2Config, sub: usize) -> Vec<f64> {
    if cfg.pole == Pole::Normal {
        return plain_masses(f, wo, h, cfg, sub);
    }
    let mut mass = vec![0.0; cfg.bins_theta * cfg.bins_phi];
    let dp = TAU / cfg.bins_phi as f64;
    for i in 0..cfg.bins_theta {
        let ua = -1.0 + 2.0 * i as f64 / cfg.bins_theta as f64;
        let ub = -1.0 + 2.0 * (i + 1) as f64 / cfg.bins_theta as f64;
        let (ta, tb) = (ua.clamp(-1.0, 1.0).asin(), ub.clamp(-1.0, 1.0).asin());
        // Cells near the poles are wide in θ: keep the θ spacing of the nodes that of the
        // equatorial cells.
        let equatorial = 2.0 / cfg.bins_theta as f64;
        let sub_theta = ((sub as f64 * (tb - ta) / equatorial).ceil() as usize).max(sub);
        let dt = (tb - ta) / sub_theta as f64;
        for j in 0..cfg.bins_phi {
            let mut m = 0.0;
            for a in 0..sub_theta {
                let t = ta + (a as f64 + 0.5) * dt;
                let (s, c) = t.sin_cos();
                for b in 0..sub {
                    let p = -PI + (j as f64 + (b as f64 + 0.5) / sub as f64) * dp;
                    m += f.pdf(direction_from_sin_cos(s, c, p), wo, h) * c;
                }
            }
            mass[i * cfg.bins_phi + j] = m * dt * dp / sub as f64;
        }
    }
    mass
}

/// Cell masses by the plain `sub × sub` midpoint rule in the grid's coordinates
/// (`dω = dz dφ`), [`Pole::Normal`].
fn plain_masses(f: &impl ScatteringFunction, wo: DVec3, h: f64, cfg: &Chi2Config, sub: usize) -> Vec<f64> {
    let mut mass = vec![0.0; cfg.bins_theta * cfg.bins_phi];
    let (dz, dp) = (2.0 / cfg.bins_theta as f64, TAU / cfg.bins_phi as f64);
    for i in 0..cfg.bins_theta {
        for j in 0..cfg.bins_phi {
            let mut m = 0.0;
            for a in 0..sub {
                let z = -1.0 + (i as f64 + (a as f64 + 0.5) / sub as f64) * dz;
                let s = (1.0 - z * z).max(0.0).sqrt();
                for b in 0..sub {
                    let p = -PI + (j as f64 + (b as f64 + 0.5) / sub as f64) * dp;
                    m += f.pdf(grid_direction(cfg.pole, z, s, p), wo, h);
                }
            }
            mass[i * cfg.bins_phi + j] = m * dz * dp / (sub * sub) as f64;
        }
    }
    mass
}

/// Runs the χ² test of `f.sample(wo, h, ·)` against `f.pdf(·, wo, h)`.
///
/// Expected masses are integrated twice (`sub` and `2·sub` nodes per side). Cells where the
/// two disagree by more than [`CHI2_QUADRATURE_SIGMAS`] of the cell's Poisson deviation (an
/// unresolved integrable singularity, such as Marschner's TRT caustic without glints) are
/// not trusted individually: they are pooled with any sampler failures into one remainder
/// cell whose expected mass is `1 − Σ` trusted masses (or, where that is smaller, the
/// untrusted cells' own quadrature), so the total (checked separately by `∫ pdf dω = 1`) is
/// still tested.
pub fn chi2_test(f: &impl ScatteringFunction, wo: DVec3, h: f64, cfg: &Chi2Config) -> Chi2Outcome {
    let coarse = masses_with(f, wo, h, cfg, cfg.sub);
    let fine = masses_with(f, wo, h, cfg, 2 * cfg.sub);
    let n = cfg.samples as f64;
    let trusted: Vec<bool> = coarse
        .iter()
        .zip(&fine)
        .map(|(&a, &b)| (a - b).abs() * n <= CHI2_QUADRATURE_SIGMAS * (b * n).sqrt() + 1e-9)
        .collect();
    let mut observed = vec![0u64; fine.len()];
    let mut rng = TestRng::new(cfg.seed);
    let mut failures = 0;
    for _ in 0..cfg.samples {
        match f.sample(wo, h, rng.u4()) {
            Some(s) => observed[cell_of(cfg, s.wi)] += 1,
            None => failures += 1,
        }
    }
    let (mut stat, mut cells, mut impossible, mut untrusted) = (0.0, 0usize, 0usize, 0usize);
    let (mut pooled_obs, mut pooled_exp) = (0.0, 0.0);
    let (mut rest_obs, mut trusted_mass, mut untrusted_mass) = (failures as f64, 0.0, 0.0);
    for ((&m, &o), &ok) in fine.iter().zip(&observed).zip(&trusted) {
        if !ok {
            rest_obs += o as f64;
            untrusted += 1;
            untrusted_mass += m;
            continue;
        }
        trusted_mass += m;
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
    // The remainder: untrusted cells and sampler failures against 1 − Σ trusted masses, or
    // against the untrusted cells' own quadrature where the trusted cells' rounding and
    // quadrature errors (≈ 1e−4) leave less than that (else a remainder of a few samples
    // would be compared with an expectation of 0).
    let rest_exp = (1.0 - trusted_mass).max(untrusted_mass).max(0.0) * n;
    if rest_obs > 0.0 || rest_exp >= CHI2_MIN_EXPECTED {
        let e = rest_exp.max(1e-300);
        stat += (rest_obs - e).powi(2) / e;
        cells += 1;
    }
    let (dof, p_value) = upper_tail(stat, cells);
    Chi2Outcome {
        statistic: stat,
        dof,
        p_value,
        impossible,
        failures,
        untrusted,
        untrusted_mass,
        pdf_integral: fine.iter().sum(),
    }
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
    let mut rng = TestRng::new(seed);
    let (mut failures, mut off_cone) = (0, 0);
    for _ in 0..samples {
        match f.sample(wo, 0.0, rng.u4()) {
            Some(s) => {
                if (s.wi.x + wo.x).abs() > ROUNDING_REL {
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
    let (dof, p_value) = upper_tail(stat, cells);
    Chi2Outcome {
        statistic: stat,
        dof,
        p_value,
        impossible,
        failures,
        untrusted: 0,
        untrusted_mass: 0.0,
        pdf_integral: mass.iter().sum(),
    }
}

/// Degrees of freedom (`cells − 1`, at least 1) and the probability that a χ² variable of
/// them exceeds `stat`.
fn upper_tail(stat: f64, cells: usize) -> (usize, f64) {
    let dof = cells.saturating_sub(1).max(1);
    (dof, ChiSquared::new(dof as f64).map(|d| 1.0 - d.cdf(stat)).unwrap_or(0.0))
}
