//! Precomputed tables of the dual scattering approximation (Zinke, Yuksel, Weber and Keyser
//! 2008, *Dual scattering approximation for fast multiple scattering in hair*, SIGGRAPH):
//! the average forward and backward attenuations ā_f(θ), ā_b(θ) and the backscatter
//! attenuation Ā_b(θ), per colour channel, as functions of the light's inclination θ
//! (Marschner's θ_i: the inclination of the incident light, not a difference angle).
//!
//! Pure math, deterministic midpoint quadrature (no Monte Carlo). Conventions are those of
//! `docs/theory/conventions.md`: θ from the fiber's normal plane, φ about the fiber axis,
//! `ω_i` toward the light, `f_s` in sr⁻¹ with the *outgoing* cosine `cosθ_r` in the albedo.
//!
//! # Definitions (per colour channel)
//! The light comes from azimuths `φ_i ∈ H = [−π/2, π/2]` (one half-circle of the fiber);
//! the backward half of outgoing azimuths is that same half `B = [−π/2, π/2]`, the forward
//! half the opposite one `F = [π/2, 3π/2]`. The paper's eqs. 6 and 12 then read
//!
//! `ā_f(θ) = (1/π) ∫_H dφ_i ∫_F dφ_r ∫_{−π/2}^{π/2} dθ_r f_s(θ, φ_i; θ_r, φ_r) cos²θ_r`
//!
//! and `ā_b` with `B` in place of `F`: the incident azimuth is *averaged* (the `1/π`) over
//! the half-circle the light can arrive from, the outgoing direction is *integrated* over
//! the forward or backward half-sphere (`cos²θ_r dθ_r dφ_r = cosθ_r dω_r`). Hence
//! `ā_f + ā_b = ρ̄(θ) = (1/π) ∫_H ρ(θ, φ_i) dφ_i`, the light-side albedo
//! `ρ = ∫ f_s cosθ_r dω_r` averaged over H — 1 for a lossless model.
//!
//! Near-field models are averaged over the offset `h ∈ [−1, 1]` (their far-field form), by
//! midpoints in `u` with `h = sin u` (smooth at the fiber's edges).
//!
//! The backscatter attenuation (paper eqs. 11, 13, 14) sums the paths with one or three
//! backward events and any even number of forward events:
//! `Ā_b = ā_b ā_f²/(1 − ā_f²) + ā_b³ ā_f²/(1 − ā_f²)³`, with `ā_f` clamped to
//! `≤ 1 −` [`MAX_FORWARD_GAP`] so that it stays finite for white hair (`ā_f → 1`), and `ā_f`,
//! `ā_b` scaled to sum to 1 where they sum to more (see [`backscatter_attenuation`]); the
//! tables keep the unscaled `ā_f`, `ā_b`.
//!
//! Not yet here: the lobe-weighted shifts and widths (ᾱ_f, β̄_f, ᾱ_b, β̄_b) and from them the
//! backscatter shift Δ̄_b and spread σ̄_b (they need per-lobe contributions, which
//! [`ScatteringFunction`] does not expose).

use crate::{Field, Lobes, ScatteringFunction};
use fiberlab_math::Rgb;
use fiberlab_math::frame::direction_from_sin_cos;
use rayon::prelude::*;
use std::f64::consts::{FRAC_PI_2, PI};
use thiserror::Error;

/// `ā_f` is clamped to at most `1 − MAX_FORWARD_GAP` in the backscatter sums.
pub const MAX_FORWARD_GAP: f64 = 1e-9;

/// Why tables cannot be built.
#[non_exhaustive]
#[derive(Clone, Debug, Error, PartialEq)]
pub enum DualTablesError {
    /// The model concentrates its light on a cone (a delta in θ): it has no density that the
    /// quadrature could integrate, and no far-field lobes for dual scattering.
    #[error(
        "model has delta lobes (light on a cone, no density): dual-scattering tables need a smooth far-field model"
    )]
    DeltaLobes,
    /// A resolution of zero, or an odd number of outgoing-azimuth cells (the forward and
    /// backward halves must split on a cell boundary).
    #[error("bad resolution: {0}")]
    Resolution(String),
    /// The model returned a value that is not finite.
    #[error("the model's integral is not finite at θ = {theta_deg:.3}°")]
    NotFinite {
        /// The light inclination of the failing node, degrees.
        theta_deg: f64,
    },
}

