//! A square cloth draped over a sphere that rests on the floor `y = 0`: a procedural height
//! field (no cloth simulation), written as an OBJ by `fiberlab mesh cloth` for
//! `scenes/cloth.toml`.
//!
//! # Shape
//! The sphere has radius `R` and centre `(0, R, 0)`; the cloth spans `|x|, |z| ≤ L` seen from
//! above. With `r = √(x² + z²)` and `φ = atan2(z, x)` the cloth's height is
//!
//! `y(x, z) = y_f + H·exp(−r²/ρ(r, φ)²)`,  `H = 2R + c − y_f`,
//! `ρ(r, φ) = ρ₀·(1 + a·s(r)·cos(kφ + φ₀))`,  `ρ₀ = 2R`,
//!
//! a Gaussian bump of peak `2R + c` (the sphere's top plus a clearance `c`) that falls to the
//! floor offset `y_f`, with `k` folds whose amplitude `a` is faded in by `s(r)`, the smoothstep
//! from `r = R` (the sphere's silhouette seen from above) to `r = 2R`. Inside the silhouette
//! `ρ = ρ₀`, and there the bump stays above the sphere: near the top the Gaussian's curvature
//! `2H/ρ₀² ≈ 1/R` equals the sphere's, and at `r = R` the bump is at `H·e^{−1/4} + y_f ≈ 1.56R`,
//! above the sphere's equator `R` (the test measures the clearance of every vertex and of
//! points inside the triangles).
//!
//! # Attributes
//! A regular grid of `(n + 1)²` vertices, two triangles per cell, counter-clockwise seen from
//! above (geometric normals up). Texture coordinates are the top view, `u = ½ + x/(2L)` and
//! `v = ½ − z/(2L)` (as the cabochon's, [`crate::cabochon`]), both in `[0, 1]`: `u` runs
//! along the cloth's `x` edge, `v` along its `z` edge, so the renderer's tangent `∂P/∂u`
//! follows one thread direction over the whole cloth. Shading normals are the height field's,
//! `normalize(−∂y/∂x, 1, −∂y/∂z)`, from central differences of the closed form.

use fiberlab_geometry::TriangleMesh;
use fiberlab_math::DVec3;
use fiberlab_math::special::smoothstep;
use std::fmt::Write;

/// Why a draped cloth cannot be made.
#[derive(Debug, thiserror::Error, PartialEq)]
#[error("draped cloth: {0}")]
pub struct DrapedClothError(String);

/// The shape's parameters (module documentation).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DrapedCloth {
    /// Sphere radius `R`.
    pub sphere_radius: f64,
    /// Half the cloth's side, `L`.
    pub half_size: f64,
    /// Clearance `c` above the sphere's top.
    pub clearance: f64,
    /// Height `y_f` of the cloth's edge above the floor.
    pub floor_offset: f64,
    /// Number of folds `k` around the sphere.
    pub folds: u32,
    /// Relative fold amplitude `a` of the width `ρ`.
    pub fold_amplitude: f64,
    /// Phase `φ₀` of the folds, radians.
    pub fold_phase: f64,
    /// Grid cells `n` per side.
    pub resolution: usize,
}

impl Default for DrapedCloth {
    fn default() -> Self {
        Self {
            sphere_radius: 0.5,
            half_size: 1.5,
            clearance: 0.01,
            floor_offset: 0.004,
            folds: 7,
            fold_amplitude: 0.12,
            fold_phase: 0.4,
            resolution: 64,
        }
    }
}

/// An indexed triangle grid: positions, unit normals and uvs per vertex, triangles as vertex
/// indices.
#[derive(Clone, Debug)]
pub struct ClothGrid {
    /// Vertex positions.
    pub positions: Vec<DVec3>,
    /// Unit shading normals per vertex.
    pub normals: Vec<DVec3>,
    /// Texture coordinates per vertex.
    pub uvs: Vec<[f64; 2]>,
    /// Triangles (counter-clockwise seen from above).
    pub triangles: Vec<[usize; 3]>,
}

/// The coarsest grid accepted (cells per side).
pub const MIN_RESOLUTION: usize = 32;

impl DrapedCloth {
    /// Checks the parameters: every length finite and > 0 (the floor offset ≥ 0 and below
    /// the sphere's top), the cloth wider than the sphere, `0 ≤ a < 0.5`, `n ≥ 32`.
    pub fn validate(&self) -> Result<(), DrapedClothError> {
        let fail = |m: String| Err(DrapedClothError(m));
        let positive = [("sphere radius", self.sphere_radius), ("clearance", self.clearance)];
        for (name, x) in positive {
            if !(x.is_finite() && x > 0.0) {
                return fail(format!("{name} = {x:?} must be finite and > 0"));
            }
        }
        if !(self.half_size.is_finite() && self.half_size > self.sphere_radius) {
            return fail(format!(
                "half size = {:?} must be finite and larger than the sphere radius {}",
                self.half_size, self.sphere_radius
            ));
        }
        if !(self.floor_offset.is_finite() && (0.0..self.sphere_radius).contains(&self.floor_offset)) {
            return fail(format!("floor offset = {:?} must be in [0, sphere radius)", self.floor_offset));
        }
        if !(self.fold_amplitude.is_finite() && (0.0..0.5).contains(&self.fold_amplitude)) {
            return fail(format!("fold amplitude = {:?} must be in [0, 0.5)", self.fold_amplitude));
        }
        if !self.fold_phase.is_finite() {
            return fail(format!("fold phase = {:?} must be finite", self.fold_phase));
        }
        if self.resolution < MIN_RESOLUTION {
            // Coarser, the flat triangles over the top cut into the sphere (their sag
            // ≈ d²/(4R) on the cell diagonal d exceeds the clearance).
            return fail(format!("resolution = {} must be ≥ {MIN_RESOLUTION}", self.resolution));
        }
        Ok(())
    }

