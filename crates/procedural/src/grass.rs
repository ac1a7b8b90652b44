//! A patch of grass: blades as thin curved ribbons (triangle strips with per-corner normals and
//! texture coordinates) standing on the plane `y = 0`, for a two-sided transmitting surface
//! model such as `leaf`.
//!
//! Why ribbons and not fibers: a grass blade is a few millimetres wide and a fraction of a
//! millimetre thick, flat, and what makes backlit grass glow is light crossing its face; a
//! fiber model (even `hollow-fiber`) assumes a round cross-section whose width the pixel
//! footprint averages over, which a blade is not. A ribbon carries the leaf model's reflection
//! and transmission on both faces, and the renderer's triangle meshes, BVH and surface
//! models already handle it.
//!
//! Deterministic for a seed: blade `i` draws from its own stream
//! (`SplitMix64::stream(seed, i)`), so a blade does not depend on the others or on thread count.
//!
//! # A blade
//! 1. **Root**: uniform in the patch `[−sx/2, sx/2] × [−sz/2, sz/2]` (`size = [sx, sz]`); with
//!    `clumps > 0` blade `i` belongs to tuft `i mod clumps`, whose centre is uniform in the
//!    patch, and its root is uniform in the disk of radius `clump_radius` around it.
//! 2. **Centreline**: a circular arc of length `L = height·(1 − height_jitter·ξ)` in the
//!    vertical plane of the blade's azimuth ψ (uniform, or pointing away from its tuft's
//!    centre), its tangent's angle from `+y` growing linearly from `θ₀ = lean·ξ` to
//!    `θ₀ + b`, `b = bend·(½ + ½ξ)`: with `k = b/L`, the point at arc length s is
//!    `P(s) = root + c(s)·T(θ₀ + ks/2)`, `T(θ) = sinθ·d_ψ + cosθ·ŷ`, `c(s) = 2 sin(ks/2)/k`
//!    (the chord; `s` as `k → 0`). `2·lean + bend ≤ 180°`, so the centreline stays above the
//!    ground: `y(s) = (sin(θ₀ + ks) − sin θ₀)/k ≥ 0` while `θ₀ + ks ≤ π − θ₀`.
//! 3. **Ribbon**: the width direction starts horizontal, `ŵ = d_ψ × ŷ` normalised (the blade
//!    bends over its face), and turns about the tangent by `τ(s) = τ·s/L`, `τ = twist·(2ξ − 1)`.
//!    The width is `w(s) = w₀(1 − (1 − tip_ratio)·s/L)`, `w₀ = width·(¾ + ¼ξ)` (at most
//!    `width`); the corners are `P(s) ± ½w(s)·ŵ(s)`, the shading normal `T × ŵ`.
//! 4. **Triangles**: two per segment (`segments` equal steps in s), one for the last segment of
//!    a pointed blade (`tip_ratio = 0`). Texture coordinates: `u` across (0 → 1), `v = s/L`.
//!
//! Each ξ is a fresh uniform number of the blade's stream.
//!
//! # As ribbon curves
//! [`GrassParams::strands`] gives the same blades as linear ribbon curves (the centreline
//! points `P(s)` of the stations, the width `w(s)` and the normal `T × ŵ` at each), what
//! `fiberlab hair generate --style grass` writes to a `.usda` file. The renderer rebuilds the
//! ribbon from them (`fiberlab_geometry::ribbons`: width along `n × t`, with `t` the bisector
//! of the chords): the same corners at every station but the root and the tip, where the
//! one-sided chord turns the width by at most half a segment's bend about the normal.

use fiberlab_geometry::TriangleMesh;
use fiberlab_io::{Basis, CurveKind, Strands};
use fiberlab_math::DVec3;
use fiberlab_math::split_mix::SplitMix64;
use serde::Deserialize;
use std::f64::consts::TAU;

/// Most triangles one patch may have (about 600 bytes each while the mesh is built: the
/// geometry here, the mesh's copy, tangents and BVH; 4M triangles ≈ 2.4 GB).
pub const MAX_TRIANGLES: u64 = 4_000_000;

/// Bytes per triangle while a patch is generated and turned into a mesh (see [`MAX_TRIANGLES`]).
pub const BYTES_PER_TRIANGLE: u64 = 600;

