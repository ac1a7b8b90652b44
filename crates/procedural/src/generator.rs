//! Procedural hair: strands grown over the scalp of a head sphere, or fur over a sphere.
//!
//! Deterministic for a seed (its own SplitMix64 generator, independent of crate versions and
//! thread count). Each strand:
//! 1. **Root**: uniform on the sphere cap within [`HairParams::scalp_angle_deg`] of the crown
//!    (`+y`), minus a face region (front, below [`FACE_CUTOFF_Y`]); lifted by one radius.
//! 2. **Guide path**: `segments` steps of length `length/segments` from the root. The direction
//!    starts tangent to the scalp, combed backward, is pulled toward `−y` by `gravity`, jittered
//!    by `noise`, and every point is pushed out of the head so strands drape over it.
//! 3. **Style**: `straight`; `wavy` adds a planar sine offset `A sin(2πs/λ + φ₀)` across the
//!    strand; `curly` a helix of radius `A` and pitch `λ` around the path. Amplitude grows from
//!    0 at the root over the first 10 % of the length.
//! 4. **Clumping**: the first `clumps` strands are clump guides; every other strand is blended
//!    toward its nearest guide (by root distance) with weight `clumping·(s/L)` at arc length s.
//!
//! Thickness: diameter `root_diameter` at the root, tapering linearly to `tip_ratio` of it.
//!
//! **Fur** ([`Style::Fur`], defaults in [`HairParams::fur`]): the same root placement, without
//! the face region (fur covers the whole cap, the whole sphere at `scalp_angle_deg = 180`).
//! Each strand's length is drawn uniformly in `[length·(1 − length_jitter), length]`; it leaves
//! the surface along the normal leaned by [`FUR_LEAN`] toward the comb direction, then gravity
//! and noise bend it as above. No waves. Clumping pulls the strand's points toward the clump
//! guide's own points (not its shape), with weight `clumping·(s/L)`, so the tips of a clump
//! converge on the guide's tip — the clump centre — while the roots stay where they grew.

use fiberlab_io::HairFile;
use fiberlab_math::DVec3;
use serde::Deserialize;
use std::f64::consts::TAU;

/// Largest size (length, diameter, head radius, amplitude) and head-centre coordinate: far
/// from `f32` overflow, where the points are stored.
const MAX_SIZE: f64 = 1e30;

/// Roots in front (`z > 0`) below this height (fraction of the head radius) are face, not scalp.
pub const FACE_CUTOFF_Y: f64 = 0.35;

/// Sideways (outward) part of the comb direction per unit of the scalp normal's x.
const COMB_SPREAD: f64 = 0.5;
/// Downward part of the comb direction (relative to backward = 1).
const COMB_DOWN: f64 = 0.2;
/// Normal component of the root direction (0 = flat on the scalp).
const ROOT_LIFT: f64 = 0.25;
/// Fur: tangential (comb-direction) part of a strand's first direction per unit of the
/// surface normal (0.6: leaning about 31° from the normal).
pub const FUR_LEAN: f64 = 0.6;

/// Hair style.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Style {
    /// No waves.
    #[default]
    Straight,
    /// Planar sine waves.
    Wavy,
    /// Helical curls.
    Curly,
    /// Short strands leaning off the surface, tips pulled together into clumps.
    Fur,
}

impl std::fmt::Display for Style {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Style::Straight => "straight",
            Style::Wavy => "wavy",
            Style::Curly => "curly",
            Style::Fur => "fur",
        })
    }
}

impl std::str::FromStr for Style {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "straight" => Ok(Style::Straight),
            "wavy" => Ok(Style::Wavy),
            "curly" => Ok(Style::Curly),
            "fur" => Ok(Style::Fur),
            _ => Err(format!("unknown style `{s}`; expected straight, wavy, curly or fur")),
        }
    }
}

