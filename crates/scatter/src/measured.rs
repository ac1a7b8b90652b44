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
//! **Sampling** uses Helmholtz reciprocity as a proposal, with the slices moved along the
//! specular cone as `eval` moves them: given `ω_o`, a slice `k` around `θ_o` is chosen with
//! its interpolation weight and a bin with probability ∝ `lum(T_k)·∫_bin cosθ dω`, then a
//! point `x` uniform (in solid angle) within the bin's φ range and its θ range widened by one
//! row on each side, translated to `θ_i = x + θ_k − θ_o` (the reciprocal of `eval`'s read at
//! `θ_o + θ_i − θ_k`). Without the translation a narrow TT lobe between two slices is
//! proposed at the slices' positions; without the widening a lobe narrower than a bin, which
//! the bins of neighbouring slices quantize up to one row apart, is missed where `eval` takes
//! it from the other slice; either way it is found only by the defensive lobe, with weights of
//! hundreds. A translated point beyond ±π/2 is replaced by a draw from the ideal diffuse
//! fiber's lobe, and a defensive fraction [`DEFENSIVE`] of the samples comes from that lobe
//! too, so the pdf is positive wherever `f_s` can be. The pdf is exactly the density of that
//! mixture (per steradian, `Σ p_bin·cos x/(Ω_widened·cosθ_i)` over the three rows whose
//! widened span holds x, growing like 1/cosθ_i toward the axis, [`crate::MIN_COS`] on it) and
//! the weight is `f_s cosθ_i/pdf`. Far-field, smooth; reciprocity and energy hold only as well as
//! the measurement does, so neither is claimed.

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
/// pdf is positive wherever `f_s` may be (the table proposal is zero where the reciprocal
/// slice is).
pub const DEFENSIVE: f64 = 0.1;

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
    /// Per slice: cumulative bin probabilities (length bins + 1, last = 1 or 0).
    cdf: Arc<Vec<Vec<f64>>>,
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
        let cdf = table
            .f
            .iter()
            .map(|slice| {
                let mut c = Vec::with_capacity(cells + 1);
                c.push(0.0);
                let mut acc = 0.0;
                for (k, v) in slice.iter().enumerate() {
                    acc += v.luminance().max(0.0) * row_cos_solid_angle(&table, k / table.bins_phi);
                    c.push(acc);
                }
                if acc > 0.0 {
                    c.iter_mut().for_each(|x| *x /= acc);
                }
                c
            })
            .collect();
        Ok(Self { table: Arc::new(table), cdf: Arc::new(cdf) })
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

    /// Slices around `theta` (an incidence) and the weight of the upper one.
    fn slices(&self, theta_o: f64) -> (usize, usize, f64) {
        let t = &self.table.theta_in;
        if theta_o <= t[0] {
            return (0, 0, 0.0);
        }
        if theta_o >= t[t.len() - 1] {
            return (t.len() - 1, t.len() - 1, 0.0);
        }
        let k = t.partition_point(|&x| x <= theta_o) - 1;
        (k, k + 1, (theta_o - t[k]) / (t[k + 1] - t[k]))
    }

    /// Slice `k` moved along the specular cone to light at `theta_i` (see the module docs),
    /// read at outgoing inclination `theta_o` and relative azimuth `phi_rel`.
    fn shifted(&self, k: usize, theta_i: f64, theta_o: f64, phi_rel: f64) -> Rgb {
        let x = theta_o + theta_i - self.table.theta_in[k];
        if x.abs() > FRAC_PI_2 { Rgb::ZERO } else { self.table.f[k][self.bin(x, phi_rel)] }
    }

    /// Density of the table proposal (reciprocal slices around `θ_o`, translated; a slice with
    /// no mass proposes the ideal diffuse fiber's lobe instead).
    fn table_pdf(&self, wi: DVec3, wo: DVec3) -> f64 {
        let theta_o = theta(wo);
        let (k0, k1, t) = self.slices(theta_o);
        let phi_rel = relative_phi(wo, wi);
        let diffuse = cos_theta_pdf(cos_theta(wi));
        let slice_pdf = |k: usize| {
            if self.cdf[k][self.cdf[k].len() - 1] <= 0.0 {
                return diffuse;
            }
            let shift = self.table.theta_in[k] - theta_o;
            let x = theta(wi) - shift;
            let in_table = if x.abs() <= FRAC_PI_2 {
                // The widened spans of the row of x and its two neighbours contain x.
                let (nt, np) = (self.table.bins_theta, self.table.bins_phi);
                let b = self.bin(x, phi_rel);
                let (row, j) = (b / np, b % np);
                let dphi = TAU / np as f64;
                let density: f64 = (row.saturating_sub(1)..=(row + 1).min(nt - 1))
                    .map(|r| {
                        let (lo, hi) = self.widened_span(r);
                        self.bin_probability(k, r * np + j) / ((hi - lo) * dphi)
                    })
                    .sum();
                density * x.cos() / cos_theta(wi).max(crate::MIN_COS)
            } else {
                0.0
            };
            in_table + self.mass_beyond_pole(k, shift) * diffuse
        };
        slice_pdf(k0) * (1.0 - t) + if t > 0.0 { slice_pdf(k1) * t } else { 0.0 }
    }

    /// `[sin lo, sin hi]` of row `row` widened by one row on each side (within the table):
    /// where the proposal places `x` for a bin of that row.
    fn widened_span(&self, row: usize) -> (f64, f64) {
        let nt = self.table.bins_theta;
        let dt = PI / nt as f64;
        let lo = -FRAC_PI_2 + row.saturating_sub(1) as f64 * dt;
        let hi = -FRAC_PI_2 + ((row + 2).min(nt)) as f64 * dt;
        (lo.sin(), hi.sin())
    }

    /// Where `x` drawn for row `row` (uniform in its widened `[sin lo, sin hi]`) leaves
    /// [−π/2, π/2] when translated by `shift`: the fraction of the span beyond, and the
    /// threshold `sin x*`.
    fn row_beyond_pole(&self, row: usize, shift: f64) -> (f64, f64) {
        let (sa, sb) = self.widened_span(row);
        if shift > 0.0 {
            let limit = (FRAC_PI_2 - shift).sin();
            (((sb - limit.max(sa)) / (sb - sa)).clamp(0.0, 1.0), limit)
        } else if shift < 0.0 {
            let limit = (-FRAC_PI_2 - shift).sin();
            (((limit.min(sb) - sa) / (sb - sa)).clamp(0.0, 1.0), limit)
        } else {
            (0.0, 0.0)
        }
    }

    /// Probability that slice `k`'s proposal, translated by `shift`, leaves [−π/2, π/2].
    fn mass_beyond_pole(&self, k: usize, shift: f64) -> f64 {
        if shift == 0.0 {
            return 0.0;
        }
        let (nt, np) = (self.table.bins_theta, self.table.bins_phi);
        let c = &self.cdf[k];
        let mut mass = 0.0;
        // Walk from the pole the shift pushes past toward the equator (no allocation per pdf call).
        for step in 0..nt {
            let row = if shift > 0.0 { nt - 1 - step } else { step };
            let (fraction, _) = self.row_beyond_pole(row, shift);
            if fraction <= 0.0 {
                break;
            }
            mass += fraction * (c[(row + 1) * np] - c[row * np]);
        }
        mass
    }

    fn bin(&self, theta_out: f64, phi_rel: f64) -> usize {
        let (nt, np) = (self.table.bins_theta, self.table.bins_phi);
        let i = (((theta_out + FRAC_PI_2) / PI * nt as f64) as usize).min(nt - 1);
        let j = (((phi_rel + PI) / TAU * np as f64) as usize).min(np - 1);
        i * np + j
    }

    fn bin_probability(&self, slice: usize, bin: usize) -> f64 {
        let c = &self.cdf[slice];
        c[bin + 1] - c[bin]
    }
}

