//! A surface model against a measured surface table (`fiberlab measure --surface`, the woven
//! patch's table), in one of two ways:
//!
//! * **Fiber highlight** — a surface whose shine comes from fibers under a finish
//!   ([`fiberlab_scatter::FiberHighlight`], wood) against the table's `fiber` class
//!   (single-fiber paths), its fiber term alone: the highlight's locus (per φ_o column, the θ_o
//!   of the peak), its width (energy-weighted RMS of ψ_h = ψ_i′ + ψ_o′ over the bins) and its
//!   strength (albedo of the class), each against [`SURFACE_TOLERANCES`].
//! * **Residual** — any other surface model against the table's `all` class (a cloth's BRDF as
//!   a whole): the model averaged over each bin as `fiberlab fit` does, the per-bin RMS of
//!   model − measured (weighted by the bins' `cosθ dω`), the relative L2 error (and the table's
//!   own Monte Carlo relative L2), the worst bins by |model − measured|/σ, and the slices
//!   through the plane of incidence and across it.

use crate::CompareError;
use fiberlab_fit::observation::std_floor;
use fiberlab_io::table::LobeSlices;
use fiberlab_math::DVec3;
use fiberlab_math::frame::wrap_pi;
use fiberlab_render::model_loader::ModelRequest;
use fiberlab_scatter::{FiberHighlight, SurfaceModel, SurfaceScattering};
use rayon::prelude::*;
use serde::Serialize;
use std::collections::BTreeMap;
use std::f64::consts::{FRAC_PI_2, PI, TAU};

/// Tolerances of the highlight comparison: the locus within this many θ_o bins in every column,
/// the RMS width of ψ_h within this many θ_o bins, the strength (albedo of the `fiber` class)
/// within this relative error.
pub const SURFACE_TOLERANCES: (f64, f64, f64) = (1.0, 1.0, 0.25);

/// Fraction of the highest column's energy below which a column's peak is not located.
const COLUMN_THRESHOLD: f64 = 0.05;

/// Midpoint sub-samples per bin along φ_o (θ_o takes the caller's `subsamples`).
const PHI_SUBSAMPLES: usize = 3;

/// Most bins listed as the worst of an incidence.
pub const WORST_BINS: usize = 5;

/// The result of comparing a surface model with a surface table.
#[derive(Clone, Debug)]
pub enum SurfaceComparison {
    /// A fiber highlight against the `fiber` class.
    Highlight(Vec<HighlightComparison>),
    /// A residual against the `all` class.
    Residual(Vec<ResidualComparison>),
}

/// One incidence of a highlight comparison.
#[derive(Clone, Debug)]
pub struct HighlightComparison {
    /// Light inclination and azimuth, radians.
    pub theta_i: f64,
    /// Light azimuth, radians.
    pub phi_i: f64,
    /// Per column with enough energy: (φ_o°, measured peak θ_o°, model peak θ_o°).
    pub locus: Vec<(f64, f64, f64)>,
    /// RMS ψ_h (degrees), measured and model.
    pub width: (f64, f64),
    /// Albedo of the class: measured, its standard error, model.
    pub strength: (f64, f64, f64),
    /// The column through φ_i + 180°: (φ_o°, θ_o° bin centres, measured, std, model).
    pub profile: (f64, Vec<f64>, Vec<f64>, Vec<f64>, Vec<f64>),
    /// Height of a θ_o bin, degrees.
    pub bin_degrees: f64,
    /// The model's fiber strength `k_f` (luminance).
    pub k_f: f64,
}

