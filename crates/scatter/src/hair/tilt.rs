//! The cuticle tilt: the scales on a hair's surface lean toward the root by a small angle α,
//! which shifts each lobe's longitudinal centre (`docs/theory/hair.md`, "Cuticle tilt").
//!
//! fiberlab rotates the **fixed** direction (the camera side in Chiang et al. 2016's backward
//! form) of lobe p by `τ_p = (+2α, −α, −4α, 0)` for (R, TT, TRT, higher orders), so that every
//! `M_p(·, θ_o + τ_p)` stays normalized in θ_i and sampling stays exact. With θ positive toward
//! the tip and α > 0 the lobe centres are then `θ_i + θ_o = −2α` (R, toward the root), `+α`
//! (TT), `+4α` (TRT; Marschner 2003's ratio would be 3α, d'Eon et al. 2013 and Chiang use 4α):
//! the physical sign. pbrt-v4, Mitsuba 3 and Tungsten write the same rotation with the
//! opposite sign of α, Cycles rotates the integrated direction instead
//! (`docs/theory/peer-discrepancies.md`, "Tilt sign").
//!
//! Marschner's own parametrization (a shift α_R of the R lobe's Gaussian, α_R < 0 toward the
//! root) is in [`super::longitudinal::GaussianLobes`].

/// The rotation of the fixed direction for lobes p = 0…3, as `(sin τ_p, cos τ_p)` with
/// `τ = (+2α, −α, −4α, 0)`, α in radians.
#[must_use]
pub fn lobe_tilts(alpha: f64) -> [(f64, f64); 4] {
    [(2.0 * alpha).sin_cos(), (-alpha).sin_cos(), (-4.0 * alpha).sin_cos(), (0.0, 1.0)]
}

/// The rotation of the fixed direction for lobes R, TT, TRT with Marschner 2003's ratio of
/// shifts (`α_TT = −α_R/2`, `α_TRT = −3α_R/2`), as used by Yan et al. 2015/2017's fur:
/// `τ = (+2α, −α, −3α)`, α in radians, so that the lobe centres are `θ_i + θ_o = −2α`, `+α`,
/// `+3α` (physical sign, as [`lobe_tilts`]).
#[must_use]
pub fn marschner_ratio_tilts(alpha: f64) -> [(f64, f64); 3] {
    [(2.0 * alpha).sin_cos(), (-alpha).sin_cos(), (-3.0 * alpha).sin_cos()]
}

/// `(sin(θ + τ), |cos(θ + τ)|)` from `(sinθ, cosθ)` and `(sin τ, cos τ)`; the absolute value
/// keeps the cosine of an inclination rotated past ±90° non-negative, as `M_p` requires.
#[must_use]
#[inline]
pub fn rotate(sin_t: f64, cos_t: f64, (sin_tau, cos_tau): (f64, f64)) -> (f64, f64) {
    (sin_t * cos_tau + cos_t * sin_tau, (cos_t * cos_tau - sin_t * sin_tau).abs())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rotation_adds_the_lobe_tilt_to_the_inclination() {
        let alpha = 3f64.to_radians();
        for (p, tau) in [2.0 * alpha, -alpha, -4.0 * alpha, 0.0].into_iter().enumerate() {
            for &theta in &[-1.2, -0.3, 0.0, 0.4, 1.5] {
                let (s, c) = rotate(f64::sin(theta), f64::cos(theta), lobe_tilts(alpha)[p]);
                assert!((s - (theta + tau).sin()).abs() < 1e-15 && (c - (theta + tau).cos().abs()).abs() < 1e-15);
            }
        }
        for (p, tau) in [2.0 * alpha, -alpha, -3.0 * alpha].into_iter().enumerate() {
            let (s, c) = marschner_ratio_tilts(alpha)[p];
            assert!((s - tau.sin()).abs() < 1e-15 && (c - tau.cos()).abs() < 1e-15);
        }
    }
}