    /// The cloth's height at `(x, z)` (module documentation).
    #[must_use]
    pub fn height(&self, x: f64, z: f64) -> f64 {
        let big_r = self.sphere_radius;
        let r2 = x * x + z * z;
        let r = r2.sqrt();
        let phi = z.atan2(x);
        let fold = self.fold_amplitude * smoothstep(big_r, 2.0 * big_r, r);
        let rho = 2.0 * big_r * (1.0 + fold * (f64::from(self.folds) * phi + self.fold_phase).cos());
        let peak = 2.0 * big_r + self.clearance - self.floor_offset;
        self.floor_offset + peak * (-r2 / (rho * rho)).exp()
    }

    /// The point of the cloth above `(x, z)`.
    #[must_use]
    pub fn point(&self, x: f64, z: f64) -> DVec3 {
        DVec3::new(x, self.height(x, z), z)
    }

    /// The unit normal of the height field at `(x, z)` (central differences).
    #[must_use]
    pub fn normal(&self, x: f64, z: f64) -> DVec3 {
        let h = 1e-6 * self.half_size;
        let dx = (self.height(x + h, z) - self.height(x - h, z)) / (2.0 * h);
        let dz = (self.height(x, z + h) - self.height(x, z - h)) / (2.0 * h);
        DVec3::new(-dx, 1.0, -dz).normalize()
    }

    /// The sphere's centre.
    #[must_use]
    pub fn sphere_center(&self) -> DVec3 {
        DVec3::new(0.0, self.sphere_radius, 0.0)
    }

    /// The grid (module documentation).
    pub fn grid(&self) -> Result<ClothGrid, DrapedClothError> {
        self.validate()?;
        let n = self.resolution;
        let l = self.half_size;
        let (mut positions, mut normals, mut uvs) = (Vec::new(), Vec::new(), Vec::new());
        for j in 0..=n {
            for i in 0..=n {
                let (x, z) = (-l + 2.0 * l * i as f64 / n as f64, -l + 2.0 * l * j as f64 / n as f64);
                positions.push(self.point(x, z));
                normals.push(self.normal(x, z));
                uvs.push([0.5 + x / (2.0 * l), 0.5 - z / (2.0 * l)]);
            }
        }
        let index = |i: usize, j: usize| j * (n + 1) + i;
        let mut triangles = Vec::with_capacity(2 * n * n);
        for j in 0..n {
            for i in 0..n {
                // (Δz) × (Δx) points up: corners ordered z-edge first.
                triangles.push([index(i, j), index(i, j + 1), index(i + 1, j)]);
                triangles.push([index(i + 1, j), index(i, j + 1), index(i + 1, j + 1)]);
            }
        }
        Ok(ClothGrid { positions, normals, uvs, triangles })
    }
}

impl ClothGrid {
    /// The grid as a mesh for the renderer.
    #[must_use]
    pub fn mesh(&self) -> TriangleMesh {
        let corners = |t: &[usize; 3]| t.map(|k| self.positions[k]);
        let triangles = self.triangles.iter().map(corners).collect();
        let uvs = self.triangles.iter().map(|t| t.map(|k| self.uvs[k])).collect();
        let normals = self.triangles.iter().map(|t| t.map(|k| self.normals[k])).collect();
        TriangleMesh::with_attributes(triangles, uvs, normals)
    }

