//! What is fitted to: one measured number of `f_s` at a pair of directions, in luminance or one
//! colour channel — from a fiber table (bin centres), a surface table (bins), a user's CSV, or
//! another model on a fixed grid of directions.

use crate::outcome::FitError;
use fiberlab_io::table::LobeSlices;
use fiberlab_math::frame::direction;
use fiberlab_math::{DVec3, Rgb};
use fiberlab_scatter::{Model, ScatteringFunction};
use std::path::Path;

/// What an observation measures of `f_s`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Channel {
    /// Its Rec. 709 luminance.
    #[default]
    Luminance,
    /// One colour channel: 0 red, 1 green, 2 blue.
    Rgb(usize),
}

impl Channel {
    /// This channel of a colour.
    #[must_use]
    pub fn of(self, f: Rgb) -> f64 {
        match self {
            Channel::Luminance => f.luminance(),
            Channel::Rgb(c) => f[c.min(2)],
        }
    }
}

/// One measured value.
#[derive(Clone, Copy, Debug)]
pub struct Observation {
    /// Direction toward the light (fiber frame).
    pub wi: DVec3,
    /// Direction toward the viewer (fiber frame).
    pub wo: DVec3,
    /// Measured `f_s` (sr⁻¹) in `channel`.
    pub value: f64,
    /// Its standard error (> 0).
    pub sigma: f64,
    /// What of `f_s` was measured.
    pub channel: Channel,
}

/// The grid on which a model is fitted to another model: θ_i and θ_r every 10° in
/// [−80°, 80°], relative azimuth every 15°, each pair with the weight `sqrt(cosθ_i cosθ_r)`
/// of a `cosθ_i cosθ_r`-weighted fit (σ ∝ 1/weight).
#[must_use]
pub fn model_grid() -> Vec<(DVec3, DVec3, f64)> {
    let mut grid = Vec::with_capacity(17 * 17 * 24);
    for i in 0..17 {
        for r in 0..17 {
            for j in 0..24 {
                let (ti, tr) = (f64::to_radians(-80.0 + 10.0 * i as f64), f64::to_radians(-80.0 + 10.0 * r as f64));
                let (wi, wo) = (direction(ti, 0.0), direction(tr, f64::to_radians(-172.5 + 15.0 * j as f64)));
                grid.push((wi, wo, (ti.cos() * tr.cos()).sqrt()));
            }
        }
    }
    grid
}

/// The channels an observation of colour data is split into: the luminance alone, or r, g, b.
pub fn channels(per_channel: bool) -> Vec<Channel> {
    if per_channel { (0..3).map(Channel::Rgb).collect() } else { vec![Channel::Luminance] }
}

/// Observations from a table lobe: bin centres, values (per channel or luminance), standard
/// errors with a floor (empty bins have no spread: 1 % of the largest value).
#[must_use]
pub fn from_fiber_table(t: &LobeSlices, per_channel: bool) -> Vec<Observation> {
    let (nt, np) = (t.bins_theta, t.bins_phi);
    let peak = t.f.iter().flatten().map(|v| v.luminance()).fold(0.0, f64::max);
    let mut obs = Vec::new();
    for s in 0..t.theta_in.len() {
        let wi = direction(t.theta_in[s], t.phi_in[s]);
        for b in 0..nt * np {
            let tr = -std::f64::consts::FRAC_PI_2 + ((b / np) as f64 + 0.5) * std::f64::consts::PI / nt as f64;
            let p = -std::f64::consts::PI + ((b % np) as f64 + 0.5) * std::f64::consts::TAU / np as f64;
            for channel in channels(per_channel) {
                obs.push(Observation {
                    wi,
                    wo: direction(tr, t.phi_in[s] + p),
                    value: channel.of(t.f[s][b]),
                    sigma: channel.of(t.std[s][b]).max(0.01 * peak),
                    channel,
                });
            }
        }
    }
    obs
}

/// The σ of a surface-table bin no path reached (which has no spread): the median of the
/// positive standard errors of the lobe (about one path's contribution to a bin), or 1 % of
/// the peak if none is positive. A floor relative to the peak (as for fiber tables) would
/// drown a cloth's diffuse bins under a sharp highlight, and the smallest σ (one weak path)
/// would give an empty bin all the weight.
#[must_use]
pub fn std_floor(t: &LobeSlices) -> f64 {
    let mut spread: Vec<f64> = t.std.iter().flatten().flat_map(|v| [v[0], v[1], v[2]]).filter(|&v| v > 0.0).collect();
    spread.sort_by(f64::total_cmp);
    let peak = t.f.iter().flatten().map(|v| v.luminance()).fold(0.0, f64::max);
    spread.get(spread.len() / 2).copied().unwrap_or(0.01 * peak)
}

