//! Phase functions of scattering media: the Henyey–Greenstein phase function (Henyey and
//! Greenstein 1941), used by the medulla of fur in the scattering crate's random-walk tables
//! and by the goniophotometer's explicit medulla, so both draw directions the same way.

use crate::frame::FiberFrame;
use glam::DVec3;
use std::f64::consts::TAU;

/// A unit direction drawn from the Henyey–Greenstein phase function about the unit direction
/// `d` of travel, asymmetry `g ∈ (−1, 1)` (g > 0 scatters forward, g = 0 uniformly), from two
/// uniform numbers in [0, 1): the cosine by inverting the phase function's CDF, the azimuth
/// uniformly. Below |g| = 1e-4 the cosine is drawn uniformly (the inversion's limit).
#[inline]
pub fn sample_henyey_greenstein(d: DVec3, g: f64, u0: f64, u1: f64) -> DVec3 {
    let cos_t = if g.abs() < 1e-4 {
        1.0 - 2.0 * u0
    } else {
        let s = (1.0 - g * g) / (1.0 - g + 2.0 * g * u0);
        ((1.0 + g * g - s * s) / (2.0 * g)).clamp(-1.0, 1.0)
    };
    let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
    let frame = FiberFrame::from_tangent(d);
    let (sp, cp) = (TAU * u1).sin_cos();
    frame.to_world(DVec3::new(cos_t, sin_t * cp, sin_t * sp))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::split_mix::SplitMix64;

    /// The phase function's mean cosine is g (its defining moment), and its second moment
    /// `⟨cos²⟩ = (1 + 2g²)/3` (a closed form of the HG distribution).
    #[test]
    fn henyey_greenstein_moments_match_the_closed_forms() {
        let mut rng = SplitMix64::new(3);
        let d = DVec3::new(0.3, -0.5, 0.8).normalize();
        for g in [-0.6, 0.0, 0.3, 0.9] {
            let n = 200_000;
            let (mut m1, mut m2) = (0.0, 0.0);
            for _ in 0..n {
                let w = sample_henyey_greenstein(d, g, rng.next_f64(), rng.next_f64());
                assert!((w.length() - 1.0).abs() < 1e-12);
                let c = w.dot(d);
                m1 += c;
                m2 += c * c;
            }
            let (m1, m2) = (m1 / n as f64, m2 / n as f64);
            // σ of either mean ≤ 1/√n ≈ 2.2e-3.
            assert!((m1 - g).abs() < 1e-2, "g = {g}: mean cosine {m1}");
            assert!((m2 - (1.0 + 2.0 * g * g) / 3.0).abs() < 1e-2, "g = {g}: mean cos² {m2}");
        }
    }
}
