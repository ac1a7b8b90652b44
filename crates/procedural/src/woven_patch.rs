//! An explicit woven patch built from its fibers: warp and weft yarns whose centre lines pass
//! over and under each other, each yarn made of plies of twisted fibers, as polylines (the
//! "cloth from fibers" of issue 20, the geometry behind the yarn-level models of Irawan and
//! Marschner 2012 and Sadeghi et al. 2013, `crates/scatter/src/irawan_2012/`,
//! `crates/scatter/src/sadeghi_2013.rs`).
//!
//! # Geometry (lengths in one unit, e.g. millimetres; `z` is the cloth normal)
//! - **Weave.** Warp yarn `i` runs along `+y` at `x = (i + ½)·s`, weft yarn `j` along `+x` at
//!   `y = (j + ½)·s` (`s` = `spacing`). The pattern repeats every `n × n` yarns: plain weave
//!   `n = 2` (warp over where `i + j` is even), twill 2/1 `n = 3` and twill 2/2 `n = 4` (warp
//!   over where `(i − j) mod n < 2`, so the floats step one yarn per row: the twill line).
//! - **Crimp.** A yarn's centre sits at height `+a` (`a` = `crimp`) at a crossing where it is
//!   over and `−a` where it is under; between two crossings the height follows the half
//!   cosine `h = h₀ + (h₁ − h₀)(1 − cos πt)/2`. Plain weave is then the sinusoid
//!   `a·cos(π y/s)` of period `2s`; the floats of a twill are straight.
//! - **Plies.** A yarn of radius `R` holds `plies` circular plies of radius
//!   `R_p = R/(1 + 1/sin(π/plies))` whose centres lie at `d = R − R_p` from the yarn centre
//!   (one ply: `R_p = R`, `d = 0`); they wind about the yarn centre by the ply twist angle
//!   `α` (the helix angle at radius `d`: the ply centres turn by `tan α / d` per unit arc length).
//! - **Fibers.** A ply holds `fibers_per_ply` fibers of radius `r` at the sunflower positions
//!   `ρ_k = (R_p − r)·√((k + ½)/m)`, `θ_k = k·137.5°`; they turn about the ply centre, against
//!   the ply's sense, by `tan ψ / R_p` per unit arc length, so the fibers on the ply's surface
//!   make the twist angle `ψ` with its axis and a fiber at `ρ` the angle `atan(ρ tan ψ / R_p)`.
//!   Every fiber point lies within `R − r` of its yarn's centre line, so fibers stay inside
//!   their yarn.
//! - **Periodic.** Twist rates are rounded to a whole number of turns per pattern repeat
//!   (the angles used are reported by [`WovenPatch::effective_twists`]), so a patch of several
//!   repeats is seamless and one repeat tiles the plane: the goniophotometer
//!   (`fiberlab_gonio::cloth`) wraps rays across its lateral sides.

use fiberlab_math::DVec3;
use std::f64::consts::PI;
use thiserror::Error;

/// Largest segment count a patch may have (≈ 64 bytes each in the renderer).
pub const MAX_SEGMENTS: u64 = 40_000_000;

/// The weave pattern.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Weave {
    /// Plain weave: over one, under one (repeat 2 × 2).
    Plain,
    /// Twill 2/1: over two, under one (repeat 3 × 3).
    Twill21,
    /// Twill 2/2: over two, under two (repeat 4 × 4).
    Twill22,
}

impl Weave {
    /// Yarns per pattern repeat in each direction.
    #[must_use]
    pub fn repeat(self) -> usize {
        match self {
            Weave::Plain => 2,
            Weave::Twill21 => 3,
            Weave::Twill22 => 4,
        }
    }

    /// True when warp yarn `i` lies over weft yarn `j` at their crossing.
    #[must_use]
    pub fn warp_over(self, i: usize, j: usize) -> bool {
        let n = self.repeat();
        match self {
            Weave::Plain => (i + j).is_multiple_of(2),
            Weave::Twill21 | Weave::Twill22 => (i % n + n - j % n) % n < 2,
        }
    }

