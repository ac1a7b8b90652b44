//! Elliptical cross-sections: the boundary of an elliptical fiber in the normal plane, where a
//! ray enters at a given offset, where an internal ray leaves, and the exact smooth paths
//! through it (`docs/theory/hair.md`, "Elliptical cross-sections").
//!
//! The ellipse has semi-axis 1 along its major axis, at angle ψ (the orientation) from `v`
//! toward `w`, and semi-axis `b` (the aspect ratio, minor/major, in (0, 1]) across it, so that
//! lengths stay in units of the major semi-axis (the "radius", in which σ_a is given), as in
//! the goniophotometer's explicit fiber (`fiberlab_gonio::surface`) and in Cycles.
//!
//! * Offsets: seen from the normal-plane direction `t` (unit, pointing from the fiber toward
//!   the viewer or the light), the fiber's projected half-width is
//!   `W(t) = √((e·a)² + b²(e·a⊥)²)` with `e` = `t` turned by −90° and `a`, `a⊥` the axes; the
//!   offset `h ∈ [−1, 1]` is the distance from the centre along `e` in units of `W`. For a
//!   circle this is the hair core's `h` (`γ = asin h`, increasing toward +y when `t = +z`).
//! * Smooth paths ([`smooth_path`]): a ray inclined by θ keeps its inclination outside and
//!   `θ_t` inside (`sin θ_t = sin θ/η`), and its normal-plane projection refracts by Snell's law
//!   with Bravais' index η′ at every boundary point, because every normal of a cylinder (of any
//!   cross-section) lies in the normal plane; Fresnel is the exact 3D reflectance at
//!   `cos ι = cosθ·cosγ` outside and `cosθ_t·cosγ` inside (γ the angle in the normal plane),
//!   absorption `exp(−σ_a ℓ/cosθ_t)` over the normal-plane length ℓ (Khungurn & Marschner
//!   2017's reduction). For `b = 1` it is the circular path of [`super::normal_plane`]
//!   (`Φ(p, h) = 2pγ_t − 2γ + pπ`) and [`super::attenuation`] (tested).

use super::attenuation::transmittance;
use fiberlab_math::{DVec2, Rgb, bravais, fresnel};

/// An elliptical cross-section (semi-axes 1 and `aspect`, major axis at `orientation`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ellipse {
    b: f64,
    /// Unit major axis `a = (cos ψ, sin ψ)` in (v, w) coordinates.
    a: DVec2,
}

/// A point of the boundary with its outward unit normal.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BoundaryPoint {
    /// The point (v, w coordinates, units of the major semi-axis).
    pub p: DVec2,
    /// Outward unit normal there (in the normal plane).
    pub n: DVec2,
}

impl Ellipse {
    /// The cross-section of aspect ratio `aspect` ∈ (0, 1] whose major axis is at
    /// `orientation` radians from `v` toward `w`.
    #[must_use]
    pub fn new(aspect: f64, orientation: f64) -> Self {
        let (s, c) = orientation.sin_cos();
        Self { b: aspect, a: DVec2::new(c, s) }
    }

    /// The unit circle.
    #[must_use]
    pub fn circle() -> Self {
        Self::new(1.0, 0.0)
    }

    /// The aspect ratio `b` (minor/major).
    #[must_use]
    pub fn aspect(&self) -> f64 {
        self.b
    }

    /// True for a circle.
    #[must_use]
    pub fn is_circle(&self) -> bool {
        self.b == 1.0
    }

    /// Coordinates along the major and the minor axis, the minor one divided by `b` (the
    /// ellipse becomes the unit circle).
    #[inline]
    fn unit(&self, x: DVec2) -> DVec2 {
        DVec2::new(x.dot(self.a), -x.perp_dot(self.a) / self.b)
    }

    /// `e`: the viewing direction `t` turned by −90° (the direction in which h grows).
    #[inline]
    fn across(t: DVec2) -> DVec2 {
        DVec2::new(t.y, -t.x)
    }

    /// Half the projected width seen from the unit normal-plane direction `t`:
    /// `√((e·a)² + b²(e·a⊥)²)`, `e` = `t` turned by −90° (1 for the circle).
    #[must_use]
    #[inline]
    pub fn half_width(&self, t: DVec2) -> f64 {
        let e = Self::across(t);
        let (ea, eb) = (e.dot(self.a), e.perp_dot(self.a));
        (ea * ea + self.b * self.b * eb * eb).sqrt()
    }

    /// Outward unit normal at a boundary point `p`: the gradient of `(p·a)² + (p·a⊥)²/b²`.
    #[must_use]
    #[inline]
    pub fn normal(&self, p: DVec2) -> DVec2 {
        let (pa, pb) = (p.dot(self.a), -p.perp_dot(self.a));
        let a_perp = self.a.perp();
        (self.a * pa + a_perp * (pb / (self.b * self.b))).normalize()
    }

