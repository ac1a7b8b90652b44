//! A measured (tabulated) scattering function, e.g. from the virtual goniophotometer: bin
//! values of `f_s` over (θ_r, φ) for a set of incidence inclinations, usable like any model.
//!
//! Parameters: the registry entry (the `params` of `Registered::INFO` below) is the one table of
//! keys, units, defaults and valid ranges; `fiberlab models --model measured` prints it and the
//! book's page `docs/book/src/models/measured.md` shows it.
//!
//! # Formula
//! Bins are uniform in θ_out ∈ [−π/2, π/2] and φ = φ_out − φ_in ∈ [−π, π]; slice `k` holds
//! `T_k(θ_out, φ)` for light at inclination `θ_k`. At a measured incidence `f_s` is the table
//! itself, `f_s(ω_i, ω_o) = T_k(θ_o, φ_o − φ_i)` for `θ_i = θ_k`, so a table compared with the
//! model built from it agrees to the last bit.
//!
//! **Between incidences** the slices are moved along the specular cone before they are
//! blended: a fiber's lobes (R, TT, TRT) sit near `θ_out = −θ_in`, so light at `θ_i = θ_k + Δ`
//! sees slice `k` shifted by `−Δ` in θ_out:
//! `f_s = (1 − t)·T_{k}(θ_o + θ_i − θ_k) + t·T_{k+1}(θ_o + θ_i − θ_{k+1})`, with `t` the linear
//! weight of θ_i between `θ_k` and `θ_{k+1}` (a plain blend of the two slices would show two
//! half-height copies of a narrow lobe instead of one lobe in between). A shifted row beyond
//! ±π/2 contributes 0. Outside the measured range the nearest slice is shifted the same way
//! (documented, not claimed accurate: measure the range you render).
//!
//! **One incidence**: a table of a single incidence is refused wherever a table file becomes
//! a model (`crates/render/src/model_loader.rs`, `LoadError::OneIncidence`: scenes,
//! `render`, `evaluate`, `eval`, `sample`, …), since one slice says nothing about light from
//! other inclinations; measure several with `fiberlab measure --theta-i -60,-30,0,30,60`.
//! Built directly from a [`MeasuredTable`], such a table is extended by the shift rule above
//! (the example below uses this).
//!
//! **Sampling** follows `eval` itself. `eval` reads, for light at θ_i and a viewer at θ_o,
//! bins at `x = θ_o + θ_i − θ_k` of the slices around θ_i; so moving the viewer by δ and the
//! light by −δ reads the same bins. At construction, for a grid of viewer rows `θ_r` (cell
//! centres, one per θ_out bin up to [`CONDITIONAL_MAX_ROWS`]), the incidences are cut at every
//! place where `eval` can jump (each slice's bin edges moved along the cone, `θ_i = e − θ_r +
//! θ_k`, and the incidences θ_k themselves), so that within a θ_i cell and a φ bin `eval` only
//! blends fixed bins linearly; each such cell gets probability `∝ lum f_s(middle)·∫_cell cosθ
//! dω`. Given `ω_o` the nearest row is drawn from (a cell, then a point uniform in φ within
//! the bin) and its cells moved along the cone by `d = θ_r − θ_o`: θ_i is uniform in `sinθ`
//! over `[a + d, b + d]` (clipped to ±π/2), where `eval` reads exactly the bins the row was
//! tabulated at. The pdf is that density, `P(cell)/((sin(b + d) − sin(a + d))·Δφ)`, bounded
//! wherever the clipped cell is not a sliver; a cell the move pushes wholly beyond the pole
//! (within `|d|` ≤ half a row of ±π/2) is drawn from the ideal diffuse fiber's lobe instead,
//! and counted in the pdf as that lobe's density times its probability. A row where the table is zero everywhere proposes that lobe too, and a
//! defensive fraction [`DEFENSIVE`] of the samples comes from it, so the pdf is positive
//! wherever `f_s` can be. The weight `f_s cosθ_i/pdf` then varies only with the blend, the
//! colour and `cosθ` within a cell. (A viewer between rows blends as at `θ_i − d`, which
//! can cross an incidence where the row's cell did not: each cell's probability is the
//! largest blend over `|d|` ≤ half a row, so that a sharp lobe a neighbouring slice brings in
//! with a small weight just past an incidence is proposed too.)
//!
//! An earlier proposal read each slice backwards (Helmholtz reciprocity) and moved it along
//! the cone; on the gallery's measured blond fiber (60 × 120 bins, 1M rays per incidence) its
//! weights had a relative variance of 1.9–21 per bounce (largest weight 630 against an albedo
//! below 1), which deep paths in light hair multiply into fireflies; this one has 0.03–0.19
//! (largest weight 2.0) on the same table and viewers (`docs/book/src/models/measured.md`
//! has the figures and the command). Far-field,
//! smooth; reciprocity and energy hold only as well as the measurement does, so neither is
//! claimed.