/// Largest length in the parameters (size, height, width, clump radius): far from overflow.
const MAX_LENGTH: f64 = 1e6;

/// Parameters of a grass patch (module documentation). In a scene file:
/// `[[mesh]] grass = { blades = 4000, height = 0.25, … }`.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GrassParams {
    /// Number of blades.
    pub blades: usize,
    /// Segments along each blade, 1–64.
    pub segments: usize,
    /// Patch size `[sx, sz]` (centred on the origin).
    pub size: [f64; 2],
    /// Largest blade length.
    pub height: f64,
    /// Blade lengths are uniform in `[height·(1 − height_jitter), height]`; [0, 1).
    pub height_jitter: f64,
    /// Largest width at the root.
    pub width: f64,
    /// Width at the tip over width at the root, [0, 1].
    pub tip_ratio: f64,
    /// Largest lean of the root's tangent from vertical, degrees, [0, 90).
    pub lean_deg: f64,
    /// Largest turn of the tangent from root to tip, degrees (each blade: ½ to all of it);
    /// `2·lean_deg + bend_deg ≤ 180`.
    pub bend_deg: f64,
    /// Largest twist of the ribbon about its centreline from root to tip, degrees, [0, 720].
    pub twist_deg: f64,
    /// Number of tufts (0: blades uniform over the patch).
    pub clumps: usize,
    /// Radius of a tuft.
    pub clump_radius: f64,
    /// Random seed.
    pub seed: u64,
}

impl Default for GrassParams {
    /// A lawn-like 1 × 1 patch: 4000 blades up to 0.25 long and 1 cm wide, pointed, leaning up
    /// to 20° and bending up to 50°, twisted up to 60°, in 200 tufts of radius 0.04.
    fn default() -> Self {
        Self {
            blades: 4000,
            segments: 8,
            size: [1.0, 1.0],
            height: 0.25,
            height_jitter: 0.4,
            width: 0.01,
            tip_ratio: 0.0,
            lean_deg: 20.0,
            bend_deg: 50.0,
            twist_deg: 60.0,
            clumps: 200,
            clump_radius: 0.04,
            seed: 1,
        }
    }
}

/// Why parameters were rejected.
#[derive(Debug, thiserror::Error, PartialEq)]
#[error("grass: `{key}` = {value} is invalid; expected {expected}")]
pub struct GrassError {
    /// Parameter name.
    pub key: &'static str,
    /// Value given.
    pub value: String,
    /// Valid range.
    pub expected: String,
}

/// The triangles of a patch, with per-corner texture coordinates and unit shading normals.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct GrassGeometry {
    /// Triangles, blade after blade, root to tip.
    pub triangles: Vec<[DVec3; 3]>,
    /// Per-corner `(u, v)`: u across the blade, v = s/L along it.
    pub uvs: Vec<[[f64; 2]; 3]>,
    /// Per-corner unit normals `T × ŵ`.
    pub normals: Vec<[DVec3; 3]>,
}

impl GrassGeometry {
    /// The mesh, moved by `offset`.
    #[must_use]
    pub fn into_mesh(self, offset: DVec3) -> TriangleMesh {
        let triangles = self.triangles.into_iter().map(|t| t.map(|p| p + offset)).collect();
        TriangleMesh::with_attributes(triangles, self.uvs, self.normals)
    }
}

