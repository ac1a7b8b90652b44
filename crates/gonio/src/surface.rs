//! Ray intersection with the fiber surface: an elliptical cylinder, optionally cut into a
//! sawtooth of conical cuticle scales.
//!
//! # Geometry
//! In cross-section coordinates `Y = y cosψ + z sinψ`, `Z = (−y sinψ + z cosψ)/a` (ψ the
//! orientation of the major axis, a the axis ratio) the surface is `sqrt(Y² + Z²) = s(x)`.
//! Smooth fiber: `s = 1`. Scales: on each scale `k` (x ∈ [kL, (k+1)L)) the surface is a cone,
//! `s(x) = 1 + tanα·(x − (k + ½)L)`, so for α > 0 the scale surface rises toward the tip and
//! its normal leans toward the root by α (along the major axis); at `x = kL` a flat annular
//! step (normal ±x) joins the thick end of one scale to the thin start of the next.

use fiberlab_math::DVec3;

/// A surface hit: ray parameter and outward unit normal.
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    /// Ray parameter of the hit.
    pub t: f64,
    /// Outward unit normal at the hit.
    pub normal: DVec3,
}

/// The fiber surface with its cross-section transform precomputed.
#[derive(Clone, Copy, Debug)]
pub struct Surface {
    cos_psi: f64,
    sin_psi: f64,
    aspect: f64,
    /// tan α (0 for a smooth fiber).
    slope: f64,
    /// Scale length L.
    length: f64,
    /// Overall size of the cross-section (1 for the fiber, < 1 for a medulla).
    radius_scale: f64,
}

impl Surface {
    /// A surface with orientation ψ (radians), axis ratio `aspect`, scale angle α and length L.
    #[must_use]
    pub fn new(psi: f64, aspect: f64, scale_angle: f64, scale_length: f64) -> Self {
        let (sin_psi, cos_psi) = psi.sin_cos();
        Self { cos_psi, sin_psi, aspect, slope: scale_angle.tan(), length: scale_length, radius_scale: 1.0 }
    }

    /// A smooth surface with the same cross-section shape and orientation, scaled by
    /// `scale` (the medulla of a fiber with cross-section `of`).
    #[must_use]
    pub fn new_smooth_scaled(of: &Surface, scale: f64) -> Self {
        // Scaling the cross-section by `scale` is a smooth surface at radius `scale`;
        // represented by dividing coordinates, i.e. an aspect-preserving shrink.
        Self {
            cos_psi: of.cos_psi,
            sin_psi: of.sin_psi,
            aspect: of.aspect,
            slope: 0.0,
            length: of.length,
            radius_scale: scale,
        }
    }

    /// Cross-section coordinates `(Y, Z)` of a point or direction.
    #[inline]
    fn yz(&self, v: DVec3) -> (f64, f64) {
        let k = 1.0 / self.radius_scale;
        (k * (v.y * self.cos_psi + v.z * self.sin_psi), k * (-v.y * self.sin_psi + v.z * self.cos_psi) / self.aspect)
    }

    /// Scaled radius `q = sqrt(Y² + Z²)` of a point (1 on a smooth surface).
    #[must_use]
    pub fn radius(&self, p: DVec3) -> f64 {
        let (y, z) = self.yz(p);
        (y * y + z * z).sqrt()
    }

    /// Outward normal of the conical (or cylindrical) part at `p`, where `s = s(x)`.
    fn cone_normal(&self, p: DVec3, s: f64) -> DVec3 {
        let (y, z) = self.yz(p);
        let gy = y * self.cos_psi - z * self.sin_psi / self.aspect;
        let gz = y * self.sin_psi + z * self.cos_psi / self.aspect;
        DVec3::new(-s * self.slope, gy, gz).normalize()
    }

    /// Smallest root `t > t_min` of `|(Y,Z)(o + t d)|² = (s0 + s1 t)²` within `[lo, hi]`
    /// and with `s0 + s1 t > 0`.
    fn quadric(&self, o: DVec3, d: DVec3, s0: f64, s1: f64, lo: f64, hi: f64) -> Option<f64> {
        let (oy, oz) = self.yz(o);
        let (dy, dz) = self.yz(d);
        let a = dy * dy + dz * dz - s1 * s1;
        let b = 2.0 * (oy * dy + oz * dz - s0 * s1);
        let c = oy * oy + oz * oz - s0 * s0;
        let roots = if a.abs() < 1e-14 {
            if b.abs() < 1e-300 {
                return None;
            }
            [-c / b, f64::INFINITY]
        } else {
            let disc = b * b - 4.0 * a * c;
            if disc < 0.0 {
                return None;
            }
            // Stable quadratic formula.
            let q = -0.5 * (b + b.signum() * disc.sqrt());
            let (r0, r1) = (q / a, if q != 0.0 { c / q } else { -b / a });
            if r0 < r1 { [r0, r1] } else { [r1, r0] }
        };
        roots.into_iter().find(|&t| t >= lo && t <= hi && s0 + s1 * t > 0.0)
    }