    /// Parses `plain`, `twill` (= `twill-2/1`), `twill-2/1`, `twill-2/2`.
    pub fn parse(text: &str) -> Result<Self, PatchError> {
        match text {
            "plain" => Ok(Weave::Plain),
            "twill" | "twill-2/1" | "twill21" => Ok(Weave::Twill21),
            "twill-2/2" | "twill22" => Ok(Weave::Twill22),
            _ => Err(PatchError::UnknownWeave(text.to_string())),
        }
    }
}

/// An invalid patch; messages name the parameter and its valid range.
#[non_exhaustive]
#[derive(Clone, Debug, Error, PartialEq)]
pub enum PatchError {
    /// A value outside its range or not finite.
    #[error("cloth patch parameter `{key}` = {value} is invalid; valid range {range}")]
    OutOfRange {
        /// Parameter.
        key: &'static str,
        /// Value given (degrees for angles).
        value: f64,
        /// Valid range.
        range: String,
    },
    /// An unknown weave name.
    #[error("unknown weave `{0}`; expected plain, twill (= twill-2/1) or twill-2/2")]
    UnknownWeave(String),
    /// Too many segments.
    #[error(
        "the patch would have {segments} segments ({fibers} fibers × {per_fiber} segments), more than {MAX_SEGMENTS}; \
         use fewer fibers per ply, fewer periods or fewer samples"
    )]
    TooLarge {
        /// Estimated segments.
        segments: u64,
        /// Fibers.
        fibers: u64,
        /// Segments per fiber.
        per_fiber: u64,
    },
}

/// The parameters of a patch (angles in radians).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WovenPatch {
    /// Weave pattern.
    pub weave: Weave,
    /// Distance between neighbouring yarn centres (> 0).
    pub spacing: f64,
    /// Yarn radius `R`, ≤ spacing/2.
    pub yarn_radius: f64,
    /// Crimp amplitude `a` (height of a yarn centre at a crossing), ≥ yarn radius.
    pub crimp: f64,
    /// Plies per yarn, 1 … 8.
    pub plies: usize,
    /// Ply twist angle α (radians, [0, 80°]); unused with one ply.
    pub ply_twist: f64,
    /// Fibers per ply, 1 … 2000.
    pub fibers_per_ply: usize,
    /// Fiber radius `r` (> 0, < ply radius).
    pub fiber_radius: f64,
    /// Fiber twist angle ψ at the ply surface (radians, [0, 80°]).
    pub psi: f64,
    /// Polyline vertices per yarn spacing along a yarn (≥ 4); more are added where the
    /// twist needs them (≥ 16 per turn).
    pub samples_per_spacing: usize,
    /// Seed of the per-fiber phase jitter.
    pub seed: u64,
}

impl Default for WovenPatch {
    /// A cotton-like plain weave in millimetres: yarns 0.32 mm apart, radius 0.1 mm, crimp 0.11 mm, two plies
    /// of 24 fibers of radius 8 µm twisted at 30°.
    fn default() -> Self {
        Self {
            weave: Weave::Plain,
            spacing: 0.32,
            yarn_radius: 0.1,
            crimp: 0.11,
            plies: 2,
            ply_twist: 20f64.to_radians(),
            fibers_per_ply: 24,
            fiber_radius: 0.008,
            psi: 30f64.to_radians(),
            samples_per_spacing: 24,
            seed: 1,
        }
    }
}

/// One yarn's centre line over `periods` repeats: `(points, cumulative arc length)`.
struct CentreLine {
    points: Vec<DVec3>,
    arc: Vec<f64>,
    /// In-plane unit vector across the yarn.
    across: DVec3,
}

/// Polylines of fibers: points of every fiber concatenated, with counts.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Fibers {
    /// Points, fiber after fiber.
    pub points: Vec<DVec3>,
    /// Vertices per fiber.
    pub counts: Vec<usize>,
    /// Yarn of each fiber: `(warp?, index)`.
    pub yarn: Vec<(bool, usize)>,
    /// Fiber radius.
    pub radius: f64,
}

impl Fibers {
    /// The fibers as `(points, radii)` slices for [`fiberlab_geometry::CurveSet::from_polylines`].
    #[must_use]
    pub fn polylines(&self) -> Vec<(&[DVec3], Vec<f64>)> {
        let mut start = 0;
        self.counts
            .iter()
            .map(|&n| {
                let s = &self.points[start..start + n];
                start += n;
                (s, vec![self.radius; n])
            })
            .collect()
    }