impl GrassParams {
    /// Checks every parameter's range and the triangle count against [`MAX_TRIANGLES`].
    pub fn validate(&self) -> Result<(), GrassError> {
        let bad = |key, value: f64, expected: &str| {
            Err(GrassError { key, value: format!("{value:?}"), expected: expected.into() })
        };
        let length = |key, v: f64| {
            if v.is_finite() && v > 0.0 && v <= MAX_LENGTH {
                Ok(())
            } else {
                bad(key, v, "finite, > 0 and at most 1e6")
            }
        };
        if !(1..=64).contains(&self.segments) {
            return Err(GrassError { key: "segments", value: self.segments.to_string(), expected: "1 to 64".into() });
        }
        length("size", self.size[0])?;
        length("size", self.size[1])?;
        length("height", self.height)?;
        length("width", self.width)?;
        if self.clumps > 0 {
            length("clump_radius", self.clump_radius)?;
        } else if !(self.clump_radius.is_finite() && self.clump_radius >= 0.0) {
            return bad("clump_radius", self.clump_radius, "finite and ≥ 0");
        }
        if !(0.0..1.0).contains(&self.height_jitter) {
            return bad("height_jitter", self.height_jitter, "in [0, 1)");
        }
        if !(0.0..=1.0).contains(&self.tip_ratio) {
            return bad("tip_ratio", self.tip_ratio, "in [0, 1]");
        }
        if !(0.0..90.0).contains(&self.lean_deg) {
            return bad("lean_deg", self.lean_deg, "in [0, 90)");
        }
        if !(self.bend_deg >= 0.0 && 2.0 * self.lean_deg + self.bend_deg <= 180.0) {
            return bad("bend_deg", self.bend_deg, "≥ 0 with 2·lean_deg + bend_deg ≤ 180 (tips above the ground)");
        }
        if !(0.0..=720.0).contains(&self.twist_deg) {
            return bad("twist_deg", self.twist_deg, "in [0, 720]");
        }
        let triangles = self.triangle_count();
        if self.blades == 0 || triangles > MAX_TRIANGLES {
            return Err(GrassError {
                key: "blades",
                value: self.blades.to_string(),
                expected: format!(
                    "1 or more, with blades × segments × 2 ≤ {MAX_TRIANGLES} triangles ({} MB while built; this is {triangles})",
                    MAX_TRIANGLES * BYTES_PER_TRIANGLE / 1_000_000
                ),
            });
        }
        Ok(())
    }

    /// Triangles the patch has (two per segment; one fewer per blade when pointed).
    #[must_use]
    pub fn triangle_count(&self) -> u64 {
        let per_blade = 2 * self.segments as u64 - u64::from(self.tip_ratio == 0.0);
        (self.blades as u64).saturating_mul(per_blade)
    }

    /// Peak bytes generating the patch and building its mesh take ([`BYTES_PER_TRIANGLE`]).
    #[must_use]
    pub fn estimated_bytes(&self) -> u64 {
        self.triangle_count().saturating_mul(BYTES_PER_TRIANGLE)
    }

    /// Bytes [`GrassParams::strands`] and their `.usda` text take: per point, 28 in the
    /// strands and about 100 of text (three coordinates, a width and a normal).
    #[must_use]
    pub fn estimated_strand_bytes(&self) -> u64 {
        (self.blades as u64).saturating_mul(self.segments as u64 + 1).saturating_mul(128)
    }

    /// Grows the patch.
    pub fn generate(&self) -> Result<GrassGeometry, GrassError> {
        self.validate()?;
        let n = self.triangle_count() as usize;
        let mut g = GrassGeometry {
            triangles: Vec::with_capacity(n),
            uvs: Vec::with_capacity(n),
            normals: Vec::with_capacity(n),
        };
        // Tuft centres from their own stream (index beyond any blade's).
        let mut tuft_rng = SplitMix64::stream(self.seed, u64::MAX);
        let tufts: Vec<DVec3> = (0..self.clumps).map(|_| self.uniform_in_patch(&mut tuft_rng)).collect();
        let mut corners = Vec::with_capacity(self.segments + 1);
        for i in 0..self.blades {
            let mut rng = SplitMix64::stream(self.seed, i as u64);
            self.blade(&mut rng, tufts.get(i % self.clumps.max(1)).copied(), &mut corners);
            self.push_strip(&corners, &mut g);
        }
        Ok(g)
    }

