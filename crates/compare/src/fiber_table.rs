//! A fiber model against a measured fiber table (`fiberlab measure`), lobe by lobe: the model
//! averaged over each bin as the table's values are, the relative L2 error in the bins'
//! `cos²θ_r dθ_r dφ` measure, the table's own Monte Carlo relative L2 (what a perfect model
//! would score on average), the peaks, and the difference as a map.
//!
//! # Formula
//! Per incidence, `rel L2 = sqrt(Σ w_b (m_b − t_b)² / Σ w_b t_b²)` and
//! `MC rel L2 = sqrt(Σ w_b σ_b² / Σ w_b t_b²)`, where `m_b` is the model's bin average of the
//! width-averaged `f_s` ([`fiberlab_scatter::ScatteringFunction::eval_far`]), `t_b` the table's
//! value, `σ_b` its standard error and `w_b = ∫_bin cos²θ_r dθ_r` (luminance throughout). Over
//! several incidences the sums are pooled.

use crate::CompareError;
use crate::maps::{ScatteringMap, table_map};
use fiberlab_io::table::LobeSlices;
use fiberlab_math::frame::direction;
use fiberlab_render::model_loader::ModelRequest;
use fiberlab_scatter::{Model, ScatteringFunction};
use rayon::prelude::*;
use serde::Serialize;
use std::collections::BTreeMap;
use std::f64::consts::{FRAC_PI_2, PI, TAU};

/// The measured lobes compared, and the model's `lobes=` value for each (`None`: the whole
/// model).
pub const LOBES: [(&str, Option<&str>); 5] =
    [("r", Some("r")), ("tt", Some("tt")), ("trt", Some("trt")), ("medulla", Some("tts,trts")), ("all", None)];

/// Midpoint sub-samples per bin along φ (azimuthal lobes are wide; θ_r takes `subsamples`).
pub const PHI_SUBSAMPLES: usize = 3;

/// One incidence of one lobe.
#[derive(Clone, Debug, Serialize)]
pub struct IncidenceComparison {
    /// Light inclination, degrees.
    pub theta_i: f64,
    /// Light azimuth, degrees.
    pub phi_i: f64,
    /// Relative L2 error of the model (NaN when the measured lobe is zero).
    pub rel_l2: f64,
    /// The table's Monte Carlo relative L2.
    pub mc_rel_l2: f64,
    /// The highest measured bin: `[θ_r°, φ°, f]`.
    pub peak_measured: [f64; 3],
    /// The model's highest bin: `[θ_r°, φ°, f]`.
    pub peak_model: [f64; 3],
    /// `|model − measured|` over the bins.
    #[serde(skip)]
    pub difference: ScatteringMap,
    /// `Σ w (m − t)²`, `Σ w t²`, `Σ w σ²`, for pooling.
    #[serde(skip)]
    sums: [f64; 3],
}

/// One lobe over every incidence of the table.
#[derive(Clone, Debug, Serialize)]
pub struct LobeComparison {
    /// The lobe's name in the table (`r`, `tt`, `trt`, `medulla`, `all`).
    #[serde(skip)]
    pub lobe: String,
    /// Pooled over the incidences.
    pub rel_l2: f64,
    /// Pooled Monte Carlo relative L2.
    pub mc_rel_l2: f64,
    /// The highest measured bin over all incidences.
    pub peak_measured: [f64; 3],
    /// The model's highest bin over all incidences.
    pub peak_model: [f64; 3],
    /// Per incidence.
    pub per_theta_i: Vec<IncidenceComparison>,
}

/// The bin-averaged, width-averaged model `f_s` (luminance) over a fiber table's `nt × np`
/// bins for light at `(theta_i, phi_i)`: `sub` midpoint nodes in θ_r weighted by `cos²θ_r`,
/// [`PHI_SUBSAMPLES`] in φ.
#[must_use]
pub fn bin_averages(model: &Model, theta_i: f64, phi_i: f64, nt: usize, np: usize, sub: usize) -> Vec<f64> {
    let wi = direction(theta_i, phi_i);
    let sub = sub.max(1);
    (0..nt * np)
        .into_par_iter()
        .map(|b| {
            let (i, j) = (b / np, b % np);
            let (mut num, mut den) = (0.0, 0.0);
            for a in 0..sub {
                let tr = -FRAC_PI_2 + (i as f64 + (a as f64 + 0.5) / sub as f64) * PI / nt as f64;
                let w = tr.cos().powi(2);
                for c in 0..PHI_SUBSAMPLES {
                    let p = -PI + (j as f64 + (c as f64 + 0.5) / PHI_SUBSAMPLES as f64) * TAU / np as f64;
                    num += model.eval_far(wi, direction(tr, phi_i + p)).luminance() * w;
                    den += w;
                }
            }
            num / den
        })
        .collect()
}