    /// The fibers as linear cylinder strands, for the strand-file writers of `fiberlab_io`.
    #[must_use]
    pub fn strands(&self) -> fiberlab_io::Strands {
        fiberlab_io::Strands {
            points: self.points.iter().map(|p| [p.x as f32, p.y as f32, p.z as f32]).collect(),
            widths: vec![(2.0 * self.radius) as f32; self.points.len()],
            counts: self.counts.iter().map(|&n| n as u32).collect(),
            basis: fiberlab_io::Basis::Linear,
            kind: fiberlab_io::CurveKind::Cylinder,
            normals: Vec::new(),
        }
    }

    /// Segment count.
    #[must_use]
    pub fn segment_count(&self) -> usize {
        self.counts.iter().map(|n| n.saturating_sub(1)).sum()
    }
}

impl WovenPatch {
    /// Length of one pattern repeat (`repeat · spacing`), the lateral period.
    #[must_use]
    pub fn period(&self) -> f64 {
        self.weave.repeat() as f64 * self.spacing
    }

    /// Ply radius and the distance of the ply centres from the yarn centre.
    #[must_use]
    pub fn ply_radius_and_offset(&self) -> (f64, f64) {
        if self.plies <= 1 {
            (self.yarn_radius, 0.0)
        } else {
            let rp = self.yarn_radius / (1.0 + 1.0 / (PI / self.plies as f64).sin());
            (rp, self.yarn_radius - rp)
        }
    }

    /// Checks every parameter.
    pub fn validate(&self) -> Result<(), PatchError> {
        let bad = |key, value: f64, range: String| Err(PatchError::OutOfRange { key, value, range });
        let deg = |x: f64| x.to_degrees();
        for (key, v) in
            [("spacing", self.spacing), ("yarn_radius", self.yarn_radius), ("fiber_radius", self.fiber_radius)]
        {
            if !(v.is_finite() && v > 0.0 && v < 1e6) {
                return bad(key, v, "(0, 1e6)".into());
            }
        }
        if self.yarn_radius > 0.5 * self.spacing + 1e-12 {
            return bad("yarn_radius", self.yarn_radius, format!("(0, spacing/2 = {}]", 0.5 * self.spacing));
        }
        if !(self.crimp.is_finite() && self.crimp >= self.yarn_radius - 1e-12 && self.crimp <= 4.0 * self.spacing) {
            return bad(
                "crimp",
                self.crimp,
                format!("[yarn_radius = {}, 4·spacing] (yarns must not cut through each other)", self.yarn_radius),
            );
        }
        if !(1..=8).contains(&self.plies) {
            return bad("plies", self.plies as f64, "1 … 8".into());
        }
        if !(1..=2000).contains(&self.fibers_per_ply) {
            return bad("fibers_per_ply", self.fibers_per_ply as f64, "1 … 2000".into());
        }
        for (key, v) in [("ply_twist", self.ply_twist), ("psi", self.psi)] {
            if !(v.is_finite() && (0.0..=80f64.to_radians()).contains(&v)) {
                return bad(key, deg(v), "[0, 80] degrees".into());
            }
        }
        let (rp, _) = self.ply_radius_and_offset();
        if self.fiber_radius >= rp {
            return bad("fiber_radius", self.fiber_radius, format!("(0, ply radius = {rp})"));
        }
        if !(4..=10_000).contains(&self.samples_per_spacing) {
            return bad("samples_per_spacing", self.samples_per_spacing as f64, "4 … 10000".into());
        }
        self.check_clearance()
    }