    /// The grid as Wavefront OBJ text (`v`, `vt`, `vn`, faces `a/a/a`), with a header comment.
    #[must_use]
    pub fn to_obj(&self, header: &str) -> String {
        let mut s = String::new();
        for line in header.lines() {
            let _ = writeln!(s, "# {line}");
        }
        let _ = writeln!(s, "o cloth");
        for p in &self.positions {
            let _ = writeln!(s, "v {:.5} {:.5} {:.5}", p.x, p.y, p.z);
        }
        for [u, v] in &self.uvs {
            let _ = writeln!(s, "vt {u:.5} {v:.5}");
        }
        for n in &self.normals {
            let _ = writeln!(s, "vn {:.5} {:.5} {:.5}", n.x, n.y, n.z);
        }
        for t in &self.triangles {
            let [a, b, c] = t.map(|k| k + 1);
            let _ = writeln!(s, "f {a}/{a}/{a} {b}/{b}/{b} {c}/{c}/{c}");
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid() -> (DrapedCloth, ClothGrid) {
        let cloth = DrapedCloth::default();
        (cloth, cloth.grid().unwrap())
    }

    #[test]
    fn uvs_cover_the_unit_square_and_follow_x() {
        let (cloth, g) = grid();
        assert_eq!(g.positions.len(), (cloth.resolution + 1).pow(2));
        for (p, [u, v]) in g.positions.iter().zip(&g.uvs) {
            assert!((0.0..=1.0).contains(u) && (0.0..=1.0).contains(v), "uv ({u}, {v})");
            assert!((u - (0.5 + p.x / 3.0)).abs() < 1e-12 && (v - (0.5 - p.z / 3.0)).abs() < 1e-12);
        }
        let (lo, hi) = g.uvs.iter().fold((1.0f64, 0.0f64), |(lo, hi), [u, _]| (lo.min(*u), hi.max(*u)));
        assert!(lo == 0.0 && hi == 1.0);
    }

    /// Normals: unit, up, and perpendicular to the surface (against the triangles' geometric
    /// normals, an independent finite difference at the grid's own spacing).
    #[test]
    fn normals_are_unit_and_agree_with_the_faces() {
        let (_, g) = grid();
        for n in &g.normals {
            assert!((n.length() - 1.0).abs() < 1e-12 && n.y > 0.0);
        }
        let mut worst = 1.0f64;
        for t in &g.triangles {
            let [a, b, c] = t.map(|k| g.positions[k]);
            let face = (b - a).cross(c - a).normalize();
            assert!(face.y > 0.0, "triangle {t:?} faces down");
            let mean = (g.normals[t[0]] + g.normals[t[1]] + g.normals[t[2]]).normalize();
            worst = worst.min(face.dot(mean));
        }
        assert!(worst > 0.995, "worst cos(face, vertex normals) = {worst}");
    }

    #[test]
    fn no_degenerate_triangles() {
        let (cloth, g) = grid();
        assert_eq!(g.triangles.len(), 2 * cloth.resolution.pow(2));
        let cell = 2.0 * cloth.half_size / cloth.resolution as f64;
        for t in &g.triangles {
            let [a, b, c] = t.map(|k| g.positions[k]);
            let area = 0.5 * (b - a).cross(c - a).length();
            // The top view of every triangle has area cell²/2; tilting only enlarges it.
            assert!(area >= 0.5 * cell * cell * (1.0 - 1e-9), "area {area}");
        }
    }

    /// No vertex, edge midpoint or centroid is inside the sphere (clearance > 0), and the
    /// cloth touches down near its top: the smallest clearance is close to `c`.
    #[test]
    fn the_sphere_is_not_pierced() {
        for resolution in [MIN_RESOLUTION, 64, 160] {
            let cloth = DrapedCloth { resolution, ..DrapedCloth::default() };
            let g = cloth.grid().unwrap();
            let (centre, r) = (cloth.sphere_center(), cloth.sphere_radius);
            let mut nearest = f64::INFINITY;
            for t in &g.triangles {
                let [a, b, c] = t.map(|k| g.positions[k]);
                for p in [a, (a + b) / 2.0, (b + c) / 2.0, (c + a) / 2.0, (a + b + c) / 3.0] {
                    nearest = nearest.min((p - centre).length() - r);
                }
            }
            assert!(nearest > 0.0, "resolution {resolution}: a point {nearest} inside the sphere");
            // And the closed form itself, on a fine polar grid over the silhouette.
            for i in 0..=200 {
                for k in 0..64 {
                    let (rr, phi) = (r * f64::from(i) / 200.0, std::f64::consts::TAU * f64::from(k) / 64.0);
                    let p = cloth.point(rr * phi.cos(), rr * phi.sin());
                    assert!((p - centre).length() > r, "closed form inside at r = {rr}");
                }
            }
            if resolution == 160 || resolution == 64 {
                assert!(nearest < 2.0 * cloth.clearance, "the cloth floats {nearest} above the sphere");
            }
        }
    }

    #[test]
    fn the_obj_reads_back_with_its_attributes() {
        let cloth = DrapedCloth { resolution: MIN_RESOLUTION, ..DrapedCloth::default() };
        let g = cloth.grid().unwrap();
        let text = g.to_obj("test cloth");
        let mesh = fiberlab_io::obj::parse_obj(&text, std::path::Path::new("cloth.obj"), 1.0, DVec3::ZERO).unwrap();
        assert!(mesh.has_uvs());
        assert_eq!(mesh.len(), 2 * MIN_RESOLUTION.pow(2));
    }

    #[test]
    fn bad_parameters_are_refused() {
        let bad = [
            DrapedCloth { resolution: MIN_RESOLUTION - 1, ..DrapedCloth::default() },
            DrapedCloth { half_size: 0.4, ..DrapedCloth::default() },
            DrapedCloth { sphere_radius: f64::NAN, ..DrapedCloth::default() },
            DrapedCloth { fold_amplitude: 0.6, ..DrapedCloth::default() },
            DrapedCloth { floor_offset: -0.1, ..DrapedCloth::default() },
        ];
        for c in bad {
            assert!(c.grid().is_err(), "{c:?}");
        }
    }
}
