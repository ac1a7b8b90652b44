//! Oriented bounding boxes for thin primitives (hair segments): the frame a set of segments is
//! boxed in, the boxes in it, and the wide node whose eight children each carry their own frame.
//!
//! A diagonal hair segment fills a small part of its axis-aligned box; boxed in a frame whose
//! first axis follows the local strand direction, a bundle of nearly parallel segments is
//! bounded tightly without being cut into pieces. This is the approach of Woop, Benthin, Wald,
//! Johnson and Tabellion, "Exploiting Local Orientation Similarity for Efficient Ray Traversal
//! of Hair and Fur" (HPG 2014): nodes whose children are boxed in frames aligned to their
//! segments, mixed with axis-aligned nodes where orientation does not pay (the build decides by
//! the surface-area heuristic, see [`super`]).
//!
//! The frame of a set of segments: its first axis is the principal direction of the segments'
//! directions (the dominant eigenvector of `Σ dᵢ dᵢᵀ` with `dᵢ` the segment vectors, so opposite
//! directions agree and long segments weigh more); its second axis is the principal direction
//! of the segments' end points across the first axis (a sheet of parallel strands gets a thin
//! box); the third completes a right-handed frame. The frame is stored as integers (its rows
//! scaled by 127 and rounded, [`IntRows`]); bounds are computed with those integer rows as they
//! are, so the box bounds the segments in the frame the traversal uses, whatever the rounding.

use super::BuildPrim;
use crate::simd::{OrientedBoxes, OrientedTerms};
use fiberlab_math::DVec3;
use glam::Vec3;

/// Rows of a rotation in `f32` (each close to unit length, mutually close to orthogonal).
pub(super) type Rows = [Vec3; 3];

/// A frame as stored in a node: the rows of a rotation scaled by [`SCALE`] and rounded to
/// integers (so a node holds a child's frame in nine bytes, and the rows are exact as `f32`).
/// The rows are not exactly orthonormal; bounds are computed with them as they are.
pub(super) type IntRows = [[i8; 3]; 3];

/// The integer frames' scale.
const SCALE: f32 = 127.0;

/// A bound on the 1-norm of an [`IntRows`] row (`√3 · 127.5`): the rounding bound of the test
/// in the scaled frames grows with it.
pub(super) const ROW_NORM_1: f32 = 221.0;

/// The identity frame (the axis-aligned box of a child in an oriented node).
pub(super) const IDENTITY: IntRows = [[127, 0, 0], [0, 127, 0], [0, 0, 127]];

/// The integer rows as `f64` vectors (exact).
fn rows_f64(rows: &IntRows) -> [DVec3; 3] {
    rows.map(|r| DVec3::new(r[0].into(), r[1].into(), r[2].into()))
}

/// `rows` scaled and rounded to integers.
pub(super) fn integer_rows(rows: &Rows) -> IntRows {
    rows.map(|r| r.to_array().map(|x| (x * SCALE).round().clamp(-127.0, 127.0) as i8))
}

/// The frame of `records`' segments (module docs), or `None` when they have no length.
pub(super) fn frame_of(records: &[BuildPrim]) -> Option<Rows> {
    // At most this many records, evenly spaced, decide the frame (it only orients the box; the
    // bounds are exact whatever the frame).
    const SAMPLE: usize = 64;
    let step = records.len().div_ceil(SAMPLE).max(1);
    let sample = || records.iter().step_by(step);
    // Second moments of the segment vectors.
    let mut m = [[0.0f64; 3]; 3];
    for r in sample() {
        let d = (r.p1() - r.p0()).as_dvec3();
        let d = d.to_array();
        for i in 0..3 {
            for j in i..3 {
                m[i][j] += d[i] * d[j];
            }
        }
    }
    let sym = |i: usize, j: usize| if i <= j { m[i][j] } else { m[j][i] };
    let trace = m[0][0] + m[1][1] + m[2][2];
    if trace.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) || !trace.is_finite() {
        return None;
    }
    // Power iteration from the column of the largest diagonal entry (never orthogonal to the
    // dominant eigenvector of a positive semi-definite matrix).
    let start = (0..3).max_by(|&a, &b| m[a][a].total_cmp(&m[b][b])).unwrap_or(0);
    let mut v = DVec3::new(sym(0, start), sym(1, start), sym(2, start));
    for _ in 0..4 {
        let w = DVec3::new(
            sym(0, 0) * v.x + sym(0, 1) * v.y + sym(0, 2) * v.z,
            sym(1, 0) * v.x + sym(1, 1) * v.y + sym(1, 2) * v.z,
            sym(2, 0) * v.x + sym(2, 1) * v.y + sym(2, 2) * v.z,
        );
        v = w.try_normalize()?;
    }
    let e1 = v;
    // A basis (u, w) of the plane across e1, then the end points' principal direction in it.
    let u = e1.any_orthonormal_vector();
    let w = e1.cross(u);
    let n = (2 * sample().count()) as f64;
    let mut mean = DVec3::ZERO;
    for r in sample() {
        mean += (r.p0() + r.p1()).as_dvec3();
    }
    mean /= n;
    let (mut cuu, mut cuw, mut cww) = (0.0f64, 0.0f64, 0.0f64);
    for r in sample() {
        for p in [r.p0(), r.p1()] {
            let q = p.as_dvec3() - mean;
            let (a, b) = (q.dot(u), q.dot(w));
            cuu += a * a;
            cuw += a * b;
            cww += b * b;
        }
    }
    // The angle θ of the principal axis in (u, w): tan 2θ = 2c_uw / (c_uu − c_ww); cos θ and
    // sin θ by the half-angle formulas (no trigonometric calls).
    let (a, b) = (cuu - cww, 2.0 * cuw);
    let r = a.hypot(b);
    let cos_2 = if r > 0.0 { a / r } else { 1.0 };
    let (cos, sin) = (((1.0 + cos_2) * 0.5).max(0.0).sqrt(), ((1.0 - cos_2) * 0.5).max(0.0).sqrt().copysign(b));
    let e2 = u * cos + w * sin;
    let e3 = e1.cross(e2);
    let rows = [e1, e2, e3].map(|e| e.as_vec3());
    rows.iter().all(|r| r.is_finite()).then_some(rows)
}

