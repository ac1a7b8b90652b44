//! Dielectric Fresnel reflectance: the one implementation every model uses.

/// Unpolarized Fresnel reflectance of a smooth dielectric interface.
///
/// # Formula
/// `F = ½(R_s + R_p)`, `R_s = ((cosι − η cosτ)/(cosι + η cosτ))²`,
/// `R_p = ((η cosι − cosτ)/(η cosι + cosτ))²`, where `sinτ = sinι/η`.
///
/// `cos_i` is the cosine of the incidence angle ι measured on the side the light comes
/// from; a negative value means the light arrives from inside (the index is inverted).
/// `eta` = n_inside / n_outside. Returns 1 under total internal reflection.
///
/// ```
/// // Normal incidence on glass, η = 1.5: ((1.5 − 1)/(1.5 + 1))² = 0.04.
/// assert!((fiberlab_math::fresnel::dielectric(1.0, 1.5) - 0.04).abs() < 1e-15);
/// ```
#[must_use]
#[inline]
pub fn dielectric(cos_i: f64, eta: f64) -> f64 {
    let (cos_i, eta) = if cos_i < 0.0 { (-cos_i, 1.0 / eta) } else { (cos_i, eta) };
    let cos_i = cos_i.min(1.0);
    let sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let r_s = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    let r_p = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    0.5 * (r_s * r_s + r_p * r_p)
}

/// Fresnel reflectance written with Bravais' indices in the normal plane (Marschner 2003;
/// docs/theory/hair.md, "Fresnel with Bravais indices"): `γ_i` is the 2D incidence angle,
/// `η′`, `η″` the modified indices, `γ_t = asin(sinγ_i/η′)` in both polarizations.
///
/// It equals [`dielectric`] at `cos ι = cosθ·cosγ_i` to rounding error (tested); models use
/// [`dielectric`]. This form exists to document and test that equivalence.
#[must_use]
pub fn bravais(eta_prime: f64, eta_double_prime: f64, gamma_i: f64) -> f64 {
    let (si, ci) = gamma_i.sin_cos();
    let st = si / eta_prime;
    if st.abs() >= 1.0 {
        return 1.0;
    }
    let ct = (1.0 - st * st).sqrt();
    let r_s = (ci - eta_prime * ct) / (ci + eta_prime * ct);
    let r_p = (eta_double_prime * ci - ct) / (eta_double_prime * ci + ct);
    0.5 * (r_s * r_s + r_p * r_p)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bravais;
    use proptest::prelude::*;

    #[test]
    fn total_internal_reflection_from_inside() {
        // Critical angle for η = 1.5 is asin(1/1.5) = 41.8°; at 60° from inside: TIR.
        assert_eq!(dielectric(-(60f64.to_radians().cos()), 1.5), 1.0);
        assert!(dielectric(-1.0, 1.5) < 0.05);
        assert_eq!(dielectric(0.0, 1.5), 1.0);
    }

    proptest! {
        #[test]
        fn bravais_form_equals_3d_fresnel(theta in -1.55f64..1.55, h in -0.999f64..0.999, eta in 1.01f64..2.5) {
            let (s, c) = theta.sin_cos();
            let ep = bravais::eta_prime(eta, s, c);
            let epp = bravais::eta_double_prime(eta, s, c);
            let gamma = h.asin();
            let a = bravais(ep, epp, gamma);
            let b = dielectric(c * gamma.cos(), eta);
            prop_assert!((a - b).abs() < 1e-12, "{a} vs {b}");
        }
    }
}
