//! The goniophotometer's rough interface (`fiberlab_gonio::interface::cross`) on a flat surface
//! against the closed-form GGX BRDF and BTDF of Walter, Marschner, Li & Torrance 2007: the
//! weighted outgoing directions, binned over the sphere, have per bin the mass
//! `∫_bin f(ω_i, ω_o)|ω_o·n| dω_o` (reflection above the surface, refraction below), written here
//! from the paper's formulas (GGX `D`, Smith `Λ` by its tangent form, height-correlated
//! `G₂ = 1/(1 + Λ_i + Λ_o)`, the exact dielectric Fresnel at the half-vector) and integrated by
//! midpoint quadrature; a wrong sampler, weight or Jacobian moves mass between bins.

use fiberlab_gonio::interface::{Crossing, cross};
use fiberlab_math::microfacet::Ggx;
use fiberlab_math::{DVec3, fresnel};
use rand::SeedableRng;
use rand_pcg::Pcg64;
use std::f64::consts::{PI, TAU};

/// GGX normal distribution, `α²/(π cos⁴θ (α² + tan²θ)²)`.
fn ggx_d(alpha: f64, cos_m: f64) -> f64 {
    if cos_m <= 0.0 {
        return 0.0;
    }
    let tan2 = (1.0 - cos_m * cos_m) / (cos_m * cos_m);
    alpha * alpha / (PI * cos_m.powi(4) * (alpha * alpha + tan2).powi(2))
}

/// Smith's `Λ = (−1 + √(1 + α² tan²θ))/2`.
fn smith_lambda(alpha: f64, cos_v: f64) -> f64 {
    let c = cos_v.abs();
    let tan2 = (1.0 - c * c) / (c * c);
    0.5 * (-1.0 + (1.0 + alpha * alpha * tan2).sqrt())
}

/// `f(ω_i, ω_o)|ω_o·n|` of Walter 2007 (n = +z, ω_i above), `eta` = η_o/η_i.
fn walter(alpha: f64, eta: f64, wi: DVec3, wo: DVec3) -> f64 {
    let (ci, co) = (wi.z, wo.z);
    let g2 = 1.0 / (1.0 + smith_lambda(alpha, ci) + smith_lambda(alpha, co));
    if co > 0.0 {
        let h = (wi + wo).normalize();
        let f = fresnel::dielectric(wi.dot(h), eta);
        f * ggx_d(alpha, h.z) * g2 / (4.0 * ci)
    } else {
        let mut h = -(wi + wo * eta).normalize();
        if h.z < 0.0 {
            h = -h;
        }
        let (ih, oh) = (wi.dot(h), wo.dot(h));
        if ih <= 0.0 || oh >= 0.0 {
            return 0.0;
        }
        let f = fresnel::dielectric(ih, eta);
        ih * oh.abs() * eta * eta * (1.0 - f) * ggx_d(alpha, h.z) * g2 / (ci * (ih + eta * oh).powi(2))
    }
}

