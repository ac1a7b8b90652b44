//! A measured (tabulated) scattering function, e.g. from the virtual goniophotometer: bin
//! values of `f_s` over (θ_r, φ) for a set of incidence inclinations, usable like any model.
//!
//! | parameter | unit | default | range |
//! |---|---|---|---|
//! | `table` | path | — | a `fiberlab measure` CSV (loaded by the command line or scene loader) |
//!
//! # Formula
//! Bins are uniform in θ_out ∈ [−π/2, π/2] and φ = φ_out − φ_in ∈ [−π, π]; between measured
//! incidences `f_s` is interpolated linearly in θ_in (clamped outside the measured range).
//! The table is used through Helmholtz reciprocity, `f_s(ω_i, ω_o) = T(θ_in = θ_o; θ_i,
//! φ_i − φ_o)`, so that sampling `ω_i` given `ω_o` draws from the measured distribution of
//! the slice(s) at `θ_o`: a slice is chosen with its interpolation weight, a bin with
//! probability ∝ `lum(T)·∫_bin cosθ dω`, then a uniform direction (in solid angle) within
//! the bin. The pdf is exactly that mixture's density. Far-field, smooth; reciprocity and
//! energy hold only as well as the measurement does, so neither is claimed.

use crate::params::{ParamKind, ParamSet, ParamSpec};
use crate::{ExternalData, Field, Lobes, Model, ModelError, ModelSpec, Properties, Sample, ScatteringFunction};
use fiberlab_math::frame::{direction_from_sin_cos, phi, relative_phi, theta};
use fiberlab_math::{DVec3, Rgb};
use std::f64::consts::{FRAC_PI_2, PI, TAU};
use std::sync::Arc;
use thiserror::Error;

/// Registry entry: `measured`. Building it needs the table's data, which the I/O layer
/// loads; [`crate::build`] alone reports how to provide it.
pub const SPEC: ModelSpec = ModelSpec {
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
    build: |_: &ParamSet| Err(ModelError::NeedsData { model: "measured", key: "table" }),
};

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

    /// Slices around θ_o and the weight of the upper one.
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

    fn bin(&self, theta_out: f64, phi_rel: f64) -> usize {
        let (nt, np) = (self.table.bins_theta, self.table.bins_phi);
        let i = (((theta_out + FRAC_PI_2) / PI * nt as f64) as usize).min(nt - 1);
        let j = (((phi_rel + PI) / TAU * np as f64) as usize).min(np - 1);
        i * np + j
    }

    /// Solid angle of a bin in row `i`.
    fn bin_solid_angle(&self, i: usize) -> f64 {
        let nt = self.table.bins_theta as f64;
        let a = -FRAC_PI_2 + i as f64 * PI / nt;
        ((a + PI / nt).sin() - a.sin()) * TAU / self.table.bins_phi as f64
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
        let (k0, k1, t) = self.slices(theta(wo));
        let b = self.bin(theta(wi), relative_phi(wo, wi));
        self.table.f[k0][b] * (1.0 - t) + self.table.f[k1][b] * t
    }

    fn pdf(&self, wi: DVec3, wo: DVec3, _h: f64) -> f64 {
        let (k0, k1, t) = self.slices(theta(wo));
        let b = self.bin(theta(wi), relative_phi(wo, wi));
        let p = self.bin_probability(k0, b) * (1.0 - t) + self.bin_probability(k1, b) * t;
        p / self.bin_solid_angle(b / self.table.bins_phi)
    }

    fn sample(&self, wo: DVec3, h: f64, u: [f64; 4]) -> Option<Sample> {
        let (k0, k1, t) = self.slices(theta(wo));
        let slice = if u[0] < t { k1 } else { k0 };
        let c = &self.cdf[slice];
        if c[c.len() - 1] <= 0.0 {
            return None;
        }
        let b = (c.partition_point(|&x| x <= u[1]).max(1) - 1).min(c.len() - 2);
        let (nt, np) = (self.table.bins_theta, self.table.bins_phi);
        let (i, j) = (b / np, b % np);
        let a = -FRAC_PI_2 + i as f64 * PI / nt as f64;
        let (sa, sb) = (a.sin(), (a + PI / nt as f64).sin());
        let s = (sa + u[2] * (sb - sa)).clamp(-1.0, 1.0);
        let rel = -PI + (j as f64 + u[3]) * TAU / np as f64;
        let wi = direction_from_sin_cos(s, (1.0 - s * s).max(0.0).sqrt(), phi(wo) + rel);
        let pdf = self.pdf(wi, wo, h);
        if pdf <= 0.0 {
            return None;
        }
        let weight = self.eval(wi, wo, h) * ((1.0 - s * s).max(0.0).sqrt() / pdf);
        Some(Sample { wi, weight, pdf, delta: false })
    }
}

impl From<Measured> for Model {
    fn from(m: Measured) -> Self {
        Model::Measured(m)
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
}