    /// Refuses crimp too small for the spacing: at every crossing of one repeat, on a grid
    /// of offsets `(ε, δ)` ∈ [−R, R]² from the crossing, the lower surface of the upper
    /// yarn must lie above the upper surface of the lower yarn (circular cross-sections).
    fn check_clearance(&self) -> Result<(), PatchError> {
        let n = self.weave.repeat();
        let r = self.yarn_radius;
        let s = self.spacing;
        for i in 0..n {
            for j in 0..n {
                let (cx, cy) = ((i as f64 + 0.5) * s, (j as f64 + 0.5) * s);
                let sign = if self.weave.warp_over(i, j) { 1.0 } else { -1.0 };
                for a in -10..=10 {
                    for b in -10..=10 {
                        let (e, d) = (r * f64::from(a) / 10.0, r * f64::from(b) / 10.0);
                        let (half_e, half_d) = ((r * r - e * e).max(0.0).sqrt(), (r * r - d * d).max(0.0).sqrt());
                        // Warp at (cx + ε, cy + δ): height from its along-coordinate y.
                        let warp = self.height(true, i, cy + d);
                        let weft = self.height(false, j, cx + e);
                        let gap = if sign > 0.0 {
                            (warp - half_e) - (weft + half_d)
                        } else {
                            (weft - half_d) - (warp + half_e)
                        };
                        if gap < -1e-9 * s {
                            return Err(PatchError::OutOfRange {
                                key: "crimp",
                                value: self.crimp,
                                range: format!(
                                    "large enough that crossing yarns do not cut through each other (they do at crossing \
                                     ({i}, {j}) by {:.3e}); raise crimp or spacing, or lower yarn_radius",
                                    -gap
                                ),
                            });
                        }
                    }
                }
            }
        }
        Ok(())
    }

    /// Whole turns per repeat of the plies and of the fibers (rounded from α, ψ).
    fn turns(&self, arc_per_period: f64) -> (f64, f64) {
        let (rp, d) = self.ply_radius_and_offset();
        let ply = if d > 0.0 { (arc_per_period * self.ply_twist.tan() / d / (2.0 * PI)).round() } else { 0.0 };
        let fiber = (arc_per_period * self.psi.tan() / rp / (2.0 * PI)).round();
        (ply, fiber)
    }

    /// The ply and fiber twist angles after rounding to whole turns per repeat (radians).
    #[must_use]
    pub fn effective_twists(&self) -> (f64, f64) {
        let line = self.centre_line(true, 0, 1);
        let arc = *line.arc.last().unwrap_or(&1.0);
        let (ply, fiber) = self.turns(arc);
        let (rp, d) = self.ply_radius_and_offset();
        let alpha = if d > 0.0 { (ply * 2.0 * PI * d / arc).atan() } else { 0.0 };
        (alpha, (fiber * 2.0 * PI * rp / arc).atan())
    }

    /// Vertices per fiber per repeat.
    fn samples_per_period(&self) -> usize {
        let n = self.weave.repeat();
        let base = self.samples_per_spacing * n;
        let (rp, d) = self.ply_radius_and_offset();
        // Arc length ≤ straight length × (1 + π a/s): a bound, for the twist's sample count.
        let arc = self.period() * (1.0 + PI * self.crimp / self.spacing);
        let turns_fiber = arc * self.psi.tan() / rp / (2.0 * PI) + 1.0;
        let turns_ply = if d > 0.0 { arc * self.ply_twist.tan() / d / (2.0 * PI) + 1.0 } else { 0.0 };
        base.max((16.0 * (turns_fiber + turns_ply)).ceil() as usize)
    }

    /// Segments of a patch of `px × py` repeats (before generating it).
    #[must_use]
    pub fn estimated_segments(&self, px: usize, py: usize) -> (u64, u64, u64) {
        let n = self.weave.repeat() as u64;
        let fibers_per_yarn = (self.plies * self.fibers_per_ply) as u64;
        let fibers = (n * py as u64 + n * px as u64).saturating_mul(fibers_per_yarn);
        // A warp fiber spans py repeats, a weft fiber px: take the longer.
        let per_fiber = (self.samples_per_period() as u64).saturating_mul(px.max(py) as u64);
        (fibers.saturating_mul(per_fiber), fibers, per_fiber)
    }