/// The box of `records`' tubes in the frame `rows`, for points relative to `center`, in
/// `f64` (the caller rounds it outward): per row `k`, the end points' extent along the row
/// widened by the reach times the row's length (the extent of a ball of that radius).
pub(super) fn bounds_in(records: &[BuildPrim], rows: &IntRows, center: DVec3) -> (DVec3, DVec3) {
    let r = rows_f64(rows);
    let norm = DVec3::new(r[0].length(), r[1].length(), r[2].length());
    let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
    for rec in records {
        let reach = f64::from(rec.reach()) * norm;
        for p in [rec.p0(), rec.p1()] {
            let q = p.as_dvec3() - center;
            let x = DVec3::new(r[0].dot(q), r[1].dot(q), r[2].dot(q));
            lo = lo.min(x - reach);
            hi = hi.max(x + reach);
        }
    }
    (lo, hi)
}

/// Half the surface area of the box `lo..hi` (0 when empty).
pub(super) fn half_area(lo: DVec3, hi: DVec3) -> f64 {
    let e = (hi - lo).max(DVec3::ZERO);
    e.x * e.y + e.y * e.z + e.z * e.x
}

/// Half the surface area, in scene units, of the box `lo..hi` in the integer frame `rows`
/// (each extent divided by its row's length).
pub(super) fn scaled_half_area(rows: &IntRows, lo: DVec3, hi: DVec3) -> f64 {
    let norm = DVec3::from(rows_f64(rows).map(DVec3::length));
    half_area(lo / norm, hi / norm)
}

/// A wide node whose children are boxed each in its own frame: the boxes as the kernel reads
/// them ([`OrientedBoxes`]), relative to `center`; `center[3]` is a radius around `center`
/// holding every child's geometry (it bounds the ray distance in the rounding bound of the
/// test); child references and the used-slot mask as in the axis-aligned node.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(64))]
pub(super) struct OrientedNode {
    pub boxes: OrientedBoxes,
    pub center: [f32; 4],
    pub child: [u32; 8],
    pub used: u32,
}

const _: () = assert!(std::mem::size_of::<OrientedNode>() == 320, "five cache lines");

/// One child of an [`OrientedNode`] being made: its frame, its box in that frame relative to the
/// node's centre (`f64`, rounded outward when stored) and its reference.
pub(super) struct OrientedChild {
    pub rows: IntRows,
    pub lo: DVec3,
    pub hi: DVec3,
    pub child: u32,
}

impl OrientedNode {
    /// A node around `center` (f32, so the traversal subtracts exactly this point) holding
    /// geometry within `radius` of it, over up to eight children.
    pub fn new(center: Vec3, radius: f32, children: &[OrientedChild], empty: u32) -> Self {
        assert!(children.len() <= 8, "{} children for a wide node", children.len());
        let mut n = Self {
            boxes: OrientedBoxes { rot: [[[0; 8]; 3]; 3], lo: [[0.0; 8]; 3], hi: [[0.0; 8]; 3] },
            center: [center.x, center.y, center.z, radius],
            child: [empty; 8],
            used: 0,
        };
        // Unused slots hold the identity frame (any finite frame would do).
        for (row, identity) in IDENTITY.iter().enumerate() {
            n.boxes.rot[row][row] = [identity[row]; 8];
        }
        for (k, c) in children.iter().enumerate() {
            n.child[k] = c.child;
            n.used |= u32::from(c.child != empty) << k;
            for row in 0..3 {
                for col in 0..3 {
                    n.boxes.rot[row][col][k] = c.rows[row][col];
                }
                n.boxes.lo[row][k] = super::clamp_finite(super::round_down(c.lo[row]));
                n.boxes.hi[row][k] = super::clamp_finite(super::round_up(c.hi[row]));
            }
        }
        n
    }

