//! Independent expected values: closed forms of docs/theory/radiometry.md, computed here
//! without calling the models' own code paths (1D quadratures of the formulas, Gamma
//! functions).

use fiberlab_math::{Rgb, fresnel};
use fiberlab_scatter::deon_2011::AzimuthalInclination;
use fiberlab_scatter::ideal_specular::Azimuth;
use fiberlab_scatter::{Field, Model};
use std::f64::consts::{FRAC_PI_2, PI, TAU};

/// Composite Simpson rule of `f` on `[a, b]` with `n` (even) intervals.
pub fn simpson(a: f64, b: f64, n: usize, f: impl Fn(f64) -> f64) -> f64 {
    let n = n + n % 2;
    let h = (b - a) / n as f64;
    let mut s = f(a) + f(b);
    for i in 1..n {
        s += f(a + i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 };
    }
    s * h / 3.0
}

/// Kajiya–Kay specular energy `E_p(θ_i) = (2π/cosθ_i) ∫ max(0, cos(θ_i+θ_r))^p cos²θ_r dθ_r`
/// (docs/theory/radiometry.md, "Energy of Kajiya–Kay"), by Simpson's rule over the non-zero
/// part of the lobe.
#[must_use]
pub fn kajiya_kay_energy(p: f64, theta_i: f64) -> f64 {
    let lo = (-FRAC_PI_2 - theta_i).max(-FRAC_PI_2);
    let hi = (FRAC_PI_2 - theta_i).min(FRAC_PI_2);
    let integral = simpson(lo, hi, 20_000, |tr| (theta_i + tr).cos().max(0.0).powf(p) * tr.cos().powi(2));
    TAU * integral / theta_i.cos()
}

/// `E_p(0) = 2π^{3/2} Γ((p+3)/2)/Γ((p+4)/2)` (docs/theory/radiometry.md, "Energy of Kajiya–Kay").
#[must_use]
pub fn kajiya_kay_energy_normal(p: f64) -> f64 {
    use statrs::function::gamma::ln_gamma;
    2.0 * PI.powf(1.5) * (ln_gamma((p + 3.0) / 2.0) - ln_gamma((p + 4.0) / 2.0)).exp()
}

/// The light-side albedo `ρ(θ_i)` a model must have, when a closed form is known
/// (docs/theory/radiometry.md, "Reference fibers", "Kajiya–Kay as a scattering function").
#[must_use]
pub fn albedo(model: &Model, theta_i: f64) -> Option<Rgb> {
    match model {
        Model::Diffuse(m) => Some(m.albedo()),
        Model::LambertianCylinder(m) => Some(m.albedo()),
        Model::Specular(m) => Some(Rgb::splat(match (m.fresnel_eta(), m.azimuth()) {
            (None, _) => 1.0,
            (Some(eta), Azimuth::Uniform) => fresnel::dielectric(theta_i.cos(), eta),
            // h uniform on [−1, 1], incidence cos ι = cosθ·sqrt(1 − h²)
            // (docs/theory/radiometry.md, "Ideal specular fiber").
            (Some(eta), Azimuth::Mirror) => {
                0.5 * simpson(-1.0, 1.0, 20_000, |h| fresnel::dielectric(theta_i.cos() * (1.0 - h * h).sqrt(), eta))
            }
        })),
        Model::KajiyaKay(m) => Some(m.k_d() * (PI * PI) + m.k_s() * kajiya_kay_energy(m.p(), theta_i)),
        Model::Goldman(m) => {
            let kk = m.kajiya_kay();
            let (r, t) = m.directional_weights();
            Some((r + t) * 0.5 * (kk.k_d() * (PI * PI) + kk.k_s() * kajiya_kay_energy(kk.p(), theta_i)))
        }
        #[allow(unreachable_patterns)]
        _ => None,
    }
}

/// The camera-side white furnace `∫ f_s(ω_i, ω_o) cosθ_i dω_i` a model must have for every
/// `ω_o` (and h), when it claims exact camera-side energy conservation: 1 for lossless
/// Chiang (Σ_p A_p = 1, docs/theory/hair.md, "Attenuation"), for the lossless hollow fiber
/// with every lobe (the same sum over its sub-lobes) and for lossless d'Eon with the
/// camera-side azimuthal inclination.
#[must_use]
pub fn camera_furnace(model: &Model) -> Option<Rgb> {
    match model {
        Model::Chiang(m) if m.sigma_a().is_black() => Some(Rgb::ONE),
        Model::HollowFiber(m)
            if m.sigma_a().is_black() && m.params().lobes == [true; 4] && m.params().field == Field::Near =>
        {
            Some(Rgb::ONE)
        }
        Model::Deon(m) if m.sigma_a().is_black() && m.azimuthal_inclination() == AzimuthalInclination::Camera => {
            Some(Rgb::ONE)
        }
        _ => None,
    }
}

/// Predicted `f(ω_i, ω_r)/f(ω_r, ω_i)` for models that are knowingly non-reciprocal, when the
/// prediction is closed-form: Kajiya–Kay's specular part gives `cosθ_r/cosθ_i`.
#[must_use]
pub fn kajiya_kay_reciprocity_ratio(cos_i: f64, cos_r: f64) -> f64 {
    cos_r / cos_i
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tolerance::PUBLISHED_VALUE_REL;
    use approx::assert_relative_eq;

    /// The values in docs/theory/radiometry.md, "Energy of Kajiya–Kay" (derived there
    /// independently: Wallis integral at θ_i = 0, separate quadrature elsewhere).
    #[test]
    fn kajiya_kay_energy_matches_the_derived_values() {
        for (p, e0) in [(1.0, 8.378), (10.0, 4.453), (100.0, 1.556)] {
            assert_relative_eq!(kajiya_kay_energy(p, 0.0), e0, max_relative = PUBLISHED_VALUE_REL);
            assert_relative_eq!(kajiya_kay_energy_normal(p), e0, max_relative = PUBLISHED_VALUE_REL);
        }
        for (t, e10, e100) in [(0.5, 4.014, 1.369), (1.0, 2.932, 0.861), (1.4, 2.627, 0.351)] {
            assert_relative_eq!(kajiya_kay_energy(10.0, t), e10, max_relative = PUBLISHED_VALUE_REL);
            assert_relative_eq!(kajiya_kay_energy(100.0, t), e100, max_relative = PUBLISHED_VALUE_REL);
        }
        assert!(kajiya_kay_energy(10.0, FRAC_PI_2 - 1e-4) > 1e3);
    }
}