use crate::params::{ParamKind, ParamSet, ParamSpec};
use crate::sampling::{cos_theta_direction, cos_theta_pdf};
use crate::{
    ExternalData, Field, LobeInfo, Lobes, ModelError, ModelInfo, Properties, Registered, Sample, ScatteringFunction,
};
use fiberlab_math::frame::{cos_theta, direction_from_sin_cos, phi, relative_phi, theta};
use fiberlab_math::{DVec3, Rgb};
use std::f64::consts::{FRAC_PI_2, PI, TAU};
use std::sync::Arc;
use thiserror::Error;

/// Registry entry: `measured`. Building it needs the table's data, which the I/O layer
/// loads; [`crate::build`] alone reports how to provide it.
impl Registered for Measured {
    const INFO: ModelInfo = ModelInfo {
        name: "measured",
        summary: "tabulated f_s from a goniophotometer table (fiberlab measure CSV)",
        citation: "fiberlab measure; docs/theory/radiometry.md (normalization)",
        params: &[ParamSpec {
            key: "table",
            kind: ParamKind::Text,
            unit: "path",
            default: "",
            doc: "CSV written by `fiberlab measure` (rows with lobe=all are used)",
        }],
        data: Some(ExternalData::Table { key: "table" }),
    };

    fn from_param_set(_p: &ParamSet) -> Result<Self, ModelError> {
        Err(ModelError::NeedsData { model: "measured", key: "table" })
    }
}

/// Why a [`Measured`] function cannot be built from a table.
#[non_exhaustive]
#[derive(Clone, Debug, Error, PartialEq)]
pub enum MeasuredError {
    /// No incidence or no bins.
    #[error("measured table: no data")]
    Empty,
    /// Slice count or sizes disagree with the bins.
    #[error("measured table: expected {slices} slices of {cells} bins")]
    Shape {
        /// Incidences.
        slices: usize,
        /// Bins per slice.
        cells: usize,
    },
    /// Incidences not strictly increasing inside (−90°, 90°).
    #[error("measured table: incidence angles must be distinct, increasing, in (−90°, 90°)")]
    Incidences,
    /// A NaN, infinite or negative value.
    #[error("measured table: values must be finite and non-negative")]
    Values,
}

impl From<MeasuredError> for ModelError {
    fn from(e: MeasuredError) -> Self {
        ModelError::Inconsistent(e.to_string())
    }
}

/// Fraction of [`Measured`]'s samples drawn from the ideal diffuse fiber's lobe, so that the
/// pdf is positive wherever `f_s` may be (the tabulated proposal is zero in a cell where
/// `eval` is zero at the points it was tabulated at). Each such sample is a weight near 0
/// beside weights near albedo/(1 − DEFENSIVE): a relative variance of about
/// DEFENSIVE/(1 − DEFENSIVE) per bounce, so the fraction is small.
pub const DEFENSIVE: f64 = 0.02;

/// Bin values of `f_s` (sr⁻¹) for each measured incidence inclination.
#[derive(Clone, Debug, PartialEq)]
pub struct MeasuredTable {
    /// Incidence inclinations θ_in (radians), strictly increasing.
    pub theta_in: Vec<f64>,
    /// Bins in θ_out over [−π/2, π/2].
    pub bins_theta: usize,
    /// Bins in φ over [−π, π].
    pub bins_phi: usize,
    /// One slice per θ_in, row-major `[θ_out][φ]`.
    pub f: Vec<Vec<Rgb>>,
}

/// A tabulated scattering function.
///
/// A table holding one value everywhere is that value, whatever the directions (the
/// shift rule moves rows that are all alike), here from a single incidence:
/// ```
/// use fiberlab_scatter::ScatteringFunction;
/// use fiberlab_scatter::measured::{Measured, MeasuredTable};
/// use fiberlab_math::{Rgb, frame::direction};
/// let table = MeasuredTable { theta_in: vec![0.3], bins_theta: 8, bins_phi: 8, f: vec![vec![Rgb::splat(0.07); 64]] };
/// let f = Measured::new(table).unwrap();
/// assert_eq!(f.eval(direction(0.3, 0.0), direction(-0.2, 1.0), 0.0), Rgb::splat(0.07));
/// ```
#[derive(Clone, Debug)]
pub struct Measured {
    table: Arc<MeasuredTable>,
    /// The sampling distribution: `eval` tabulated per viewer row.
    conditional: Arc<Conditional>,
}

/// Most viewer rows of [`Measured`]'s sampling table (one per θ_out bin of the table up to
/// this). The rows only follow what varies slowly with the viewer (which slices `eval` blends,
/// and how), since each row is moved along the cone to the viewer's exact inclination.
pub const CONDITIONAL_MAX_ROWS: usize = 60;

/// Most cumulative probabilities the sampling table holds (32 MB): a large table gets fewer
/// viewer rows (at least [`CONDITIONAL_MIN_ROWS`]). A 60 × 120 table needs about 1M.
pub const CONDITIONAL_MAX_CELLS: usize = 4 << 20;

/// Fewest viewer rows of the sampling table.
pub const CONDITIONAL_MIN_ROWS: usize = 12;

