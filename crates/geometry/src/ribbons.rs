//! Ribbons: flat strips of a given width along a polyline centreline, as triangles with
//! per-corner shading normals and texture coordinates (a [`TriangleMesh`] for a surface model).
//! What a pbrt `ribbon` or `flat` curve, or a USD `BasisCurves` prim with `normals`, becomes
//! when a surface model (such as `leaf`) is put on it.
//!
//! # A ribbon
//! At station `j` of the centreline `c_0 … c_{n−1}` (widths `w_j`):
//! 1. **Tangent** `t_j`: the unit chord at the ends; inside, the bisector of the unit chords on
//!    either side (the exact tangent of a circular arc sampled at equal steps).
//! 2. **Width direction** `ŵ_j = (o_j × t_j)/|o_j × t_j|`, pbrt-v4's rule for ribbons
//!    (`dpdv = cross(n, dpdu)`), with `o_j` the given normal `n_j` ([`Facing::Normals`]) or the
//!    direction to the camera `e − c_j` ([`Facing::Toward`]: a **camera-facing flat curve**).
//!    Where `o_j` is parallel to the tangent (no width direction), `ŵ` of the previous station
//!    made perpendicular to `t_j` is kept (for the first station, any perpendicular).
//! 3. **Corners** `c_j ∓ ½w_j ŵ_j` (u = 0 and 1), **shading normal** `t_j × ŵ_j` — the part of
//!    `o_j` perpendicular to the tangent, so a camera-facing ribbon turns its face to the
//!    camera — and `v` the arc length from the root over the strand's length.
//! 4. **Triangles** `[l_j, r_j, r_{j+1}]` and `[l_j, r_{j+1}, l_{j+1}]` per segment, each left
//!    out where it has no area (a station of width 0: a pointed tip or root).
//!
//! pbrt intersects `flat` curves facing each ray's own origin; a mesh faces one point, the
//! camera: camera rays see a flat curve at its full width, as pbrt shows it, while shadow and
//! indirect rays see the same fixed strip from their own side (foreshortened, as a real blade
//! would be).

use crate::shapes::TriangleMesh;
use fiberlab_math::DVec3;

/// What turns a ribbon's face (module docs, step 2).
#[derive(Clone, Copy, Debug)]
pub enum Facing<'a> {
    /// One normal per station of the centreline.
    Normals(&'a [DVec3]),
    /// Toward a point (the camera's eye).
    Toward(DVec3),
}

/// Triangles of ribbons with their per-corner texture coordinates and unit shading normals.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Ribbons {
    /// Triangles, ribbon after ribbon, root to tip.
    pub triangles: Vec<[DVec3; 3]>,
    /// Per-corner `(u, v)`: `u` across (0 → 1), `v` the arc length over the length.
    pub uvs: Vec<[[f64; 2]; 3]>,
    /// Per-corner unit shading normals.
    pub normals: Vec<[DVec3; 3]>,
}

impl Ribbons {
    /// Most triangles `push` adds for `n` stations.
    #[must_use]
    pub fn max_triangles(stations: usize) -> usize {
        2 * stations.saturating_sub(1)
    }

    /// Adds the ribbon along `centre` with diameters `widths` (one per station), turned by
    /// `facing` (module docs). Fewer than two stations add nothing.
    ///
    /// # Panics
    /// When `widths` (or the normals of [`Facing::Normals`]) are not one per station.
    pub fn push(&mut self, centre: &[DVec3], widths: &[f64], facing: Facing<'_>) {
        let n = centre.len();
        assert_eq!(widths.len(), n, "one width per station");
        if let Facing::Normals(normals) = facing {
            assert_eq!(normals.len(), n, "one normal per station");
        }
        if n < 2 {
            return;
        }
        let chord = |j: usize| (centre[j + 1] - centre[j]).try_normalize();
        let mut length = vec![0.0; n];
        for j in 1..n {
            length[j] = length[j - 1] + centre[j].distance(centre[j - 1]);
        }
        let total = length[n - 1];
        let mut previous_tangent = DVec3::X;
        let mut previous_side: Option<DVec3> = None;
        let mut stations = Vec::with_capacity(n);
        for j in 0..n {
            let before = if j > 0 { chord(j - 1) } else { None };
            let after = if j + 1 < n { chord(j) } else { None };
            let t = match (before, after) {
                (Some(a), Some(b)) => (a + b).try_normalize().unwrap_or(b),
                (Some(a), None) | (None, Some(a)) => a,
                (None, None) => previous_tangent,
            };
            previous_tangent = t;
            let o = match facing {
                Facing::Normals(normals) => normals[j],
                Facing::Toward(eye) => eye - centre[j],
            };
            let side = o
                .cross(t)
                .try_normalize()
                .or_else(|| previous_side.and_then(|s| (s - t * s.dot(t)).try_normalize()))
                .unwrap_or_else(|| t.any_orthonormal_vector());
            previous_side = Some(side);
            let half = 0.5 * widths[j];
            let v = if total > 0.0 { length[j] / total } else { 0.0 };
            stations.push((centre[j] - side * half, centre[j] + side * half, t.cross(side), v, widths[j] > 0.0));
        }
        for pair in stations.windows(2) {
            let [(l0, r0, n0, v0, wide0), (l1, r1, n1, v1, wide1)] = [pair[0], pair[1]];
            if wide0 {
                self.triangles.push([l0, r0, r1]);
                self.uvs.push([[0.0, v0], [1.0, v0], [1.0, v1]]);
                self.normals.push([n0, n0, n1]);
            }
            if wide1 {
                self.triangles.push([l0, r1, l1]);
                self.uvs.push([[0.0, v0], [1.0, v1], [0.0, v1]]);
                self.normals.push([n0, n1, n1]);
            }
        }
    }