    /// The blades as linear ribbon curves (module docs, "As ribbon curves"): one strand of
    /// `segments + 1` points per blade, its diameter the blade's width, a unit normal per point.
    pub fn strands(&self) -> Result<Strands, GrassError> {
        self.validate()?;
        let n = self.blades * (self.segments + 1);
        let mut s = Strands {
            points: Vec::with_capacity(n),
            widths: Vec::with_capacity(n),
            counts: Vec::with_capacity(self.blades),
            basis: Basis::Linear,
            kind: CurveKind::Ribbon,
            normals: Vec::with_capacity(n),
        };
        let mut tuft_rng = SplitMix64::stream(self.seed, u64::MAX);
        let tufts: Vec<DVec3> = (0..self.clumps).map(|_| self.uniform_in_patch(&mut tuft_rng)).collect();
        let mut corners = Vec::with_capacity(self.segments + 1);
        let f32s = |v: DVec3| [v.x as f32, v.y as f32, v.z as f32];
        for i in 0..self.blades {
            let mut rng = SplitMix64::stream(self.seed, i as u64);
            self.blade(&mut rng, tufts.get(i % self.clumps.max(1)).copied(), &mut corners);
            for &(l, r, normal, _) in &corners {
                s.points.push(f32s(0.5 * (l + r)));
                s.widths.push(l.distance(r) as f32);
                s.normals.push(f32s(normal));
            }
            s.counts.push((self.segments + 1) as u32);
        }
        Ok(s)
    }

    /// A point uniform in the patch at `y = 0`.
    fn uniform_in_patch(&self, rng: &mut SplitMix64) -> DVec3 {
        let [sx, sz] = self.size;
        DVec3::new(sx * (rng.next_f64() - 0.5), 0.0, sz * (rng.next_f64() - 0.5))
    }

    /// The corners of one blade at `segments + 1` stations: (left, right, centre normal, v).
    fn blade(&self, rng: &mut SplitMix64, tuft: Option<DVec3>, out: &mut Vec<(DVec3, DVec3, DVec3, f64)>) {
        let (root, psi) = match tuft {
            Some(c) => {
                // Uniform in the tuft's disk; leaning away from its centre.
                let (r, a) = (self.clump_radius * rng.next_f64().sqrt(), TAU * rng.next_f64());
                (c + DVec3::new(r * a.cos(), 0.0, r * a.sin()), a)
            }
            None => (self.uniform_in_patch(rng), TAU * rng.next_f64()),
        };
        let length = self.height * (1.0 - self.height_jitter * rng.next_f64());
        let theta0 = self.lean_deg.to_radians() * rng.next_f64();
        let b = self.bend_deg.to_radians() * (0.5 + 0.5 * rng.next_f64());
        let tau = self.twist_deg.to_radians() * (2.0 * rng.next_f64() - 1.0);
        let w0 = self.width * (0.75 + 0.25 * rng.next_f64());
        let d = DVec3::new(psi.cos(), 0.0, psi.sin());
        let flat_side = d.cross(DVec3::Y).normalize();
        let k = b / length;
        let tangent = |theta: f64| d * theta.sin() + DVec3::Y * theta.cos();
        out.clear();
        for j in 0..=self.segments {
            let v = j as f64 / self.segments as f64;
            let s = v * length;
            let chord = if (k * s).abs() < 1e-9 { s } else { 2.0 * (0.5 * k * s).sin() / k };
            let centre = root + tangent(theta0 + 0.5 * k * s) * chord;
            let t = tangent(theta0 + k * s);
            // The width direction turned by τ·v about the tangent (flat_side ⟂ t always).
            let (sin_a, cos_a) = (tau * v).sin_cos();
            let side = flat_side * cos_a + t.cross(flat_side) * sin_a;
            let half = 0.5 * w0 * (1.0 - (1.0 - self.tip_ratio) * v);
            out.push((centre - side * half, centre + side * half, t.cross(side).normalize(), v));
        }
    }

