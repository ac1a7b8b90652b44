//! A scattering function as numbers one can draw: `f_s` (or a surface's `f_r`) over a grid of
//! outgoing directions at one incidence, its azimuthal distribution, and its values on the
//! specular cone (for a surface: on the ring of the light's inclination). `fiberlab plot`, the
//! difference figures of `compare-model` and `fit`, the explorer and Python all draw these.

use fiberlab_math::DVec3;
use fiberlab_math::frame::direction;
use fiberlab_scatter::{Lobes, Model, ScatteringFunction, SurfaceModel, SurfaceScattering};
use rayon::prelude::*;
use serde::Serialize;
use std::f64::consts::{FRAC_PI_2, PI, TAU};

/// Columns of a map: 2° in φ over [−180°, 180°).
pub const COLS: usize = 180;
/// Rows of a map: 2° in θ_r over [−90°, 90°] (fibers) or [0°, 90°] (surfaces).
pub const ROWS: usize = 90;
/// Samples in φ of the azimuthal distribution and the cone.
pub const AZIMUTHS: usize = 720;
/// θ cells of the azimuthal distribution's integral.
const THETA_CELLS: usize = 360;

/// What a figure of a scattering function shows (luminance, sr⁻¹).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ScatteringMap {
    /// `[row][col]`: row = θ_r from −90° up (fibers) or θ_o from 0° (surfaces), col = φ from
    /// −180°, each at its cell's centre.
    pub image: Vec<Vec<f64>>,
    /// The azimuthal distribution: `∫ f_s cos²θ_r dθ_r` (fibers) or `∫ f_r cosθ_o sinθ_o dθ_o`
    /// (surfaces), the scattered power per unit φ.
    pub azimuthal: Vec<f64>,
    /// `f_s` on the specular cone θ_r = −θ_i (fibers), `f_r` on the ring θ_o = θ_i (surfaces).
    pub cone: Vec<f64>,
}

/// Centre of cell `j` of `n` over φ ∈ [−π, π).
#[must_use]
pub fn phi_at(j: usize, n: usize) -> f64 {
    -PI + (j as f64 + 0.5) * TAU / n as f64
}

/// The map of a fiber model for light at inclination `theta_i` (φ_i = 0), width-averaged
/// ([`ScatteringFunction::eval_far`]); a delta model has an empty image and its cone.
#[must_use]
pub fn fiber_map(model: &Model, theta_i: f64) -> ScatteringMap {
    let wi = direction(theta_i, 0.0);
    if model.properties().lobes == Lobes::Delta {
        let cone: Vec<f64> =
            (0..AZIMUTHS).map(|j| model.cone(theta_i, phi_at(j, AZIMUTHS)).value.luminance()).collect();
        return ScatteringMap { image: vec![vec![0.0; COLS]; ROWS], azimuthal: cone.clone(), cone };
    }
    let f = |wr: DVec3| model.eval_far(wi, wr).luminance();
    let image = (0..ROWS)
        .into_par_iter()
        .map(|r| {
            let tr = -FRAC_PI_2 + (r as f64 + 0.5) * PI / ROWS as f64;
            (0..COLS).map(|c| f(direction(tr, phi_at(c, COLS)))).collect()
        })
        .collect();
    let azimuthal = (0..AZIMUTHS)
        .into_par_iter()
        .map(|j| {
            let p = phi_at(j, AZIMUTHS);
            (0..THETA_CELLS)
                .map(|k| {
                    let tr = -FRAC_PI_2 + (k as f64 + 0.5) * PI / THETA_CELLS as f64;
                    f(direction(tr, p)) * tr.cos().powi(2) * PI / THETA_CELLS as f64
                })
                .sum()
        })
        .collect();
    let cone = (0..AZIMUTHS).map(|j| f(direction(-theta_i, phi_at(j, AZIMUTHS)))).collect();
    ScatteringMap { image, azimuthal, cone }
}

/// The map of a surface model: `f_r` over (φ_o, θ_o ∈ [0, 90°)) for light at (θ_i, φ_i = 0).
#[must_use]
pub fn surface_map(model: &SurfaceModel, theta_i: f64) -> ScatteringMap {
    let dir = |t: f64, p: f64| DVec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos());
    let wi = dir(theta_i, 0.0);
    let f = |wo: DVec3| model.eval(wi, wo).luminance();
    let image = (0..ROWS)
        .into_par_iter()
        .map(|r| {
            let t = (r as f64 + 0.5) * FRAC_PI_2 / ROWS as f64;
            (0..COLS).map(|c| f(dir(t, phi_at(c, COLS)))).collect()
        })
        .collect();
    let azimuthal = (0..AZIMUTHS)
        .into_par_iter()
        .map(|j| {
            let p = phi_at(j, AZIMUTHS);
            (0..THETA_CELLS)
                .map(|k| {
                    let t = (k as f64 + 0.5) * FRAC_PI_2 / THETA_CELLS as f64;
                    f(dir(t, p)) * t.cos() * t.sin() * FRAC_PI_2 / THETA_CELLS as f64
                })
                .sum()
        })
        .collect();
    let cone = (0..AZIMUTHS).map(|j| f(dir(theta_i, phi_at(j, AZIMUTHS)))).collect();
    ScatteringMap { image, azimuthal, cone }
}

/// A fiber table's lobe (`f[bin]`, `[θ_r][φ]` row-major over `nt × np` bins) as a map: its
/// bins, the azimuthal distribution `Σ f cos²θ_r` over each column and the row of the
/// specular cone θ_r = −θ_i.
#[must_use]
pub fn table_map(values: &[f64], nt: usize, np: usize, theta_i: f64) -> ScatteringMap {
    let image: Vec<Vec<f64>> = (0..nt).map(|i| values[i * np..(i + 1) * np].to_vec()).collect();
    let centre = |i: usize| -FRAC_PI_2 + (i as f64 + 0.5) * PI / nt as f64;
    let azimuthal = (0..np).map(|j| (0..nt).map(|i| image[i][j] * centre(i).cos().powi(2)).sum::<f64>()).collect();
    let cone_row = (((FRAC_PI_2 - theta_i) / PI * nt as f64) as usize).min(nt.saturating_sub(1));
    ScatteringMap { azimuthal, cone: image.get(cone_row).cloned().unwrap_or_default(), image }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The ideal diffuse fiber `f_s = ρ/π²`: a flat map, and an azimuthal distribution of
    /// `ρ/π² · ∫cos²θ dθ = ρ/(2π)` in every column.
    #[test]
    fn the_ideal_diffuse_fiber_maps_to_its_closed_form() {
        let m = fiberlab_scatter::build("diffuse", &[("albedo", "0.8")]).unwrap();
        let map = fiber_map(&m, 0.3);
        let want = 0.8 / (PI * PI);
        assert!(map.image.iter().flatten().all(|&v| (v - want).abs() < 1e-12));
        assert!(map.azimuthal.iter().all(|&v| (v - 0.8 / TAU).abs() < 1e-5), "{:?}", &map.azimuthal[..3]);
        assert_eq!(map.image.len(), ROWS);
        assert_eq!(map.cone.len(), AZIMUTHS);
    }
}