impl HighlightComparison {
    /// Largest `|θ_peak measured − θ_peak model|` over the columns, in units of the extent of
    /// the bin the model's locus crosses: one θ_o bin plus the θ_o the locus travels across the
    /// column (where the cone runs steeply through a column its peak is only defined to that
    /// travel).
    #[must_use]
    pub fn locus_error_bins(&self) -> f64 {
        let n = self.locus.len();
        (0..n)
            .map(|k| {
                let (prev, next) = (self.locus[k.saturating_sub(1)].2, self.locus[(k + 1).min(n - 1)].2);
                let travel = if k == 0 || k + 1 == n { (next - prev).abs() } else { 0.5 * (next - prev).abs() };
                (self.locus[k].1 - self.locus[k].2).abs() / (self.bin_degrees + travel)
            })
            .fold(0.0, f64::max)
    }

    /// Measured over model albedo of the class.
    #[must_use]
    pub fn strength_ratio(&self) -> f64 {
        self.strength.0 / self.strength.2
    }

    /// Whether locus, width and strength are within [`SURFACE_TOLERANCES`].
    #[must_use]
    pub fn passes(&self) -> (bool, bool, bool) {
        let (l, w, s) = SURFACE_TOLERANCES;
        (
            !self.locus.is_empty() && self.locus_error_bins() <= l,
            (self.width.0 - self.width.1).abs() <= w * self.bin_degrees,
            (self.strength_ratio() - 1.0).abs() <= s,
        )
    }

    /// The θ_o (degrees) of the highlight in the column through φ_i + 180°, measured and model
    /// (NaN where that column has none).
    #[must_use]
    pub fn back_column_peaks(&self) -> (f64, f64) {
        let peak = |v: &[f64]| {
            if v.iter().any(|&x| x > 0.0) { (interpolated_peak(v) + 0.5) * self.bin_degrees } else { f64::NAN }
        };
        (peak(&self.profile.2), peak(&self.profile.4))
    }
}

/// The JSON of one highlight incidence (degrees).
#[derive(Serialize)]
pub struct HighlightJson {
    theta_i: f64,
    phi_i: f64,
    locus_max_error_bins: f64,
    locus_columns: usize,
    locus_pass: bool,
    back_column_phi: f64,
    back_peak_measured: f64,
    back_peak_model: f64,
    width_measured: f64,
    width_model: f64,
    width_pass: bool,
    albedo_measured: f64,
    albedo_std: f64,
    albedo_model: f64,
    k_f_fit: f64,
    strength_pass: bool,
}

impl From<&HighlightComparison> for HighlightJson {
    fn from(r: &HighlightComparison) -> Self {
        let (pl, pw, ps) = r.passes();
        let (back_peak_measured, back_peak_model) = r.back_column_peaks();
        Self {
            theta_i: r.theta_i.to_degrees(),
            phi_i: r.phi_i.to_degrees(),
            locus_max_error_bins: r.locus_error_bins(),
            locus_columns: r.locus.len(),
            locus_pass: pl,
            back_column_phi: r.profile.0,
            back_peak_measured,
            back_peak_model,
            width_measured: r.width.0,
            width_model: r.width.1,
            width_pass: pw,
            albedo_measured: r.strength.0,
            albedo_std: r.strength.1,
            albedo_model: r.strength.2,
            k_f_fit: r.k_f * r.strength_ratio(),
            strength_pass: ps,
        }
    }
}

/// Peak position of `v` (index space, parabolic interpolation about the highest sample).
#[must_use]
pub fn interpolated_peak(v: &[f64]) -> f64 {
    let k = (0..v.len()).max_by(|&a, &b| v[a].total_cmp(&v[b])).unwrap_or(0);
    if k == 0 || k + 1 >= v.len() {
        return k as f64;
    }
    let (a, b, c) = (v[k - 1], v[k], v[k + 1]);
    let den = a - 2.0 * b + c;
    if den.abs() < 1e-300 { k as f64 } else { k as f64 + (0.5 * (a - c) / den).clamp(-0.5, 0.5) }
}

/// Direction at `(θ, φ)` from the normal (`z`) in the surface frame.
fn dir(theta: f64, phi: f64) -> DVec3 {
    DVec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos())
}

