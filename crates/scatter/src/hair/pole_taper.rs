//! A sampling density over the inclination that vanishes on the fiber axis.
//!
//! A sampler that draws the inclination θ_i from a smooth density `q(θ_i)` and the azimuth
//! independently has the density `q(θ_i)·p(φ)/cosθ_i` per steradian (`dω = cosθ dθ dφ`), which
//! is infinite on the fiber axis (θ_i = ±π/2) wherever `q` is not zero there. That is integrable,
//! but no grid quadrature in coordinates whose pole is not the fiber axis resolves it (a
//! renderer's shading frame puts the axis on the equator of its grid), and it wastes samples:
//! the integrand `f_s cosθ_i` is finite there, so the weights of those samples tend to 0. It
//! happens whenever a lobe leaves the sphere: a Gaussian in θ_h centred beyond the pole
//! (Marschner's R at a grazing viewer, `θ_i = 2θ_h − θ_r < −π/2`) is truncated at the pole,
//! which then holds its largest density.
//!
//! The taper is a monotone map `W` of [−π/2, π/2] onto itself, the identity farther than
//! [`POLE_TAPER_WIDTH`] δ from either pole. Nearer, with `d = π/2 − |θ|` the distance to the
//! pole, `W` replaces d by `m(d) = d²(2δ − d)/δ²` (m(0) = 0, m′(0) = 0, m(δ) = δ, m′(δ) = 1,
//! increasing). A sampler draws θ* from its density q and returns `θ = W⁻¹(θ*)`; the density
//! of θ is `q(W(θ))·W′(θ)`, and `W′ = m′(d) = d(4δ − 3d)/δ²` vanishes like d = cosθ at the
//! pole, so the density per steradian stays finite (at most `4q/δ` there) and continuous away
//! from the pole. Mass is preserved (W maps the interval onto itself). `W⁻¹` solves the cubic
//! `t²(2 − t) = s` (t = x/δ, s = m/δ) by its trigonometric root, polished by one Newton step.
//!
//! On the axis every azimuth meets, so a density that stays finite there but depends on φ is
//! discontinuous at that point; with a narrow azimuthal lobe it varies faster than any grid
//! near the axis resolves. A sampler that draws φ after θ can blend φ toward uniform with
//! probability [`pole_blend`]`(θ) = b = max(0, 1 − W′(θ))` (1 on the axis, 0 outside the
//! band): its density per steradian near the axis becomes `q(W)W′/cosθ·[(1 − b)p(φ) + b/2π]`,
//! which tends to the same value from every azimuth.

use std::f64::consts::{FRAC_PI_2, PI};

/// Width δ (radians, 6°) of the band next to each pole where the taper acts: a few cells of a
/// 150-cell grid in cosθ (each 0.77° wide at the equator), narrow enough that the lobes of
/// non-grazing viewers never reach it in practice.
pub const POLE_TAPER_WIDTH: f64 = 6.0 * PI / 180.0;

/// `W(θ)`: the inclination whose density the sampler draws, for the returned θ.
#[must_use]
#[inline]
pub fn taper(theta: f64) -> f64 {
    let d = FRAC_PI_2 - theta.abs();
    if d >= POLE_TAPER_WIDTH {
        return theta;
    }
    let x = d.max(0.0) / POLE_TAPER_WIDTH;
    (FRAC_PI_2 - POLE_TAPER_WIDTH * x * x * (2.0 - x)).copysign(theta)
}

/// `W′(θ)`, the factor the sampler's density is multiplied by (1 away from the poles).
#[must_use]
#[inline]
pub fn taper_derivative(theta: f64) -> f64 {
    let d = FRAC_PI_2 - theta.abs();
    if d >= POLE_TAPER_WIDTH {
        return 1.0;
    }
    let x = d.max(0.0) / POLE_TAPER_WIDTH;
    x * (4.0 - 3.0 * x)
}