    /// The mesh of the triangles (its BVH built).
    #[must_use]
    pub fn into_mesh(self) -> TriangleMesh {
        TriangleMesh::with_attributes(self.triangles, self.uvs, self.normals)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ray::Ray;
    use crate::test_random::Lcg;
    use std::f64::consts::PI;

    /// A planar arc ribbon with normals along the plane's normal lies in the plane: an annulus
    /// sector. Rays from above hit the mesh exactly where they meet the sector (at the plane's
    /// distance), and miss outside it, except within the chords' sagitta of its arcs.
    #[test]
    fn a_flat_arc_ribbon_is_its_annulus_sector() {
        let (radius, width, sweep, stations) = (1.0, 0.3, 0.75 * PI, 33);
        let phi = |j: usize| sweep * j as f64 / (stations - 1) as f64;
        let centre: Vec<DVec3> = (0..stations).map(|j| DVec3::new(phi(j).cos(), phi(j).sin(), 0.0) * radius).collect();
        let widths = vec![width; stations];
        let normals = vec![DVec3::Z; stations];
        let mut r = Ribbons::default();
        r.push(&centre, &widths, Facing::Normals(&normals));
        assert_eq!(r.triangles.len(), 2 * (stations - 1));
        let mesh = r.into_mesh();
        // The chords of the edges lie within their sagitta of the arcs; the end stations' width
        // runs along the one-sided chord, turned by half a step from the radius.
        let step = sweep / (stations - 1) as f64;
        let margin = (radius + 0.5 * width) * (1.0 - (0.5 * step).cos()) + 0.5 * width * (0.5 * step).sin() + 1e-6;
        let (inner, outer) = (radius - 0.5 * width, radius + 0.5 * width);
        let mut rng = Lcg(7);
        let (mut hits, mut misses) = (0, 0);
        for _ in 0..20_000 {
            let target = DVec3::new(3.0 * rng.next() - 1.5, 3.0 * rng.next() - 1.5, 0.0);
            let origin = target + DVec3::new(rng.next() - 0.5, rng.next() - 0.5, 1.0) * 2.0;
            let ray = Ray::new(origin, (target - origin).normalize());
            let rho = target.truncate().length();
            // The angle from the sector's start, in (−π, π]; arc lengths to its two radial edges.
            let angle = target.y.atan2(target.x);
            let (from_start, from_end) = (angle * rho, (sweep - angle) * rho);
            let surely_in = rho > inner + margin && rho < outer - margin && from_start > margin && from_end > margin;
            let surely_out = rho < inner - margin
                || rho > outer + margin
                || (angle < 0.0 && -from_start > margin)
                || (angle > sweep && -from_end > margin);
            let got = mesh.intersect(&ray);
            if surely_in {
                let (t, n) = got.expect("a ray into the sector hits the ribbon");
                assert!((t - origin.distance(target)).abs() < 1e-9, "t = {t}");
                assert!(n.z.abs() > 1.0 - 1e-12);
                hits += 1;
            } else if surely_out {
                assert!(got.is_none(), "a ray outside the sector hits at {target}");
                misses += 1;
            }
        }
        assert!(hits > 1000 && misses > 8000, "hits {hits}, misses {misses}");
    }

    /// A camera-facing straight curve seen from the camera is a band of the curve's width:
    /// rays from the eye that pass closer to the centreline than half the width (less a
    /// margin) hit it, at the distance of the point where they pass it; rays passing farther
    /// miss. The distance between a ray and the centreline is computed here on its own (two
    /// skew lines), not from the mesh's construction.
    #[test]
    fn a_flat_curve_faces_the_camera_at_its_full_width() {
        let eye = DVec3::new(0.3, 4.0, -2.0);
        let (a, b) = (DVec3::new(-1.0, 0.0, 0.0), DVec3::new(1.0, 0.2, 0.5));
        let stations = 9;
        let centre: Vec<DVec3> = (0..stations).map(|j| a.lerp(b, j as f64 / (stations - 1) as f64)).collect();
        let width = 0.05;
        let mut r = Ribbons::default();
        r.push(&centre, &vec![width; stations], Facing::Toward(eye));
        // Shading normals face the eye.
        for (tri, n) in r.triangles.iter().zip(&r.normals) {
            for k in 0..3 {
                assert!(n[k].dot((eye - tri[k]).normalize()) > 0.0);
            }
        }
        let mesh = r.into_mesh();
        let axis = (b - a).normalize();
        let mut rng = Lcg(11);
        let (mut hits, mut misses) = (0, 0);
        for _ in 0..4000 {
            let s = -0.1 + 1.2 * rng.next();
            let target = a.lerp(b, s) + (rng.vec() - 0.5) * 0.12;
            let d = (target - eye).normalize();
            // Closest approach of the ray eye + λd and the line a + μ·axis.
            let w0 = eye - a;
            let (bb, dd, ee) = (d.dot(axis), d.dot(w0), axis.dot(w0));
            let denom = 1.0 - bb * bb;
            let (lambda, mu) = ((bb * ee - dd) / denom, (ee - bb * dd) / denom);
            let gap = (eye + d * lambda).distance(a + axis * mu);
            let along = mu / (b - a).length();
            let got = mesh.intersect(&Ray::new(eye, d));
            if gap < 0.49 * width && (0.02..0.98).contains(&along) {
                let (t, _) = got.expect("a ray passing within half the width hits");
                assert!((t - lambda).abs() < width, "t {t}, closest approach at {lambda}");
                hits += 1;
            } else if gap > 0.51 * width {
                assert!(got.is_none(), "a ray passing {gap} from the centreline hits");
                misses += 1;
            }
        }
        assert!(hits > 300 && misses > 1500, "hits {hits}, misses {misses}");
    }

    /// A twisted ribbon: normals turning about a straight centreline by a quarter turn. The
    /// width direction at each station is perpendicular to the tangent and the normal, the
    /// shading normal is the normal, the corners are half a width out, v runs 0 → 1, and a
    /// pointed tip (width 0) leaves out its degenerate triangle.
    #[test]
    fn ribbon_corners_follow_the_normals_and_the_width() {
        let stations = 5;
        let centre: Vec<DVec3> = (0..stations).map(|j| DVec3::new(j as f64, 0.0, 0.0)).collect();
        let angle = |j: usize| 0.5 * PI * j as f64 / (stations - 1) as f64;
        let normals: Vec<DVec3> = (0..stations).map(|j| DVec3::new(0.0, angle(j).cos(), angle(j).sin())).collect();
        let widths: Vec<f64> = (0..stations).map(|j| 0.2 * (1.0 - j as f64 / (stations - 1) as f64)).collect();
        let mut r = Ribbons::default();
        r.push(&centre, &widths, Facing::Normals(&normals));
        assert_eq!(r.triangles.len(), 2 * (stations - 1) - 1);
        for j in 0..stations - 1 {
            let [l, right, _] = r.triangles[2 * j];
            let mid = 0.5 * (l + right);
            assert!(mid.distance(centre[j]) < 1e-12);
            assert!((l.distance(right) - widths[j]).abs() < 1e-12);
            let side = (right - l).normalize();
            assert!(side.dot(DVec3::X).abs() < 1e-12 && side.dot(normals[j]).abs() < 1e-12);
            // ŵ = n × t: right of the centreline along n × x̂.
            assert!(side.distance(normals[j].cross(DVec3::X)) < 1e-12);
            assert!(r.normals[2 * j][0].distance(normals[j]) < 1e-12);
            assert!((r.uvs[2 * j][0][1] - j as f64 / (stations - 1) as f64).abs() < 1e-12);
        }
        // A normal along the tangent keeps the previous width direction.
        let mut bad = normals.clone();
        bad[2] = DVec3::X;
        let mut r2 = Ribbons::default();
        r2.push(&centre, &widths, Facing::Normals(&bad));
        assert!(r2.triangles.iter().flatten().all(|p| p.is_finite()));
        assert!(r2.normals.iter().flatten().all(|n| (n.length() - 1.0).abs() < 1e-12));
    }
}