    /// Height of a yarn's centre at coordinate `t` along it (in spacings from the first
    /// crossing's half-spacing offset): `warp` yarn `k`.
    fn height(&self, warp: bool, k: usize, along: f64) -> f64 {
        // Crossing c sits at along = (c + ½)·s.
        let x = along / self.spacing - 0.5;
        let c0 = x.floor();
        let t = x - c0;
        let n = self.weave.repeat() as i64;
        let at = |c: i64| {
            let c = c.rem_euclid(n) as usize;
            let over = if warp { self.weave.warp_over(k, c) } else { !self.weave.warp_over(c, k) };
            if over { self.crimp } else { -self.crimp }
        };
        let (h0, h1) = (at(c0 as i64), at(c0 as i64 + 1));
        h0 + (h1 - h0) * 0.5 * (1.0 - (PI * t).cos())
    }

    /// Centre line of warp (`true`) or weft yarn `k` over `periods` repeats.
    fn centre_line(&self, warp: bool, k: usize, periods: usize) -> CentreLine {
        let m = self.samples_per_period() * periods;
        let length = self.period() * periods as f64;
        let offset = (k as f64 + 0.5) * self.spacing;
        let n = self.weave.repeat();
        let mut points = Vec::with_capacity(m + 1);
        let mut arc = Vec::with_capacity(m + 1);
        for q in 0..=m {
            let along = length * q as f64 / m as f64;
            let h = self.height(warp, k % n, along);
            let p = if warp { DVec3::new(offset, along, h) } else { DVec3::new(along, offset, h) };
            let s = points.last().map_or(0.0, |&last: &DVec3| arc.last().copied().unwrap_or(0.0) + (p - last).length());
            points.push(p);
            arc.push(s);
        }
        CentreLine { points, arc, across: if warp { DVec3::X } else { DVec3::Y } }
    }

    /// The fibers of a patch of `px × py` repeats over `[0, px·P] × [0, py·P]`, refused up
    /// front when too large.
    pub fn fibers(&self, px: usize, py: usize) -> Result<Fibers, PatchError> {
        self.validate()?;
        if px == 0 || py == 0 || px > 1000 || py > 1000 {
            return Err(PatchError::OutOfRange {
                key: "periods",
                value: if px == 0 || px > 1000 { px as f64 } else { py as f64 },
                range: "1 … 1000".into(),
            });
        }
        let (segments, fibers, per_fiber) = self.estimated_segments(px, py);
        if segments > MAX_SEGMENTS {
            return Err(PatchError::TooLarge { segments, fibers, per_fiber });
        }
        let n = self.weave.repeat();
        let (rp, d) = self.ply_radius_and_offset();
        let rho_max = rp - self.fiber_radius;
        let golden = PI * (3.0 - 5f64.sqrt());
        let mut out = Fibers { radius: self.fiber_radius, ..Fibers::default() };
        let mut rng = fiberlab_math::split_mix::SplitMix64::new(self.seed);
        for (warp, yarns, periods) in [(true, n * px, py), (false, n * py, px)] {
            for k in 0..yarns {
                let line = self.centre_line(warp, k, periods);
                let arc_period = line.arc.last().copied().unwrap_or(0.0) / periods as f64;
                let (ply_turns, fiber_turns) = self.turns(arc_period);
                let ply_rate = ply_turns * 2.0 * PI / arc_period;
                let fiber_rate = fiber_turns * 2.0 * PI / arc_period;
                // The same phases for every yarn of one direction would line the fibers up
                // across yarns: a jitter per yarn.
                let yarn_phase = rng.next_f64() * 2.0 * PI;
                for ply in 0..self.plies {
                    let ply_phase = yarn_phase + 2.0 * PI * ply as f64 / self.plies as f64;
                    for f in 0..self.fibers_per_ply {
                        let rho = rho_max * ((f as f64 + 0.5) / self.fibers_per_ply as f64).sqrt();
                        let fiber_phase = f as f64 * golden;
                        let start = out.points.len();
                        for (q, &c) in line.points.iter().enumerate() {
                            let s = line.arc[q];
                            let tangent = tangent_at(&line.points, q);
                            let b = tangent.cross(line.across).normalize();
                            let across = line.across;
                            let tp = ply_phase + ply_rate * s;
                            let ply_centre = c + (across * tp.cos() + b * tp.sin()) * d;
                            let tf = tp + fiber_phase - fiber_rate * s;
                            out.points.push(ply_centre + (across * tf.cos() + b * tf.sin()) * rho);
                        }
                        out.counts.push(out.points.len() - start);
                        out.yarn.push((warp, k));
                    }
                }
            }
        }
        Ok(out)
    }
}

