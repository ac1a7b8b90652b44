//! Surfaces: spheres and triangle meshes (with per-corner texture coordinates and normals when
//! they have them; OBJ files are read by `fiberlab_io::obj`), for heads, floors, emitters and
//! textured surfaces; their shading geometry (uv, shading normal, tangent) is in [`crate::mesh`].

use crate::bvh::{Aabb, Bvh};
use crate::mesh::{SurfacePoint, triangle_tangent};
use crate::ray::Ray;
use fiberlab_math::DVec3;

/// Nearest `t > t_min` where the ray `p + t·d` meets the sphere (either root).
#[must_use]
pub fn sphere_hit(o: DVec3, d: DVec3, c: DVec3, r: f64, t_min: f64, t_max: f64) -> Option<f64> {
    let oc = o - c;
    let b = oc.dot(d);
    // Discriminant via the closest-approach vector (precise for small spheres far away).
    let q = oc - d * b;
    let disc = r * r - q.length_squared();
    if disc < 0.0 {
        return None;
    }
    let s = disc.sqrt();
    let (t0, t1) = (-b - s, -b + s);
    if t0 > t_min && t0 < t_max {
        Some(t0)
    } else if t1 > t_min && t1 < t_max {
        Some(t1)
    } else {
        None
    }
}

/// Distance from `p` (outside) along `d` to the sphere's surface.
#[must_use]
pub fn sphere_entry(p: DVec3, d: DVec3, c: DVec3, r: f64) -> Option<f64> {
    sphere_hit(p, d, c, r, 0.0, f64::INFINITY)
}

/// A triangle mesh with its own BVH, optional per-corner texture coordinates and normals,
/// and one tangent per triangle ([`crate::mesh`]).
#[derive(Clone, Debug, Default)]
pub struct TriangleMesh {
    triangles: Vec<[DVec3; 3]>,
    /// Per-corner texture coordinates (empty: none).
    uvs: Vec<[[f64; 2]; 3]>,
    /// Per-corner unit shading normals (empty: the geometric normal).
    normals: Vec<[DVec3; 3]>,
    /// Unit `∂P/∂u` per triangle (the first edge without uvs).
    tangents: Vec<DVec3>,
    bvh: Bvh,
}

impl TriangleMesh {
    /// A mesh from triangles.
    #[must_use]
    pub fn new(triangles: Vec<[DVec3; 3]>) -> Self {
        Self::with_attributes(triangles, Vec::new(), Vec::new())
    }

    /// A mesh from triangles with per-corner texture coordinates and normals (each empty or
    /// one per triangle; normals are normalized here).
    ///
    /// # Panics
    /// When `uvs` or `normals` is neither empty nor as long as `triangles`.
    #[must_use]
    pub fn with_attributes(triangles: Vec<[DVec3; 3]>, uvs: Vec<[[f64; 2]; 3]>, normals: Vec<[DVec3; 3]>) -> Self {
        assert!(uvs.is_empty() || uvs.len() == triangles.len(), "one uv triple per triangle");
        assert!(normals.is_empty() || normals.len() == triangles.len(), "one normal triple per triangle");
        let bounds: Vec<Aabb> =
            triangles.iter().map(|t| Aabb::point(t[0]).union(Aabb::point(t[1])).union(Aabb::point(t[2]))).collect();
        let bvh = Bvh::build(&bounds);
        let tangents = triangles.iter().enumerate().map(|(i, t)| triangle_tangent(t, uvs.get(i))).collect();
        let normals = normals.into_iter().map(|n| n.map(|v| v.try_normalize().unwrap_or(DVec3::ZERO))).collect();
        Self { triangles, uvs, normals, tangents, bvh }
    }

    /// An axis-aligned quad at height `y` spanning `[-half, half]²` in x and z (a floor), with
    /// texture coordinates `u = x`, `v = z` in scene units (tangent `+x`, normal `+y`).
    #[must_use]
    pub fn floor(y: f64, half: f64) -> Self {
        let c = |x: f64, z: f64| DVec3::new(x * half, y, z * half);
        let uv = |x: f64, z: f64| [x * half, z * half];
        Self::with_attributes(
            vec![[c(-1.0, -1.0), c(1.0, 1.0), c(1.0, -1.0)], [c(-1.0, -1.0), c(-1.0, 1.0), c(1.0, 1.0)]],
            vec![[uv(-1.0, -1.0), uv(1.0, 1.0), uv(1.0, -1.0)], [uv(-1.0, -1.0), uv(-1.0, 1.0), uv(1.0, 1.0)]],
            Vec::new(),
        )
    }

    /// True when the mesh has texture coordinates.
    #[must_use]
    pub fn has_uvs(&self) -> bool {
        !self.uvs.is_empty()
    }

    /// Number of triangles.
    #[must_use]
    pub fn len(&self) -> usize {
        self.triangles.len()
    }