    /// The test's inputs for a ray with `f32` origin `o` (`slack`: the widening its rounding
    /// needs) and direction `d` over `(t_min, t_max)`. The widening bounds the rounding of the
    /// frame's image of the origin and the direction (a few ulps of the origin's distance from
    /// the centre and of the ray distance, which is at most that distance plus the radius for
    /// any point of the node's geometry, times a row's 1-norm) and of the slab arithmetic; it is
    /// generous (32 ulps), which costs nothing measurable against hair radii.
    #[inline(always)]
    pub fn terms(&self, o: Vec3, d: Vec3, slack: f32, t_min: f32, t_max: f32) -> OrientedTerms {
        let rel = o - Vec3::new(self.center[0], self.center[1], self.center[2]);
        let l1 = rel.abs().element_sum();
        let widen = (slack + (l1 + self.center[3]) * (32.0 * f32::EPSILON)) * ROW_NORM_1;
        OrientedTerms { o: rel.to_array(), d: d.to_array(), widen, t_min, t_max }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_random::Lcg;

    /// Parallel segments give the frame their direction; a sheet of them (spread along one
    /// direction across it) gives the second axis along the sheet.
    #[test]
    fn frame_follows_the_segments_and_the_sheet() {
        let mut g = Lcg(3);
        for _ in 0..200 {
            let u = (g.vec() - 0.5).normalize();
            let across = u.any_orthonormal_vector();
            let records: Vec<BuildPrim> = (0..40)
                .map(|i| {
                    // Along `u`, some reversed; spread along `across` (0.5) far more than off it.
                    let p = across * (0.5 * g.next()) + u.cross(across) * (0.001 * g.next());
                    let d = if i % 3 == 0 { -u } else { u } * (0.1 + 0.05 * g.next());
                    BuildPrim::segment(p, p + d, 0.002, i)
                })
                .collect();
            let rows = frame_of(&records).unwrap().map(|r| r.as_dvec3());
            assert!(rows[0].dot(u).abs() > 0.9999, "first axis {:?} vs {u:?}", rows[0]);
            assert!(rows[1].dot(across).abs() > 0.999, "second axis {:?} vs {across:?}", rows[1]);
            for (a, b) in [(0, 1), (1, 2), (0, 2)] {
                assert!(rows[a].dot(rows[b]).abs() < 1e-5);
            }
        }
        // Segments without length have no frame.
        assert!(frame_of(&[BuildPrim::segment(DVec3::ONE, DVec3::ONE, 0.1, 0)]).is_none());
    }

    /// Every point within the reach of a record's segment maps into the box (random frames,
    /// including the identity and degenerate integer rows; points on the reach's boundary).
    #[test]
    fn bounds_hold_every_point_of_the_records() {
        let mut g = Lcg(5);
        for case in 0..500 {
            let records: Vec<BuildPrim> = (0..1 + case % 9)
                .map(|i| {
                    let p = (g.vec() - 0.5) * 4.0;
                    BuildPrim::segment(p, p + (g.vec() - 0.5) * 0.5, 0.001 + 0.05 * g.next(), i as u32)
                })
                .collect();
            let rows: IntRows = match case % 3 {
                0 => IDENTITY,
                1 => integer_rows(&[g.vec() - 0.5, g.vec() - 0.5, g.vec() - 0.5].map(|v| v.normalize().as_vec3())),
                _ => [0; 3].map(|_| [0; 3].map(|_| (g.next() * 7.0) as i8 - 3)),
            };
            let center = g.vec() - 0.5;
            let (lo, hi) = bounds_in(&records, &rows, center);
            let r = rows_f64(&rows);
            for rec in &records {
                let (p0, p1, reach) = (rec.p0().as_dvec3(), rec.p1().as_dvec3(), f64::from(rec.reach()));
                for _ in 0..50 {
                    let p = p0 + (p1 - p0) * g.next() + (g.vec() - 0.5).normalize() * reach;
                    let x = DVec3::new(r[0].dot(p - center), r[1].dot(p - center), r[2].dot(p - center));
                    let slack = 1e-9 * (1.0 + x.abs().max_element());
                    assert!(x.cmpge(lo - slack).all() && x.cmple(hi + slack).all(), "{x:?} outside {lo:?}..{hi:?}");
                }
            }
        }
    }
}