/// `eval` tabulated for sampling. For each viewer row `θ_r` (cell centres over [−π/2, π/2])
/// the incidences `θ_i` are cut at every place where `eval`'s value can jump (the slices'
/// incidences, and each slice's θ_out bin edges moved along the cone: `θ_i = e − θ_r + θ_k`),
/// so that within a θ_i cell and a φ bin of the table `eval` reads fixed bins and only blends
/// them linearly. Each (θ_i cell, φ bin) gets probability `∝ lum f_s(middle)·∫_cell cosθ dω`.
#[derive(Clone, Debug)]
struct Conditional {
    rows: usize,
    bins_phi: usize,
    /// Row `r`'s θ_i cut points are `cuts[cut_start[r]..cut_start[r + 1]]`, increasing from
    /// −π/2 to π/2.
    cuts: Vec<f64>,
    cut_start: Vec<usize>,
    /// Row `r`'s cumulative probabilities over its cells (θ_i cell major, φ bin minor), from 0
    /// to 1 (or all 0 where `f_s` is zero everywhere for that viewer), at `cdf_start[r]`.
    cdf: Vec<f64>,
    cdf_start: Vec<usize>,
}

/// Where a draw of a viewer row lands once moved along the cone.
enum RowDraw {
    /// On the sphere: the incidence θ_i and φ = φ_o − φ_i.
    Within { theta_i: f64, rel: f64 },
    /// Beyond the pole (a cell the move pushes wholly past ±π/2): two uniforms, fresh given
    /// this outcome, for the ideal diffuse fiber's lobe.
    Beyond { fresh: [f64; 2] },
}

impl Conditional {
    fn new(table: &MeasuredTable, rows: usize) -> Self {
        let (nt, np) = (table.bins_theta, table.bins_phi);
        let dphi = TAU / np as f64;
        let k_last = table.theta_in.len() - 1;
        let prim = |x: f64| 0.5 * x + 0.25 * (2.0 * x).sin();
        let (mut cuts, mut cut_start, mut cdf, mut cdf_start) = (Vec::new(), vec![0], Vec::new(), vec![0]);
        // A row serves viewers up to half a row away, moved by |d| ≤ half.
        let half = 0.5 * PI / rows as f64;
        for r in 0..rows {
            let theta_r = -FRAC_PI_2 + (r as f64 + 0.5) * PI / rows as f64;
            let start = cuts.len();
            cuts.extend([-FRAC_PI_2, FRAC_PI_2]);
            cuts.extend(table.theta_in.iter().copied());
            for (k, &theta_k) in table.theta_in.iter().enumerate() {
                // Where `eval` uses slice k for a viewer this row serves: between its
                // neighbours (to the pole for the ends), widened by the move.
                let lo = if k == 0 { -FRAC_PI_2 } else { table.theta_in[k - 1] - half };
                let hi = if k == k_last { FRAC_PI_2 } else { table.theta_in[k + 1] + half };
                for j in 0..=nt {
                    let theta_i = -FRAC_PI_2 + j as f64 * PI / nt as f64 - theta_r + theta_k;
                    if theta_i > lo && theta_i < hi && theta_i.abs() < FRAC_PI_2 {
                        cuts.push(theta_i);
                    }
                }
            }
            let row = &mut cuts[start..];
            row.sort_by(f64::total_cmp);
            let mut kept = start + 1;
            for m in start + 1..cuts.len() {
                if cuts[m] - cuts[kept - 1] > 1e-9 {
                    cuts[kept] = cuts[m];
                    kept += 1;
                }
            }
            // The last cut is π/2 (a cut within 1e-9 of it is replaced by it).
            cuts[kept - 1] = FRAC_PI_2;
            cuts.truncate(kept);
            cut_start.push(cuts.len());
            let first = cdf.len();
            cdf.push(0.0);
            let mut acc = 0.0;
            for w in cuts[start..].windows(2) {
                let middle = 0.5 * (w[0] + w[1]);
                let cos_solid = (prim(w[1]) - prim(w[0])) * dphi;
                // A viewer this row serves reads the same bins (θ_i + θ_o is kept) but blends
                // them as at θ_i = middle + d, |d| ≤ half: the largest blend over that range
                // (piecewise linear in d, so at its ends and at the incidences between), so
                // that a sharp lobe a neighbouring slice brings in with a small weight just
                // past an incidence is proposed too.
                let blends = [middle - half, middle + half]
                    .into_iter()
                    .chain(table.theta_in.iter().copied().filter(|t| (t - middle).abs() < half));
                let cone = middle + theta_r;
                for j in 0..np {
                    let rel = -PI + (j as f64 + 0.5) * dphi;
                    let value = blends.clone().map(|b| table.blend(b, cone, rel).luminance()).fold(0.0, f64::max);
                    acc += value * cos_solid;
                    cdf.push(acc);
                }
            }
            if acc > 0.0 {
                cdf[first..].iter_mut().for_each(|x| *x /= acc);
                let last = cdf.len() - 1;
                cdf[last] = 1.0;
            }
            cdf_start.push(cdf.len());
        }
        Self { rows, bins_phi: np, cuts, cut_start, cdf, cdf_start }
    }

    fn cuts(&self, r: usize) -> &[f64] {
        &self.cuts[self.cut_start[r]..self.cut_start[r + 1]]
    }