    /// True when there are no triangles.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.triangles.is_empty()
    }

    /// True when the ray hits any triangle within `(t_min, t_max)`.
    #[must_use]
    pub fn occluded(&self, ray: &Ray) -> bool {
        self.bvh.any(ray, |i| triangle_hit(ray, &self.triangles[i as usize], ray.t_max).is_some())
    }

    /// Nearest hit: `(t, geometric unit normal)`.
    #[must_use]
    pub fn intersect(&self, ray: &Ray) -> Option<(f64, DVec3)> {
        self.intersect_point(ray).map(|(t, n, _)| (t, n))
    }

    /// The triangles (corners in order; the geometric normal is `(b − a) × (c − a)`).
    #[must_use]
    pub fn triangles(&self) -> &[[DVec3; 3]] {
        &self.triangles
    }

    /// Per-corner texture coordinates (empty: none).
    #[must_use]
    pub fn uvs(&self) -> &[[[f64; 2]; 3]] {
        &self.uvs
    }

    /// Per-corner shading normals (empty: none).
    #[must_use]
    pub fn normals(&self) -> &[[DVec3; 3]] {
        &self.normals
    }

    /// Per-triangle tangents along `u` ([`crate::mesh::triangle_tangent`]), before the
    /// Gram–Schmidt step against the shading normal at a hit.
    #[must_use]
    pub fn tangents(&self) -> &[DVec3] {
        &self.tangents
    }

    /// The tree over the triangles (its leaves list triangle indices).
    #[must_use]
    pub fn bvh(&self) -> &Bvh {
        &self.bvh
    }

    /// Nearest hit: `(t, geometric unit normal, shading point)`. The shading normal is the
    /// barycentric interpolation of the vertex normals (the geometric normal without them, or
    /// where they cancel), on the geometric normal's side of the vertex normals' winding.
    #[must_use]
    pub fn intersect_point(&self, ray: &Ray) -> Option<(f64, DVec3, SurfacePoint)> {
        let mut best = None;
        self.bvh.traverse(ray, |i, t_max| {
            let tri = &self.triangles[i as usize];
            let (t, b1, b2) = triangle_hit_barycentric(ray, tri, t_max)?;
            best = Some((t, i as usize, b1, b2));
            Some(t)
        });
        let (t, i, b1, b2) = best?;
        let tri = &self.triangles[i];
        let ng = (tri[1] - tri[0]).cross(tri[2] - tri[0]).normalize();
        let b0 = 1.0 - b1 - b2;
        let uv = self.uvs.get(i).map(|c| [0, 1].map(|k| b0 * c[0][k] + b1 * c[1][k] + b2 * c[2][k]));
        let normal =
            self.normals.get(i).and_then(|n| (n[0] * b0 + n[1] * b1 + n[2] * b2).try_normalize()).unwrap_or(ng);
        Some((t, ng, SurfacePoint::new(uv, normal, self.tangents[i])))
    }
}

/// Möller–Trumbore ray–triangle intersection with `t_min < t < t_max`.
#[must_use]
pub fn triangle_hit(ray: &Ray, tri: &[DVec3; 3], t_max: f64) -> Option<f64> {
    triangle_hit_barycentric(ray, tri, t_max).map(|(t, _, _)| t)
}

/// Möller–Trumbore with the barycentric coordinates of the hit: `(t, b₁, b₂)`, the point being
/// `(1 − b₁ − b₂) P₀ + b₁ P₁ + b₂ P₂`.
#[must_use]
pub fn triangle_hit_barycentric(ray: &Ray, tri: &[DVec3; 3], t_max: f64) -> Option<(f64, f64, f64)> {
    let e1 = tri[1] - tri[0];
    let e2 = tri[2] - tri[0];
    let pv = ray.d.cross(e2);
    let det = e1.dot(pv);
    if det.abs() < 1e-300 {
        return None;
    }
    let inv = 1.0 / det;
    let tv = ray.o - tri[0];
    let u = tv.dot(pv) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let qv = tv.cross(e1);
    let v = ray.d.dot(qv) * inv;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    let t = e2.dot(qv) * inv;
    (t > ray.t_min && t < t_max).then_some((t, u, v))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn floor_and_sphere_hits() {
        let floor = TriangleMesh::floor(-1.0, 10.0);
        let (t, n) = floor.intersect(&Ray::new(DVec3::new(0.3, 2.0, 0.7), -DVec3::Y)).unwrap();
        assert!((t - 3.0).abs() < 1e-12 && n.y.abs() > 0.999);
        assert!(floor.intersect(&Ray::new(DVec3::new(20.0, 2.0, 0.0), -DVec3::Y)).is_none());
        let t = sphere_hit(DVec3::new(0.0, 0.0, 5.0), -DVec3::Z, DVec3::ZERO, 1.0, 0.0, f64::INFINITY).unwrap();
        assert!((t - 4.0).abs() < 1e-12);
        // From inside: the far root.
        let t = sphere_hit(DVec3::ZERO, DVec3::X, DVec3::ZERO, 1.0, 1e-9, f64::INFINITY).unwrap();
        assert!((t - 1.0).abs() < 1e-12);
    }

    #[test]
    fn floor_uvs_are_scene_coordinates() {
        let floor = TriangleMesh::floor(-1.0, 10.0);
        let (_, _, s) = floor.intersect_point(&Ray::new(DVec3::new(0.3, 2.0, -0.7), -DVec3::Y)).unwrap();
        let [u, v] = s.uv.unwrap();
        assert!((u - 0.3).abs() < 1e-12 && (v + 0.7).abs() < 1e-12);
        assert!((s.tangent - DVec3::X).length() < 1e-12);
    }
}