/// `∫ cos²θ dθ` over θ-row `i` of `nt` rows over [−π/2, π/2]: a bin's weight in the L2 sums.
fn row_weight(i: usize, nt: usize) -> f64 {
    let a = -FRAC_PI_2 + i as f64 * PI / nt as f64;
    let primitive = |x: f64| 0.5 * x + 0.25 * (2.0 * x).sin();
    primitive(a + PI / nt as f64) - primitive(a)
}

/// Compares `model` with incidence `s` of a table lobe.
#[must_use]
pub fn compare_incidence(model: &Model, t: &LobeSlices, s: usize, sub: usize) -> IncidenceComparison {
    let (nt, np) = (t.bins_theta, t.bins_phi);
    let modelled = bin_averages(model, t.theta_in[s], t.phi_in[s], nt, np, sub);
    let measured: Vec<f64> = t.f[s].iter().map(|v| v.luminance()).collect();
    let std: Vec<f64> = t.std[s].iter().map(|v| v.luminance()).collect();
    let mut sums = [0.0; 3];
    for b in 0..nt * np {
        let w = row_weight(b / np, nt);
        sums[0] += w * (modelled[b] - measured[b]).powi(2);
        sums[1] += w * measured[b].powi(2);
        sums[2] += w * std[b].powi(2);
    }
    let peak = |v: &[f64]| {
        let b = (0..v.len()).max_by(|&a, &b| v[a].total_cmp(&v[b])).unwrap_or(0);
        let theta = (-FRAC_PI_2 + ((b / np) as f64 + 0.5) * PI / nt as f64).to_degrees();
        let phi = (-PI + ((b % np) as f64 + 0.5) * TAU / np as f64).to_degrees();
        [theta, phi, v.get(b).copied().unwrap_or(0.0)]
    };
    let difference: Vec<f64> = modelled.iter().zip(&measured).map(|(m, t)| (m - t).abs()).collect();
    IncidenceComparison {
        theta_i: t.theta_in[s].to_degrees(),
        phi_i: t.phi_in[s].to_degrees(),
        rel_l2: relative(sums[0], sums[1]),
        mc_rel_l2: relative(sums[2], sums[1]),
        peak_measured: peak(&measured),
        peak_model: peak(&modelled),
        difference: table_map(&difference, nt, np, t.theta_in[s]),
        sums,
    }
}

/// `sqrt(num/den)`, NaN when `den` is zero.
fn relative(num: f64, den: f64) -> f64 {
    if den > 0.0 { (num / den).sqrt() } else { f64::NAN }
}

/// Compares the model of `request` with every lobe of a fiber table that both have ([`LOBES`]:
/// the model reduced to the lobe through its `lobes` parameter; lobes the table or the model
/// lacks are left out), `subsamples` nodes per bin in θ_r.
pub fn compare_fiber_table(
    table: &BTreeMap<String, LobeSlices>,
    request: &ModelRequest,
    subsamples: usize,
) -> Result<Vec<LobeComparison>, CompareError> {
    let mut out = Vec::new();
    for (lobe, model_lobes) in LOBES {
        let Some(slices) = table.get(lobe) else { continue };
        let model = match model_lobes {
            None => request.build()?,
            Some(names) => match request.build_lobes(names)? {
                Some(m) => m,
                None => continue,
            },
        };
        let rows: Vec<IncidenceComparison> =
            (0..slices.theta_in.len()).map(|s| compare_incidence(&model, slices, s, subsamples)).collect();
        out.push(pooled(lobe, rows));
    }
    Ok(out)
}

/// One lobe's rows pooled over the incidences.
fn pooled(lobe: &str, rows: Vec<IncidenceComparison>) -> LobeComparison {
    let sum = |k: usize| rows.iter().map(|r| r.sums[k]).sum::<f64>();
    let highest = |peak: fn(&IncidenceComparison) -> [f64; 3]| {
        rows.iter().map(peak).max_by(|a, b| a[2].total_cmp(&b[2])).unwrap_or([f64::NAN; 3])
    };
    LobeComparison {
        lobe: lobe.to_string(),
        rel_l2: relative(sum(0), sum(1)),
        mc_rel_l2: relative(sum(2), sum(1)),
        peak_measured: highest(|r| r.peak_measured),
        peak_model: highest(|r| r.peak_model),
        per_theta_i: rows,
    }
}