/// The highlight comparison of incidence `s` of the `fiber` class.
fn compare_highlight(highlight: &dyn FiberHighlight, t: &LobeSlices, s: usize, sub: usize) -> HighlightComparison {
    let (nt, np) = (t.bins_theta, t.bins_phi);
    let (theta_i, phi_i) = (t.theta_in[s], t.phi_in[s]);
    let wi = dir(theta_i, phi_i);
    let (dt, dp) = (FRAC_PI_2 / nt as f64, TAU / np as f64);
    let sub = sub.max(1);
    let modelled: Vec<f64> = (0..nt * np)
        .into_par_iter()
        .map(|b| {
            let (i, j) = (b / np, b % np);
            let (mut num, mut den) = (0.0, 0.0);
            for a in 0..sub {
                let th = (i as f64 + (a as f64 + 0.5) / sub as f64) * dt;
                let w = th.sin() * th.cos();
                for c in 0..PHI_SUBSAMPLES {
                    let ph = -PI + (j as f64 + (c as f64 + 0.5) / PHI_SUBSAMPLES as f64) * dp;
                    num += highlight.fiber_term(wi, dir(th, ph)).luminance() * w;
                    den += w;
                }
            }
            num / den
        })
        .collect();
    let measured: Vec<f64> = t.f[s].iter().map(|v| v.luminance()).collect();
    let std: Vec<f64> = t.std[s].iter().map(|v| v.luminance()).collect();
    let omega = |i: usize| 0.5 * (((i + 1) as f64 * dt).sin().powi(2) - (i as f64 * dt).sin().powi(2)) * dp;
    let centre = |i: usize, j: usize| ((i as f64 + 0.5) * dt, -PI + (j as f64 + 0.5) * dp);
    // ψ_h of each bin centre, on the directions refracted into the finish.
    let u = highlight.axis();
    let psi_i = highlight.refract_in(wi).dot(u).clamp(-1.0, 1.0).asin();
    let psi_h = |i: usize, j: usize| {
        let (th, ph) = centre(i, j);
        psi_i + highlight.refract_in(dir(th, ph)).dot(u).clamp(-1.0, 1.0).asin()
    };
    let (mut a_meas, mut var, mut a_mod) = (0.0, 0.0, 0.0);
    let (mut w2_meas, mut w2_mod) = (0.0, 0.0);
    for i in 0..nt {
        for j in 0..np {
            let b = i * np + j;
            let h2 = psi_h(i, j).powi(2);
            a_meas += measured[b] * omega(i);
            var += (std[b] * omega(i)).powi(2);
            a_mod += modelled[b] * omega(i);
            w2_meas += measured[b] * omega(i) * h2;
            w2_mod += modelled[b] * omega(i) * h2;
        }
    }
    let rms = |w2: f64, a: f64| if a > 0.0 { (w2 / a).sqrt().to_degrees() } else { f64::NAN };
    let column = |v: &[f64], j: usize| -> Vec<f64> { (0..nt).map(|i| v[i * np + j]).collect() };
    let energy = |v: &[f64], j: usize| (0..nt).map(|i| v[i * np + j] * omega(i)).sum::<f64>();
    let max_meas = (0..np).map(|j| energy(&measured, j)).fold(0.0, f64::max);
    let max_mod = (0..np).map(|j| energy(&modelled, j)).fold(0.0, f64::max);
    let locus = (0..np)
        .filter(|&j| {
            energy(&measured, j) > COLUMN_THRESHOLD * max_meas && energy(&modelled, j) > COLUMN_THRESHOLD * max_mod
        })
        .map(|j| {
            let to_deg = |k: f64| ((k + 0.5) * dt).to_degrees();
            (
                centre(0, j).1.to_degrees(),
                to_deg(interpolated_peak(&column(&measured, j))),
                to_deg(interpolated_peak(&column(&modelled, j))),
            )
        })
        .collect();
    let back = wrap_pi(phi_i + PI);
    let jb = (((back + PI) / dp) as usize).min(np - 1);
    let thetas = (0..nt).map(|i| centre(i, jb).0.to_degrees()).collect();
    let profile =
        (centre(0, jb).1.to_degrees(), thetas, column(&measured, jb), column(&std, jb), column(&modelled, jb));
    HighlightComparison {
        theta_i,
        phi_i,
        locus,
        width: (rms(w2_meas, a_meas), rms(w2_mod, a_mod)),
        strength: (a_meas, var.sqrt(), a_mod),
        profile,
        bin_degrees: dt.to_degrees(),
        k_f: highlight.fiber_strength().luminance(),
    }
}

