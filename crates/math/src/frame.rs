//! The fiber frame and the angles every model is written in (docs/theory/conventions.md,
//! "Fiber frame", "Angles", "Relative azimuth").
//!
//! Local coordinates: `x` = tangent (root → tip), `y` = `v`, `z` = `w`. A direction is
//! `ω = (sinθ, cosθ·cosφ, cosθ·sinφ)`.

use glam::DVec3;
use std::f64::consts::{PI, TAU};

/// Largest deviation from 1 of the length of a direction given as input (a CSV row, a NumPy
/// array) that is accepted — the direction is then normalized ([`unit_direction`]).
pub const UNIT_TOLERANCE: f64 = 1e-3;

/// The rule for directions given as input, the same on the command line and in Python: `w`
/// normalized when it is finite with length within [`UNIT_TOLERANCE`] of 1, `None` otherwise.
#[must_use]
#[inline]
pub fn unit_direction(w: DVec3) -> Option<DVec3> {
    let len = w.length();
    (w.is_finite() && (len - 1.0).abs() <= UNIT_TOLERANCE).then(|| w / len)
}

/// Sine of the inclination θ from the normal plane (`ω.x`), clamped to [−1, 1].
#[must_use]
#[inline]
pub fn sin_theta(w: DVec3) -> f64 {
    w.x.clamp(-1.0, 1.0)
}

/// Cosine of the inclination θ (≥ 0), computed as `|ω_yz|`, accurate at grazing angles.
#[must_use]
#[inline]
pub fn cos_theta(w: DVec3) -> f64 {
    (w.y * w.y + w.z * w.z).sqrt().min(1.0)
}

/// Inclination θ ∈ [−π/2, π/2] from the normal plane, radians.
#[must_use]
#[inline]
pub fn theta(w: DVec3) -> f64 {
    sin_theta(w).atan2(cos_theta(w))
}

/// Azimuth φ = atan2(ω.z, ω.y) ∈ (−π, π] about the fiber axis, radians.
#[must_use]
#[inline]
pub fn phi(w: DVec3) -> f64 {
    w.z.atan2(w.y)
}

/// Unit direction with inclination `theta` and azimuth `phi` (radians).
#[must_use]
#[inline]
pub fn direction(theta: f64, phi: f64) -> DVec3 {
    let (s, c) = theta.sin_cos();
    direction_from_sin_cos(s, c, phi)
}

/// Unit direction from `sinθ`, `cosθ` and the azimuth φ (radians).
#[must_use]
#[inline]
pub fn direction_from_sin_cos(sin_theta: f64, cos_theta: f64, phi: f64) -> DVec3 {
    let (sp, cp) = phi.sin_cos();
    DVec3::new(sin_theta, cos_theta * cp, cos_theta * sp)
}

/// Wraps an angle to (−π, π] without loops (non-finite input gives NaN, never hangs).
#[must_use]
#[inline]
pub fn wrap_pi(x: f64) -> f64 {
    let y = (x + PI).rem_euclid(TAU) - PI;
    if y <= -PI { y + TAU } else { y }
}

/// Relative azimuth `φ = φ_r − φ_i` wrapped to (−π, π]; 0 is backscatter, ±π forward.
#[must_use]
#[inline]
pub fn relative_phi(wi: DVec3, wr: DVec3) -> f64 {
    wrap_pi(phi(wr) - phi(wi))
}

/// Marschner's half and difference angles `(θ_h, θ_d)` = ((θ_i + θ_r)/2, (θ_r − θ_i)/2).
#[must_use]
#[inline]
pub fn half_difference(wi: DVec3, wr: DVec3) -> (f64, f64) {
    let (ti, tr) = (theta(wi), theta(wr));
    (0.5 * (ti + tr), 0.5 * (tr - ti))
}