/// Probability `max(0, 1 − W′(θ))` with which a sampler draws φ uniformly at the inclination
/// θ it has drawn (module docs): 1 on the axis, 0 outside the band and where `W′ ≥ 1` (W′
/// peaks at 4/3 two thirds of the way to the band's edge).
#[must_use]
#[inline]
pub fn pole_blend(theta: f64) -> f64 {
    (1.0 - taper_derivative(theta)).clamp(0.0, 1.0)
}

/// `W⁻¹(θ*)`: the inclination returned for the drawn θ*.
#[must_use]
#[inline]
pub fn untaper(theta_star: f64) -> f64 {
    let d = FRAC_PI_2 - theta_star.abs();
    if d >= POLE_TAPER_WIDTH {
        return theta_star;
    }
    let s = (d.max(0.0) / POLE_TAPER_WIDTH).min(1.0);
    // t³ − 2t² + s = 0 on [0, 1]: t = 2/3 + (4/3)cos(acos(1 − 27s/16)/3 − 2π/3).
    let mut t =
        2.0 / 3.0 + 4.0 / 3.0 * (((1.0 - 27.0 * s / 16.0).clamp(-1.0, 1.0)).acos() / 3.0 - 2.0 * PI / 3.0).cos();
    t = t.clamp(0.0, 1.0);
    // One Newton step on t²(2 − t) − s (derivative t(4 − 3t)) against the rounding near s = 0.
    let slope = t * (4.0 - 3.0 * t);
    if slope > 1e-12 {
        t = (t - (t * t * (2.0 - t) - s) / slope).clamp(0.0, 1.0);
    }
    (FRAC_PI_2 - POLE_TAPER_WIDTH * t).copysign(theta_star)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn taper_is_a_monotone_bijection_with_its_inverse_and_derivative() {
        let n = 20_000;
        let mut previous = -FRAC_PI_2;
        for k in 0..=n {
            let theta = -FRAC_PI_2 + PI * k as f64 / n as f64;
            let w = taper(theta);
            assert!(w >= previous - 1e-15, "not monotone at {theta}");
            previous = w;
            assert!((untaper(w) - theta).abs() < 1e-9, "W⁻¹(W({theta})) = {}", untaper(w));
            // The derivative against a central difference (inside [−π/2, π/2]).
            let e = 1e-7;
            if theta.abs() < FRAC_PI_2 - e {
                let fd = (taper(theta + e) - taper(theta - e)) / (2.0 * e);
                assert!((fd - taper_derivative(theta)).abs() < 1e-6, "W′({theta}) {} vs {fd}", taper_derivative(theta));
            }
        }
        assert_eq!(taper(FRAC_PI_2), FRAC_PI_2);
        assert_eq!(taper(-FRAC_PI_2), -FRAC_PI_2);
        assert_eq!(taper(0.3), 0.3);
        // Continuous at the band's edge, value and slope; vanishing slope like cosθ at the pole.
        let edge = FRAC_PI_2 - POLE_TAPER_WIDTH;
        assert!((taper(edge - 1e-12) - taper(edge + 1e-12)).abs() < 1e-11);
        assert!((taper_derivative(edge + 1e-12) - 1.0).abs() < 1e-9);
        // The blend probability: 1 on the axis, in [0, 1] everywhere, 0 outside the band.
        assert_eq!(pole_blend(FRAC_PI_2), 1.0);
        assert_eq!(pole_blend(0.3), 0.0);
        for k in 0..=1000 {
            let b = pole_blend(FRAC_PI_2 - POLE_TAPER_WIDTH * k as f64 / 1000.0);
            assert!((0.0..=1.0).contains(&b), "{b}");
        }
        for d in [1e-2, 1e-4, 1e-8] {
            let ratio = taper_derivative(FRAC_PI_2 - d) / d;
            assert!((ratio - 4.0 / POLE_TAPER_WIDTH).abs() < 4.0 / POLE_TAPER_WIDTH * 0.2, "W′/cosθ at d={d}: {ratio}");
        }
    }
}