    fn cdf(&self, r: usize) -> &[f64] {
        &self.cdf[self.cdf_start[r]..self.cdf_start[r + 1]]
    }

    /// The viewer row nearest `theta_o` and the move `d = θ_r − θ_o` along the cone that maps
    /// the row's incidences to this viewer's (`θ_i = θ_row + d` keeps `θ_o + θ_i` and with it
    /// every bin `eval` reads).
    fn row_of(&self, theta_o: f64) -> (usize, f64) {
        let q = (theta_o + FRAC_PI_2) / PI * self.rows as f64;
        let r = (q.max(0.0) as usize).min(self.rows - 1);
        (r, -FRAC_PI_2 + (r as f64 + 0.5) * PI / self.rows as f64 - theta_o)
    }

    /// θ_i cell of row `r` holding `theta` (in [−π/2, π/2]).
    fn cell_of(&self, r: usize, theta: f64) -> usize {
        let cuts = self.cuts(r);
        (cuts.partition_point(|&c| c <= theta).max(1) - 1).min(cuts.len() - 2)
    }

    fn probability(&self, r: usize, cell: usize, j: usize) -> f64 {
        let c = self.cdf(r);
        let b = cell * self.bins_phi + j;
        (c[b + 1]) - (c[b])
    }

    /// A cell of row `r` moved by `d` and clipped to [−π/2, π/2]: `[sin lo, sin hi]`, or `None`
    /// where the move pushes it wholly beyond the pole.
    fn moved_span(&self, r: usize, m: usize, d: f64) -> Option<(f64, f64)> {
        let cuts = self.cuts(r);
        let (lo, hi) = ((cuts[m] + d).max(-FRAC_PI_2), (cuts[m + 1] + d).min(FRAC_PI_2));
        (hi > lo).then(|| (lo.sin(), hi.sin()))
    }

    /// Probability of row `r`'s cells that the move `d` pushes wholly beyond the pole.
    fn mass_beyond(&self, r: usize, d: f64) -> f64 {
        let (c, cuts, np) = (self.cdf(r), self.cuts(r), self.bins_phi);
        if d > 0.0 {
            let first = cuts.partition_point(|&a| a + d < FRAC_PI_2).min(cuts.len() - 1);
            1.0 - c[first * np]
        } else if d < 0.0 {
            let cells = cuts[1..].partition_point(|&b| b + d <= -FRAC_PI_2);
            c[cells * np]
        } else {
            0.0
        }
    }

    /// Density per steradian of row `r`'s draws moved by `d`, at `(theta_i, rel)`, besides the
    /// cells beyond the pole: a cell's probability spread uniformly over its moved, clipped
    /// solid angle.
    fn density(&self, r: usize, d: f64, theta_i: f64, rel: f64) -> f64 {
        let theta_row = theta_i - d;
        if theta_row.abs() > FRAC_PI_2 {
            return 0.0;
        }
        let m = self.cell_of(r, theta_row);
        let Some((sa, sb)) = self.moved_span(r, m, d) else { return 0.0 };
        let j = (((rel + PI) / TAU * self.bins_phi as f64) as usize).min(self.bins_phi - 1);
        self.probability(r, m, j) / ((sb - sa) * TAU / self.bins_phi as f64)
    }

    /// A draw of row `r` from `(u1, u2, u3)`, moved by `d`: a cell, then θ_i uniform in `sinθ`
    /// over the moved cell and φ uniform within the φ bin.
    fn draw(&self, r: usize, d: f64, u: [f64; 3]) -> RowDraw {
        let c = self.cdf(r);
        let np = self.bins_phi;
        let b = (c.partition_point(|&x| x <= u[0]).max(1) - 1).min(c.len() - 2);
        let (m, j) = (b / np, b % np);
        match self.moved_span(r, m, d) {
            Some((sa, sb)) => RowDraw::Within {
                theta_i: (sa + u[1] * (sb - sa)).clamp(-1.0, 1.0).asin(),
                rel: -PI + (j as f64 + u[2]) * TAU / np as f64,
            },
            None => {
                let (lo, hi) = (c[b], c[b + 1]);
                let fresh = if hi > lo { ((u[0] - lo) / (hi - lo)).clamp(0.0, 1.0) } else { 0.5 };
                RowDraw::Beyond { fresh: [fresh, u[1]] }
            }
        }
    }

    fn is_empty(&self, r: usize) -> bool {
        let c = self.cdf(r);
        c[c.len() - 1] <= 0.0
    }
}

