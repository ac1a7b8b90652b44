//! Shading geometry of surfaces: texture coordinates, interpolated shading normals and tangents
//! of triangle meshes, spheres and the floor, and the local shading frame a surface model is
//! evaluated in (`z` = shading normal, `x` = tangent along the texture coordinate `u`).
//!
//! # Tangents
//! A triangle with texture coordinates has the tangent `∂P/∂u` of the affine map from `(u, v)`
//! to its plane: with edges `e₁ = P₁ − P₀`, `e₂ = P₂ − P₀` and `(Δu₁, Δv₁)`, `(Δu₂, Δv₂)` their
//! texture-coordinate differences, `∂P/∂u = (Δv₂ e₁ − Δv₁ e₂)/(Δu₁Δv₂ − Δu₂Δv₁)` (constant over
//! the triangle). Without texture coordinates, or when they are degenerate (zero area in uv),
//! the tangent is the first edge `e₁`. At a hit the tangent is made orthogonal to the shading
//! normal by one Gram–Schmidt step, `t ← normalize(t − n (n·t))`; should that vanish (a tangent
//! along the normal) any unit vector orthogonal to `n` is used.
//!
//! Spheres: `p − c = r (sinθ cosφ, cosθ, sinθ sinφ)` with θ from `+y`, `u = φ/2π ∈ [0, 1)`,
//! `v = 1 − θ/π` (1 at the top, as image rows run: see `fiberlab_render::texture`), tangent `∂P/∂φ ∝ (−sinφ, 0, cosφ)`. The floor `y = y₀`: `u = x`, `v = z` in
//! scene units, tangent `+x`.

use fiberlab_math::DVec3;

/// Where a ray meets a surface, for shading.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfacePoint {
    /// Texture coordinates (`None`: the surface has none).
    pub uv: Option<[f64; 2]>,
    /// Unit shading normal (interpolated vertex normals, else the geometric normal), on the
    /// side of the geometric normal it was given with (not flipped toward the ray).
    pub normal: DVec3,
    /// Unit tangent along `u`, orthogonal to `normal`.
    pub tangent: DVec3,
}

impl SurfacePoint {
    /// A point with normal `normal` and tangent `tangent` made orthogonal to it (Gram–Schmidt).
    #[must_use]
    pub fn new(uv: Option<[f64; 2]>, normal: DVec3, tangent: DVec3) -> Self {
        let normal = normal.normalize();
        let along = tangent - normal * normal.dot(tangent);
        // A residual at the rounding level of a tangent along the normal has no direction.
        let tangent =
            if along.length() > 1e-9 * tangent.length() { along.normalize() } else { normal.any_orthonormal_vector() };
        Self { uv, normal, tangent }
    }

    /// The point on a sphere of centre `c` at `p`: normal, spherical texture coordinates and
    /// the tangent along φ (see the module documentation).
    #[must_use]
    pub fn on_sphere(p: DVec3, c: DVec3, r: f64) -> Self {
        let n = (p - c) / r;
        let phi = n.z.atan2(n.x);
        let u = if phi < 0.0 { phi / std::f64::consts::TAU + 1.0 } else { phi / std::f64::consts::TAU };
        let v = 1.0 - n.y.clamp(-1.0, 1.0).acos() / std::f64::consts::PI;
        Self::new(Some([u, v]), n, DVec3::new(-phi.sin(), 0.0, phi.cos()))
    }

    /// The shading frame for light arriving from the side of `toward` (e.g. `−ray direction`):
    /// the normal flipped to that side (the tangent kept, `y = z × x` then flips with it).
    #[must_use]
    pub fn frame_facing(&self, toward: DVec3) -> ShadingFrame {
        let z = if self.normal.dot(toward) < 0.0 { -self.normal } else { self.normal };
        ShadingFrame { x: self.tangent, y: z.cross(self.tangent), z }
    }
}

/// An orthonormal shading frame: `z` the normal, `x` the tangent along `u`, `y = z × x`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShadingFrame {
    /// Tangent.
    pub x: DVec3,
    /// Bitangent `z × x`.
    pub y: DVec3,
    /// Normal.
    pub z: DVec3,
}

impl ShadingFrame {
    /// World → local.
    #[must_use]
    pub fn to_local(&self, w: DVec3) -> DVec3 {
        DVec3::new(w.dot(self.x), w.dot(self.y), w.dot(self.z))
    }