/// One incidence of a residual comparison with the `all` class.
#[derive(Clone, Debug)]
pub struct ResidualComparison {
    /// Light inclination, radians.
    pub theta_i: f64,
    /// Light azimuth, radians.
    pub phi_i: f64,
    /// Per-bin RMS of model − measured (sr⁻¹), weighted by `cosθ dω`.
    pub rms: f64,
    /// Relative L2 error.
    pub rel_l2: f64,
    /// The table's Monte Carlo relative L2.
    pub mc_rel_l2: f64,
    /// The worst bins: (θ_o°, φ_o°, measured, model, (model − measured)/σ).
    pub worst: Vec<(f64, f64, f64, f64, f64)>,
    /// Slices through the plane of incidence and across it.
    pub slices: Vec<ResidualSlice>,
}

/// A slice of a residual comparison: its label and its points (signed θ_o°, measured, std,
/// model).
pub type ResidualSlice = (String, Vec<(f64, f64, f64, f64)>);

/// The JSON of one residual incidence (degrees).
#[derive(Serialize)]
pub struct ResidualJson {
    theta_i: f64,
    phi_i: f64,
    rms: f64,
    rel_l2: f64,
    mc_rel_l2: f64,
    worst: Vec<WorstBinJson>,
}

/// One of the worst bins.
#[derive(Serialize)]
struct WorstBinJson {
    theta_o: f64,
    phi_o: f64,
    measured: f64,
    model: f64,
    pull: f64,
}

impl From<&ResidualComparison> for ResidualJson {
    fn from(r: &ResidualComparison) -> Self {
        Self {
            theta_i: r.theta_i.to_degrees(),
            phi_i: r.phi_i.to_degrees(),
            rms: r.rms,
            rel_l2: r.rel_l2,
            mc_rel_l2: r.mc_rel_l2,
            worst: r
                .worst
                .iter()
                .map(|&(theta_o, phi_o, measured, model, pull)| WorstBinJson { theta_o, phi_o, measured, model, pull })
                .collect(),
        }
    }
}