/// An orthonormal fiber frame in world space: `u` tangent (root → tip), `v`, `w = u × v`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FiberFrame {
    /// Unit tangent, root → tip (local `x`).
    pub u: DVec3,
    /// Unit normal-plane axis (local `y`; the major axis for elliptical fibers).
    pub v: DVec3,
    /// `u × v` (local `z`).
    pub w: DVec3,
}

impl FiberFrame {
    /// A frame with tangent `u` and an arbitrary but continuous choice of `v`
    /// (Duff et al. 2017 branchless basis). `u` must be unit length.
    #[must_use]
    pub fn from_tangent(u: DVec3) -> Self {
        let sign = 1.0_f64.copysign(u.z);
        let a = -1.0 / (sign + u.z);
        let b = u.x * u.y * a;
        let v = DVec3::new(1.0 + sign * u.x * u.x * a, sign * b, -sign * u.x);
        let w = u.cross(v);
        Self { u, v, w }
    }

    /// A frame with tangent `u` and `v` along the part of `toward` perpendicular to `u`
    /// (e.g. the direction toward the camera, or an ellipse's major axis). Falls back to
    /// [`FiberFrame::from_tangent`] when `toward` is parallel to `u`.
    #[must_use]
    pub fn from_tangent_toward(u: DVec3, toward: DVec3) -> Self {
        let v = toward - u * u.dot(toward);
        let len = v.length();
        if len < 1e-12 || !len.is_finite() {
            return Self::from_tangent(u);
        }
        let v = v / len;
        Self { u, v, w: u.cross(v) }
    }

    /// World → fiber-frame coordinates.
    #[must_use]
    #[inline]
    pub fn to_local(&self, d: DVec3) -> DVec3 {
        DVec3::new(d.dot(self.u), d.dot(self.v), d.dot(self.w))
    }

    /// Fiber-frame → world coordinates.
    #[must_use]
    #[inline]
    pub fn to_world(&self, d: DVec3) -> DVec3 {
        self.u * d.x + self.v * d.y + self.w * d.z
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_abs_diff_eq;
    use proptest::prelude::*;

    #[test]
    fn backscatter_is_zero_and_forward_is_pi() {
        let wi = direction(0.3, 1.0);
        assert_abs_diff_eq!(relative_phi(wi, direction(-0.3, 1.0)), 0.0, epsilon = 1e-12);
        assert_abs_diff_eq!(relative_phi(wi, direction(0.1, 1.0 + PI)).abs(), PI, epsilon = 1e-12);
    }

    #[test]
    fn wrap_pi_never_hangs_on_infinity() {
        assert!(wrap_pi(f64::INFINITY).is_nan());
        assert_abs_diff_eq!(wrap_pi(-PI), PI);
        assert_abs_diff_eq!(wrap_pi(3.0 * PI), PI, epsilon = 1e-12);
    }

    proptest! {
        #[test]
        fn angles_round_trip(t in -1.5f64..1.5, p in -3.1f64..3.1) {
            let d = direction(t, p);
            prop_assert!((d.length() - 1.0).abs() < 1e-12);
            prop_assert!((theta(d) - t).abs() < 1e-12);
            prop_assert!((phi(d) - p).abs() < 1e-12);
        }

        #[test]
        fn frame_is_orthonormal(x in -1.0f64..1.0, y in -1.0f64..1.0, z in -1.0f64..1.0) {
            let u = DVec3::new(x, y, z);
            prop_assume!(u.length() > 1e-3);
            let f = FiberFrame::from_tangent(u.normalize());
            prop_assert!((f.v.length() - 1.0).abs() < 1e-12);
            prop_assert!(f.u.dot(f.v).abs() < 1e-12);
            prop_assert!((f.u.cross(f.v) - f.w).length() < 1e-12);
            let d = DVec3::new(0.3, -0.5, 0.8).normalize();
            prop_assert!((f.to_world(f.to_local(d)) - d).length() < 1e-12);
        }
    }
}