/// Quadrature resolution of [`DualTables::new`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Resolution {
    /// Table nodes: midpoints of equal cells over the light inclination `(−π/2, π/2)`.
    pub inclinations: usize,
    /// Midpoint cells of the incident azimuth over H (π wide).
    pub incident_azimuths: usize,
    /// Midpoint cells of the outgoing inclination over `(−π/2, π/2)`.
    pub outgoing_inclinations: usize,
    /// Midpoint cells of the outgoing azimuth over the whole circle (even).
    pub outgoing_azimuths: usize,
    /// Midpoint cells of u with h = sin u (near-field models only).
    pub offsets: usize,
}

impl Default for Resolution {
    fn default() -> Self {
        Self { inclinations: 64, incident_azimuths: 16, outgoing_inclinations: 128, outgoing_azimuths: 128, offsets: 8 }
    }
}

/// One table row: the values at one light inclination.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DualTableRow {
    /// Light inclination θ (radians).
    pub theta: f64,
    /// Average forward attenuation ā_f.
    pub forward: Rgb,
    /// Average backward attenuation ā_b.
    pub backward: Rgb,
    /// Backscatter attenuation Ā_b (eqs. 11, 13, 14).
    pub backscatter: Rgb,
}

/// The dual-scattering tables of one model, indexed by the light's inclination.
#[derive(Clone, Debug, PartialEq)]
pub struct DualTables {
    rows: Vec<DualTableRow>,
    resolution: Resolution,
}

/// `Ā_b = ā_b ā_f²/(1 − ā_f²) + ā_b³ ā_f²/(1 − ā_f²)³` (one channel). The series it sums
/// assumes each fiber loses energy, so when `ā_f + ā_b > 1` (a model whose light-side albedo
/// exceeds 1, e.g. Chiang 2016 near grazing light) both are first scaled to sum to 1; then
/// `ā_f ≤ 1 − MAX_FORWARD_GAP`. With `ā_b ≤ 1 − ā_f` both terms stay bounded as `ā_f → 1`
/// (their limits are ½ and ⅛).
#[must_use]
pub fn backscatter_attenuation(forward: f64, backward: f64) -> f64 {
    let (forward, backward) = (forward.max(0.0), backward.max(0.0));
    let total = forward + backward;
    let (forward, backward) = if total > 1.0 { (forward / total, backward / total) } else { (forward, backward) };
    let af = forward.min(1.0 - MAX_FORWARD_GAP);
    let af2 = af * af;
    let gap = 1.0 - af2;
    backward * af2 / gap + backward.powi(3) * af2 / gap.powi(3)
}

