//! Attenuation `A_p`: the fraction of the light entering at offset h that leaves after p
//! internal segments, from Fresnel reflection at the surface and absorption along the
//! internal chords (`docs/theory/hair.md`, "Fresnel with Bravais indices", "Chord-length
//! absorption", "Attenuation", "Concentric core").
//!
//! * Fresnel: the exact 3D unpolarized dielectric reflectance of η at `cos ι = cosθ·cosγ`
//!   ([`surface_fresnel`]). It equals Marschner 2003's form with both Bravais indices η′, η″,
//!   and the internal reflections have the same value; running Snell with η″ instead (as
//!   some Marschner ports do) fakes total internal reflection at grazing θ
//!   (`docs/theory/peer-discrepancies.md`, "Fresnel with the parallel Bravais index").
//! * One internal segment is a chord of the unit circle at distance `|sinγ_t| = |h|/η′` from
//!   the axis, tilted out of the normal plane by θ_t: length `2cosγ_t/cosθ_t`
//!   ([`chord_length`]). Marschner 2003 print `2(1 + cos 2γ_t)/cosθ_t = 4cos²γ_t/cosθ_t`
//!   instead, which is not the chord (Zinke & Weber 2007); it is kept as
//!   [`PathLength::Paper`] for comparison (`docs/theory/peer-discrepancies.md`, "Printed
//!   absorption path").
//! * `T = exp(−σ_a·ℓ)` per segment, `A_0 = f`, `A_1 = (1 − f)²T`, `A_p = A_{p−1}·f·T`, and
//!   Chiang 2016's residual `A_3 = A_2·fT/(1 − fT)`, the sum of every order p ≥ 3
//!   ([`hit_attenuation`]); with σ_a = 0, `Σ_{p ≤ 3} A_p = 1` exactly.
//! * A concentric core of relative radius κ (a medulla, as in Yan et al. 2015's fur): a
//!   segment at `|h|/η′ < κ` crosses it along `2√(κ² − (h/η′)²)/cosθ_t` and spends the rest
//!   of its chord in the cortex ([`chord_lengths`]). The core is taken to have the cortex's
//!   index (no refraction at its boundary).

use super::normal_plane::NormalPlane;
use fiberlab_math::special::{safe_asin, safe_sqrt};
use fiberlab_math::{Rgb, bravais, fresnel};

/// Internal path length used for absorption.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PathLength {
    /// `2cosγ_t/cosθ_t`, the chord of a radius-1 circle.
    Chord,
    /// `2(1 + cos2γ_t)/cosθ_t = 4cos²γ_t/cosθ_t`, as printed in Marschner 2003.
    Paper,
}

impl PathLength {
    /// The length of one internal segment for `cosγ_t` and `cosθ_t`.
    #[must_use]
    #[inline]
    pub fn length(self, cos_gamma_t: f64, cos_theta_t: f64) -> f64 {
        let along_normal_plane = match self {
            PathLength::Chord => 2.0 * cos_gamma_t,
            PathLength::Paper => 4.0 * cos_gamma_t * cos_gamma_t,
        };
        along_normal_plane / cos_theta_t
    }
}

/// Exact 3D dielectric Fresnel reflectance of index `eta` at the surface point where the
/// inclination has cosine `cos_theta` and the 2D incidence angle cosine `cos_gamma`.
#[must_use]
#[inline]
pub fn surface_fresnel(eta: f64, cos_theta: f64, cos_gamma: f64) -> f64 {
    fresnel::dielectric(cos_theta * cos_gamma, eta)
}

/// Length `2cosγ_t/cosθ_t` of one internal chord of the unit circle (radius-1 fiber).
#[must_use]
#[inline]
pub fn chord_length(cos_gamma_t: f64, cos_theta_t: f64) -> f64 {
    2.0 * cos_gamma_t / cos_theta_t
}

/// Transmittance `exp(−σ_a·ℓ)` along a path of length `length` (radius units).
#[must_use]
#[inline]
pub fn transmittance(sigma_a: Rgb, length: f64) -> Rgb {
    (sigma_a * -length).exp()
}

/// Lengths of one internal segment inside a fiber with a concentric core.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ChordLengths {
    /// Length in the cortex (outside the core).
    pub cortex: f64,
    /// Length in the core (0 when the segment misses it).
    pub core: f64,
}