    /// The boundary point seen at offset `h` ∈ [−1, 1] from direction `t` (unit, pointing
    /// from the fiber toward the observer): the first point a line travelling along `−t` at
    /// signed distance `h·W(t)` along `e` meets. `h` is clamped to [−1, 1]; at |h| = 1 the
    /// line grazes the silhouette.
    #[must_use]
    pub fn entry(&self, t: DVec2, h: f64) -> BoundaryPoint {
        let h = h.clamp(-1.0, 1.0);
        let e = Self::across(t);
        let o = e * (h * self.half_width(t));
        // |unit(o + s·t)|² = 1, the larger root s (closest to the observer).
        let (uo, ut) = (self.unit(o), self.unit(t));
        let (qa, qb, qc) = (ut.length_squared(), uo.dot(ut), uo.length_squared() - 1.0);
        let s = (qb * qb - qa * qc).max(0.0).sqrt() / qa - qb / qa;
        let p = o + t * s;
        BoundaryPoint { p, n: self.normal(p) }
    }

    /// From the boundary point `p`, travelling inside along `d` (any length; a 3D direction's
    /// normal-plane part gives the 3D distance), the parameter `s > 0` where `p + s·d` meets
    /// the boundary again, with that point. `None` when `d` does not point inward.
    #[must_use]
    pub fn exit(&self, p: DVec2, d: DVec2) -> Option<(f64, BoundaryPoint)> {
        let (up, ud) = (self.unit(p), self.unit(d));
        let (qa, qb, qc) = (ud.length_squared(), up.dot(ud), up.length_squared() - 1.0);
        if qa <= 0.0 {
            return None;
        }
        // Roots of qa s² + 2 qb s + qc = 0; the larger one (qc ≈ 0 for a boundary point).
        let s = ((qb * qb - qa * qc).max(0.0).sqrt() - qb) / qa;
        if s <= 0.0 {
            return None;
        }
        let q = p + d * s;
        Some((s, BoundaryPoint { p: q, n: self.normal(q) }))
    }
}

/// One smooth path with `p` internal segments through an elliptical fiber.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SmoothPath {
    /// Normal-plane azimuth of the leaving direction (radians, not wrapped).
    pub exit_azimuth: f64,
    /// Fresnel factors times absorption: the fraction of the power entering at this offset
    /// that leaves along this path.
    pub attenuation: Rgb,
    /// Internal path length (3D, units of the major semi-axis).
    pub length: f64,
}

/// 2D refraction of the unit direction `d` at unit normal `n` facing it, index ratio
/// `ratio` = n_incident/n_transmitted (Bravais' η′ or 1/η′); `None` under total reflection.
fn refract_2d(d: DVec2, n: DVec2, ratio: f64) -> Option<DVec2> {
    let cos_i = -d.dot(n);
    let sin2_t = ratio * ratio * (1.0 - cos_i * cos_i).max(0.0);
    if sin2_t >= 1.0 {
        return None;
    }
    Some((d * ratio + n * (ratio * cos_i - (1.0 - sin2_t).sqrt())).normalize())
}

/// The smooth path with `p` internal segments of light arriving from normal-plane azimuth
/// `phi` (the direction toward the light) at inclination θ (`sin_theta`, `cos_theta > 0`),
/// entering at offset `h` across the width seen from the light: its leaving azimuth and
/// attenuation. `None` when the path does not exist (it would leave by total internal
/// reflection, or p = 0 … is impossible only at a grazing silhouette).
#[must_use]
pub fn smooth_path(
    ellipse: &Ellipse,
    eta: f64,
    sigma_a: Rgb,
    (sin_theta, cos_theta): (f64, f64),
    phi: f64,
    h: f64,
    p: usize,
) -> Option<SmoothPath> {
    let t = DVec2::new(phi.cos(), phi.sin());
    let entry = ellipse.entry(t, h);
    let d = -t;
    let cos_gamma = -d.dot(entry.n);
    if cos_gamma <= 0.0 {
        return None;
    }
    let f = fresnel::dielectric(cos_theta * cos_gamma, eta);
    if p == 0 {
        let r = d - entry.n * (2.0 * d.dot(entry.n));
        return Some(SmoothPath { exit_azimuth: r.y.atan2(r.x), attenuation: Rgb::splat(f), length: 0.0 });
    }
    // Bravais' η′ for the normal-plane projection; inside, the inclination θ_t.
    let inv_eta_prime = bravais::sin_gamma_t(1.0, eta, sin_theta, cos_theta);
    let cos_theta_t = bravais::cos_theta_t(eta, sin_theta);
    let mut dir = refract_2d(d, entry.n, inv_eta_prime)?;
    let mut point = entry.p;
    let mut fresnel_product = 1.0 - f;
    let mut planar_length = 0.0;
    for k in 1..=p {
        let (s, at) = ellipse.exit(point, dir)?;
        planar_length += s;
        point = at.p;
        let cos_gamma_in = dir.dot(at.n);
        let f_in = fresnel::dielectric(cos_theta_t * cos_gamma_in, 1.0 / eta);
        if k < p {
            fresnel_product *= f_in;
            dir = (dir - at.n * (2.0 * dir.dot(at.n))).normalize();
        } else {
            let out = refract_2d(dir, -at.n, 1.0 / inv_eta_prime.max(f64::MIN_POSITIVE))?;
            fresnel_product *= 1.0 - f_in;
            dir = out;
        }
    }
    let length = planar_length / cos_theta_t;
    let attenuation = transmittance(sigma_a, length) * fresnel_product;
    Some(SmoothPath { exit_azimuth: dir.y.atan2(dir.x), attenuation, length })
}

