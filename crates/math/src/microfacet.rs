//! The GGX (Trowbridge–Reitz) microfacet distribution of an isotropic rough dielectric
//! interface, the one implementation the rough fiber models and the goniophotometer share.
//!
//! Sources: Walter, Marschner, Li & Torrance 2007, *Microfacet models for refraction through
//! rough surfaces* (the distribution `D`, the reflection and refraction half-vectors and their
//! Jacobians); Heitz 2014, *Understanding the masking-shadowing function in microfacet-based
//! BRDFs* (Smith's `Λ`, `G₁ = 1/(1 + Λ)` and the height-correlated
//! `G₂ = 1/(1 + Λ(ω_i) + Λ(ω_o))`); Heitz 2018, *Sampling the GGX distribution of visible
//! normals* (exact sampling of `D_v(m) = G₁(v)·max(0, v·m)·D(m)/(v·n)`).
//!
//! Every function takes cosines measured from the (macro- or meso-) normal `n` of the rough
//! surface, or unit vectors together with `n`; directions point away from the surface on their
//! own side. fiberlab uses the height-correlated `G₂` for reflection and for refraction alike
//! (Cycles' choice; Heitz 2014 derives a different height-correlated form for transmission,
//! see `docs/theory/peer-discrepancies.md`, "Huang 2022: masking").
//!
//! ```
//! use fiberlab_math::microfacet::Ggx;
//! // D integrates to 1 against the projected area: ∫ D(m)(m·n) dω_m = 1.
//! let g = Ggx::new(0.3);
//! let n = 20_000;
//! let sum: f64 = (0..n)
//!     .map(|k| {
//!         let c = (k as f64 + 0.5) / n as f64; // cos θ_m, dω = 2π d(cos θ)
//!         g.d(c) * c * std::f64::consts::TAU / n as f64
//!     })
//!     .sum();
//! assert!((sum - 1.0).abs() < 1e-6);
//! ```

use crate::FiberFrame;
use glam::DVec3;
use std::f64::consts::{PI, TAU};

/// An isotropic GGX distribution of roughness `α` (the slope scale; `α²` is the variance-like
/// parameter of the paper's `D`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ggx {
    alpha: f64,
    alpha2: f64,
}

impl Ggx {
    /// A distribution of roughness `alpha > 0`.
    #[must_use]
    pub fn new(alpha: f64) -> Self {
        Self { alpha, alpha2: alpha * alpha }
    }

    /// The roughness α.
    #[must_use]
    pub fn alpha(&self) -> f64 {
        self.alpha
    }

    /// `D(m) = α²/(π·(cos²θ_m·(α² − 1) + 1)²)` for `cos θ_m = m·n`; 0 for `cos θ_m ≤ 0`
    /// (Walter 2007's GGX normal distribution, normalized by `∫ D(m)(m·n) dω_m = 1`).
    #[must_use]
    #[inline]
    pub fn d(&self, cos_m: f64) -> f64 {
        if cos_m <= 0.0 {
            return 0.0;
        }
        let c2 = (cos_m * cos_m).min(1.0);
        let t = c2 * (self.alpha2 - 1.0) + 1.0;
        self.alpha2 / (PI * t * t)
    }

    /// Smith's `Λ(v) = (√(1 + α² tan²θ_v) − 1)/2` for `cos θ_v = |v·n|`, written as
    /// `(√(cos²θ + α² sin²θ)/cosθ − 1)/2` (no tangent); +∞ at grazing (`cos θ_v = 0`).
    #[must_use]
    #[inline]
    pub fn lambda(&self, cos_v: f64) -> f64 {
        let c = cos_v.abs().min(1.0);
        if c == 0.0 {
            return f64::INFINITY;
        }
        let c2 = c * c;
        0.5 * ((c2 + self.alpha2 * (1.0 - c2)).sqrt() / c - 1.0)
    }

    /// Smith's masking `G₁(v) = 1/(1 + Λ(v))`.
    #[must_use]
    #[inline]
    pub fn g1(&self, cos_v: f64) -> f64 {
        1.0 / (1.0 + self.lambda(cos_v))
    }

    /// Height-correlated masking-shadowing `G₂ = 1/(1 + Λ(ω_i) + Λ(ω_o))`.
    #[must_use]
    #[inline]
    pub fn g2(&self, cos_i: f64, cos_o: f64) -> f64 {
        1.0 / (1.0 + self.lambda(cos_i) + self.lambda(cos_o))
    }