/// `∫ cosθ dω` over one bin of row `i`.
fn row_cos_solid_angle(t: &MeasuredTable, i: usize) -> f64 {
    let nt = t.bins_theta as f64;
    let a = -FRAC_PI_2 + i as f64 * PI / nt;
    let b = a + PI / nt;
    let prim = |x: f64| 0.5 * x + 0.25 * (2.0 * x).sin();
    (prim(b) - prim(a)) * TAU / t.bins_phi as f64
}

impl ScatteringFunction for Measured {
    fn properties(&self) -> Properties {
        Properties { reciprocal: false, energy_conserving: false, field: Field::Far, lobes: Lobes::Smooth }
    }

    fn eval(&self, wi: DVec3, wo: DVec3, _h: f64) -> Rgb {
        let (theta_i, theta_o, phi_rel) = (theta(wi), theta(wo), relative_phi(wi, wo));
        let (k0, k1, t) = self.slices(theta_i);
        let lower = self.shifted(k0, theta_i, theta_o, phi_rel);
        if t == 0.0 { lower } else { lower * (1.0 - t) + self.shifted(k1, theta_i, theta_o, phi_rel) * t }
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
        // Lobe 0: the table; lobe 1: the ideal diffuse fiber's lobe (the defensive fraction,
        // an empty slice, and the part of a bin beyond the pole).
        let mut lobe = 1;
        let wi = if u[0] < DEFENSIVE {
            cos_theta_direction(u[1], u[2], TAU * u[3])
        } else {
            let theta_o = theta(wo);
            let (k0, k1, t) = self.slices(theta_o);
            let u0 = (u[0] - DEFENSIVE) / (1.0 - DEFENSIVE);
            let slice = if u0 < t { k1 } else { k0 };
            let c = &self.cdf[slice];
            if c[c.len() - 1] <= 0.0 {
                cos_theta_direction(u[1], u[2], TAU * u[3])
            } else {
                let b = (c.partition_point(|&x| x <= u[1]).max(1) - 1).min(c.len() - 2);
                let np = self.table.bins_phi;
                let (i, j) = (b / np, b % np);
                let (sa, sb) = self.widened_span(i);
                let s = (sa + u[2] * (sb - sa)).clamp(-1.0, 1.0);
                let shift = self.table.theta_in[slice] - theta_o;
                let theta_i = s.asin() + shift;
                if theta_i.abs() <= FRAC_PI_2 {
                    lobe = 0;
                    let rel = -PI + (j as f64 + u[3]) * TAU / np as f64;
                    let (si, ci) = theta_i.sin_cos();
                    direction_from_sin_cos(si, ci.max(0.0), phi(wo) + rel)
                } else {
                    // Beyond the pole: the ideal diffuse fiber's lobe, from uniforms that are
                    // fresh given this outcome (u[1] within the bin, u[2] within the part of
                    // the bin beyond the pole).
                    let (lo, hi) = (c[b], c[b + 1]);
                    let fresh1 = if hi > lo { ((u[1] - lo) / (hi - lo)).clamp(0.0, 1.0) } else { 0.5 };
                    let (_, limit) = self.row_beyond_pole(i, shift);
                    let cut = ((limit - sa) / (sb - sa)).clamp(0.0, 1.0);
                    let fresh2 = if shift > 0.0 {
                        if cut < 1.0 { ((u[2] - cut) / (1.0 - cut)).clamp(0.0, 1.0) } else { 0.5 }
                    } else if cut > 0.0 {
                        (u[2] / cut).clamp(0.0, 1.0)
                    } else {
                        0.5
                    };
                    cos_theta_direction(fresh1, fresh2, TAU * u[3])
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

    /// The pdf integrates to 1 over the sphere and `sample` agrees with `pdf` and `eval`.
    #[test]
    fn pdf_integrates_to_one_and_sampling_agrees() {
        let m = Measured::new(cone_table(&[-30.0, 0.0, 40.0], 45)).unwrap();
        for theta_o in [-0.9, -0.2, 0.35, 1.2] {
            let wo = fiberlab_math::frame::direction(theta_o, 0.7);
            // Midpoint rule in (θ_i, φ), where `pdf·cosθ_i` is bounded (the table part is
            // piecewise smooth, with steps at the translated bin edges).
            let (nt, np) = (45 * 64, 36 * 8);
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