/// Generator parameters (scene units: the head radius is usually 1).
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct HairParams {
    /// Number of strands.
    pub strands: usize,
    /// Segments per strand.
    pub segments: usize,
    /// Strand length (the longest, with `length_jitter`).
    pub length: f64,
    /// Each strand's length is uniform in `[length·(1 − length_jitter), length]`, [0, 1).
    pub length_jitter: f64,
    /// Diameter at the root.
    pub root_diameter: f64,
    /// Tip diameter as a fraction of the root diameter.
    pub tip_ratio: f64,
    /// Style.
    pub style: Style,
    /// Wave/curl amplitude.
    pub amplitude: f64,
    /// Wave/curl length (pitch).
    pub wavelength: f64,
    /// Number of clumps (0: no clumping).
    pub clumps: usize,
    /// Blend toward the clump guide at the tip, [0, 1].
    pub clumping: f64,
    /// Pull toward −y per unit length.
    pub gravity: f64,
    /// Random direction jitter per step.
    pub noise: f64,
    /// Head centre.
    pub head_center: [f64; 3],
    /// Head radius.
    pub head_radius: f64,
    /// Half-angle of the scalp cap around +y, degrees.
    pub scalp_angle_deg: f64,
    /// Random seed.
    pub seed: u64,
}

impl Default for HairParams {
    fn default() -> Self {
        Self {
            strands: 20_000,
            segments: 24,
            length: 1.6,
            length_jitter: 0.0,
            root_diameter: 0.002,
            tip_ratio: 0.5,
            style: Style::Wavy,
            amplitude: 0.03,
            wavelength: 0.35,
            clumps: 400,
            clumping: 0.35,
            gravity: 3.0,
            noise: 0.04,
            head_center: [0.0; 3],
            head_radius: 1.0,
            scalp_angle_deg: 105.0,
            seed: 1,
        }
    }
}

impl HairParams {
    /// Fur on a unit sphere: 60,000 short strands (0.09–0.14 radius, 6 segments) over the
    /// whole sphere, diameter 0.005 at the root tapering to a tenth of it, 3,000 clumps pulled
    /// together to 60 % at the tips, a little gravity and noise.
    #[must_use]
    pub fn fur() -> Self {
        Self {
            strands: 60_000,
            segments: 6,
            length: 0.14,
            length_jitter: 0.35,
            root_diameter: 0.005,
            tip_ratio: 0.1,
            style: Style::Fur,
            amplitude: 0.0,
            wavelength: 0.0,
            clumps: 3000,
            clumping: 0.6,
            gravity: 1.5,
            noise: 0.08,
            scalp_angle_deg: 180.0,
            ..Self::default()
        }
    }
}

/// Why parameters were rejected.
#[derive(Debug, thiserror::Error, PartialEq)]
#[error("hair generator: `{key}` = {value} is invalid; expected {expected}")]
pub struct GeneratorError {
    /// Parameter name.
    pub key: &'static str,
    /// Value given.
    pub value: String,
    /// Valid range.
    pub expected: &'static str,
}

/// The strands' generator (moved to `fiberlab_math::split_mix`, shared with the medulla tables).
pub use fiberlab_math::split_mix::SplitMix64;