/// Unit tangent of a polyline at vertex `q` (central difference).
fn tangent_at(points: &[DVec3], q: usize) -> DVec3 {
    let a = points[q.saturating_sub(1)];
    let b = points[(q + 1).min(points.len() - 1)];
    (b - a).normalize()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn small(weave: Weave) -> WovenPatch {
        WovenPatch { weave, plies: 1, fibers_per_ply: 12, samples_per_spacing: 32, ..WovenPatch::default() }
    }

    /// The centre line of `warp` yarn `k` by the formula, at `along`.
    fn centre(p: &WovenPatch, warp: bool, k: usize, along: f64) -> DVec3 {
        let h = p.height(warp, k % p.weave.repeat(), along);
        let o = (k as f64 + 0.5) * p.spacing;
        if warp { DVec3::new(o, along, h) } else { DVec3::new(along, o, h) }
    }

    /// Every fiber vertex lies within R − r of its yarn's centre line (distance to a dense
    /// sampling of the centre line, found by search), for plain and twill, one and three plies.
    #[test]
    fn fibers_stay_inside_their_yarn() {
        for patch in [small(Weave::Plain), WovenPatch { plies: 3, ..small(Weave::Twill21) }] {
            let fibers = patch.fibers(1, 1).unwrap();
            let mut start = 0;
            let mut worst: f64 = 0.0;
            for (f, &n) in fibers.counts.iter().enumerate() {
                let (warp, k) = fibers.yarn[f];
                for p in &fibers.points[start..start + n] {
                    let along0 = if warp { p.y } else { p.x };
                    let dist = (-200..=200)
                        .map(|q| centre(&patch, warp, k, along0 + q as f64 * patch.spacing * 1e-3))
                        .map(|c| (*p - c).length())
                        .fold(f64::INFINITY, f64::min);
                    worst = worst.max(dist);
                }
                start += n;
            }
            let limit = patch.yarn_radius - patch.fiber_radius;
            assert!(worst <= limit * 1.001, "{patch:?}: worst distance {worst} > R − r = {limit}");
            // And they do fill it: the outermost fibers reach near the limit.
            assert!(worst > 0.8 * limit, "{worst} vs {limit}");
        }
    }

    /// The heights repeat with the weave's period and each yarn is over exactly where the
    /// pattern says: at every crossing the fibers of the upper yarn lie above those of the
    /// lower one (within 5 % of a spacing of the crossing: the yarns do not cut through each
    /// other).
    #[test]
    fn crimp_has_the_weave_period_and_the_upper_yarn_is_on_top() {
        for weave in [Weave::Plain, Weave::Twill21, Weave::Twill22] {
            let patch = small(weave);
            let n = weave.repeat();
            let period = patch.period();
            for k in 0..n {
                for q in 0..50 {
                    let along = q as f64 * period / 50.0;
                    let (a, b) = (patch.height(true, k, along), patch.height(true, k, along + period));
                    assert!((a - b).abs() < 1e-12, "{weave:?}: not periodic");
                }
            }
            // Plain weave: the sinusoid a·cos(π(y − s/2)/s) for warp 0.
            if weave == Weave::Plain {
                for q in 0..40 {
                    let y = q as f64 * period / 40.0;
                    let expected = patch.crimp * (PI * (y / patch.spacing - 0.5)).cos();
                    assert!((patch.height(true, 0, y) - expected).abs() < 1e-12);
                }
            }
            let fibers = patch.fibers(1, 1).unwrap();
            let s = patch.spacing;
            for i in 0..n {
                for j in 0..n {
                    let (cx, cy) = ((i as f64 + 0.5) * s, (j as f64 + 0.5) * s);
                    let (mut warp_z, mut weft_z) = (Vec::new(), Vec::new());
                    let mut start = 0;
                    for (f, &cnt) in fibers.counts.iter().enumerate() {
                        let (warp, k) = fibers.yarn[f];
                        for p in &fibers.points[start..start + cnt] {
                            let near = (p.x - cx).abs() < 0.05 * s && (p.y - cy).abs() < 0.05 * s;
                            if near && warp && k == i {
                                warp_z.push(p.z);
                            }
                            if near && !warp && k == j {
                                weft_z.push(p.z);
                            }
                        }
                        start += cnt;
                    }
                    assert!(!warp_z.is_empty() && !weft_z.is_empty());
                    let (wmin, wmax) = warp_z.iter().fold((f64::MAX, f64::MIN), |(a, b), &z| (a.min(z), b.max(z)));
                    let (fmin, fmax) = weft_z.iter().fold((f64::MAX, f64::MIN), |(a, b), &z| (a.min(z), b.max(z)));
                    if weave.warp_over(i, j) {
                        assert!(wmin > fmax, "{weave:?} ({i},{j}): warp should be on top: {wmin} vs {fmax}");
                    } else {
                        assert!(fmin > wmax, "{weave:?} ({i},{j}): weft should be on top: {fmin} vs {wmax}");
                    }
                }
            }
        }
    }

    /// On a straight twill float the angle between a fiber's chord and the yarn axis is
    /// `atan(ρ tan ψ / R_p)` (one ply: R_p = R), with ψ the effective (rounded) twist.
    #[test]
    fn twist_angle_measured_from_the_curves() {
        let patch = WovenPatch { psi: 35f64.to_radians(), samples_per_spacing: 64, ..small(Weave::Twill21) };
        let (_, psi) = patch.effective_twists();
        // One repeat holds about one turn here: rounding to whole turns moves ψ by a few degrees.
        assert!((psi - patch.psi).abs() < 8f64.to_radians(), "rounding moved ψ too far: {}", psi.to_degrees());
        let fibers = patch.fibers(1, 1).unwrap();
        // Warp 1 is over weft 0 and 1: its centre is straight (z = a) for y ∈ [s/2, 3s/2].
        let s = patch.spacing;
        let rp = patch.yarn_radius;
        let mut start = 0;
        let mut checked = 0;
        for (f, &cnt) in fibers.counts.iter().enumerate() {
            let pts = &fibers.points[start..start + cnt];
            start += cnt;
            if fibers.yarn[f] != (true, 1) {
                continue;
            }
            for w in pts.windows(2) {
                let mid = (w[0] + w[1]) * 0.5;
                if (0.7 * s..1.3 * s).contains(&mid.y) {
                    let rho = DVec3::new(mid.x - 1.5 * s, 0.0, mid.z - patch.crimp).length();
                    let chord = (w[1] - w[0]).normalize();
                    let angle = chord.y.clamp(-1.0, 1.0).acos();
                    let expected = (rho * psi.tan() / rp).atan();
                    assert!(
                        (angle - expected).abs() < 0.01,
                        "angle {} expected {}",
                        angle.to_degrees(),
                        expected.to_degrees()
                    );
                    checked += 1;
                }
            }
        }
        assert!(checked > 100, "{checked}");
    }

    #[test]
    fn absurd_patches_are_refused_up_front() {
        let e = WovenPatch { fibers_per_ply: 2000, plies: 8, ..WovenPatch::default() }.fibers(100, 100).unwrap_err();
        assert!(matches!(e, PatchError::TooLarge { .. }) && e.to_string().contains("segments"), "{e}");
        let e = WovenPatch { yarn_radius: 0.17, ..WovenPatch::default() }.validate().unwrap_err();
        assert!(e.to_string().contains("yarn_radius"), "{e}");
        let e = WovenPatch { crimp: 0.01, ..WovenPatch::default() }.validate().unwrap_err();
        assert!(e.to_string().contains("crimp"), "{e}");
        // Crimp equal to the radius but yarns too close: they would cut through each other.
        let e = WovenPatch { spacing: 0.22, crimp: 0.1, ..WovenPatch::default() }.validate().unwrap_err();
        assert!(e.to_string().contains("cut through"), "{e}");
        let e = WovenPatch { spacing: f64::NAN, ..WovenPatch::default() }.validate().unwrap_err();
        assert!(e.to_string().contains("spacing"), "{e}");
        assert!(Weave::parse("satin").is_err());
    }
}