/// Observations of a target model on a 10° (θ_i, θ_r) × 15° φ grid, weighted by
/// cosθ_i cosθ_r: σ = s/sqrt(cosθ_i cosθ_r) with s the grid's mean value; luminances, or
/// per channel when `per_channel` (each channel's σ from its own mean).
#[must_use]
pub fn from_model(model: &Model, per_channel: bool) -> Vec<Observation> {
    let mut obs = Vec::new();
    for (wi, wo, weight) in model_grid() {
        let f = model.eval_far(wi, wo);
        for channel in channels(per_channel) {
            obs.push(Observation { wi, wo, value: channel.of(f), sigma: 1.0 / weight, channel });
        }
    }
    for channel in channels(per_channel) {
        let of_channel = || obs.iter().filter(|o| o.channel == channel);
        let mean = of_channel().map(|o| o.value).sum::<f64>() / of_channel().count() as f64;
        obs.iter_mut().filter(|o| o.channel == channel).for_each(|o| o.sigma *= mean.max(1e-12));
    }
    obs
}

/// The angle columns of a CSV and the range each must lie in (degrees).
const ANGLE_RANGES: [(&str, f64, f64); 4] =
    [("theta_i", -90.0, 90.0), ("phi_i", -360.0, 360.0), ("theta_r", -90.0, 90.0), ("phi_r", -360.0, 360.0)];

/// A user's CSV: `value` (luminance) or `f_r,f_g,f_b` (per channel, or their luminance when
/// `per_channel` is false), with optional standard errors `std` / `std_r,std_g,std_b`
/// (default 5 % of the value). `text` is the file's content, `path` names it in errors, which
/// give the line and column.
pub fn from_csv(text: &str, path: &Path, per_channel: bool) -> Result<Vec<Observation>, FitError> {
    let mut r = csv::ReaderBuilder::new().trim(csv::Trim::All).from_reader(text.as_bytes());
    let header = r.headers().map_err(|e| FitError::Data(format!("{}: {e}", path.display())))?.clone();
    let col = |c: &str| header.iter().position(|h| h == c);
    let required =
        |c: &str| col(c).ok_or_else(|| FitError::Data(format!("{}: line 1: missing column `{c}`", path.display())));
    let angles: Vec<usize> = ANGLE_RANGES.iter().map(|(c, _, _)| required(c)).collect::<Result<_, _>>()?;
    let rgb_cols: Option<Vec<usize>> = ["f_r", "f_g", "f_b"].iter().map(|c| col(c)).collect();
    // Value columns with their standard-error columns, and the channel each measures.
    let values: Vec<(usize, Option<usize>, Channel)> = match rgb_cols {
        Some(v) => {
            let std: Vec<Option<usize>> = ["std_r", "std_g", "std_b"].iter().map(|c| col(c)).collect();
            (0..3).map(|c| (v[c], std[c], Channel::Rgb(c))).collect()
        }
        None => vec![(required("value")?, col("std"), Channel::Luminance)],
    };
    let mut obs = Vec::new();
    for rec in r.records() {
        let rec = rec.map_err(|e| FitError::Data(format!("{}: {e}", path.display())))?;
        let line = rec.position().map_or(0, |p| p.line());
        let num = |i: usize| -> Result<f64, FitError> {
            let t = rec.get(i).unwrap_or("");
            t.parse::<f64>().ok().filter(|v| v.is_finite()).ok_or_else(|| {
                FitError::Data(format!(
                    "{}: line {line}, column {} (`{}`): expected a finite number, got `{t}`",
                    path.display(),
                    i + 1,
                    &header[i]
                ))
            })
        };
        let mut a = [0.0; 4];
        for (k, (&i, (name, lo, hi))) in angles.iter().zip(ANGLE_RANGES).enumerate() {
            a[k] = num(i)?;
            if !(lo..=hi).contains(&a[k]) {
                return Err(FitError::Data(format!(
                    "{}: line {line}, column {} (`{name}`): {:?} degrees is outside [{lo}, {hi}]",
                    path.display(),
                    i + 1,
                    a[k]
                )));
            }
        }
        let (wi, wo) =
            (direction(a[0].to_radians(), a[1].to_radians()), direction(a[2].to_radians(), a[3].to_radians()));
        let mut row = Vec::new();
        for &(i, std, channel) in &values {
            let value = num(i)?;
            let sigma = match std {
                Some(s) => num(s)?,
                None => 0.05 * value.abs().max(1e-6),
            };
            if sigma <= 0.0 {
                return Err(FitError::Data(format!(
                    "{}: line {line}, column {}: std must be positive",
                    path.display(),
                    std.map_or(0, |s| s + 1)
                )));
            }
            row.push(Observation { wi, wo, value, sigma, channel });
        }
        if row.len() == 3 && !per_channel {
            // Luminance of the channels, σ by propagation of independent errors.
            let weights = fiberlab_math::spectrum::LUMINANCE_WEIGHTS;
            let value = (0..3).map(|c| weights[c] * row[c].value).sum();
            let sigma = (0..3).map(|c| (weights[c] * row[c].sigma).powi(2)).sum::<f64>().sqrt();
            row = vec![Observation { wi, wo, value, sigma, channel: Channel::Luminance }];
        }
        obs.extend(row);
    }
    Ok(obs)
}
