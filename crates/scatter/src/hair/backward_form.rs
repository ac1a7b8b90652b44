//! The backward form of the near-field and far-field hair models of Chiang et al. 2016 and
//! d'Eon et al. 2011: each lobe is a density over the light direction ω_i for a fixed camera
//! direction ω_o, `g(ω_o, ω_i) = Σ_p M_p(θ_i, θ_o^(p))·A_p·N_p`, with `∫ g dω_i = Σ_p A_p`. In
//! fiberlab's convention `L_r = ∫ f_s L_i cosθ_i dω_i` this is the scattering function
//! `f_s = g/cosθ_i` (`docs/theory/conventions.md`, "Fiber scattering function versus
//! renderer BSDF"; `docs/theory/radiometry.md`, "Backward-form models").
//!
//! Such a model conserves energy exactly on the camera side but is not reciprocal: its
//! light-side albedo `ρ(ω_i) = (1/cosθ_i)∫ cos²θ_o Σ_p M_p Ā_p dθ_o` exceeds 1 at grazing light.
//! For one lossless lobe: v = 0.0846 (β_m = 0.3) gives 0.959, 0.972, 1.076, 2.23, 17.0 at
//! θ_i = 0, 0.5, 1.0, 1.4, 1.55 rad, and v → ∞ gives `π/(4cosθ_i)`.
//! Path tracing from the camera is unaffected; light tracing and bidirectional methods see
//! the asymmetry, which [`max_relative_non_reciprocity`] measures.

use super::longitudinal::Longitudinal;
use crate::ScatteringFunction;
use fiberlab_math::DVec3;
use fiberlab_math::frame::direction_from_sin_cos;
use fiberlab_math::special::safe_sqrt;
use std::f64::consts::{FRAC_PI_2, PI, TAU};

pub use crate::function::MIN_COS;

/// Light-side albedo of a single lobe seen as a backward-form fiber scattering function
/// (see the module docs): `(1/cosθ_i)·∫ cos²θ_o M_p(θ_i, θ_o) dθ_o`, by 4096-node midpoint
/// quadrature. It exceeds 1 at grazing light (e.g. 2.23 at θ_i = 1.4 for v = 0.0846), which
/// is why Chiang-type models conserve energy only on the camera side.
#[must_use]
pub fn single_lobe_light_side_albedo(v: f64, theta_i: f64) -> f64 {
    let m = Longitudinal::new(v);
    let (sin_i, cos_i) = theta_i.sin_cos();
    let n = 4096;
    let d = PI / n as f64;
    let mut sum = 0.0;
    for k in 0..n {
        let (s, c) = (-FRAC_PI_2 + (k as f64 + 0.5) * d).sin_cos();
        sum += c * c * m.eval(sin_i, cos_i, s, c) * d;
    }
    sum / cos_i.max(1e-300)
}

/// `max |f̄(i, r) − f̄(r, i)| / max(f̄(i, r), f̄(r, i))` (luminance of the width average
/// [`ScatteringFunction::eval_far`]) over `pairs` directions uniform on the sphere (SplitMix64 from `seed`);
/// pairs where both values are below 1e−6 of the largest value seen are skipped.
#[must_use]
pub fn max_relative_non_reciprocity(f: &impl ScatteringFunction, pairs: usize, seed: u64) -> f64 {
    let mut state = seed;
    let mut uniform = move || {
        state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut sphere = move || {
        let s: f64 = 2.0 * uniform() - 1.0;
        direction_from_sin_cos(s, safe_sqrt(1.0 - s * s), TAU * uniform())
    };
    let averaged = |wi: DVec3, wr: DVec3| -> f64 { f.eval_far(wi, wr).luminance() };
    let (mut worst, mut largest) = (0.0f64, 0.0f64);
    for _ in 0..pairs {
        let (a, b) = (sphere(), sphere());
        let (x, y) = (averaged(a, b), averaged(b, a));
        let m = x.max(y);
        largest = largest.max(m);
        if m > 1e-6 * largest && m > 0.0 {
            worst = worst.max((x - y).abs() / m);
        }
    }
    worst
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn single_lobe_light_side_albedo_matches_the_quoted_values() {
        let want = [(0.0, 0.959), (0.5, 0.972), (1.0, 1.076), (1.4, 2.23), (1.55, 17.0)];
        for &(t, w) in &want {
            let got = single_lobe_light_side_albedo(0.0846, t);
            assert!((got - w).abs() < 0.006 * w, "θi={t}: {got} vs {w}");
            let broad = single_lobe_light_side_albedo(1e7, t);
            assert!((broad - PI / (4.0 * t.cos())).abs() < 1e-5 * broad, "v→∞ θi={t}: {broad}");
        }
    }
}