/// The segment at distance `|sin_gamma_t|` (= |h|/η′) from the axis, inclined by θ_t inside
/// the fiber, split between a core of relative radius `kappa` ∈ [0, 1] and the cortex: core
/// `2√(κ² − sin²γ_t)/cosθ_t` when `|sinγ_t| < κ`, cortex the rest of `2cosγ_t/cosθ_t`.
#[must_use]
pub fn chord_lengths(sin_gamma_t: f64, cos_theta_t: f64, kappa: f64) -> ChordLengths {
    let s2 = sin_gamma_t * sin_gamma_t;
    let outer = safe_sqrt(1.0 - s2);
    let inner = if sin_gamma_t.abs() < kappa { safe_sqrt(kappa * kappa - s2) } else { 0.0 };
    ChordLengths { cortex: 2.0 * (outer - inner) / cos_theta_t, core: 2.0 * inner / cos_theta_t }
}

/// `A(p, γ)` of a far-field model in `plane` (whose inclination and index are the lobe's), at
/// `γ = asin h`: `A_0 = F`, `A_p = (1 − F)²F^{p−1}T^p`. `with_fresnel = false` sets F ≡ 1 in
/// the reflection and the transmissions alike (a geometric check only).
#[must_use]
pub fn plane_attenuation(
    plane: &NormalPlane,
    p: usize,
    gamma: f64,
    sigma_a: Rgb,
    path: PathLength,
    with_fresnel: bool,
) -> Rgb {
    let f = if with_fresnel { surface_fresnel(plane.eta(), plane.cos_theta_d(), gamma.cos()) } else { 1.0 };
    if p == 0 {
        return Rgb::splat(f);
    }
    let st = gamma.sin() * plane.inv_eta_prime();
    let cos_gamma_t = safe_sqrt(1.0 - st * st);
    let t = transmittance(sigma_a, path.length(cos_gamma_t, plane.cos_theta_t()));
    let mut a = first_transmission(f, t);
    for _ in 1..p {
        a = next_order(a, f, t);
    }
    a
}

/// `A_1 = (1 − f)²T`.
#[must_use]
#[inline]
pub fn first_transmission(f: f64, t: Rgb) -> Rgb {
    t * ((1.0 - f) * (1.0 - f))
}

/// `A_{p+1} = A_p·T·f` from `A_p` (p ≥ 1).
#[must_use]
#[inline]
pub fn next_order(a: Rgb, f: f64, t: Rgb) -> Rgb {
    a * t * f
}

/// Geometry and attenuation of one near-field hit (Chiang 2016): `γ_o`, `γ_t` and `A_0..A_3`.
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    /// 2D incidence angle `γ_o = asin h`.
    pub gamma_o: f64,
    /// 2D refraction angle `γ_t = asin(h/η′)`.
    pub gamma_t: f64,
    /// `A_p` for p = 0, 1, 2 and the residual p ≥ 3.
    pub a: [Rgb; 4],
}