impl HairParams {
    /// Checks every parameter's range.
    pub fn validate(&self) -> Result<(), GeneratorError> {
        // Values in their shortest form (`{:?}`: exponent form for huge or tiny ones).
        let bad = |key, value: f64, expected| Err(GeneratorError { key, value: format!("{value:?}"), expected });
        if self.segments == 0 || self.segments > usize::from(u16::MAX) {
            return Err(GeneratorError { key: "segments", value: self.segments.to_string(), expected: "1 to 65535" });
        }
        // The .hair format stores the strand and point counts in 32 bits.
        if self.strands > u32::MAX as usize {
            let (value, expected) =
                (self.strands.to_string(), "at most 4294967295 (the .hair format's 32-bit strand count)");
            return Err(GeneratorError { key: "strands", value, expected });
        }
        if self.point_count().is_none_or(|n| n > u64::from(u32::MAX)) {
            let points = (self.strands as u128) * (self.segments as u128 + 1);
            return Err(GeneratorError {
                key: "strands",
                value: format!("{} (× ({} segments + 1) = {points} points)", self.strands, self.segments),
                expected: "strands × (segments + 1) ≤ 4294967295 points (the .hair format's 32-bit point count)",
            });
        }
        for (key, v) in
            [("length", self.length), ("root_diameter", self.root_diameter), ("head_radius", self.head_radius)]
        {
            if !(v.is_finite() && v > 0.0) {
                return bad(key, v, "a finite number > 0");
            }
        }
        if !(0.0..1.0).contains(&self.length_jitter) {
            return bad("length_jitter", self.length_jitter, "a number in [0, 1) (every strand keeps a length > 0)");
        }
        for (key, v) in [("tip_ratio", self.tip_ratio), ("clumping", self.clumping)] {
            if !(0.0..=1.0).contains(&v) {
                return bad(key, v, "a number in [0, 1]");
            }
        }
        for (key, v) in [
            ("amplitude", self.amplitude),
            ("wavelength", self.wavelength),
            ("gravity", self.gravity),
            ("noise", self.noise),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return bad(key, v, "a finite number ≥ 0");
            }
        }
        // Points are stored in `f32`: sizes that would carry a coordinate toward its overflow
        // (3.4e38) are refused by name rather than written as infinite points.
        for (key, v) in [
            ("length", self.length),
            ("root_diameter", self.root_diameter),
            ("head_radius", self.head_radius),
            ("amplitude", self.amplitude),
        ] {
            if v > MAX_SIZE {
                return bad(key, v, "at most 1e30 (points are stored as 32-bit floats)");
            }
        }
        if matches!(self.style, Style::Wavy | Style::Curly) && self.wavelength <= 0.0 {
            return bad("wavelength", self.wavelength, "> 0 for wavy or curly hair");
        }
        if !(self.scalp_angle_deg > 0.0 && self.scalp_angle_deg <= 180.0) {
            return bad("scalp_angle_deg", self.scalp_angle_deg, "(0, 180]");
        }
        if !self.head_center.iter().all(|c| c.is_finite() && c.abs() <= MAX_SIZE) {
            let value = format!("{:?}", self.head_center);
            return Err(GeneratorError {
                key: "head_center",
                value,
                expected: "finite coordinates, each at most 1e30",
            });
        }
        Ok(())
    }

    /// Points of the generated hair, `strands × (segments + 1)`, in u64; `None` on overflow.
    #[must_use]
    pub fn point_count(&self) -> Option<u64> {
        (self.strands as u64).checked_mul((self.segments as u64).checked_add(1)?)
    }

    /// Segments of the generated hair, `strands × segments`, in u64; `None` on overflow.
    #[must_use]
    pub fn segment_count(&self) -> Option<u64> {
        (self.strands as u64).checked_mul(self.segments as u64)
    }

    /// Peak bytes [`HairParams::generate`] holds: per point the guide path (`DVec3`, 24), the
    /// output point (3 × f32, 12) and its thickness (f32, 4); per strand its root (`DVec3`,
    /// 24), its path's `Vec` (24) and its segment count (u16, 2). `None` on overflow.
    /// Checked with `/usr/bin/time -v fiberlab hair generate --strands 160000` (24 segments,
    /// 4M points): maximum RSS 172 MB against the 168 MB estimated.
    #[must_use]
    pub fn estimated_bytes(&self) -> Option<u64> {
        let points = self.point_count()?.checked_mul(24 + 12 + 4)?;
        points.checked_add((self.strands as u64).checked_mul(24 + 24 + 2)?)
    }

    /// Grows the hair.
    pub fn generate(&self) -> Result<HairFile, GeneratorError> {
        self.validate()?;
        let center = DVec3::from(self.head_center);
        let mut rng = SplitMix64::new(self.seed ^ 0x6A09_E667_F3BC_C908);
        let roots: Vec<DVec3> = (0..self.strands).map(|_| self.sample_root(&mut rng)).collect();
        let paths: Vec<Vec<DVec3>> = roots
            .iter()
            .enumerate()
            .map(|(i, &n)| {
                let mut strand_rng = SplitMix64::new(self.seed.wrapping_mul(0x9E37_79B9).wrapping_add(i as u64));
                self.grow(center, n, &mut strand_rng)
            })
            .collect();
        let guides = self.clumps.min(self.strands);
        let mut points = Vec::with_capacity(self.strands * (self.segments + 1));
        let mut thickness = Vec::with_capacity(points.capacity());
        for (i, path) in paths.iter().enumerate() {
            let guide = if guides > 0 && i >= guides && self.clumping > 0.0 {
                (0..guides).min_by(|&a, &b| {
                    roots[a].distance_squared(roots[i]).total_cmp(&roots[b].distance_squared(roots[i]))
                })
            } else {
                None
            };
            for (k, &p) in path.iter().enumerate() {
                let s = k as f64 / self.segments as f64;
                let q = match guide {
                    // Fur: toward the guide's point itself, so a clump's tips meet at its centre.
                    Some(g) if self.style == Style::Fur => p.lerp(paths[g][k], self.clumping * s),
                    Some(g) => {
                        // Follow the guide's shape, anchored at this strand's own root.
                        let follow = paths[g][k] - paths[g][0] + path[0];
                        p.lerp(follow, self.clumping * s)
                    }
                    None => p,
                };
                // Clumping and style offsets may dip into the head: push such points out again.
                let rel = q - center;
                let min_r = self.head_radius + self.root_diameter;
                let q = if k > 0 && rel.length() < min_r { center + rel.normalize_or(DVec3::Y) * min_r } else { q };
                points.push([q.x as f32, q.y as f32, q.z as f32]);
                thickness.push((self.root_diameter * (1.0 - (1.0 - self.tip_ratio) * s)) as f32);
            }
        }
        let mut hair = HairFile {
            segments: Some(vec![self.segments as u16; self.strands]),
            points,
            thickness: Some(thickness),
            strand_count: self.strands as u32,
            default_segments: self.segments as u32,
            default_thickness: self.root_diameter as f32,
            ..HairFile::default()
        };
        hair.set_info(&format!("fiberlab hair generator, {:?}, seed {}", self.style, self.seed));
        Ok(hair)
    }

    /// A unit scalp normal (rejection sampling on the cap, excluding the face).
    fn sample_root(&self, rng: &mut SplitMix64) -> DVec3 {
        let cos_max = self.scalp_angle_deg.to_radians().cos();
        for _ in 0..1000 {
            let y = 1.0 - rng.next_f64() * (1.0 - cos_max);
            let phi = TAU * rng.next_f64();
            let s = (1.0 - y * y).max(0.0).sqrt();
            let n = DVec3::new(s * phi.cos(), y, s * phi.sin());
            if self.style == Style::Fur || !(n.z > 0.0 && n.y < FACE_CUTOFF_Y) {
                return n;
            }
        }
        DVec3::Y
    }

    /// The strand's points: guide path plus style offsets.
    fn grow(&self, center: DVec3, n: DVec3, rng: &mut SplitMix64) -> Vec<DVec3> {
        let r_head = self.head_radius;
        // Drawn only when asked for, so the other styles' strands do not change.
        let length = if self.length_jitter > 0.0 {
            self.length * (1.0 - self.length_jitter * rng.next_f64())
        } else {
            self.length
        };
        let step = length / self.segments as f64;
        let lift = 0.5 * self.root_diameter;
        let mut p = center + n * (r_head + lift);
        // Initial direction: combed backward (−z), slightly down and outward, projected onto
        // the scalp's tangent plane, lifted a little off it.
        let comb = DVec3::new(COMB_SPREAD * n.x, -COMB_DOWN, -1.0);
        let along = (comb - n * n.dot(comb)).normalize_or(DVec3::NEG_Y);
        let mut dir = if self.style == Style::Fur {
            (n + along * FUR_LEAN).normalize()
        } else {
            (along + n * ROOT_LIFT).normalize()
        };
        let mut path = Vec::with_capacity(self.segments + 1);
        path.push(p);
        for _ in 0..self.segments {
            dir = (dir + DVec3::NEG_Y * (self.gravity * step) + rng.next_signed_vec() * self.noise).normalize_or(dir);
            let mut next = p + dir * step;
            // Drape over the head: keep points outside the sphere (plus a little).
            let rel = next - center;
            let min_r = r_head + lift * 2.0;
            if rel.length() < min_r {
                next = center + rel.normalize_or(n) * min_r;
                dir = (next - p).normalize_or(dir);
            }
            path.push(next);
            p = next;
        }
        if matches!(self.style, Style::Straight | Style::Fur) || self.amplitude == 0.0 {
            return path;
        }
        let phase = TAU * rng.next_f64();
        let mut out = Vec::with_capacity(path.len());
        for (k, &q) in path.iter().enumerate() {
            let t = if k + 1 < path.len() { path[k + 1] - q } else { q - path[k - 1] };
            let t = t.normalize_or(DVec3::NEG_Y);
            let e1 = t.cross(n).normalize_or(t.any_orthonormal_vector());
            let e2 = t.cross(e1);
            let s = k as f64 * step;
            let ramp = (s / (0.1 * length)).min(1.0);
            let a = TAU * s / self.wavelength + phase;
            let offset = match self.style {
                Style::Wavy => e1 * a.sin(),
                _ => e1 * a.cos() + e2 * a.sin(),
            };
            out.push(q + offset * (self.amplitude * ramp));
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn small(style: Style) -> HairParams {
        HairParams { strands: 300, segments: 16, clumps: 20, style, ..HairParams::default() }
    }

    #[test]
    fn counts_and_memory_estimate_in_u64_and_the_format_limits() {
        let p = HairParams { strands: 1000, segments: 24, ..HairParams::default() };
        assert_eq!((p.point_count(), p.segment_count()), (Some(25_000), Some(24_000)));
        // 40 bytes per point, 50 per strand.
        assert_eq!(p.estimated_bytes(), Some(25_000 * 40 + 1000 * 50));
        let absurd = HairParams { strands: 4_000_000_000, ..HairParams::default() };
        assert_eq!(absurd.point_count(), Some(100_000_000_000));
        assert_eq!(absurd.estimated_bytes(), Some(100_000_000_000 * 40 + 4_000_000_000 * 50));
        let e = absurd.validate().unwrap_err();
        assert_eq!(e.key, "strands");
        assert!(e.value.contains("100000000000 points") && e.expected.contains("4294967295"), "{e}");
        assert_eq!(HairParams { strands: usize::MAX, ..HairParams::default() }.point_count(), None);
        assert_eq!(HairParams { strands: usize::MAX, ..HairParams::default() }.estimated_bytes(), None);
        let e = HairParams { strands: 5_000_000_000, segments: 1, ..HairParams::default() }.validate().unwrap_err();
        assert!(e.expected.contains("32-bit strand count"), "{e}");
        // Exactly at the point limit: 65535 · (65535 + 1) < 2³², and one strand more is over it.
        let at = HairParams { strands: 65_537, segments: 65_534, ..HairParams::default() };
        assert_eq!(at.point_count(), Some(65_537 * 65_535));
        assert!(at.validate().is_ok());
        assert!(HairParams { strands: 65_538, ..at }.validate().is_err());
    }

    #[test]
    fn deterministic_for_a_seed_and_different_for_another() {
        let a = small(Style::Curly).generate().unwrap();
        let b = small(Style::Curly).generate().unwrap();
        assert_eq!(a, b);
        let c = HairParams { seed: 2, ..small(Style::Curly) }.generate().unwrap();
        assert_ne!(a.points, c.points);
    }

    #[test]
    fn strands_start_on_the_scalp_stay_outside_the_head_and_have_the_length() {
        for style in [Style::Straight, Style::Wavy, Style::Curly] {
            let p = small(style);
            let hair = p.generate().unwrap();
            assert_eq!(hair.strand_count(), 300);
            hair.validate().unwrap();
            for r in hair.strand_ranges() {
                let pts: Vec<DVec3> =
                    hair.points[r].iter().map(|q| DVec3::new(q[0].into(), q[1].into(), q[2].into())).collect();
                let root = pts[0];
                assert!((root.length() - 1.0).abs() < 1e-2, "root at radius {}", root.length());
                assert!(!(root.z > 0.0 && root.y < FACE_CUTOFF_Y - 1e-3), "root on the face: {root}");
                for q in &pts {
                    assert!(q.length() > 1.0 + 0.9e-3, "point inside the head: {}", q.length());
                }
                let len: f64 = pts.windows(2).map(|w| w[0].distance(w[1])).sum();
                if style == Style::Straight {
                    assert!(len <= p.length * 1.35 && len > 0.5 * p.length, "length {len}");
                }
            }
            let th = hair.thickness.as_ref().unwrap();
            assert!((th[0] - 0.002).abs() < 1e-7 && (th[16] - 0.001).abs() < 1e-7);
        }
    }

    #[test]
    fn gravity_pulls_tips_down() {
        let hair = HairParams { clumps: 0, ..small(Style::Straight) }.generate().unwrap();
        let mean_tip_y: f64 = hair.strand_ranges().iter().map(|r| f64::from(hair.points[r.end - 1][1])).sum::<f64>()
            / hair.strand_count() as f64;
        let mean_root_y: f64 = hair.strand_ranges().iter().map(|r| f64::from(hair.points[r.start][1])).sum::<f64>()
            / hair.strand_count() as f64;
        assert!(mean_tip_y < mean_root_y - 0.5, "tips {mean_tip_y} roots {mean_root_y}");
    }

    /// A small fur: 2,000 strands over the whole unit sphere.
    fn small_fur() -> HairParams {
        HairParams { strands: 2000, clumps: 100, ..HairParams::fur() }
    }

    fn strand_points(hair: &HairFile) -> Vec<Vec<DVec3>> {
        hair.strand_ranges()
            .into_iter()
            .map(|r| hair.points[r].iter().map(|q| DVec3::new(q[0].into(), q[1].into(), q[2].into())).collect())
            .collect()
    }

    #[test]
    fn fur_strands_are_short_within_the_length_range_and_cover_the_sphere() {
        // Without clumping a fur strand is its own guide path: a polyline of `segments` steps
        // of its drawn length / segments, bent only where it would dip into the sphere.
        let p = HairParams { clumping: 0.0, ..small_fur() };
        let hair = p.generate().unwrap();
        hair.validate().unwrap();
        let strands = strand_points(&hair);
        assert_eq!(strands.len(), 2000);
        let (lo, hi) = (p.length * (1.0 - p.length_jitter), p.length);
        let mut lengths = Vec::new();
        let mut faces = 0;
        for pts in &strands {
            assert_eq!(pts.len(), p.segments + 1);
            assert!((pts[0].length() - 1.0).abs() < 1e-2, "root at radius {}", pts[0].length());
            faces += usize::from(pts[0].z > 0.0 && pts[0].y < FACE_CUTOFF_Y);
            let len: f64 = pts.windows(2).map(|w| w[0].distance(w[1])).sum();
            assert!(len >= lo * (1.0 - 1e-4) && len <= hi * (1.0 + 1e-4), "length {len} outside [{lo}, {hi}]");
            lengths.push(len);
            // Leaning off the surface: the tip is farther out than the root.
            assert!(pts[p.segments].length() > 1.0 + 0.15 * len, "tip at radius {}", pts[p.segments].length());
        }
        // Lengths spread over the range: mean of a uniform distribution, ± 5 standard errors.
        let mean = lengths.iter().sum::<f64>() / lengths.len() as f64;
        let sd = (hi - lo) / 12f64.sqrt() / (lengths.len() as f64).sqrt();
        assert!((mean - 0.5 * (lo + hi)).abs() < 5.0 * sd, "mean length {mean}");
        // No face cut-out for fur: the front-below region gets its share of the roots. On the
        // unit sphere y is uniform in [−1, 1] (Archimedes) and independent of the azimuth, so
        // the region's area fraction is P(y < c)·P(z > 0) = (1 + c)/2 · 1/2.
        let frac = faces as f64 / 2000.0;
        let area = 0.5 * (1.0 + FACE_CUTOFF_Y) * 0.5;
        let se = (area * (1.0 - area) / 2000.0).sqrt();
        assert!((frac - area).abs() < 5.0 * se, "roots on the front-below region {frac}, expected {area}");
    }

    #[test]
    fn fur_tapers_from_root_to_tip() {
        let p = small_fur();
        let hair = p.generate().unwrap();
        let th = hair.thickness.as_ref().unwrap();
        for r in hair.strand_ranges() {
            let t = &th[r];
            assert!((f64::from(t[0]) - p.root_diameter).abs() < 1e-8);
            assert!((f64::from(t[t.len() - 1]) - p.root_diameter * p.tip_ratio).abs() < 1e-8);
            assert!(t.windows(2).all(|w| w[1] < w[0]), "not decreasing: {t:?}");
        }
    }

    /// Mean distance of every non-guide tip to its clump centre (the tip of the guide nearest
    /// its root), computed here from the generated points.
    fn mean_tip_to_clump_centre(p: &HairParams) -> f64 {
        let strands = strand_points(&p.generate().unwrap());
        let guides = p.clumps;
        let mut sum = 0.0;
        for pts in &strands[guides..] {
            let g = (0..guides)
                .min_by(|&a, &b| {
                    strands[a][0].distance_squared(pts[0]).total_cmp(&strands[b][0].distance_squared(pts[0]))
                })
                .unwrap();
            sum += pts[p.segments].distance(strands[g][p.segments]);
        }
        sum / (strands.len() - guides) as f64
    }

    #[test]
    fn fur_clumping_pulls_tips_toward_the_clump_centre() {
        let loose = mean_tip_to_clump_centre(&HairParams { clumping: 0.0, ..small_fur() });
        let tight = mean_tip_to_clump_centre(&HairParams { clumping: 0.6, ..small_fur() });
        // The tip moves to (1 − 0.6) of its distance to the guide's tip (unless pushed out of
        // the sphere, which only moves it along the radius).
        assert!(tight < 0.45 * loose && tight > 0.3 * loose, "tight {tight} loose {loose}");
        // The roots do not move.
        let a = HairParams { clumping: 0.0, ..small_fur() }.generate().unwrap();
        let b = small_fur().generate().unwrap();
        for r in a.strand_ranges() {
            assert_eq!(a.points[r.start], b.points[r.start]);
        }
    }

    #[test]
    fn fur_is_deterministic_for_a_seed() {
        let a = small_fur().generate().unwrap();
        assert_eq!(a, small_fur().generate().unwrap());
        assert_ne!(a.points, HairParams { seed: 7, ..small_fur() }.generate().unwrap().points);
        assert_eq!("fur".parse::<Style>(), Ok(Style::Fur));
        assert_eq!(Style::Fur.to_string(), "fur");
    }

    #[test]
    fn fur_parameters_are_validated() {
        for bad in [1.0, -0.1, f64::NAN] {
            let e = HairParams { length_jitter: bad, ..small_fur() }.generate().unwrap_err();
            assert_eq!(e.key, "length_jitter");
            assert!(e.to_string().contains("[0, 1)"), "{e}");
        }
        let e = HairParams { clumping: 1.5, ..small_fur() }.validate().unwrap_err();
        assert_eq!(e.key, "clumping");
        let e = HairParams { tip_ratio: -0.1, ..small_fur() }.validate().unwrap_err();
        assert_eq!(e.key, "tip_ratio");
        // Fur has no waves: a zero wavelength is fine.
        assert!(HairParams::fur().validate().is_ok());
    }

    #[test]
    fn invalid_parameters_name_the_key() {
        let e = HairParams { tip_ratio: 2.0, ..HairParams::default() }.generate().unwrap_err();
        assert_eq!(e.key, "tip_ratio");
        let e = HairParams { length: f64::NAN, ..HairParams::default() }.generate().unwrap_err();
        assert_eq!(e.key, "length");
        assert!("frizzy".parse::<Style>().is_err());
        // Huge values in exponent form, not 309 digits; the array that is wrong as written.
        let e = HairParams { length: -1e308, ..HairParams::default() }.generate().unwrap_err().to_string();
        assert!(e.contains("`length` = -1e308 is invalid"), "{e}");
        let e = HairParams { head_center: [0.0, f64::INFINITY, 0.0], ..HairParams::default() }.validate();
        assert!(e.unwrap_err().to_string().contains("[0.0, inf, 0.0]"));
        // Finite but beyond what f32 points hold: refused by name instead of infinite points.
        let e = HairParams { length: 1e308, ..HairParams::default() }.validate().unwrap_err().to_string();
        assert!(e.contains("`length` = 1e308 is invalid; expected at most 1e30"), "{e}");
        assert!(HairParams { length: 1e30, strands: 2, ..HairParams::default() }.generate().is_ok());
    }
}