    /// Two triangles per segment of `corners` (one for a pointed last segment).
    fn push_strip(&self, corners: &[(DVec3, DVec3, DVec3, f64)], g: &mut GrassGeometry) {
        for pair in corners.windows(2) {
            let [(l0, r0, n0, v0), (l1, r1, n1, v1)] = [pair[0], pair[1]];
            g.triangles.push([l0, r0, r1]);
            g.uvs.push([[0.0, v0], [1.0, v0], [1.0, v1]]);
            g.normals.push([n0, n0, n1]);
            let pointed_tip = v1 == 1.0 && self.tip_ratio == 0.0;
            if !pointed_tip {
                g.triangles.push([l0, r1, l1]);
                g.uvs.push([[0.0, v0], [1.0, v1], [0.0, v1]]);
                g.normals.push([n0, n1, n1]);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn small() -> GrassParams {
        GrassParams { blades: 300, clumps: 20, ..GrassParams::default() }
    }

    /// Same parameters, same triangles, bit for bit; another seed, other triangles; a blade does
    /// not depend on how many blades follow it.
    #[test]
    fn generation_is_deterministic_and_blades_are_independent() {
        let p = small();
        let (a, b) = (p.generate().unwrap(), p.generate().unwrap());
        assert_eq!(a, b);
        let c = GrassParams { seed: 2, ..p.clone() }.generate().unwrap();
        assert_ne!(a.triangles, c.triangles);
        let fewer = GrassParams { blades: 100, ..p.clone() }.generate().unwrap();
        assert_eq!(fewer.triangles[..], a.triangles[..fewer.triangles.len()]);
        assert_eq!(a.triangles.len() as u64, p.triangle_count());
        assert_eq!(GrassParams { tip_ratio: 0.3, ..p }.generate().unwrap().triangles.len(), 300 * 16);
    }

    /// Every vertex within the bounds the parameters allow; every blade's length, width and
    /// tangent angle within theirs (measured on the triangles: the centreline is the mean of a
    /// station's corners); normals unit and perpendicular to the width.
    #[test]
    fn blades_stay_within_their_parameter_bounds() {
        for p in [
            small(),
            GrassParams { clumps: 0, twist_deg: 720.0, lean_deg: 60.0, bend_deg: 60.0, ..small() },
            GrassParams { tip_ratio: 1.0, bend_deg: 0.0, lean_deg: 0.0, twist_deg: 0.0, ..small() },
        ] {
            let g = p.generate().unwrap();
            let reach = p.height + p.width; // a blade's horizontal reach from its root, at most
            let half = |k: usize| 0.5 * p.size[k] + if p.clumps > 0 { p.clump_radius } else { 0.0 } + reach;
            let per_blade = (p.triangle_count() / p.blades as u64) as usize;
            for (b, blade) in g.triangles.chunks(per_blade).enumerate() {
                let normals = &g.normals[b * per_blade..(b + 1) * per_blade];
                // Stations (left, right): segment j's first triangle is [l_j, r_j, r_j+1], its
                // second (absent at a pointed tip, where l = r) [l_j, r_j+1, l_j+1].
                let mut stations: Vec<(DVec3, DVec3)> =
                    (0..p.segments).map(|j| (blade[2 * j][0], blade[2 * j][1])).collect();
                let last = 2 * (p.segments - 1);
                let tip_left = if p.tip_ratio == 0.0 { blade[last][2] } else { blade[last + 1][2] };
                stations.push((tip_left, blade[last][2]));
                let root = 0.5 * (stations[0].0 + stations[0].1);
                assert!(root.y.abs() < 1e-12, "blade {b}: root at y = {}", root.y);
                assert!(root.x.abs() <= half(0) - reach && root.z.abs() <= half(1) - reach, "blade {b} root {root}");
                let mut length = 0.0;
                for w in stations.windows(2) {
                    let (c0, c1) = (0.5 * (w[0].0 + w[0].1), 0.5 * (w[1].0 + w[1].1));
                    length += c0.distance(c1);
                    let theta = (c1 - c0).normalize().y.clamp(-1.0, 1.0).acos();
                    assert!(theta <= (p.lean_deg + p.bend_deg).to_radians() + 1e-6, "blade {b}: chord angle {theta}");
                }
                // The chord polygon is at most the arc, and at 8 segments within 1 % of it.
                assert!(length <= p.height * (1.0 + 1e-12), "blade {b} length {length}");
                assert!(length >= 0.99 * p.height * (1.0 - p.height_jitter), "blade {b} length {length}");
                for (l, r) in &stations {
                    let w = l.distance(*r);
                    assert!(w <= p.width * (1.0 + 1e-12), "blade {b} width {w}");
                }
                for (i, (t, n)) in blade.iter().zip(normals).enumerate() {
                    for (k, v) in t.iter().enumerate() {
                        assert!(v.y >= -0.5 * p.width && v.y <= p.height + 0.5 * p.width, "blade {b}: y {}", v.y);
                        assert!(v.x.abs() <= half(0) && v.z.abs() <= half(1), "blade {b}: {v}");
                        assert!((n[k].length() - 1.0).abs() < 1e-12);
                    }
                    // A segment's first triangle starts with its station's left and right corner.
                    let across = t[1] - t[0];
                    if i % 2 == 0 && across.length() > 1e-12 {
                        assert!(n[0].dot(across.normalize()).abs() < 1e-9, "normal not across the width");
                    }
                }
            }
        }
    }

    /// The ribbon-curve form of a patch, rebuilt into ribbons as the renderer does, gives the
    /// patch's own corners: exactly inside each blade, and at the root and tip within the turn
    /// of the one-sided chord (half a segment's bend, at most `bend_deg / (2·segments)`).
    #[test]
    fn ribbon_curves_rebuild_the_patch() {
        use fiberlab_geometry::ribbons::{Facing, Ribbons};
        let p = GrassParams { blades: 60, clumps: 6, ..GrassParams::default() };
        let (mesh, s) = (p.generate().unwrap(), p.strands().unwrap());
        s.validate().unwrap();
        assert_eq!((s.strand_count(), s.points.len(), s.normals.len()), (60, 60 * 9, 60 * 9));
        let mut rebuilt = Ribbons::default();
        let v = |a: &[f32; 3]| DVec3::new(a[0].into(), a[1].into(), a[2].into());
        for r in s.strand_ranges() {
            let centre: Vec<DVec3> = s.points[r.clone()].iter().map(v).collect();
            let widths: Vec<f64> = s.widths[r.clone()].iter().map(|&w| w.into()).collect();
            let normals: Vec<DVec3> = s.normals[r].iter().map(v).collect();
            rebuilt.push(&centre, &widths, Facing::Normals(&normals));
        }
        assert_eq!(rebuilt.triangles.len(), mesh.triangles.len());
        let end_turn = 0.5 * (p.bend_deg / p.segments as f64).to_radians();
        let per_blade = mesh.triangles.len() / p.blades;
        for (i, (a, b)) in rebuilt.triangles.iter().zip(&mesh.triangles).enumerate() {
            // Segment j's first triangle is [l_j, r_j, r_j+1], its second [l_j, r_j+1, l_j+1].
            let (segment, first) = ((i % per_blade) / 2, (i % per_blade).is_multiple_of(2));
            for k in 0..3 {
                let station = if k == 0 || (k == 1 && first) { segment } else { segment + 1 };
                let end = station == 0 || station == p.segments;
                let tol = if end { 0.5 * p.width * end_turn * 1.01 + 1e-6 } else { 1e-6 };
                assert!(a[k].distance(b[k]) <= tol, "triangle {i} corner {k}: {} vs {}", a[k], b[k]);
            }
        }
    }

    #[test]
    fn bad_parameters_are_refused_naming_the_key() {
        let cases: [(&str, GrassParams); 9] = [
            ("segments", GrassParams { segments: 0, ..small() }),
            ("size", GrassParams { size: [1.0, f64::NAN], ..small() }),
            ("height", GrassParams { height: -1.0, ..small() }),
            ("width", GrassParams { width: f64::INFINITY, ..small() }),
            ("height_jitter", GrassParams { height_jitter: 1.0, ..small() }),
            ("tip_ratio", GrassParams { tip_ratio: 1.5, ..small() }),
            ("bend_deg", GrassParams { lean_deg: 50.0, bend_deg: 81.0, ..small() }),
            ("twist_deg", GrassParams { twist_deg: f64::NAN, ..small() }),
            ("blades", GrassParams { blades: 1_000_000, segments: 64, ..small() }),
        ];
        for (key, p) in cases {
            let e = p.generate().unwrap_err();
            assert_eq!(e.key, key, "{e}");
        }
        assert_eq!(GrassParams { blades: 0, ..small() }.validate().unwrap_err().key, "blades");
        assert_eq!(GrassParams { clump_radius: 0.0, ..small() }.validate().unwrap_err().key, "clump_radius");
        assert!(GrassParams { clumps: 0, clump_radius: 0.0, ..small() }.validate().is_ok());
    }
}
