//! A fiber model against a measurement of the explicit fiber, lobe by lobe: the model's far
//! field averaged over each bin of the [`Measurement`], its albedo per lobe, and the relative
//! L2 distance from the measured table with the distance its Monte Carlo error alone gives.
//!
//! The goniophotometer measures the fraction of the power intercepted from `ω_i` that leaves
//! into a bin (`docs/theory/radiometry.md`, "Non-circular fibers"); a model's `f_s` is the
//! radiance form, averaged over the viewer's projected width. For a fixed orientation the two
//! differ by the widths: `f_measured(ω_i → ω_r) = f_s(ω_i, ω_r)·W(ω_r)/W(ω_i)` (1 for a circle;
//! for random orientations both average over the same assembly and agree as they are).

use crate::{Fiber, Measurement, Orientation};
use fiberlab_math::frame::direction;
use fiberlab_math::{DVec2, Rgb};
use fiberlab_scatter::hair::ellipse::Ellipse;
use fiberlab_scatter::{Field, ScatteringFunction};
use rayon::prelude::*;
use std::f64::consts::{FRAC_PI_2, PI, TAU};

/// One lobe of the comparison.
#[derive(Clone, Debug)]
pub struct LobeComparison {
    /// Measured class (`r`, `tt`, `trt`, `higher`, `all`).
    pub lobe: &'static str,
    /// Its measured albedo (luminance).
    pub measured_albedo: f64,
    /// The model's (luminance, from the bins).
    pub model_albedo: f64,
    /// `‖model − measured‖/‖measured‖` over the bins (cosθ dω-weighted, all channels).
    pub rel_l2: f64,
    /// `‖σ‖/‖measured‖`: what a perfect model would get on average.
    pub mc_rel_l2: f64,
}

/// How finely the model is averaged over a bin.
#[derive(Clone, Copy, Debug)]
pub struct BinAverage {
    /// Midpoint nodes per bin in θ_r and in φ.
    pub sub: usize,
    /// Offsets h per node for a near-field model (midpoints of [−1, 1]).
    pub offsets: usize,
}

/// The model's lobes per bin (`[R, TT, TRT, rest]` as `eval_lobes` orders them, or the whole
/// model in `all` when it does not separate them), power form, `[θ][φ]`.
fn model_bins(m: &Measurement, fiber: &Fiber, model: &impl ScatteringFunction, avg: BinAverage) -> Vec<[Rgb; 5]> {
    let s = &m.setup;
    let (nt, np) = (s.bins_theta, s.bins_phi);
    let wi = direction(s.theta_i, s.phi_i);
    let width = |phi: f64| match fiber.orientation {
        Orientation::Fixed(psi) => Ellipse::new(fiber.aspect, psi).half_width(DVec2::new(phi.cos(), phi.sin())),
        Orientation::Average => 1.0,
    };
    let w_i = width(s.phi_i);
    let near = model.properties().field == Field::Near;
    let n_h = if near { avg.offsets.max(1) } else { 1 };
    let n_lobes = model.lobes().len();
    (0..nt * np)
        .into_par_iter()
        .map(|b| {
            let (i, j) = (b / np, b % np);
            let mut acc = [Rgb::ZERO; 5];
            let mut out = [Rgb::ZERO; 4];
            let mut weights = 0.0;
            for a in 0..avg.sub {
                let tr = -FRAC_PI_2 + (i as f64 + (a as f64 + 0.5) / avg.sub as f64) * PI / nt as f64;
                let c = tr.cos();
                for k in 0..avg.sub {
                    let rel = -PI + (j as f64 + (k as f64 + 0.5) / avg.sub as f64) * TAU / np as f64;
                    let wr = direction(tr, s.phi_i + rel);
                    let to_power = c * width(s.phi_i + rel) / w_i / n_h as f64;
                    for q in 0..n_h {
                        let h = if near { -1.0 + (q as f64 + 0.5) * 2.0 / n_h as f64 } else { 0.0 };
                        if n_lobes == 4 && model.eval_lobes(wi, wr, h, &mut out) {
                            for l in 0..4 {
                                acc[l] += out[l] * to_power;
                                acc[4] += out[l] * to_power;
                            }
                        } else {
                            acc[4] += model.eval(wi, wr, h) * to_power;
                        }
                    }
                    weights += c;
                }
            }
            acc.map(|x| x / weights)
        })
        .collect()
}

/// Compares `model` with the measurement `m` of `fiber`: the classes `r`, `tt`, `trt`,
/// `higher` against the model's four lobes (when it separates them) and `all` against the
/// whole model.
pub fn compare_lobes(
    m: &Measurement,
    fiber: &Fiber,
    model: &impl ScatteringFunction,
    avg: BinAverage,
) -> Vec<LobeComparison> {
    let bins = model_bins(m, fiber, model, avg);
    let (nt, np) = (m.setup.bins_theta, m.setup.bins_phi);
    let prim = |x: f64| 0.5 * x + 0.25 * (2.0 * x).sin();
    let omega = |i: usize| {
        let a = -FRAC_PI_2 + i as f64 * PI / nt as f64;
        (prim(a + PI / nt as f64) - prim(a)) * TAU / np as f64
    };
    let separated = model.lobes().len() == 4;
    ["r", "tt", "trt", "higher", "all"]
        .iter()
        .enumerate()
        .filter(|&(l, _)| separated || l == 4)
        .map(|(l, &lobe)| {
            let t = m.lobe(lobe).expect("a measured class");
            let (mut num, mut den, mut mc, mut albedo) = (0.0, 0.0, 0.0, 0.0);
            for i in 0..nt {
                let w = omega(i);
                for j in 0..np {
                    let (f, sd, g) = (t.f[i * np + j], t.std[i * np + j], bins[i * np + j][l]);
                    for c in 0..3 {
                        num += (g[c] - f[c]).powi(2) * w;
                        den += f[c] * f[c] * w;
                        mc += sd[c] * sd[c] * w;
                    }
                    albedo += g.luminance() * w;
                }
            }
            LobeComparison {
                lobe,
                measured_albedo: t.albedo.luminance(),
                model_albedo: albedo,
                rel_l2: (num / den).sqrt(),
                mc_rel_l2: (mc / den).sqrt(),
            }
        })
        .collect()
}