impl MeasuredTable {
    /// A far-field function tabulated as a goniophotometer would report it, but exactly: each
    /// bin holds `f_s` at its centre, for light at each of `theta_in` (radians, φ_i = 0, h = 0).
    /// What tests and comparisons use to give a known function the table's form.
    #[must_use]
    pub fn of_function(f: &impl ScatteringFunction, theta_in: Vec<f64>, bins_theta: usize, bins_phi: usize) -> Self {
        let centre = |b: usize| {
            let theta_out = -FRAC_PI_2 + ((b / bins_phi) as f64 + 0.5) * PI / bins_theta as f64;
            let phi_rel = -PI + ((b % bins_phi) as f64 + 0.5) * TAU / bins_phi as f64;
            direction_from_sin_cos(theta_out.sin(), theta_out.cos(), phi_rel)
        };
        let f = theta_in
            .iter()
            .map(|&ti| {
                let wi = direction_from_sin_cos(ti.sin(), ti.cos(), 0.0);
                (0..bins_theta * bins_phi).map(|b| f.eval(wi, centre(b), 0.0)).collect()
            })
            .collect();
        Self { theta_in, bins_theta, bins_phi, f }
    }

    /// Slices around `theta` (an incidence) and the weight of the upper one.
    fn slices(&self, theta_o: f64) -> (usize, usize, f64) {
        let t = &self.theta_in;
        if theta_o <= t[0] {
            return (0, 0, 0.0);
        }
        if theta_o >= t[t.len() - 1] {
            return (t.len() - 1, t.len() - 1, 0.0);
        }
        let k = t.partition_point(|&x| x <= theta_o) - 1;
        (k, k + 1, (theta_o - t[k]) / (t[k + 1] - t[k]))
    }

    /// Slice `k` moved along the specular cone to a light and viewer whose inclinations sum to
    /// `cone` (`θ_i + θ_o`; see the module docs), read at relative azimuth `phi_rel`.
    fn shifted(&self, k: usize, cone: f64, phi_rel: f64) -> Rgb {
        let x = cone - self.theta_in[k];
        if x.abs() > FRAC_PI_2 { Rgb::ZERO } else { self.f[k][self.bin(x, phi_rel)] }
    }

    /// The slices around `theta_blend`, with its blend weights, each moved along the cone to
    /// `cone` = θ_i + θ_o. [`MeasuredTable::value`] is this with `theta_blend` = θ_i.
    fn blend(&self, theta_blend: f64, cone: f64, phi_rel: f64) -> Rgb {
        let (k0, k1, t) = self.slices(theta_blend);
        let lower = self.shifted(k0, cone, phi_rel);
        if t == 0.0 { lower } else { lower * (1.0 - t) + self.shifted(k1, cone, phi_rel) * t }
    }

    /// `f_s` for light at inclination `theta_i`, a viewer at `theta_o` and `phi_rel` =
    /// φ_o − φ_i: the slices around `theta_i` moved along the specular cone and blended.
    fn value(&self, theta_i: f64, theta_o: f64, phi_rel: f64) -> Rgb {
        self.blend(theta_i, theta_i + theta_o, phi_rel)
    }

    fn bin(&self, theta_out: f64, phi_rel: f64) -> usize {
        let (nt, np) = (self.bins_theta, self.bins_phi);
        let i = (((theta_out + FRAC_PI_2) / PI * nt as f64) as usize).min(nt - 1);
        let j = (((phi_rel + PI) / TAU * np as f64) as usize).min(np - 1);
        i * np + j
    }
}

impl Measured {
    /// Validates the table (finite, non-negative, consistent sizes, increasing θ_in).
    pub fn new(table: MeasuredTable) -> Result<Self, MeasuredError> {
        let cells = table.bins_theta * table.bins_phi;
        if table.theta_in.is_empty() || cells == 0 {
            return Err(MeasuredError::Empty);
        }
        if table.f.len() != table.theta_in.len() || table.f.iter().any(|s| s.len() != cells) {
            return Err(MeasuredError::Shape { slices: table.theta_in.len(), cells });
        }
        if table.theta_in.windows(2).any(|w| w[1] <= w[0]) || table.theta_in.iter().any(|t| t.abs() >= FRAC_PI_2) {
            return Err(MeasuredError::Incidences);
        }
        if table.f.iter().flatten().any(|v| !v.is_finite() || v.min_component() < 0.0) {
            return Err(MeasuredError::Values);
        }
        // Cells per row: about (2·bins_theta + incidences) θ_i cells by bins_phi.
        let per_row = (2 * table.bins_theta + table.theta_in.len() + 2) * table.bins_phi;
        let rows =
            table.bins_theta.min(CONDITIONAL_MAX_ROWS).min((CONDITIONAL_MAX_CELLS / per_row).max(CONDITIONAL_MIN_ROWS));
        let conditional = Conditional::new(&table, rows);
        Ok(Self { table: Arc::new(table), conditional: Arc::new(conditional) })
    }

    /// The table.
    #[must_use]
    pub fn table(&self) -> &MeasuredTable {
        &self.table
    }

    /// The measured incidences θ_k (radians).
    #[must_use]
    pub fn incidences(&self) -> &[f64] {
        &self.table.theta_in
    }

    /// Density of the tabulated proposal (the ideal diffuse fiber's lobe for an empty row and
    /// for the draws moved beyond the pole).
    fn table_pdf(&self, wi: DVec3, wo: DVec3) -> f64 {
        let c = &self.conditional;
        let (r, d) = c.row_of(theta(wo));
        let diffuse = cos_theta_pdf(cos_theta(wi));
        if c.is_empty(r) {
            return diffuse;
        }
        c.density(r, d, theta(wi), relative_phi(wi, wo)) + c.mass_beyond(r, d) * diffuse
    }
}

