//! Bravais' modified indices for oblique incidence on a cylinder
//! (docs/theory/conventions.md, "Bravais indices").
//!
//! A ray inclined by θ to the normal plane refracts, in the normal-plane projection, as if
//! the index were `η′` (perpendicular polarization) or `η″` (parallel). Formulas are
//! written to stay finite at grazing θ.

/// `η′ = sqrt(η² − sin²θ)/cosθ` (≥ η; +∞ at cosθ = 0).
#[must_use]
#[inline]
pub fn eta_prime(eta: f64, sin_theta: f64, cos_theta: f64) -> f64 {
    (eta * eta - sin_theta * sin_theta).sqrt() / cos_theta
}

/// `η″ = η² cosθ / sqrt(η² − sin²θ) = η²/η′` (≤ η; 0 at cosθ = 0).
#[must_use]
#[inline]
pub fn eta_double_prime(eta: f64, sin_theta: f64, cos_theta: f64) -> f64 {
    eta * eta * cos_theta / (eta * eta - sin_theta * sin_theta).sqrt()
}

/// `sin γ_t = h/η′ = h·cosθ/sqrt(η² − sin²θ)`, the cancellation-free form (no 1/cosθ).
#[must_use]
#[inline]
pub fn sin_gamma_t(h: f64, eta: f64, sin_theta: f64, cos_theta: f64) -> f64 {
    h * cos_theta / (eta * eta - sin_theta * sin_theta).sqrt()
}

/// `cos θ_t` inside the fiber, from Snell's law along the axis: `sinθ_t = sinθ/η`.
#[must_use]
#[inline]
pub fn cos_theta_t(eta: f64, sin_theta: f64) -> f64 {
    let s = sin_theta / eta;
    (1.0 - s * s).max(0.0).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn indices_at_normal_and_grazing_incidence() {
        assert_eq!(eta_prime(1.55, 0.0, 1.0), 1.55);
        assert_eq!(eta_double_prime(1.55, 0.0, 1.0), 1.55);
        assert!(eta_prime(1.55, 1.0, 0.0).is_infinite());
        assert_eq!(sin_gamma_t(1.0, 1.55, 1.0, 0.0), 0.0);
        let (s, c) = 0.7f64.sin_cos();
        let ep = eta_prime(1.55, s, c);
        assert!((ep * eta_double_prime(1.55, s, c) - 1.55 * 1.55).abs() < 1e-12);
        assert!((sin_gamma_t(0.4, 1.55, s, c) - 0.4 / ep).abs() < 1e-15);
    }
}
