//! Surfaces: spheres and triangle meshes (OBJ via `tobj`, with texture coordinates `vt` and
//! vertex normals `vn` when the file has them), for heads, floors, emitters and textured
//! surfaces; their shading geometry (uv, shading normal, tangent) is in [`crate::mesh`].

use crate::bvh::{Aabb, Bvh, Ray};
use crate::mesh::{SurfacePoint, triangle_tangent};
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
        check_faces(text, path)?;
        for (n, line) in text.lines().enumerate() {
            let mut words = line.split_whitespace();
            if let Some("vt") = words.clone().next() {
                let ok = words
                    .clone()
                    .skip(1)
                    .take(2)
                    .map(|w| w.parse::<f32>())
                    .filter(|x| matches!(x, Ok(v) if v.is_finite()))
                    .count();
                if ok != 2 {
                    return Err(MeshError {
                        path: path.into(),
                        message: format!(
                            "line {}: expected two finite texture coordinates, got `{}`",
                            n + 1,
                            line.trim()
                        ),
                    });
                }
            }
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
        let (mut triangles, mut uvs, mut normals) = (Vec::new(), Vec::new(), Vec::new());
        for m in models {
            let p = &m.mesh.positions;
            let vertex = |i: u32| {
                let i = 3 * i as usize;
                DVec3::new(p[i].into(), p[i + 1].into(), p[i + 2].into()) * scale + translate
            };
            let (tc, nv) = (&m.mesh.texcoords, &m.mesh.normals);
            let uv = |i: u32| {
                let i = 2 * i as usize;
                [f64::from(tc[i]), f64::from(tc[i + 1])]
            };
            // A scale keeps normals; negative scales are refused by the scene file.
            let normal = |i: u32| {
                let i = 3 * i as usize;
                DVec3::new(nv[i].into(), nv[i + 1].into(), nv[i + 2].into())
            };
            for t in m.mesh.indices.chunks_exact(3) {
                triangles.push([vertex(t[0]), vertex(t[1]), vertex(t[2])]);
                if !tc.is_empty() {
                    uvs.push([uv(t[0]), uv(t[1]), uv(t[2])]);
                }
                if !nv.is_empty() {
                    normals.push([normal(t[0]), normal(t[1]), normal(t[2])]);
                }
            }
        }
        // Faces all have vt (vn) or none do (`check_faces`), but one model of several may lack
        // them: then the mesh has none.
        if uvs.len() != triangles.len() {
            uvs.clear();
        }
        if normals.len() != triangles.len() {
            normals.clear();
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
        Ok(Self::with_attributes(triangles, uvs, normals))
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

/// Checks the `f` records of OBJ text: every `vt`/`vn` index refers to a record before it,
/// and every face has texture coordinates (normals) or none does. Errors name the line.
fn check_faces(text: &str, path: &Path) -> Result<(), MeshError> {
    let fail =
        |n: usize, message: String| MeshError { path: path.into(), message: format!("line {}: {message}", n + 1) };
    let (mut counts, mut first_with, mut first_without) = ([0i64; 3], [None; 3], [None; 3]);
    const NAMES: [&str; 3] = ["vertex `v`", "texture coordinate `vt`", "normal `vn`"];
    for (n, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => counts[0] += 1,
            Some("vt") => counts[1] += 1,
            Some("vn") => counts[2] += 1,
            Some("f") => {
                for corner in words {
                    let parts: Vec<&str> = corner.split('/').collect();
                    for k in 0..3 {
                        let Some(&w) = parts.get(k).filter(|w| !w.is_empty()) else {
                            first_without[k].get_or_insert(n);
                            continue;
                        };
                        first_with[k].get_or_insert(n);
                        let Ok(i) = w.parse::<i64>() else {
                            return Err(fail(n, format!("face corner `{corner}`: `{w}` is not an index")));
                        };
                        let resolved = if i < 0 { counts[k] + i + 1 } else { i };
                        if i == 0 || resolved < 1 || resolved > counts[k] {
                            return Err(fail(
                                n,
                                format!(
                                    "face corner `{corner}` refers to {} {i}, but {} are defined before it",
                                    NAMES[k], counts[k]
                                ),
                            ));
                        }
                    }
                }
            }
            _ => {}
        }
    }
    for k in 1..3 {
        if let (Some(with), Some(without)) = (first_with[k], first_without[k]) {
            return Err(fail(
                without,
                format!(
                    "a face without a {} while the face at line {} has one; give every face one or none",
                    NAMES[k],
                    with + 1
                ),
            ));
        }
    }
    Ok(())
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

    /// Texture coordinates and normals are interpolated at the hit; the tangent is ∂P/∂u.
    #[test]
    fn obj_uvs_normals_and_tangents() {
        // A unit quad in z = 0 whose u runs along −y and v along +x (a rotated map), with
        // vertex normals tilted toward +x on the right edge.
        let text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 1 0\nvt 1 1\nvt 0 1\nvt 0 0\n\
                    vn 0 0 1\nvn 1 0 1\nf 1/1/1 2/2/2 3/3/2 4/4/1\n";
        let mesh = TriangleMesh::parse_obj(text, Path::new("q.obj"), 1.0, DVec3::ZERO).unwrap();
        assert!(mesh.has_uvs());
        let (x, y) = (0.25, 0.6);
        let (t, ng, s) = mesh.intersect_point(&Ray::new(DVec3::new(x, y, 2.0), -DVec3::Z)).unwrap();
        assert!((t - 2.0).abs() < 1e-12 && (ng - DVec3::Z).length() < 1e-12);
        // The map: u = 1 − y, v = x.
        let [u, v] = s.uv.unwrap();
        assert!((u - (1.0 - y)).abs() < 1e-6 && (v - x).abs() < 1e-6, "{u} {v}");
        assert!((s.tangent - DVec3::new(0.0, -1.0, 0.0)).length() < 1e-6, "{}", s.tangent);
        // Normals: (1 − x)·(0,0,1) + x·(1,0,1)/√2, normalized.
        let expected = (DVec3::Z * (1.0 - x) + DVec3::new(1.0, 0.0, 1.0).normalize() * x).normalize();
        assert!((s.normal - expected).length() < 1e-6, "{} vs {expected}", s.normal);
        assert!(s.tangent.dot(s.normal).abs() < 1e-12);
        // Without vt: no uvs.
        let bare =
            TriangleMesh::parse_obj("v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 3\n", Path::new("b.obj"), 1.0, DVec3::ZERO);
        assert!(!bare.unwrap().has_uvs());
    }

    #[test]
    fn faces_referring_to_missing_records_name_the_file_and_line() {
        let cases = [
            (
                "v 0 0 0\nv 1 0 0\nv 1 1 0\nvt 0 0\nf 1/1 2/2 3/1\n",
                "line 5: face corner `2/2` refers to texture coordinate `vt` 2, but 1 are defined",
            ),
            (
                "v 0 0 0\nv 1 0 0\nv 1 1 0\nvn 0 0 1\nf 1//1 2//1 3//-2\n",
                "line 5: face corner `3//-2` refers to normal `vn` -2",
            ),
            ("v 0 0 0\nv 1 0 0\nf 1 2 3\n", "line 3: face corner `3` refers to vertex `v` 3"),
            (
                "v 0 0 0\nv 1 0 0\nv 1 1 0\nvt 0 0\nf 1/1 2/1 3/1\nf 1 2 3\n",
                "line 6: a face without a texture coordinate `vt` while the face at line 5 has one",
            ),
            ("v 0 0 0\nvt 0 nan\n", "line 2: expected two finite texture coordinates, got `vt 0 nan`"),
        ];
        for (text, says) in cases {
            let e = TriangleMesh::parse_obj(text, Path::new("dir/m.obj"), 1.0, DVec3::ZERO).unwrap_err().to_string();
            assert!(e.starts_with("dir/m.obj: ") && e.contains(says), "{e}");
        }
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