#[cfg(test)]
mod tests {
    use super::super::attenuation::{PathLength, plane_attenuation};
    use super::super::normal_plane::{NormalPlane, RootMode, exit_azimuth};
    use super::*;
    use fiberlab_math::wrap_pi;
    use std::f64::consts::{FRAC_PI_2, PI};

    /// Entry points lie on the ellipse, facing the observer, at the offset asked for, and the
    /// silhouette offsets ±1 graze it (normal ⟂ t).
    #[test]
    fn entry_points_lie_on_the_boundary_at_their_offset() {
        for &(b, psi) in &[(1.0, 0.0), (0.85, 0.4), (0.5, -1.2), (0.2, 2.0)] {
            let e = Ellipse::new(b, psi);
            for k in 0..24 {
                let phi = -PI + k as f64 * 0.27;
                let t = DVec2::new(phi.cos(), phi.sin());
                for &h in &[-1.0, -0.7, 0.0, 0.3, 0.99, 1.0] {
                    let bp = e.entry(t, h);
                    let u = e.unit(bp.p);
                    assert!((u.length() - 1.0).abs() < 1e-12, "on the boundary");
                    let w = e.half_width(t);
                    assert!((bp.p.dot(Ellipse::across(t)) - h * w).abs() < 1e-12, "at the offset");
                    assert!(bp.n.dot(t) >= -1e-12, "facing the observer");
                    if h.abs() == 1.0 {
                        assert!(bp.n.dot(t).abs() < 1e-6, "grazing at the silhouette: {}", bp.n.dot(t));
                    }
                    // The normal is perpendicular to the boundary (a finite difference along it).
                    let tangent = DVec2::new(-u.y, u.x * b);
                    let along = e.a * tangent.x + e.a.perp() * tangent.y;
                    assert!(along.dot(bp.n).abs() < 1e-12, "b {b} ψ {psi} h {h}");
                }
            }
        }
    }

    /// For the circle, every smooth path is the hair core's: the exit azimuth relative to the
    /// light is `Φ(p, h) = 2pγ_t − 2γ + pπ` and the attenuation is `A_p` with the chord length.
    #[test]
    fn the_circle_reproduces_the_hair_core() {
        let eta = 1.55;
        let sigma = Rgb::new(0.2, 0.5, 1.1);
        for &theta in &[0.0, 0.5, -1.1] {
            let (s, c) = f64::sin_cos(theta);
            let plane = NormalPlane::new(eta, s, c, RootMode::Exact);
            for &phi in &[0.0, 1.0, -2.5] {
                for &h in &[-0.95, -0.4, 0.0, 0.3, 0.8] {
                    let gamma = f64::asin(h);
                    for p in 0..3 {
                        let path = smooth_path(&Ellipse::new(1.0, 0.7), eta, sigma, (s, c), phi, h, p).unwrap();
                        let want = exit_azimuth(p, gamma, plane.gamma_t(gamma));
                        assert!(
                            wrap_pi(path.exit_azimuth - phi - want).abs() < 1e-12,
                            "θ {theta} φ {phi} h {h} p {p}: {} vs {want}",
                            wrap_pi(path.exit_azimuth - phi)
                        );
                        let a = plane_attenuation(&plane, p, gamma, sigma, PathLength::Chord, true);
                        for ch in 0..3 {
                            assert!((path.attenuation[ch] - a[ch]).abs() < 1e-12, "p {p}: {path:?} vs {a:?}");
                        }
                    }
                }
            }
        }
    }

    /// Through an ellipse, the lossless paths' azimuths and attenuations change with the
    /// orientation, and the attenuations of all orders at one offset (summed to high order)
    /// account for all the entering light.
    #[test]
    fn lossless_orders_sum_to_one() {
        let e = Ellipse::new(0.7, 0.3);
        for &h in &[-0.8, 0.1, 0.6] {
            let total: f64 = (0..200)
                .filter_map(|p| smooth_path(&e, 1.55, Rgb::ZERO, (0.3f64.sin(), 0.3f64.cos()), 0.9, h, p))
                .map(|path| path.attenuation[0])
                .sum();
            assert!((total - 1.0).abs() < 1e-6, "h {h}: {total}");
        }
        let a = smooth_path(&Ellipse::new(0.7, 0.0), 1.55, Rgb::ZERO, (0.0, 1.0), 0.0, 0.2, 2).unwrap();
        let b = smooth_path(&Ellipse::new(0.7, FRAC_PI_2), 1.55, Rgb::ZERO, (0.0, 1.0), 0.0, 0.2, 2).unwrap();
        assert!((a.exit_azimuth - b.exit_azimuth).abs() > 0.05);
    }
}