/// The residual comparison of `model` with every incidence of the `all` class.
fn compare_residual(model: &SurfaceModel, all: &LobeSlices, sub: usize, viewer_first: bool) -> Vec<ResidualComparison> {
    let (nt, np) = (all.bins_theta, all.bins_phi);
    let (dt, dp) = (FRAC_PI_2 / nt as f64, TAU / np as f64);
    let omega = |i: usize| 0.5 * (((i + 1) as f64 * dt).sin().powi(2) - (i as f64 * dt).sin().powi(2)) * dp;
    let floor = std_floor(all);
    (0..all.theta_in.len())
        .map(|s| {
            let (theta_i, phi_i) = (all.theta_in[s], all.phi_in[s]);
            let bins = fiberlab_fit::surface_bins(theta_i, phi_i, nt, np, sub, viewer_first);
            let modelled: Vec<f64> = bins.par_iter().map(|b| b.average(model).luminance()).collect();
            let measured: Vec<f64> = all.f[s].iter().map(|v| v.luminance()).collect();
            let std: Vec<f64> = all.std[s].iter().map(|v| v.luminance()).collect();
            let (mut num, mut den, mut mc, mut area) = (0.0, 0.0, 0.0, 0.0);
            for b in 0..nt * np {
                let w = omega(b / np);
                num += w * (modelled[b] - measured[b]).powi(2);
                den += w * measured[b].powi(2);
                mc += w * std[b].powi(2);
                area += w;
            }
            let centre = |b: usize| (((b / np) as f64 + 0.5) * dt, -PI + ((b % np) as f64 + 0.5) * dp);
            let pull = |b: usize| (modelled[b] - measured[b]) / std[b].max(floor).max(1e-300);
            let mut order: Vec<usize> = (0..nt * np).collect();
            order.sort_by(|&a, &b| pull(b).abs().total_cmp(&pull(a).abs()));
            let worst = order
                .iter()
                .take(WORST_BINS)
                .map(|&b| {
                    let (t, p) = centre(b);
                    (t.to_degrees(), p.to_degrees(), measured[b], modelled[b], pull(b))
                })
                .collect();
            // A plane through the normal at azimuth `a`: θ_o > 0 toward `a`, < 0 toward `a + π`.
            let column = |a: f64| ((wrap_pi(a) + PI) / dp).floor() as usize % np;
            let plane = |a: f64| -> Vec<(f64, f64, f64, f64)> {
                let (front, back) = (column(a), column(a + PI));
                let mut v: Vec<(f64, f64, f64, f64)> = (0..nt)
                    .rev()
                    .map(|i| {
                        let b = i * np + back;
                        (-centre(b).0.to_degrees(), measured[b], std[b], modelled[b])
                    })
                    .collect();
                v.extend((0..nt).map(|i| {
                    let b = i * np + front;
                    (centre(b).0.to_degrees(), measured[b], std[b], modelled[b])
                }));
                v
            };
            let slices = vec![
                (format!("plane of incidence (θ_o > 0 at φ_o = {:.0}°)", (phi_i + PI).to_degrees()), plane(phi_i + PI)),
                (
                    format!("plane across it (θ_o > 0 at φ_o = {:.0}°)", (phi_i + FRAC_PI_2).to_degrees()),
                    plane(phi_i + FRAC_PI_2),
                ),
            ];
            let rel = |x: f64| if den > 0.0 { (x / den).sqrt() } else { f64::NAN };
            ResidualComparison {
                theta_i,
                phi_i,
                rms: (num / area).sqrt(),
                rel_l2: rel(num),
                mc_rel_l2: rel(mc),
                worst,
                slices,
            }
        })
        .collect()
}

/// Compares the surface model of `request` with a surface table: a model with a fiber
/// highlight against the `fiber` class, any other against the `all` class (module docs).
/// `viewer_first`: the table's θ_i, φ_i is the viewer's direction (a table traced from the
/// camera, as the woven patch's); it matters for a non-reciprocal model.
pub fn compare_surface_table(
    table: &BTreeMap<String, LobeSlices>,
    request: &ModelRequest,
    subsamples: usize,
    viewer_first: bool,
) -> Result<SurfaceComparison, CompareError> {
    let model = request.build_surface()?;
    if let Some(highlight) = model.fiber_highlight() {
        let fiber = table.get("fiber").ok_or_else(|| {
            CompareError::Table(
                "a surface table needs its `fiber` lobe (single-fiber paths) for a fiber highlight".into(),
            )
        })?;
        let rows = (0..fiber.theta_in.len()).map(|s| compare_highlight(highlight, fiber, s, subsamples)).collect();
        return Ok(SurfaceComparison::Highlight(rows));
    }
    let all = table
        .get("all")
        .ok_or_else(|| CompareError::Table("a surface table needs its `all` lobe (every path)".into()))?;
    // One incidence's bins are held at a time.
    fiberlab_fit::surface::check_surface_bins(all.bins_theta, all.bins_phi, 1, subsamples)?;
    Ok(SurfaceComparison::Residual(compare_residual(&model, all, subsamples, viewer_first)))
}