    /// First hit of the ray `o + t d` with the surface for `t > t_min` (from either side).
    #[must_use]
    pub fn intersect(&self, o: DVec3, d: DVec3, t_min: f64) -> Option<Hit> {
        if self.slope == 0.0 {
            let t = self.quadric(o, d, 1.0, 0.0, t_min, f64::INFINITY)?;
            return Some(Hit { t, normal: self.cone_normal(o + d * t, 1.0) });
        }
        let half = 0.5 * self.slope.abs() * self.length;
        // The ray can only meet the surface inside the bounding cylinder s = 1 + |tanα|L/2.
        let (oy, oz) = self.yz(o);
        let (dy, dz) = self.yz(d);
        let (a, b, c) = (dy * dy + dz * dz, 2.0 * (oy * dy + oz * dz), oy * oy + oz * oz - (1.0 + half).powi(2));
        if a < 1e-300 {
            return None; // parallel to the axis: never reaches the surface
        }
        let disc = b * b - 4.0 * a * c;
        if disc < 0.0 {
            return None;
        }
        let sq = disc.sqrt();
        let (t_in, t_out) = ((-b - sq) / (2.0 * a), (-b + sq) / (2.0 * a));
        let start = t_min.max(t_in);
        if start > t_out {
            return None;
        }
        let l = self.length;
        let x_at = |t: f64| o.x + d.x * t;
        // Walk the scales crossed between `start` and `t_out`.
        let mut k = (x_at(start) / l).floor();
        if d.x.abs() < 1e-15 {
            return self.scale_hit(o, d, k, start, t_out, t_min);
        }
        let step = d.x.signum();
        let mut t0 = start;
        loop {
            let boundary = if step > 0.0 { (k + 1.0) * l } else { k * l };
            let t1 = ((boundary - o.x) / d.x).min(t_out);
            if let Some(h) = self.scale_hit(o, d, k, t0, t1, t_min) {
                return Some(h);
            }
            if t1 >= t_out {
                return None;
            }
            // Crossing into the next scale: the step face at `boundary`.
            let p = o + d * t1;
            let q = self.radius(p);
            if t1 > t_min && q >= 1.0 - half && q <= 1.0 + half {
                return Some(Hit { t: t1, normal: DVec3::new(self.slope.signum(), 0.0, 0.0) });
            }
            k += step;
            t0 = t1;
        }
    }

    /// Hit with the cone of scale `k` for `t` in `[lo, hi]`, `t > t_min`.
    fn scale_hit(&self, o: DVec3, d: DVec3, k: f64, lo: f64, hi: f64, t_min: f64) -> Option<Hit> {
        let centre = (k + 0.5) * self.length;
        let s0 = 1.0 + self.slope * (o.x - centre);
        let s1 = self.slope * d.x;
        let t = self.quadric(o, d, s0, s1, lo.max(t_min), hi)?;
        Some(Hit { t, normal: self.cone_normal(o + d * t, s0 + s1 * t) })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn smooth_circle_hit_and_normal() {
        let s = Surface::new(0.0, 1.0, 0.0, 1.0);
        let h = s.intersect(DVec3::new(0.3, 0.5, -5.0), DVec3::Z, 0.0).unwrap();
        assert!((h.t - (5.0 - (1.0f64 - 0.25).sqrt())).abs() < 1e-12);
        let p = DVec3::new(0.3, 0.5, -5.0) + DVec3::Z * h.t;
        assert!((h.normal - DVec3::new(0.0, p.y, p.z)).length() < 1e-12);
        // From inside, the exit.
        let h2 = s.intersect(p, DVec3::Z, h.t.max(1e-9) * 0.0 + 1e-9).unwrap();
        assert!((h2.t - 2.0 * (0.75f64).sqrt()).abs() < 1e-9);
    }

    #[test]
    fn scale_normals_lean_toward_the_root() {
        let alpha = 3f64.to_radians();
        let s = Surface::new(0.0, 1.0, alpha, 0.4);
        // Ray in the normal plane toward the axis, hitting mid-scale.
        let h = s.intersect(DVec3::new(0.2, 0.0, -3.0), DVec3::Z, 0.0).unwrap();
        assert!(h.normal.x < 0.0);
        assert!((h.normal.x.abs().asin() - alpha).abs() < 1e-3, "{:?}", h.normal);
    }

    #[test]
    fn hits_lie_on_the_surface() {
        let s = Surface::new(0.4, 0.8, 5f64.to_radians(), 0.3);
        let mut found = 0;
        for i in 0..2000 {
            let f = i as f64;
            let o = DVec3::new((f * 0.37).sin(), 3.0 * (f * 0.11).cos(), 3.0 * (f * 0.11).sin());
            let d = (DVec3::new((f * 0.7).sin() * 2.0, 0.0, 0.0) - DVec3::new(0.0, o.y, o.z)
                + DVec3::new(0.0, (f * 1.3).sin() * 0.9, (f * 1.9).cos() * 0.9))
            .normalize();
            if let Some(h) = s.intersect(o, d, 0.0) {
                found += 1;
                let p = o + d * h.t;
                let k = (p.x / 0.3).floor();
                let sx = 1.0 + s.slope * (p.x - (k + 0.5) * 0.3);
                let q = s.radius(p);
                let on_cone = (q - sx).abs() < 1e-9;
                let on_step = (p.x / 0.3 - (p.x / 0.3).round()).abs() < 1e-9;
                assert!(on_cone || on_step, "point {p:?} q {q} s {sx}");
                assert!(h.normal.dot(d) < 0.0, "outside ray must meet an outward normal head-on");
            }
        }
        assert!(found > 500);
    }
}
