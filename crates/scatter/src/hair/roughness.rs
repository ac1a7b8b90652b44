//! Roughness maps: Chiang et al. 2016's fits from the user roughnesses β_m, β_n ∈ (0, 1] to
//! the longitudinal variance `v_p` of d'Eon's `M_p` and the logistic scale `s` of the
//! azimuthal lobes, and the Gaussian azimuthal width σ_n that `deon` derives from `s`
//! (`docs/theory/hair.md`, "Chiang's roughness maps").
//!
//! * `v_0 = (0.726β_m + 0.812β_m² + 3.7β_m²⁰)²`, `v_1 = v_0/4` (TT), `v_2 = v_3 = 4v_0`
//!   (TRT and the residual);
//! * `s = √(π/8)·(0.265β_n + 1.194β_n² + 5.372β_n²²)`;
//! * `σ_n = π·s/√3`: the Gaussian with the logistic's variance (`π²s²/3`), so that `deon` and
//!   `chiang` with the same β_n have azimuthal lobes of the same width.
//!
//! Values (β = 0.1, 0.3, 0.5, 1): `v_0` = 0.00652, 0.0846, 0.320, 27.44; `s` = 0.0241, 0.1172,
//! 0.2701, 4.281.

use std::f64::consts::PI;

/// Coefficients of Chiang 2016's fit `v_0 = (c₁β_m + c₂β_m² + c₃β_m²⁰)²`.
const V0_COEFFS: (f64, f64, f64) = (0.726, 0.812, 3.7);
/// Coefficients of Chiang 2016's fit `s = √(π/8)·(c₁β_n + c₂β_n² + c₃β_n²²)`.
const S_COEFFS: (f64, f64, f64) = (0.265, 1.194, 5.372);

/// Longitudinal variance `v_0` of the R lobe from β_m (Chiang 2016).
#[must_use]
pub fn longitudinal_variance(beta_m: f64) -> f64 {
    let (a, b, c) = V0_COEFFS;
    (a * beta_m + b * beta_m * beta_m + c * beta_m.powi(20)).powi(2)
}

/// Per-lobe variances `[v_R, v_TT, v_TRT, v_residual] = [v_0, v_0/4, 4v_0, 4v_0]`.
#[must_use]
pub fn lobe_variances(beta_m: f64) -> [f64; 4] {
    let v0 = longitudinal_variance(beta_m);
    [v0, 0.25 * v0, 4.0 * v0, 4.0 * v0]
}

/// Variance of lobe `p` (any order; p ≥ 2 share `4v_0`) from `v_0`.
#[must_use]
pub fn lobe_variance(v0: f64, p: usize) -> f64 {
    match p {
        0 => v0,
        1 => 0.25 * v0,
        _ => 4.0 * v0,
    }
}

/// Logistic scale `s` of the azimuthal lobes from β_n (Chiang 2016), radians.
#[must_use]
pub fn logistic_scale(beta_n: f64) -> f64 {
    let (a, b, c) = S_COEFFS;
    (PI / 8.0).sqrt() * (a * beta_n + b * beta_n * beta_n + c * beta_n.powi(22))
}

/// Gaussian standard deviation σ_n of d'Eon's azimuthal lobes for `beta_n`: Chiang's
/// logistic scale converted at equal variance, `σ_n = π·s/√3`.
#[must_use]
pub fn azimuthal_sigma(beta_n: f64) -> f64 {
    PI * logistic_scale(beta_n) / 3f64.sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The fits reproduce the values quoted in the module docs (computed by hand from the
    /// polynomials) and the σ_n conversion preserves the logistic's variance π²s²/3.
    #[test]
    fn maps_reproduce_the_quoted_values() {
        for &(beta, v0, s) in
            &[(0.1, 0.00652, 0.0241), (0.3, 0.0846, 0.1172), (0.5, 0.320, 0.2701), (1.0, 27.44, 4.281)]
        {
            assert!((longitudinal_variance(beta) - v0).abs() < 2e-3 * v0, "v_0({beta})");
            assert!((logistic_scale(beta) - s).abs() < 2e-3 * s, "s({beta})");
            let sn = azimuthal_sigma(beta);
            assert!((sn * sn - PI * PI * s * s / 3.0).abs() < 3e-3 * sn * sn);
        }
        assert_eq!(lobe_variances(0.3), [0, 1, 2, 3].map(|p| lobe_variance(longitudinal_variance(0.3), p)));
    }
}
