//! Surfaces: spheres and triangle meshes (OBJ via `tobj`), for heads, floors and emitters.

use crate::bvh::{Aabb, Bvh, Ray};
use fiberlab_math::DVec3;
use std::path::Path;

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

/// A triangle mesh with its own BVH.
#[derive(Clone, Debug, Default)]
pub struct TriangleMesh {
    triangles: Vec<[DVec3; 3]>,
    bvh: Bvh,
}

/// Error loading a mesh.
#[derive(Debug, thiserror::Error)]
#[error("{path}: {message}")]
pub struct MeshError {
    /// File path.
    pub path: std::path::PathBuf,
    /// What went wrong.
    pub message: String,
}

impl TriangleMesh {
    /// A mesh from triangles.
    #[must_use]
    pub fn new(triangles: Vec<[DVec3; 3]>) -> Self {
        let bounds: Vec<Aabb> =
            triangles.iter().map(|t| Aabb::point(t[0]).union(Aabb::point(t[1])).union(Aabb::point(t[2]))).collect();
        let bvh = Bvh::build(&bounds);
        Self { triangles, bvh }
    }

    /// An axis-aligned quad at height `y` spanning `[-half, half]²` in x and z (a floor).
    #[must_use]
    pub fn floor(y: f64, half: f64) -> Self {
        let c = |x: f64, z: f64| DVec3::new(x * half, y, z * half);
        Self::new(vec![[c(-1.0, -1.0), c(1.0, 1.0), c(1.0, -1.0)], [c(-1.0, -1.0), c(-1.0, 1.0), c(1.0, 1.0)]])
    }

    /// Loads every object of a Wavefront OBJ file (triangulated), scaled and translated.
    pub fn load_obj(path: &Path, scale: f64, translate: DVec3) -> Result<Self, MeshError> {
        let text =
            std::fs::read_to_string(path).map_err(|e| MeshError { path: path.into(), message: e.to_string() })?;
        Self::parse_obj(&text, path, scale, translate)
    }

    /// Parses OBJ text (`path` names it in errors; nothing is read from the file system:
    /// `mtllib` lines are ignored, as materials come from the scene file).
    pub fn parse_obj(text: &str, path: &Path, scale: f64, translate: DVec3) -> Result<Self, MeshError> {
        // Vertex and normal records are checked here, with their line numbers (the OBJ reader
        // does not report lines, and would pass NaN coordinates on), in the single precision the
        // reader stores them in (where 1e39 is infinite).
        for (n, line) in text.lines().enumerate() {
            let mut words = line.split_whitespace();
            if matches!(words.next(), Some("v" | "vn")) {
                let ok =
                    words.take(3).map(|w| w.parse::<f32>()).filter(|x| matches!(x, Ok(v) if v.is_finite())).count();
                if ok != 3 {
                    return Err(MeshError {
                        path: path.into(),
                        message: format!("line {}: expected three finite coordinates, got `{}`", n + 1, line.trim()),
                    });
                }
            }
        }
        let opts = tobj::LoadOptions { triangulate: true, single_index: true, ..Default::default() };
        let no_materials = |_: &Path| Err(tobj::LoadError::OpenFileFailed);
        let (models, _) = tobj::load_obj_buf(&mut text.as_bytes(), &opts, no_materials)
            .map_err(|e| MeshError { path: path.into(), message: e.to_string() })?;
        let mut triangles = Vec::new();
        for m in models {
            let p = &m.mesh.positions;
            let vertex = |i: u32| {
                let i = 3 * i as usize;
                DVec3::new(p[i].into(), p[i + 1].into(), p[i + 2].into()) * scale + translate
            };
            for t in m.mesh.indices.chunks_exact(3) {
                triangles.push([vertex(t[0]), vertex(t[1]), vertex(t[2])]);
            }
        }
        if triangles.is_empty() {
            return Err(MeshError { path: path.into(), message: "no triangles".into() });
        }
        if let Some(t) = triangles.iter().position(|t| !t.iter().all(|v| v.is_finite())) {
            return Err(MeshError {
                path: path.into(),
                message: format!(
                    "triangle {t}: a vertex is not finite after scale = {scale:?}, translate = {translate}"
                ),
            });
        }
        Ok(Self::new(triangles))
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
        let mut best = None;
        self.bvh.traverse(ray, |i, t_max| {
            let tri = &self.triangles[i as usize];
            let t = triangle_hit(ray, tri, t_max)?;
            best = Some((t, (tri[1] - tri[0]).cross(tri[2] - tri[0]).normalize()));
            Some(t)
        });
        best
    }
}

/// Möller–Trumbore ray–triangle intersection with `t_min < t < t_max`.
#[must_use]
pub fn triangle_hit(ray: &Ray, tri: &[DVec3; 3], t_max: f64) -> Option<f64> {
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
    (t > ray.t_min && t < t_max).then_some(t)
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
    fn obj_loads() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("q.obj");
        std::fs::write(&path, "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n").unwrap();
        let mesh = TriangleMesh::load_obj(&path, 2.0, DVec3::ZERO).unwrap();
        assert_eq!(mesh.len(), 2);
        let (t, _) = mesh.intersect(&Ray::new(DVec3::new(1.0, 1.0, 3.0), -DVec3::Z)).unwrap();
        assert!((t - 3.0).abs() < 1e-12);
        assert!(TriangleMesh::load_obj(&dir.path().join("none.obj"), 1.0, DVec3::ZERO).is_err());
        // A NaN or missing coordinate is an error naming its line.
        std::fs::write(&path, "v 0 0 0\nv 1 nan 0\nv 1 1 0\nf 1 2 3\n").unwrap();
        let e = TriangleMesh::load_obj(&path, 1.0, DVec3::ZERO).unwrap_err().to_string();
        assert!(e.ends_with("line 2: expected three finite coordinates, got `v 1 nan 0`"), "{e}");
        std::fs::write(&path, "v 0 0 0\nv 1 0 0\nv 1 1\nf 1 2 3\n").unwrap();
        assert!(TriangleMesh::load_obj(&path, 1.0, DVec3::ZERO).unwrap_err().to_string().contains("line 3"));
        // Normals the same way; a coordinate beyond f32 (which the reader would make ∞) too.
        std::fs::write(&path, "v 0 0 0\nv 1 0 0\nv 1 1 0\nvn 0 0 1\nvn 0 inf 1\nf 1//1 2//1 3//2\n").unwrap();
        let e = TriangleMesh::load_obj(&path, 1.0, DVec3::ZERO).unwrap_err().to_string();
        assert!(e.ends_with("line 5: expected three finite coordinates, got `vn 0 inf 1`"), "{e}");
        std::fs::write(&path, "v 0 0 0\nv 1 0 0\nv 1e39 1 0\nf 1 2 3\n").unwrap();
        let e = TriangleMesh::load_obj(&path, 1.0, DVec3::ZERO).unwrap_err().to_string();
        assert!(e.contains("line 3:"), "{e}");
        // Finite vertices that scaling makes infinite.
        std::fs::write(&path, "v 0 0 0\nv 1 0 0\nv 3e38 1 0\nf 1 2 3\n").unwrap();
        let e = TriangleMesh::load_obj(&path, 1e300, DVec3::ZERO).unwrap_err().to_string();
        assert!(e.contains("triangle 0: a vertex is not finite after scale = 1e300"), "{e}");
    }
}