    /// Density of the visible normals seen from `v`, `D_v(m) = G₁(v)·max(0, v·m)·D(m)/(v·n)`
    /// (per steradian of `m`), from `cos θ_v = v·n > 0`, `v·m` and `cos θ_m = m·n`.
    #[must_use]
    #[inline]
    pub fn visible_pdf(&self, cos_v: f64, v_dot_m: f64, cos_m: f64) -> f64 {
        if cos_v <= 0.0 || v_dot_m <= 0.0 {
            return 0.0;
        }
        self.g1(cos_v) * v_dot_m * self.d(cos_m) / cos_v
    }

    /// A visible normal seen from `v` (local frame, normal `+z`, `v.z > 0`), drawn exactly from
    /// `D_v` with two uniforms (Heitz 2018: the projected hemisphere of the stretched
    /// configuration, sampled as a disk whose far half is compressed).
    #[must_use]
    pub fn sample_visible_local(&self, v: DVec3, u1: f64, u2: f64) -> DVec3 {
        let a = self.alpha;
        let vh = DVec3::new(a * v.x, a * v.y, v.z).normalize();
        let len2 = vh.x * vh.x + vh.y * vh.y;
        let t1 = if len2 > 0.0 { DVec3::new(-vh.y, vh.x, 0.0) / len2.sqrt() } else { DVec3::X };
        let t2 = vh.cross(t1);
        let r = u1.sqrt();
        let (sp, cp) = (TAU * u2).sin_cos();
        let p1 = r * cp;
        let s = 0.5 * (1.0 + vh.z);
        let p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * r * sp;
        let nh = t1 * p1 + t2 * p2 + vh * (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt();
        DVec3::new(a * nh.x, a * nh.y, nh.z.max(0.0)).normalize()
    }

    /// A visible normal seen from `v` on the surface of normal `n` (unit vectors, `v·n > 0`):
    /// [`Ggx::sample_visible_local`] in a frame about `n` (the distribution is isotropic, so
    /// any frame gives the same density).
    #[must_use]
    pub fn sample_visible(&self, n: DVec3, v: DVec3, u1: f64, u2: f64) -> DVec3 {
        let f = FiberFrame::from_tangent(n);
        let local = DVec3::new(v.dot(f.v), v.dot(f.w), v.dot(n));
        let m = self.sample_visible_local(local, u1, u2);
        f.v * m.x + f.w * m.y + n * m.z
    }
}

/// Mirror reflection of a travel direction `d` at a surface of unit normal `m` (either side).
#[must_use]
#[inline]
pub fn reflect(d: DVec3, m: DVec3) -> DVec3 {
    d - m * (2.0 * d.dot(m))
}

/// Refraction of a travel direction `d` through a surface of unit normal `m` facing the
/// incident side (`d·m < 0`), with `eta = n_incident/n_transmitted`; `None` under total
/// internal reflection.
#[must_use]
#[inline]
pub fn refract(d: DVec3, m: DVec3, eta: f64) -> Option<DVec3> {
    let cos_i = -d.dot(m);
    let sin2_t = eta * eta * (1.0 - cos_i * cos_i).max(0.0);
    if sin2_t >= 1.0 {
        return None;
    }
    Some((d * eta + m * (eta * cos_i - (1.0 - sin2_t).sqrt())).normalize())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Uniforms of a fixed low-discrepancy lattice (no RNG dependency in `math`).
    fn lattice(n: usize) -> impl Iterator<Item = (f64, f64)> {
        (0..n).map(move |k| ((k as f64 + 0.5) / n as f64, (k as f64 * 0.618_033_988_749_894_9).fract()))
    }

    /// `∫ D_v(m) dω_m = 1` (the visible-normal density is normalized; Heitz 2014's identity
    /// `∫ G₁(v) max(0, v·m) D(m) dω_m = v·n`), for several roughnesses and views.
    #[test]
    fn visible_normals_integrate_to_one() {
        for &alpha in &[0.05, 0.3, 0.8, 1.0] {
            let g = Ggx::new(alpha);
            for &theta_v in &[0.0, 0.6, 1.2, 1.5] {
                let v = DVec3::new(f64::sin(theta_v), 0.0, f64::cos(theta_v));
                // m over the hemisphere in (cos θ_m, φ_m), fine near the peak for small α.
                let (nt, np) = (4000, 256);
                let mut sum = 0.0;
                for i in 0..nt {
                    // cos θ_m = 1 − x², x uniform: dense at the pole.
                    let x = (i as f64 + 0.5) / nt as f64;
                    let c = 1.0 - x * x;
                    let dc = 2.0 * x / nt as f64;
                    let s = (1.0 - c * c).max(0.0).sqrt();
                    for j in 0..np {
                        let p = (j as f64 + 0.5) * TAU / np as f64;
                        let m = DVec3::new(s * p.cos(), s * p.sin(), c);
                        sum += g.visible_pdf(v.z, v.dot(m), c) * dc * TAU / np as f64;
                    }
                }
                assert!((sum - 1.0).abs() < 2e-3, "α {alpha} θ_v {theta_v}: {sum}");
            }
        }
    }

    /// Samples of `sample_visible` have the density `visible_pdf`: the mean of a test
    /// function under the samples equals its integral against the pdf.
    #[test]
    fn visible_sampling_matches_the_visible_pdf() {
        for &alpha in &[0.1, 0.5, 1.0] {
            let g = Ggx::new(alpha);
            for &theta_v in &[0.2, 1.0, 1.45] {
                let v = DVec3::new(f64::sin(theta_v), 0.0, f64::cos(theta_v));
                // Moments of m: E[m.x], E[m.z], E[m.x²].
                let n = 400_000;
                let (mut mx, mut mz, mut mxx) = (0.0, 0.0, 0.0);
                for (u1, u2) in lattice(n) {
                    let m = g.sample_visible_local(v, u1, u2);
                    assert!((m.length() - 1.0).abs() < 1e-12 && m.z >= 0.0 && m.dot(v) >= -1e-12);
                    mx += m.x / n as f64;
                    mz += m.z / n as f64;
                    mxx += m.x * m.x / n as f64;
                }
                let (nt, np) = (3000, 256);
                let (mut ex, mut ez, mut exx) = (0.0, 0.0, 0.0);
                for i in 0..nt {
                    let x = (i as f64 + 0.5) / nt as f64;
                    let c = 1.0 - x * x;
                    let dc = 2.0 * x / nt as f64;
                    let s = (1.0 - c * c).max(0.0).sqrt();
                    for j in 0..np {
                        let p = (j as f64 + 0.5) * TAU / np as f64;
                        let m = DVec3::new(s * p.cos(), s * p.sin(), c);
                        let w = g.visible_pdf(v.z, v.dot(m), c) * dc * TAU / np as f64;
                        ex += m.x * w;
                        ez += m.z * w;
                        exx += m.x * m.x * w;
                    }
                }
                for (got, want) in [(mx, ex), (mz, ez), (mxx, exx)] {
                    assert!((got - want).abs() < 3e-3, "α {alpha} θ_v {theta_v}: {got} vs {want}");
                }
            }
        }
    }

    /// `G₁ = 1/(1 + Λ)` against the closed form `2/(1 + √(1 + α² tan²θ))`, the
    /// height-correlated `G₂` reduces to `G₁` when one direction is normal, and a sample about
    /// a tilted normal is the local sample rotated into that frame.
    #[test]
    fn masking_closed_forms_and_frames() {
        let g = Ggx::new(0.4);
        for &t in &[0.0, 0.3, 1.0, 1.5] {
            let c = f64::cos(t);
            let want = 2.0 / (1.0 + (1.0 + 0.16 * t.tan().powi(2)).sqrt());
            assert!((g.g1(c) - want).abs() < 1e-14, "{t}");
            assert!((g.g2(c, 1.0) - g.g1(c)).abs() < 1e-15);
        }
        assert_eq!(g.g1(0.0), 0.0);
        let n = DVec3::new(0.3, -0.5, 0.8).normalize();
        let v = DVec3::new(0.1, 0.7, 0.9).normalize();
        let m = g.sample_visible(n, v, 0.37, 0.81);
        assert!((m.length() - 1.0).abs() < 1e-12 && m.dot(n) > 0.0 && m.dot(v) > 0.0);
        // Reflection and refraction obey the mirror law and Snell's law.
        let d = -v;
        let r = reflect(d, m);
        assert!((r.dot(m) + d.dot(m)).abs() < 1e-15);
        let t = refract(d, m, 1.0 / 1.55).unwrap();
        let sin_i = (1.0 - d.dot(m).powi(2)).sqrt();
        let sin_t = (1.0 - t.dot(m).powi(2)).sqrt();
        assert!((sin_i - 1.55 * sin_t).abs() < 1e-12 && t.dot(m) < 0.0);
        assert!(refract(DVec3::new(0.9, 0.0, -0.4359).normalize(), DVec3::Z, 1.55).is_none());
    }
}