impl DualTables {
    /// Tables of `f` by midpoint quadrature at `resolution`; refuses delta models.
    pub fn new(f: &(impl ScatteringFunction + ?Sized), resolution: &Resolution) -> Result<Self, DualTablesError> {
        let props = f.properties();
        if props.lobes == Lobes::Delta {
            return Err(DualTablesError::DeltaLobes);
        }
        let r = *resolution;
        if r.inclinations == 0 || r.incident_azimuths == 0 || r.outgoing_inclinations == 0 || r.offsets == 0 {
            return Err(DualTablesError::Resolution(format!("every cell count must be ≥ 1, got {r:?}")));
        }
        if r.outgoing_azimuths < 2 || !r.outgoing_azimuths.is_multiple_of(2) {
            return Err(DualTablesError::Resolution(format!(
                "outgoing_azimuths must be even and ≥ 2, got {}",
                r.outgoing_azimuths
            )));
        }
        let offsets: Vec<(f64, f64)> = if props.field == Field::Near {
            // h = sin u, u midpoints over (−π/2, π/2): the path lengths inside the fiber go as
            // √(1 − h²) near the edges, which midpoints in h resolve slowly; in u they are smooth.
            let du = PI / r.offsets as f64;
            (0..r.offsets)
                .map(|k| {
                    let u = -FRAC_PI_2 + (k as f64 + 0.5) * du;
                    (u.sin(), 0.5 * u.cos() * du)
                })
                .collect()
        } else {
            vec![(0.0, 1.0)]
        };
        let dt = PI / r.inclinations as f64;
        let rows = (0..r.inclinations)
            .into_par_iter()
            .map(|a| {
                let theta = -FRAC_PI_2 + (a as f64 + 0.5) * dt;
                let (forward, backward) = half_integrals(f, theta, &r, &offsets);
                if !(forward.is_finite() && backward.is_finite()) {
                    return Err(DualTablesError::NotFinite { theta_deg: theta.to_degrees() });
                }
                let backscatter = Rgb::new(
                    backscatter_attenuation(forward[0], backward[0]),
                    backscatter_attenuation(forward[1], backward[1]),
                    backscatter_attenuation(forward[2], backward[2]),
                );
                Ok(DualTableRow { theta, forward, backward, backscatter })
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Self { rows, resolution: r })
    }

    /// The rows, in increasing θ.
    #[must_use]
    pub fn rows(&self) -> &[DualTableRow] {
        &self.rows
    }

    /// The resolution the tables were built with.
    #[must_use]
    pub fn resolution(&self) -> &Resolution {
        &self.resolution
    }
}

/// `(ā_f, ā_b)` at light inclination `theta` (see the module documentation).
fn half_integrals(
    f: &(impl ScatteringFunction + ?Sized),
    theta: f64,
    r: &Resolution,
    offsets: &[(f64, f64)],
) -> (Rgb, Rgb) {
    let (st, ct) = theta.sin_cos();
    let dpi = PI / r.incident_azimuths as f64;
    let dtr = PI / r.outgoing_inclinations as f64;
    let dpr = 2.0 * PI / r.outgoing_azimuths as f64;
    let half = r.outgoing_azimuths / 2;
    let (mut forward, mut backward) = (Rgb::ZERO, Rgb::ZERO);
    for i in 0..r.incident_azimuths {
        let phi_i = -FRAC_PI_2 + (i as f64 + 0.5) * dpi;
        let wi = direction_from_sin_cos(st, ct, phi_i);
        for k in 0..r.outgoing_inclinations {
            let theta_r = -FRAC_PI_2 + (k as f64 + 0.5) * dtr;
            let (sr, cr) = theta_r.sin_cos();
            // (1/π)·dφ_i · cos²θ_r dθ_r dφ_r
            let weight = dpi / PI * cr * cr * dtr * dpr;
            for j in 0..r.outgoing_azimuths {
                // j < half: φ_r ∈ B = [−π/2, π/2]; j ≥ half: φ_r ∈ F = [π/2, 3π/2].
                let phi_r = -FRAC_PI_2 + (j as f64 + 0.5) * dpr;
                let wr = direction_from_sin_cos(sr, cr, phi_r);
                let mut value = Rgb::ZERO;
                for &(h, wh) in offsets {
                    value += f.eval(wi, wr, h) * wh;
                }
                if j < half {
                    backward += value * weight;
                } else {
                    forward += value * weight;
                }
            }
        }
    }
    (forward, backward)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::radiometry::{Quadrature, albedo};
    use fiberlab_math::frame::direction;

    fn small() -> Resolution {
        Resolution {
            inclinations: 6,
            incident_azimuths: 2,
            outgoing_inclinations: 160,
            outgoing_azimuths: 160,
            offsets: 24,
        }
    }

    /// Independent: the light-side albedo over the whole sphere by the radiometry module's
    /// quadrature (its own grid, midpoints in h, many of them), at one incident azimuth
    /// inside H (a circular fiber's albedo does not depend on it).
    fn averaged_albedo(f: &impl ScatteringFunction, theta: f64) -> Rgb {
        albedo(f, direction(theta, 0.3), &Quadrature { theta: 200, phi: 200, h: 400 })
    }

    #[test]
    fn lossless_diffuse_splits_in_halves_and_sums_to_one() {
        // A constant f_s scatters half of its light into each half-sphere: ā_f = ā_b = ½.
        let f = crate::build("diffuse", &[("albedo", "1")]).unwrap();
        let t = DualTables::new(&f, &small()).unwrap();
        assert_eq!(t.rows().len(), 6);
        for row in t.rows() {
            for c in 0..3 {
                assert!((row.forward[c] - 0.5).abs() < 1e-3, "θ = {}: ā_f = {}", row.theta, row.forward[c]);
                assert!((row.backward[c] - 0.5).abs() < 1e-3, "θ = {}: ā_b = {}", row.theta, row.backward[c]);
                assert!(row.backscatter[c].is_finite(), "Ā_b not finite at θ = {}", row.theta);
            }
        }
    }

    #[test]
    fn lossless_untilted_chiang_near_one_at_moderate_inclination() {
        // Chiang's light-side albedo is not exactly 1 (the model is not reciprocal; its
        // normalisation is on the camera side): 0.99–1.002 for |θ| ≤ 52.5° without tilt.
        let f = crate::build("chiang", &[("sigma_a", "0"), ("alpha", "0")]).unwrap();
        let t = DualTables::new(&f, &Resolution { inclinations: 12, ..small() }).unwrap();
        for row in t.rows().iter().filter(|r| r.theta.abs() < 1.0) {
            let sum = row.forward + row.backward;
            assert!((sum[0] - 1.0).abs() < 1.5e-2, "θ = {}: ā_f + ā_b = {}", row.theta, sum[0]);
            assert!(row.forward[0] > row.backward[0], "lossless hair scatters mostly forward");
        }
    }

    #[test]
    fn sum_matches_brute_force_albedo() {
        for (name, pairs) in [
            ("marschner", vec![("sigma_a", "0.3,0.6,1.2")]),
            ("deon", vec![("sigma_a", "0.2,0.5,1.0")]),
            ("chiang", vec![("sigma_a", "0.4,0.8,1.6")]),
        ] {
            let f = crate::build(name, &pairs).unwrap();
            let t = DualTables::new(&f, &small()).unwrap();
            // Near grazing light both quadratures are under-resolved: compare |θ| ≤ 45°.
            for row in t.rows().iter().filter(|r| r.theta.abs() < 1.0) {
                let want = averaged_albedo(&f, row.theta);
                let got = row.forward + row.backward;
                for c in 0..3 {
                    assert!((got[c] - want[c]).abs() < 2e-3, "{name} θ = {}: {} vs {}", row.theta, got[c], want[c]);
                    assert!(row.forward[c] > 0.0 && row.backward[c] > 0.0, "{name}: empty half");
                }
            }
        }
    }

    #[test]
    fn backscatter_finite_as_forward_tends_to_one() {
        // Lossless, ā_b = 1 − ā_f: Ā_b → ½ + ⅛ as ā_f → 1.
        for af in [0.999, 0.99999, 0.9999999] {
            let ab = backscatter_attenuation(af, 1.0 - af);
            assert!((ab - 0.625).abs() < 2e-3, "ā_f = {af}: Ā_b = {ab}");
        }
        // ā_f = 1 exactly (the clamp) and just above it stay finite.
        for (af, ab) in [(1.0, 0.0), (1.0 + 1e-9, 0.0), (1.0, 1e-12)] {
            let v = backscatter_attenuation(af, ab);
            assert!(v.is_finite() && (0.0..1.0).contains(&v), "({af}, {ab}): {v}");
        }
        // More than lossless (ā_f + ā_b > 1) is scaled back: (1.2, 0.8) behaves as (0.6, 0.4).
        assert!((backscatter_attenuation(1.2, 0.8) - backscatter_attenuation(0.6, 0.4)).abs() < 1e-15);
        assert!(backscatter_attenuation(2.0, 1.9).is_finite() && backscatter_attenuation(2.0, 1.9) < 1.0);
        // Closed form at a regular point: ā_f = 0.5, ā_b = 0.2.
        let want = 0.2 * 0.25 / 0.75 + 0.008 * 0.25 / 0.75_f64.powi(3);
        assert!((backscatter_attenuation(0.5, 0.2) - want).abs() < 1e-15);
    }

    #[test]
    fn refuses_delta_models_and_bad_resolution() {
        let specular = crate::build::<&str, &str>("specular", &[]).unwrap();
        assert_eq!(DualTables::new(&specular, &small()), Err(DualTablesError::DeltaLobes));
        let chiang = crate::build::<&str, &str>("chiang", &[]).unwrap();
        let odd = Resolution { outgoing_azimuths: 7, ..small() };
        assert!(matches!(DualTables::new(&chiang, &odd), Err(DualTablesError::Resolution(_))));
        let zero = Resolution { inclinations: 0, ..small() };
        assert!(matches!(DualTables::new(&chiang, &zero), Err(DualTablesError::Resolution(_))));
    }
}