    /// Local → world.
    #[must_use]
    pub fn to_world(&self, l: DVec3) -> DVec3 {
        self.x * l.x + self.y * l.y + self.z * l.z
    }
}

/// The tangent `∂P/∂u` of a triangle from its corners and texture coordinates (unnormalized
/// direction, unit length returned), or the first edge when there are no or degenerate
/// coordinates (module documentation).
#[must_use]
pub fn triangle_tangent(p: &[DVec3; 3], uv: Option<&[[f64; 2]; 3]>) -> DVec3 {
    let (e1, e2) = (p[1] - p[0], p[2] - p[0]);
    let fallback = e1.try_normalize().unwrap_or(DVec3::X);
    let Some(uv) = uv else { return fallback };
    let (du1, dv1) = (uv[1][0] - uv[0][0], uv[1][1] - uv[0][1]);
    let (du2, dv2) = (uv[2][0] - uv[0][0], uv[2][1] - uv[0][1]);
    let det = du1 * dv2 - du2 * dv1;
    if det.abs() < 1e-300 {
        return fallback;
    }
    ((e1 * dv2 - e2 * dv1) / det).try_normalize().unwrap_or(fallback)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A triangle whose uv map is a known affine map: the tangent is its `u` column.
    #[test]
    fn triangle_tangent_is_dp_du_of_the_affine_uv_map() {
        // P(u, v) = O + u·a + v·b with a, b chosen; corners at uv (0.1,0.2), (0.7,0.3), (0.2,0.9).
        let (o, a, b) = (DVec3::new(1.0, 2.0, 3.0), DVec3::new(0.0, 2.0, 1.0), DVec3::new(1.0, 0.0, -1.0));
        let uv = [[0.1, 0.2], [0.7, 0.3], [0.2, 0.9]];
        let p = uv.map(|[u, v]| o + a * u + b * v);
        let t = triangle_tangent(&p, Some(&uv));
        assert!((t - a.normalize()).length() < 1e-12, "{t}");
        // Degenerate uv (collinear): the first edge.
        let flat = [[0.0, 0.0], [1.0, 1.0], [2.0, 2.0]];
        assert!((triangle_tangent(&p, Some(&flat)) - (p[1] - p[0]).normalize()).length() < 1e-12);
        assert!((triangle_tangent(&p, None) - (p[1] - p[0]).normalize()).length() < 1e-12);
    }

    #[test]
    fn gram_schmidt_and_facing_frames_are_orthonormal_and_right_handed() {
        let n = DVec3::new(0.2, 1.0, -0.3).normalize();
        let s = SurfacePoint::new(None, n, DVec3::new(1.0, 0.5, 0.0));
        assert!(s.tangent.dot(n).abs() < 1e-12 && (s.tangent.length() - 1.0).abs() < 1e-12);
        // Tangent along the normal: any orthonormal one.
        let s2 = SurfacePoint::new(None, n, n * 3.0);
        assert!(s2.tangent.dot(n).abs() < 1e-12);
        for toward in [n, -n] {
            let f = s.frame_facing(toward);
            assert!(f.z.dot(toward) > 0.0);
            assert!((f.x.cross(f.y) - f.z).length() < 1e-12, "right-handed");
            let w = DVec3::new(0.3, -0.4, 0.5);
            assert!((f.to_world(f.to_local(w)) - w).length() < 1e-12);
        }
    }

    /// The sphere's tangent is the numerical derivative of the point along `u`.
    #[test]
    fn sphere_tangent_follows_u() {
        let (c, r) = (DVec3::new(0.5, -1.0, 2.0), 2.0);
        let at = |u: f64, v: f64| {
            let (phi, theta) = (u * std::f64::consts::TAU, (1.0 - v) * std::f64::consts::PI);
            c + r * DVec3::new(theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin())
        };
        for (u, v) in [(0.1, 0.3), (0.6, 0.7), (0.95, 0.5)] {
            let s = SurfacePoint::on_sphere(at(u, v), c, r);
            let [su, sv] = s.uv.unwrap();
            assert!((su - u).abs() < 1e-12 && (sv - v).abs() < 1e-12, "{su} {sv}");
            let d = (at(u + 1e-6, v) - at(u - 1e-6, v)).normalize();
            assert!((s.tangent - d).length() < 1e-6, "{} vs {d}", s.tangent);
        }
    }
}