#[test]
fn flat_rough_interface_matches_walters_brdf_and_btdf() {
    let (nc, np) = (40, 48); // bins in cos θ ∈ [−1, 1] and φ ∈ [0, 2π): equal solid angle
    let n = 400_000;
    let mut worst = 0.0f64;
    // (α, η_o/η_i, incidence angle from the normal): from outside, and from inside below and
    // above the critical angle (40.2° for 1.55).
    for &(alpha, eta, theta) in
        &[(0.2, 1.55, 0.35), (0.5, 1.55, 1.1), (0.3, 1.0 / 1.55, 0.3), (0.6, 1.0 / 1.55, 0.75), (0.1, 1.0 / 1.55, 1.2)]
    {
        let wi = DVec3::new(f64::sin(theta), 0.0, f64::cos(theta));
        let g = Ggx::new(alpha);
        let mut rng = Pcg64::seed_from_u64(17);
        let (mut sum, mut sum2) = (vec![0.0; nc * np], vec![0.0; nc * np]);
        let mut masked = 0usize;
        for _ in 0..n {
            let (d, w) = match cross(-wi, DVec3::Z, eta, Some(&g), &mut rng) {
                Crossing::Reflected { direction, weight } => {
                    assert!(direction.z > 0.0);
                    (direction, weight)
                }
                Crossing::Refracted { direction, weight } => {
                    assert!(direction.z < 0.0);
                    (direction, weight)
                }
                Crossing::Masked => {
                    masked += 1;
                    continue;
                }
            };
            let i = (((d.z + 1.0) * 0.5 * nc as f64) as usize).min(nc - 1);
            let j = ((d.y.atan2(d.x).rem_euclid(TAU) / TAU * np as f64) as usize).min(np - 1);
            sum[i * np + j] += w;
            sum2[i * np + j] += w * w;
        }
        let (mut total_measured, mut total_expected) = (0.0, 0.0);
        for i in 0..nc {
            for j in 0..np {
                let k = 8;
                let mut expected = 0.0;
                for a in 0..k {
                    let c = -1.0 + 2.0 * (i as f64 + (a as f64 + 0.5) / k as f64) / nc as f64;
                    let s = (1.0 - c * c).sqrt();
                    for b in 0..k {
                        let p = TAU * (j as f64 + (b as f64 + 0.5) / k as f64) / np as f64;
                        let wo = DVec3::new(s * p.cos(), s * p.sin(), c);
                        expected += walter(alpha, eta, wi, wo);
                    }
                }
                expected *= (2.0 / nc as f64) * (TAU / np as f64) / (k * k) as f64;
                let got = sum[i * np + j] / n as f64;
                let se = ((sum2[i * np + j] / n as f64 - got * got).max(0.0) / n as f64).sqrt();
                let se_expected = (expected / n as f64).sqrt();
                let z = (got - expected) / se.max(se_expected).max(1e-9);
                worst = worst.max(z.abs());
                assert!(
                    (got - expected).abs() <= 5.0 * se.max(se_expected) + 0.02 * expected + 1e-7,
                    "α {alpha} η {eta} θ {theta}: bin ({i}, {j}) measured {got} ± {se}, Walter {expected}"
                );
                total_measured += got;
                total_expected += expected;
            }
        }
        eprintln!(
            "α {alpha} η {eta:.3} θ {theta}: albedo measured {total_measured:.5}, Walter {total_expected:.5}, masked {:.4}",
            masked as f64 / n as f64
        );
        assert!((total_measured - total_expected).abs() < 3e-3, "{total_measured} vs {total_expected}");
        // Single scattering loses energy, most from inside beyond the critical angle.
        assert!(total_expected < 1.0 && total_expected > 0.5);
    }
    eprintln!("worst |z| = {worst:.2}");
}

/// A smooth interface is the roughness → 0 limit: the interface without roughness splits by
/// Fresnel exactly (reflected fraction F), and a tiny roughness stays within its lobe.
#[test]
fn smooth_interface_splits_by_fresnel() {
    let wi = DVec3::new(0.5, 0.0, 0.75f64.sqrt());
    let mut rng = Pcg64::seed_from_u64(3);
    let n = 200_000;
    let reflected = (0..n)
        .filter(|_| matches!(cross(-wi, DVec3::Z, 1.55, None, &mut rng), Crossing::Reflected { .. }))
        .count() as f64
        / n as f64;
    let f = fresnel::dielectric(wi.z, 1.55);
    assert!((reflected - f).abs() < 5.0 * (f * (1.0 - f) / n as f64).sqrt(), "{reflected} vs {f}");
    let g = Ggx::new(1e-4);
    for _ in 0..1000 {
        if let Crossing::Reflected { direction, weight } = cross(-wi, DVec3::Z, 1.55, Some(&g), &mut rng) {
            let mirror = DVec3::new(-wi.x, -wi.y, wi.z);
            assert!((direction - mirror).length() < 1e-2 && weight > 0.99);
        }
    }
}