/// Attenuations `A_p(θ_o, h)` of a hit at offset `h` seen from inclination `(sin_o, cos_o)`
/// (Chiang 2016): Fresnel at `cosθ_o cosγ_o`, chord absorption, and the residual
/// `A_3 = A_2 fT/(1 − fT)` with the silhouette guard (`A_3 = 0` where `fT = 1`).
/// (`A_1` is formed as `(T(1 − f))(1 − f)`, the order of products of the original code, which
/// renders are compared against bit for bit.)
#[must_use]
pub fn hit_attenuation(eta: f64, sigma_a: Rgb, sin_o: f64, cos_o: f64, h: f64) -> Hit {
    let h = h.clamp(-1.0, 1.0);
    let cos_gamma_o = safe_sqrt(1.0 - h * h);
    let f = surface_fresnel(eta, cos_o, cos_gamma_o);
    let sin_gamma_t = bravais::sin_gamma_t(h, eta, sin_o, cos_o);
    let cos_gamma_t = safe_sqrt(1.0 - sin_gamma_t * sin_gamma_t);
    let cos_theta_t = bravais::cos_theta_t(eta, sin_o);
    let t = transmittance(sigma_a, chord_length(cos_gamma_t, cos_theta_t));
    let a1 = t * (1.0 - f) * (1.0 - f);
    let a2 = next_order(a1, f, t);
    let ft = t * f;
    let a3 = Rgb::new(
        if ft[0] < 1.0 { a2[0] * ft[0] / (1.0 - ft[0]) } else { 0.0 },
        if ft[1] < 1.0 { a2[1] * ft[1] / (1.0 - ft[1]) } else { 0.0 },
        if ft[2] < 1.0 { a2[2] * ft[2] / (1.0 - ft[2]) } else { 0.0 },
    );
    Hit { gamma_o: h.asin(), gamma_t: safe_asin(sin_gamma_t), a: [Rgb::splat(f), a1, a2, a3] }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fiberlab_math::DVec3;

    /// Independent 3D geometry: refract a ray (inclination θ, offset h) into the unit cylinder
    /// along x with vector Snell's law, then intersect the refracted line with the cylinders
    /// of radius κ and 1 (quadratics in y, z). No Bravais index, no 2D reduction.
    fn traced_lengths(eta: f64, theta: f64, h: f64, kappa: f64) -> (f64, f64) {
        let d0 = -DVec3::new(theta.sin(), theta.cos(), 0.0); // travelling toward −y, inclined
        let n0 = DVec3::new(0.0, (1.0 - h * h).sqrt(), h); // entry point = outward normal
        let cos_i = -d0.dot(n0);
        let r = 1.0 / eta;
        let d = d0 * r + n0 * (r * cos_i - (1.0 - r * r * (1.0 - cos_i * cos_i)).sqrt());
        // |p0 + s·d|² in (y, z) = ρ²: a s² + 2b s + c = 0.
        let a = d.y * d.y + d.z * d.z;
        let b = n0.y * d.y + n0.z * d.z;
        let total = -2.0 * b / a; // second root for ρ = 1 (c = 0), in units of |d| = 1
        let disc = b * b - a * (1.0 - kappa * kappa);
        let core = if disc > 0.0 { 2.0 * disc.sqrt() / a } else { 0.0 };
        (total - core, core)
    }

    #[test]
    fn chord_lengths_match_a_traced_ray_through_a_concentric_core() {
        let eta = 1.55;
        let mut hit_core = 0;
        for &theta in &[0.0, 0.4, -0.9, 1.3] {
            for &h in &[-0.95, -0.6, -0.2, 0.0, 0.3, 0.55, 0.8, 0.99] {
                for &kappa in &[0.0, 0.3, 0.5, 0.8] {
                    let (s, c) = f64::sin_cos(theta);
                    let got = chord_lengths(bravais::sin_gamma_t(h, eta, s, c), bravais::cos_theta_t(eta, s), kappa);
                    let (cortex, core) = traced_lengths(eta, theta, h, kappa);
                    assert!((got.cortex - cortex).abs() < 1e-12, "θ {theta} h {h} κ {kappa}: {got:?} vs {cortex}");
                    assert!((got.core - core).abs() < 1e-12, "θ {theta} h {h} κ {kappa}: {got:?} vs {core}");
                    hit_core += usize::from(core > 0.0);
                    // Without a core, the whole segment is the chord the models use.
                    if kappa == 0.0 {
                        let cos_gamma_t = safe_sqrt(1.0 - bravais::sin_gamma_t(h, eta, s, c).powi(2));
                        let chord = chord_length(cos_gamma_t, bravais::cos_theta_t(eta, s));
                        assert!((chord - cortex).abs() < 1e-12);
                    }
                }
            }
        }
        assert!(hit_core > 20, "the cases exercise the core ({hit_core})");
    }

    #[test]
    fn lossless_near_field_attenuations_sum_to_one() {
        for &h in &[-1.0, -0.7, 0.0, 0.4, 0.999] {
            for &theta in &[0.0, 0.8, -1.4] {
                let (s, c) = f64::sin_cos(theta);
                let hit = hit_attenuation(1.55, Rgb::ZERO, s, c, h);
                let sum: f64 = hit.a.iter().map(|a| a[0]).sum();
                assert!((sum - 1.0).abs() < 1e-12 || (h.abs() == 1.0 && sum <= 1.0), "h {h} θ {theta}: {sum}");
            }
        }
    }
}