impl ScatteringFunction for Measured {
    fn properties(&self) -> Properties {
        Properties { reciprocal: false, energy_conserving: false, field: Field::Far, lobes: Lobes::Smooth }
    }

    fn eval(&self, wi: DVec3, wo: DVec3, _h: f64) -> Rgb {
        self.table.value(theta(wi), theta(wo), relative_phi(wi, wo))
    }

    fn pdf(&self, wi: DVec3, wo: DVec3, _h: f64) -> f64 {
        (1.0 - DEFENSIVE) * self.table_pdf(wi, wo) + DEFENSIVE * cos_theta_pdf(cos_theta(wi))
    }

    /// `table` (the measured slices) and `diffuse` (the ideal diffuse fiber's lobe that the
    /// defensive fraction of the samples comes from).
    fn lobes(&self) -> Vec<LobeInfo> {
        vec![LobeInfo::smooth("table"), LobeInfo::smooth("diffuse")]
    }

    fn sample(&self, wo: DVec3, h: f64, u: [f64; 4]) -> Option<Sample> {
        // Lobe 0: the tabulated `eval`; lobe 1: the ideal diffuse fiber's lobe (the defensive
        // fraction, and a viewer row where the table is zero everywhere).
        let mut lobe = 1;
        let wi = if u[0] < DEFENSIVE {
            cos_theta_direction(u[1], u[2], TAU * u[3])
        } else {
            let c = &self.conditional;
            let (r, d) = c.row_of(theta(wo));
            if c.is_empty(r) {
                cos_theta_direction(u[1], u[2], TAU * u[3])
            } else {
                match c.draw(r, d, [u[1], u[2], u[3]]) {
                    RowDraw::Within { theta_i, rel } => {
                        lobe = 0;
                        let (si, ci) = theta_i.sin_cos();
                        direction_from_sin_cos(si, ci.max(0.0), phi(wo) - rel)
                    }
                    RowDraw::Beyond { fresh } => cos_theta_direction(fresh[0], fresh[1], TAU * u[3]),
                }
            }
        };
        let pdf = self.pdf(wi, wo, h);
        if pdf <= 0.0 {
            return None;
        }
        let weight = self.eval(wi, wo, h) * (cos_theta(wi) / pdf);
        Some(Sample { wi, weight, pdf, delta: false, lobe })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A table sampled from an analytic far-field function must reproduce its albedo and
    /// sample consistently with its own pdf.
    #[test]
    fn tabulated_lambertian_cylinder_keeps_its_albedo() {
        let (nt, np) = (45, 90);
        let theta_in: Vec<f64> = (-8..=8).map(|k| k as f64 * 0.17).collect();
        let f: Vec<Vec<Rgb>> = theta_in
            .iter()
            .map(|_| {
                (0..nt * np)
                    .map(|b| {
                        let p = -PI + ((b % np) as f64 + 0.5) * TAU / np as f64;
                        Rgb::splat(0.7 * crate::lambertian_cylinder::azimuthal(p) / (4.0 * PI))
                    })
                    .collect()
            })
            .collect();
        let m = Measured::new(MeasuredTable { theta_in, bins_theta: nt, bins_phi: np, f }).unwrap();
        let wo = fiberlab_math::frame::direction(0.4, 1.0);
        let rho = crate::radiometry::furnace(&m, wo, &crate::radiometry::Quadrature::default());
        assert!((rho[0] - 0.7).abs() < 5e-3, "{rho:?}");
        let mut mean = 0.0;
        for k in 0..20000 {
            let u = [
                (k as f64 * 0.618) % 1.0,
                (k as f64 + 0.5) / 20000.0,
                (k as f64 * 0.414) % 1.0,
                (k as f64 * 0.732) % 1.0,
            ];
            let s = m.sample(wo, 0.0, u).unwrap();
            assert!((s.pdf - m.pdf(s.wi, wo, 0.0)).abs() <= 1e-9 * s.pdf);
            mean += s.weight[0] / 20000.0;
        }
        assert!((mean - 0.7).abs() < 5e-3, "{mean}");
        assert!(
            Measured::new(MeasuredTable {
                theta_in: vec![0.0],
                bins_theta: 2,
                bins_phi: 2,
                f: vec![vec![Rgb::ONE; 3]]
            })
            .is_err()
        );
    }

    /// A table of a narrow cone lobe `exp(−(θ_i + θ_o)²/2σ²)` (σ = 3°), uniform in φ, at the
    /// given incidences (degrees), `nt` × 36 bins, each bin holding the value at its centre.
    fn cone_table(incidences: &[f64], nt: usize) -> MeasuredTable {
        let np = 36;
        let sigma = 3f64.to_radians();
        let theta_in: Vec<f64> = incidences.iter().map(|d| d.to_radians()).collect();
        let f = theta_in
            .iter()
            .map(|&ti| {
                (0..nt * np)
                    .map(|b| {
                        let to = -FRAC_PI_2 + ((b / np) as f64 + 0.5) * PI / nt as f64;
                        Rgb::splat((-(ti + to).powi(2) / (2.0 * sigma * sigma)).exp())
                    })
                    .collect()
            })
            .collect();
        MeasuredTable { theta_in, bins_theta: nt, bins_phi: np, f }
    }

    /// At a measured incidence the model is its table, bin for bin (what `compare-model` of
    /// a table against the model built from it relies on).
    #[test]
    fn reproduces_its_own_table_at_measured_incidences() {
        let table = cone_table(&[-20.0, 0.0, 30.0], 90);
        let m = Measured::new(table.clone()).unwrap();
        let (nt, np) = (table.bins_theta, table.bins_phi);
        for (k, &ti) in table.theta_in.iter().enumerate() {
            for b in 0..nt * np {
                let to = -FRAC_PI_2 + ((b / np) as f64 + 0.5) * PI / nt as f64;
                let rel = -PI + ((b % np) as f64 + 0.5) * TAU / np as f64;
                let wi = fiberlab_math::frame::direction(ti, 0.3);
                let wo = fiberlab_math::frame::direction(to, 0.3 + rel);
                assert_eq!(m.eval(wi, wo, 0.0), table.f[k][b], "slice {k} bin {b}");
            }
        }
    }

    /// Between two incidences a narrow lobe moves along the specular cone (one peak at
    /// θ_o = −θ_i of the right height), instead of two half-height copies at the slices'
    /// positions.
    #[test]
    fn interpolation_moves_a_narrow_lobe_along_the_cone() {
        let m = Measured::new(cone_table(&[0.0, 20.0], 180)).unwrap();
        let ti = 10f64.to_radians();
        let wi = fiberlab_math::frame::direction(ti, 0.0);
        let along = |to: f64| m.eval(wi, fiberlab_math::frame::direction(to, 1.0), 0.0)[0];
        let (best, peak) = (0..=1800)
            .map(|k| -FRAC_PI_2 + k as f64 * PI / 1800.0)
            .map(|to| (to, along(to)))
            .fold((0.0, 0.0), |a, b| if b.1 > a.1 { b } else { a });
        assert!((best + ti).abs() <= 1.5 * PI / 180.0, "peak at {}°", best.to_degrees());
        assert!(peak > 0.95, "peak height {peak}");
        // A plain blend of the slices would leave half of the lobe at θ_o = 0 and −20°.
        assert!(along(-20f64.to_radians()) < 0.01 && along(0.0) < 0.01);
    }

    /// Between two slices the proposal follows the lobe `eval` moves along the cone: the
    /// sampling weights of a narrow lobe stay near its furnace value (by quadrature), where a
    /// proposal at the slices' own positions leaves the lobe to the defensive fraction
    /// (weights ~ f·π²/DEFENSIVE, hundreds here).
    #[test]
    fn sampling_follows_a_lobe_moved_between_slices() {
        let m = Measured::new(cone_table(&[0.0, 20.0], 180)).unwrap();
        let wo = fiberlab_math::frame::direction(10f64.to_radians(), 0.4);
        let w = crate::radiometry::furnace(&m, wo, &crate::radiometry::Quadrature::default())[0];
        let mut rng = fiberlab_check::rng::TestRng::new(23);
        let (mut max, mut mean) = (0.0f64, 0.0);
        for _ in 0..4000 {
            let weight = m.sample(wo, 0.0, rng.u4()).map_or(0.0, |s| s.weight[0]);
            max = max.max(weight);
            mean += weight / 4000.0;
        }
        assert!(max < 3.0 * w, "largest weight {max}, furnace {w}");
        assert!((mean - w).abs() < 0.02 * w, "mean weight {mean}, furnace {w}");
    }

    /// A lobe narrower than a bin (one bin per slice, the bin holding θ_out = −θ_in), whose
    /// bins sit at different phases in the two slices: the sampling weights stay near the
    /// furnace value (by quadrature) where `eval` takes the lobe from the other slice than the
    /// proposal does.
    #[test]
    fn sampling_covers_a_lobe_quantized_differently_by_neighbouring_slices() {
        let (nt, np) = (60, 36);
        let theta_in: Vec<f64> = [-20.0f64, -1.0].iter().map(|d| d.to_radians()).collect();
        let f = theta_in
            .iter()
            .map(|&ti| {
                let row = (((-ti + FRAC_PI_2) / PI) * nt as f64) as usize;
                (0..nt * np).map(|b| if b / np == row { Rgb::splat(10.0) } else { Rgb::ZERO }).collect()
            })
            .collect();
        let m = Measured::new(MeasuredTable { theta_in, bins_theta: nt, bins_phi: np, f }).unwrap();
        let wo = fiberlab_math::frame::direction(9f64.to_radians(), 0.4);
        let w = crate::radiometry::furnace(&m, wo, &crate::radiometry::Quadrature { theta: 14400, phi: 72, h: 1 })[0];
        let mut rng = fiberlab_check::rng::TestRng::new(29);
        let (mut max, mut mean) = (0.0f64, 0.0);
        for _ in 0..40000 {
            let weight = m.sample(wo, 0.0, rng.u4()).map_or(0.0, |s| s.weight[0]);
            max = max.max(weight);
            mean += weight / 40000.0;
        }
        assert!(max < 4.0 * w, "largest weight {max}, furnace {w}");
        assert!((mean - w).abs() < 0.03 * w, "mean weight {mean}, furnace {w}");
    }

    /// At grazing viewers (0.9° from the axis) a fiber's lobes crowd onto the axis, where a
    /// table's steps do too: `∫pdf dω` and the camera-side furnace by a midpoint rule fine
    /// enough for the steps (1,600 rows per bin; the check harness's 256 rows integrate this
    /// furnace 0.6 % high, `GRAZING_QUADRATURE_REPORTED` in `crates/check`) against 1 and
    /// against the mean sampling weight.
    #[test]
    fn grazing_furnace_and_pdf_by_a_fine_rule() {
        use crate::kajiya_kay_1989::{KajiyaKay, KajiyaKayParams};
        use fiberlab_math::frame::direction;
        let kk = KajiyaKay::new(KajiyaKayParams { k_d: Rgb::splat(0.03), k_s: Rgb::splat(0.2), p: 8.0 }).unwrap();
        let (nt, np) = (90, 72);
        let theta_in: Vec<f64> = (-7..=7).map(|k| f64::from(k) * 0.2).collect();
        let m = Measured::new(MeasuredTable::of_function(&kk, theta_in, nt, np)).unwrap();
        for theta_o in [1.555, -1.555] {
            let wo = direction(theta_o, 0.3);
            // Piecewise constant in φ over the table's bins: one point per bin is exact.
            let rows = nt * 400;
            let (mut total, mut furnace) = (0.0, 0.0);
            for i in 0..rows {
                let t = -FRAC_PI_2 + (i as f64 + 0.5) * PI / rows as f64;
                let area = t.cos() * PI / rows as f64 * TAU / np as f64;
                for b in 0..np {
                    let wi =
                        direction_from_sin_cos(t.sin(), t.cos(), phi(wo) - (-PI + (b as f64 + 0.5) * TAU / np as f64));
                    total += m.pdf(wi, wo, 0.0) * area;
                    furnace += m.eval(wi, wo, 0.0).luminance() * t.cos() * area;
                }
            }
            assert!((total - 1.0).abs() < 1e-5, "θ_o = {theta_o}: ∫ pdf = {total}");
            let mut rng = fiberlab_check::rng::TestRng::new(3);
            let n = 200_000;
            let (mut sum, mut sq) = (0.0, 0.0);
            for _ in 0..n {
                let w = m.sample(wo, 0.0, rng.u4()).map_or(0.0, |s| s.weight.luminance());
                sum += w;
                sq += w * w;
            }
            let mean = sum / f64::from(n);
            let se = ((sq / f64::from(n) - mean * mean) / f64::from(n)).sqrt();
            assert!(
                (mean - furnace).abs() < 5.0 * se + 1e-4 * furnace,
                "θ_o = {theta_o}: MC {mean} ± {se}, quadrature {furnace}"
            );
        }
    }

    /// The pdf integrates to 1 over the sphere and `sample` agrees with `pdf` and `eval`.
    #[test]
    fn pdf_integrates_to_one_and_sampling_agrees() {
        let m = Measured::new(cone_table(&[-30.0, 0.0, 40.0], 45)).unwrap();
        for theta_o in [-0.9, -0.2, 0.35, 1.2] {
            let wo = fiberlab_math::frame::direction(theta_o, 0.7);
            // Midpoint rule in (θ_i, φ), where `pdf·cosθ_i` is bounded: piecewise constant in
            // φ over the table's 36 bins (so one point per bin is exact), piecewise smooth in
            // θ_i with steps at the bin edges moved along the cone, which a fine rule needs
            // (at 64 points per bin the steps alone leave 2e−4).
            let (nt, np) = (45 * 2048, 36);
            let mut total = 0.0;
            for i in 0..nt {
                let t = -FRAC_PI_2 + (i as f64 + 0.5) * PI / nt as f64;
                for b in 0..np {
                    let rel = -PI + (b as f64 + 0.5) * TAU / np as f64;
                    let wi = direction_from_sin_cos(t.sin(), t.cos(), phi(wo) + rel);
                    total += m.pdf(wi, wo, 0.0) * t.cos() * PI / nt as f64 * TAU / np as f64;
                }
            }
            assert!((total - 1.0).abs() < 1e-4, "θ_o = {theta_o}: ∫ pdf = {total}");
            let mut rng = fiberlab_check::rng::TestRng::new(17);
            for _ in 0..500 {
                let u = rng.u4();
                let s = m.sample(wo, 0.0, u).unwrap();
                assert!((s.pdf - m.pdf(s.wi, wo, 0.0)).abs() <= 1e-12 * s.pdf);
                let expect = m.eval(s.wi, wo, 0.0) * (cos_theta(s.wi) / s.pdf);
                assert!((s.weight - expect).max_component().abs() <= 1e-12 * expect.max_component().max(1.0));
            }
        }
    }
}
