//! Strands as round tubes: polylines of mitered cylinders, with per-vertex radius.
//!
//! # Geometry
//! A strand is a polyline `p_0 … p_n` (root → tip) with a radius per vertex. Segment `k` is
//! a circular cylinder of radius `(r_k + r_{k+1})/2` around the axis `p_k → p_{k+1}`, clipped
//! at each interior vertex by the **miter plane** whose normal is the vertex tangent
//! `t_k = normalize(d_{k−1} + d_k)` (the bisector of the adjacent segment directions). Two
//! equal-radius cylinders meet on the miter plane in the same ellipse, so the tube is
//! watertight at joints without overlap. Where a strand bends by more than 120° the miter
//! would reach too far; both sides then clip perpendicular to their own axis (a small gap).
//! Roots and tips are open (no caps: they are sub-pixel).
//!
//! Cubic curves (uniform B-splines and Bézier splines) are converted to polylines at load time
//! by evaluating each cubic span at [`CubicBasis`] `subdivisions` uniform parameter steps; the
//! tube is then the polyline tube above. With hair radii ≪ curvature radius the deviation
//! from the true swept circle is the chord error `κ L²/8` of each step.
//!
//! Tubes are **one-sided**: only the entry point of a ray into a tube counts. A ray leaving a
//! fiber (reflected or transmitted, spawned on its surface) therefore never re-hits it, which
//! is what treating a fiber hit as one scattering event (`docs/theory/conventions.md`, "Fiber scattering function versus renderer BSDF") requires.
//!
//! # Shading frame at a hit (matches the scattering models' frame, math::frame)
//! * `u`: tangent, root → tip: the vertex tangents interpolated linearly along the segment
//!   (smooth highlights), normalized.
//! * `w`: the component of `ω_o = −ray.d` perpendicular to `u`, normalized: the viewer lies in
//!   the `+w` half of the normal plane, and `ω_o` has local coordinates `(sinθ_o, 0, cosθ_o)`,
//!   i.e. `φ_o = π/2`.
//! * `v = w × u` (so `u × v = w`, right-handed): `v ⟂ u` and `v ⟂ ray`.
//! * `h = (q·v)/r` ∈ [−1, 1], where `q` is the vector from the axis to the ray's point of
//!   closest approach, measured in the normal plane of the segment axis. As the projected ray
//!   runs along `−w`, its offset along `v` is constant, so `h` is exactly the normal-plane
//!   offset of `docs/theory/conventions.md`, increasing toward `+v`.
//!
//! This is pbrt's hair frame (`x` = tangent, `y` across, `z` toward the camera, `h` along
//! `+y`): the mirror reflection off the tube at offset `h` leaves at `φ_i − φ_o = −2 asin h`,
//! which is Φ(0, h) of `docs/theory/conventions.md` ("Exit azimuth") in pbrt's `φ_i − φ_o` convention (tested below by
//! reflecting the ray off the actual cylinder normal).

use crate::bvh::{Aabb, Boxes, BuildPrim, Bvh};
use crate::ray::Ray;
use crate::simd::{Lanes, Portable, RayF32, SegmentHead, SimdLevel};
use fiberlab_math::{DVec3, FiberFrame};
use glam::Vec3;

/// Bends sharper than this (cosine of the half-angle between segments) are not mitered.
const MIN_MITER_COS: f64 = 0.5;
/// In the BVH a segment is cut into pieces of its axis no longer than this many radii (each
/// boxed tightly, along the segment where its node is oriented): long thin primitives make
/// boxes that overlap and rays enter many of them. Measured on the peer scene (segments of
/// about 55 radii; render instructions against one piece per segment): 1.63 G at one piece,
/// 1.36 G at 32 radii, 1.26 G at 20, 1.20 G at 16, 1.18 G at 12 (the book's "Performance history", "Oriented boxes").
const PIECE_IN_RADII: f64 = 16.0;
/// Sets of at most this many segments are built as one tree; larger ones in clusters of at most
/// [`crate::bvh::CLUSTER_MAX`] segments (whose size is chosen for the memory and time of large
/// heads, not for the quality of a small set's tree).
const ONE_TREE_MAX: usize = 1 << 18;
/// Strands made into segments by one task of [`CurveSet::tubes_of_f32_strands`].
const STRANDS_PER_TASK: usize = 1024;
/// Segments copied at a time before their pieces are made ([`CurveSet::from_tubes`]; 16 KB).
const GATHER: usize = 256;
/// At most this many BVH pieces per segment.
const MAX_PIECES: usize = 8;
/// Sets of more than this many segments put each in the tree whole ([`DENSE_PIECES`]): the
/// pieces' tree would approach 1 GiB there (the 5M-segment thin head: 956 MiB), while below it a
/// render is 13–50 % faster with them (a 10,000-strand B-spline head of some 300k segments, a
/// 1.5M-segment head), which any render of more than a few tens of spp wants.
const DENSE_MIN: usize = 1 << 22;
/// At most this many BVH pieces per segment in sets of more than [`DENSE_MIN`] segments. On
/// the 5M-segment thin head (`hair generate --style straight --strands 333334 --segments 15`) one
/// piece made the load 5.8–6.3 s of CPU instead of 23–26 s and its peak 494 MiB instead of
/// 956 MiB, and the render at 4 spp 1.3–1.5× slower (wall 6.1–7.1 s against 4.6–4.9 s): the whole
/// render is cheaper up to some 30–60 spp (1.5M segments: ~20 spp), so at the usual 1–16 spp of
/// such heads (the book's "Performance", "One piece a segment in dense heads"). On the sparse
/// 10,000-strand heads one piece cost 48–62 % more render instructions, and they stay below this
/// size.
const DENSE_PIECES: usize = 1;

/// One tube segment (f32 storage, 64 bytes: one cache line). `repr(C)`: the first eight
/// `f32` (`p0`, `axis`, `length`, `radius`) are what the leaf pre-test reads, contiguous.
#[derive(Clone, Copy, Debug)]
#[repr(C)]
struct Segment {
    /// Root-side end of the axis.
    p0: Vec3,
    /// Unit axis direction, root → tip.
    axis: Vec3,
    /// Axis length (the tip-side end is `p0 + length·axis`).
    length: f32,
    radius: f32,
    /// Miter-plane normal (vertex tangent) at `p0`, pointing toward the tip.
    n0: Vec3,
    /// Miter-plane normal at the tip-side end.
    n1: Vec3,
    /// Curve parameter (0 at the root, 1 at the tip) at both ends, in units of 1/65535.
    v: [u16; 2],
    strand: u32,
}

const _: () = assert!(std::mem::size_of::<Segment>() == 64, "a segment is one cache line");
const _: () = assert!(std::mem::offset_of!(Segment, radius) == 28, "the pre-test's fields come first");

impl Segment {
    fn p1(&self) -> Vec3 {
        self.p0 + self.axis * self.length
    }

    /// How many pieces of its axis the segment is in the BVH ([`PIECE_IN_RADII`], at most
    /// `max_pieces`).
    fn piece_count(&self, max_pieces: usize) -> usize {
        let k = (f64::from(self.length) / (PIECE_IN_RADII * f64::from(self.radius))).ceil();
        k.clamp(1.0, max_pieces as f64) as usize
    }

    /// The fields of the leaf pre-test, in order.
    #[inline(always)]
    fn head(&self) -> SegmentHead {
        let (p, a) = (self.p0, self.axis);
        [p.x, p.y, p.z, a.x, a.y, a.z, self.length, self.radius]
    }
}

/// A hit on a tube.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CurveHit {
    /// Ray distance.
    pub t: f64,
    /// Hit point on the tube surface.
    pub p: DVec3,
    /// Unit shading tangent `u`, root → tip.
    pub tangent: DVec3,
    /// Curve parameter ∈ [0, 1] along the strand (0 root, 1 tip).
    pub v: f64,
    /// Offset across the fiber ∈ [−1, 1] (see the module docs).
    pub h: f64,
    /// Tube radius at the hit, scene units.
    pub radius: f64,
    /// Strand index.
    pub strand: u32,
    /// Segment index.
    pub segment: u32,
}

impl CurveHit {
    /// The shading frame `(u, v, w)` for a hit seen along `ray_d` (module docs): `ω_o = −ray_d`
    /// has local coordinates `(sinθ_o, 0, cosθ_o)`.
    #[must_use]
    pub fn frame(&self, ray_d: DVec3) -> FiberFrame {
        let u = self.tangent;
        let wo = -ray_d;
        let w_raw = wo - u * u.dot(wo);
        let len = w_raw.length();
        if len < 1e-12 {
            return FiberFrame::from_tangent(u);
        }
        let w = w_raw / len;
        FiberFrame { u, v: w.cross(u), w }
    }
}

/// Cubic spline bases for [`CurveSet::from_cubic`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CubicBasis {
    /// Uniform cubic B-spline: control points `c_0 … c_m` give `m − 2` spans.
    BSpline,
    /// Piecewise cubic Bézier: control points `c_0 … c_{3k}` give `k` spans.
    Bezier,
}

/// Strands as tubes whose tree is not built yet ([`CurveSet::tubes_of_f32_strands`],
/// [`CurveSet::from_tubes`]).
#[derive(Clone, Debug, Default)]
pub struct Tubes {
    segments: Vec<Segment>,
    strands: usize,
}

/// A set of strands as tubes, with a BVH over tight pieces of their segments.
#[derive(Clone, Debug, Default)]
pub struct CurveSet {
    segments: Vec<Segment>,
    /// Tree over the pieces; its leaves list segment indices.
    bvh: Bvh,
    pieces: usize,
    strands: usize,
}

impl CurveSet {
    /// Tubes from polylines: `(points, radii)` per strand, root first, one radius per point.
    /// Strands with fewer than 2 points, zero radius or non-finite data are skipped.
    #[must_use]
    pub fn from_polylines<'a>(strands: impl IntoIterator<Item = (&'a [DVec3], &'a [f64])>) -> Self {
        let (segments, count) = Self::segments_of(strands, 0);
        Self::from_segments(segments, count)
    }

    /// The segments of polylines (as [`Self::from_polylines`]) and the number of strands kept;
    /// `capacity`: the expected number of segments.
    fn segments_of<'a>(
        strands: impl IntoIterator<Item = (&'a [DVec3], &'a [f64])>,
        capacity: usize,
    ) -> (Vec<Segment>, usize) {
        let mut segments = Vec::with_capacity(capacity);
        let mut dirs = Vec::new();
        let mut count = 0u32;
        for (points, radii) in strands {
            if Self::push_strand(points, radii, count, &mut dirs, &mut segments) {
                count += 1;
            }
        }
        (segments, count as usize)
    }

    /// Whether a strand of `points` (root first) and their `radii` is kept: at least 2 points,
    /// a radius each, all finite.
    fn strand_is_kept(points: &[DVec3], radii: &[f64]) -> bool {
        points.len() >= 2 && radii.len() == points.len() && points.iter().all(|p| p.is_finite())
    }

    /// Appends the segments of one strand, numbered `strand`, to `out` (segments of no length
    /// or radius skipped); `dirs` is room for its directions. Whether the strand is kept
    /// ([`Self::strand_is_kept`]; a kept strand may have no segments).
    fn push_strand(
        points: &[DVec3],
        radii: &[f64],
        strand: u32,
        dirs: &mut Vec<DVec3>,
        out: &mut Vec<Segment>,
    ) -> bool {
        if !Self::strand_is_kept(points, radii) {
            return false;
        }
        let n = points.len();
        dirs.clear();
        dirs.extend(points.windows(2).map(|w| (w[1] - w[0]).normalize_or_zero()));
        let dirs = &dirs[..];
        // Vertex tangents: bisectors, or the adjacent direction at the ends / sharp bends.
        let miter = |k: usize, side: usize| -> DVec3 {
            // Tangent at vertex k as seen from segment `side` (k−1 or k).
            if k == 0 || k == n - 1 {
                return dirs[side];
            }
            let b = (dirs[k - 1] + dirs[k]).normalize_or_zero();
            if b.dot(dirs[side]) < MIN_MITER_COS || b == DVec3::ZERO { dirs[side] } else { b }
        };
        let total = (n - 1) as f64;
        for k in 0..n - 1 {
            let r = 0.5 * (radii[k] + radii[k + 1]);
            if dirs[k] == DVec3::ZERO || r.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
                continue;
            }
            let v = |k: usize| (k as f64 / total * f64::from(u16::MAX)).round() as u16;
            out.push(Segment {
                p0: points[k].as_vec3(),
                axis: dirs[k].as_vec3().normalize(),
                length: (points[k + 1] - points[k]).length() as f32,
                radius: r as f32,
                n0: miter(k, k).as_vec3(),
                n1: miter(k + 1, k).as_vec3(),
                v: [v(k), v(k + 1)],
                strand,
            });
        }
        true
    }

    /// Tubes from strands stored as single-precision points (as hair files hold them): strand
    /// `k` is `points[ranges[k]]`, and `radius(i)` is the tube's radius at point `i`. The points
    /// are widened to `f64` one strand at a time, so no second copy of a large groom is made.
    #[must_use]
    pub fn from_f32_strands(
        points: &[[f32; 3]],
        ranges: &[std::ops::Range<usize>],
        radius: impl Fn(usize) -> f64 + Sync,
    ) -> Self {
        Self::from_tubes(Self::tubes_of_f32_strands(points, ranges, radius))
    }

    /// The set of `tubes`, its tree built now.
    #[must_use]
    pub fn from_tubes(tubes: Tubes) -> Self {
        Self::from_segments(tubes.segments, tubes.strands)
    }

    /// The tubes of [`Self::from_f32_strands`] without their tree: the caller can free the
    /// strands before [`Self::from_tubes`] builds it (the build is a load's peak of memory).
    ///
    /// Strands keep their numbers (kept strands counted in the order of `ranges`), but a set
    /// large enough to be built in clusters (more than `ONE_TREE_MAX` segments) has its segments
    /// stored in the spatial order of the strands' roots ([`spatial_order`]): a cluster's
    /// segments are then a few runs of memory instead of one cache line each from anywhere in
    /// the set, for the build (which reads each segment to make its pieces) and the render
    /// (which reads a leaf's segments). The segments are made on all threads, a batch of strands
    /// at a time.
    #[must_use]
    pub fn tubes_of_f32_strands(
        points: &[[f32; 3]],
        ranges: &[std::ops::Range<usize>],
        radius: impl Fn(usize) -> f64 + Sync,
    ) -> Tubes {
        use rayon::prelude::*;
        let capacity = points.len().saturating_sub(ranges.len());
        let finite = |r: &std::ops::Range<usize>| points[r.clone()].iter().all(|p| p.iter().all(|c| c.is_finite()));
        // Each kept strand's number ([`Self::strand_is_kept`]), in the order of `ranges`.
        let mut numbers = vec![u32::MAX; ranges.len()];
        let mut count = 0u32;
        for (number, r) in numbers.iter_mut().zip(ranges) {
            if r.len() >= 2 && finite(r) {
                *number = count;
                count += 1;
            }
        }
        let kept = (0..ranges.len() as u32).filter(|&k| numbers[k as usize] != u32::MAX);
        let order: Vec<u32> = if capacity > ONE_TREE_MAX {
            spatial_order(&kept.map(|k| (k, points[ranges[k as usize].start])).collect::<Vec<_>>())
        } else {
            kept.collect()
        };
        // The strands of `order` as segments, appended to `out`.
        let make = |order: &[u32], out: &mut Vec<Segment>| {
            let (mut strand_points, mut strand_radii, mut dirs) = (Vec::new(), Vec::new(), Vec::new());
            for &k in order {
                let r = ranges[k as usize].clone();
                strand_points.clear();
                strand_radii.clear();
                strand_points
                    .extend(points[r.clone()].iter().map(|p| DVec3::new(p[0].into(), p[1].into(), p[2].into())));
                strand_radii.extend(r.map(&radius));
                Self::push_strand(&strand_points, &strand_radii, numbers[k as usize], &mut dirs, out);
            }
        };
        let mut segments = Vec::with_capacity(capacity);
        if order.len() < STRANDS_PER_TASK {
            make(&order, &mut segments);
        } else {
            // Batches of a few tasks a thread: only one batch's segments are held twice.
            let batch = STRANDS_PER_TASK * 4 * rayon::current_num_threads();
            for strands in order.chunks(batch) {
                let parts: Vec<Vec<Segment>> = strands
                    .par_chunks(STRANDS_PER_TASK)
                    .map(|strands| {
                        let mut out = Vec::with_capacity(16 * strands.len());
                        make(strands, &mut out);
                        out
                    })
                    .collect();
                for part in parts {
                    segments.extend_from_slice(&part);
                }
            }
        }
        Tubes { segments, strands: count as usize }
    }

    /// Tubes from cubic curves: per strand, control points and a radius per control point;
    /// each span is evaluated at `subdivisions` steps (module docs). Radii are interpolated
    /// with the same basis.
    #[must_use]
    pub fn from_cubic<'a>(
        basis: CubicBasis,
        subdivisions: usize,
        strands: impl IntoIterator<Item = (&'a [DVec3], &'a [f64])>,
    ) -> Self {
        let subdivisions = subdivisions.max(1);
        let polylines: Vec<(Vec<DVec3>, Vec<f64>)> = strands
            .into_iter()
            .map(|(c, r)| {
                let spans: Vec<usize> = match basis {
                    CubicBasis::BSpline if c.len() >= 4 => (0..c.len() - 3).collect(),
                    CubicBasis::Bezier if c.len() >= 4 => (0..(c.len() - 1) / 3).map(|k| 3 * k).collect(),
                    _ => Vec::new(),
                };
                let mut pts = Vec::new();
                let mut rad = Vec::new();
                for (i, &s) in spans.iter().enumerate() {
                    let first = if i == 0 { 0 } else { 1 };
                    for j in first..=subdivisions {
                        let t = j as f64 / subdivisions as f64;
                        let w = cubic_weights(basis, t);
                        pts.push((0..4).map(|m| c[s + m] * w[m]).sum());
                        rad.push((0..4).map(|m| r[s + m] * w[m]).sum());
                    }
                }
                (pts, rad)
            })
            .collect();
        Self::from_polylines(polylines.iter().map(|(p, r)| (p.as_slice(), r.as_slice())))
    }

    fn from_segments(segments: Vec<Segment>, strands: usize) -> Self {
        // Up to ONE_TREE_MAX segments are one tree: the peer scene's 150k segments in clusters of
        // CLUSTER_MAX cost 7.1 % more render instructions (ARCHITECTURE.md, issue 42).
        // Larger sets are built in clusters; beyond DENSE_MIN their segments are one piece each
        // (DENSE_PIECES).
        let (cluster_max, max_pieces) = if segments.len() <= ONE_TREE_MAX {
            (usize::MAX, MAX_PIECES)
        } else if segments.len() <= DENSE_MIN {
            (crate::bvh::CLUSTER_MAX, MAX_PIECES)
        } else {
            (crate::bvh::CLUSTER_MAX, DENSE_PIECES)
        };
        Self::from_segments_in(segments, strands, cluster_max, max_pieces)
    }

    /// [`Self::from_segments`] with BVH clusters of at most `cluster_max` segments, each segment
    /// in at most `max_pieces` pieces.
    fn from_segments_in(segments: Vec<Segment>, strands: usize, cluster_max: usize, max_pieces: usize) -> Self {
        use rayon::prelude::*;
        // Segment `i` as one build record over its whole axis, widened by its reach: a miter
        // ellipse reaches r/cos from the vertex, so the tube lies within that radius of the
        // axis segment (a capsule).
        let axis = |s: &Segment| {
            let (p0, p1) = (s.p0.as_dvec3(), s.p1().as_dvec3());
            let d = (p1 - p0).normalize();
            let cos = s.n0.as_dvec3().dot(d).min(s.n1.as_dvec3().dot(d)).max(MIN_MITER_COS);
            (p0, p1, f64::from(s.radius) / cos)
        };
        let items: Vec<BuildPrim> = (0..segments.len() as u32)
            .into_par_iter()
            .map(|i| {
                let (p0, p1, reach) = axis(&segments[i as usize]);
                BuildPrim::segment(p0, p1, reach, i)
            })
            .collect();
        // In the tree, each segment as pieces of its axis of at most PIECE_IN_RADII radii. A
        // cluster's segments lie anywhere in the set: they are copied GATHER at a time first,
        // in a loop of independent loads whose cache misses overlap, then cut (the cut's
        // arithmetic on each segment as it arrives left one miss in flight at a time; issue 42).
        let pieces = |indices: &[u32], out: &mut Vec<BuildPrim>| {
            let mut near = Vec::with_capacity(GATHER.min(indices.len()));
            for indices in indices.chunks(GATHER) {
                near.clear();
                near.extend(indices.iter().map(|&i| segments[i as usize]));
                for (&i, s) in indices.iter().zip(&near) {
                    let (p0, p1, reach) = axis(s);
                    let k = s.piece_count(max_pieces);
                    let step = (p1 - p0) / k as f64;
                    let mut a = p0;
                    for j in 1..=k {
                        // The last piece ends exactly at the tip.
                        let b = if j == k { p1 } else { p0 + step * j as f64 };
                        out.push(BuildPrim::segment(a, b, reach, i));
                        a = b;
                    }
                }
            }
        };
        let total = segments.iter().map(|s| s.piece_count(max_pieces)).sum();
        let bvh = Bvh::build_grouped_in(items, &pieces, cluster_max, Boxes::Oriented);
        Self { segments, pieces: total, bvh, strands }
    }

    /// Peak bytes per segment of building a `CurveSet` from a `.hair` file's strands, the BVH
    /// included: the strands as `f64` points and radii, the 64-byte segments, up to 8
    /// (`MAX_PIECES`) boxes and build records per segment, and the tree. Measured once, on the
    /// default scene's generated wavy hair (24 segments per strand; 3.1M pieces for 480k
    /// segments, 6.5 of the 8 at most): the maximum RSS of `/usr/bin/time -v fiberlab render
    /// S.toml` at 16×16 pixels and 1 spp, divided by the segments, was 1125, 1170, 1073 and
    /// 1030 bytes with 10k, 40k, 80k and 160k strands (240k–3.84M segments), 1131 with 240k
    /// strands of 8 segments, and 1190 on 1 thread instead of 2 (10k strands) — the whole
    /// process, the generator's ~44 bytes per segment and the hair data included. This
    /// constant is the largest of these, rounded up; the hair data is estimated apart
    /// ([`fiberlab_io::HairHeader::read_bytes`], `fiberlab_procedural::generator::HairParams::estimated_bytes`)
    /// and added, so the estimate stays above what was measured: the default render (512×512,
    /// 1 spp) peaks at 597 MB against 608 MB estimated in all. These figures predate building the
    /// pieces straight into `f32` records (no `f64` boxes) and the clustered build (sets of more
    /// than 2^14 segments — 2^18 until issue 42 — make and build a few clusters' pieces at a time): the 5M-segment head now
    /// peaks at 994 MiB, about 210 bytes per segment, so the constant errs on the safe side; with
    /// the oriented tree and pieces of at most 16 radii (2026-12-03) it peaks at 948–963 MiB.
    pub const BUILD_BYTES_PER_SEGMENT: u64 = 1200;

    /// At most this many segments in one set: the BVH indexes its pieces (up to
    /// 8 per segment) with u32.
    pub const MAX_SEGMENTS: u64 = (u32::MAX as u64 - 1) / MAX_PIECES as u64;

    /// Peak bytes per segment of building a set of more than `DENSE_MIN` segments (one piece
    /// each), as [`Self::BUILD_BYTES_PER_SEGMENT`] but for these: the whole process's maximum
    /// RSS over the segments was 106 bytes on the 5M-segment head (504 MiB) and 102 on the
    /// 15M-segment one (1,466 MiB; `hair generate --style straight --strands 1000000
    /// --segments 15`, the load of the book's "Performance", issue 42): the segments (64), the
    /// records of the tree over clusters (32, freed before the clusters are built) and the tree,
    /// the hair data apart. This constant is 1.5 times that, so that a 15M-segment head
    /// passes the memory check where 2.4 GB are free (at 1,200 bytes it asked for 18 GB).
    pub const DENSE_BUILD_BYTES_PER_SEGMENT: u64 = 160;

    /// Estimated peak bytes of building a set of `segments` segments
    /// ([`Self::BUILD_BYTES_PER_SEGMENT`] each, [`Self::DENSE_BUILD_BYTES_PER_SEGMENT`] above
    /// `DENSE_MIN` segments), in u64; `None` on overflow.
    #[must_use]
    pub fn estimated_bytes(segments: u64) -> Option<u64> {
        let per_segment = if segments > DENSE_MIN as u64 {
            Self::DENSE_BUILD_BYTES_PER_SEGMENT
        } else {
            Self::BUILD_BYTES_PER_SEGMENT
        };
        segments.checked_mul(per_segment)
    }

    /// Number of strands.
    #[must_use]
    pub fn strand_count(&self) -> usize {
        self.strands
    }

    /// Number of tube segments.
    #[must_use]
    pub fn segment_count(&self) -> usize {
        self.segments.len()
    }

    /// Number of BVH pieces (≥ segments; long segments are split).
    #[must_use]
    pub fn piece_count(&self) -> usize {
        self.pieces
    }

    /// Bytes of segment data, BVH nodes and indices.
    #[must_use]
    pub fn bytes(&self) -> usize {
        self.segments.len() * std::mem::size_of::<Segment>() + self.bvh.bytes()
    }

    /// The tree over the segments' pieces (its leaves list segment indices).
    #[must_use]
    pub fn bvh(&self) -> &Bvh {
        &self.bvh
    }

    /// The segments as 16 little-endian words each, the 64-byte record the walks read (for a
    /// GPU): `p0` (3 × `f32` bits), unit `axis` (3), `length`, `radius`, the miter normals `n0`
    /// (3) and `n1` (3), the curve parameters of the two ends (two `u16`, the root-side one in
    /// the low half, in units of 1/65535) and the strand index.
    #[must_use]
    pub fn segment_words(&self) -> Vec<u32> {
        let mut out = Vec::with_capacity(16 * self.segments.len());
        for s in &self.segments {
            let floats = [s.p0.to_array(), s.axis.to_array()].concat();
            out.extend(floats.iter().chain(&[s.length, s.radius]).map(|x| x.to_bits()));
            out.extend([s.n0.to_array(), s.n1.to_array()].concat().iter().map(|x| x.to_bits()));
            out.push(u32::from(s.v[0]) | (u32::from(s.v[1]) << 16));
            out.push(s.strand);
        }
        out
    }

    /// Bounds of all tubes.
    #[must_use]
    pub fn bounds(&self) -> Aabb {
        self.segments.iter().fold(Aabb::EMPTY, |b, s| {
            let r = f64::from(s.radius) / MIN_MITER_COS;
            b.union(Aabb::sphere(s.p0.as_dvec3(), r)).union(Aabb::sphere(s.p1().as_dvec3(), r))
        })
    }

    /// The instruction set of the tree walk and the leaf pre-test.
    #[must_use]
    pub fn simd_level(&self) -> SimdLevel {
        self.bvh.simd_level()
    }

    /// Makes the walks and leaf tests use `level` (every level gives the same results; for
    /// tests and benchmarks).
    pub fn set_simd_level(&mut self, level: SimdLevel) {
        self.bvh.set_simd_level(level);
    }

    /// Nearest tube entry along the ray, through the BVH.
    #[must_use]
    pub fn intersect(&self, ray: &Ray) -> Option<CurveHit> {
        match self.simd_level().avx2_token() {
            Some(k) => k.run(|| self.intersect_in(k, ray)),
            None => self.intersect_in(Portable, ray),
        }
    }

    #[inline(always)]
    fn intersect_in(&self, lanes: impl Lanes, ray: &Ray) -> Option<CurveHit> {
        let mut best: Option<CurveHit> = None;
        let quick = QuickRay::new(ray);
        // Pieces of one segment sit side by side in the tree: skip a segment just tested, and
        // the segment of the nearest hit so far (a tube is entered once).
        let mut last = u32::MAX;
        self.bvh.traverse_leaves_in(lanes, ray, |prims, mut t_max| {
            let mut found = None;
            for seg in self.candidates(lanes, &quick, prims, t_max, &mut last) {
                if best.is_some_and(|b| b.segment == seg) {
                    continue;
                }
                #[cfg(fiberlab_stats)]
                crate::bvh::stats::add(4, 1);
                if let Some(hit) = self.intersect_segment(seg, ray, t_max) {
                    #[cfg(fiberlab_stats)]
                    crate::bvh::stats::add(5, 1);
                    t_max = hit.t;
                    best = Some(hit);
                    found = Some(hit.t);
                }
            }
            found
        });
        best
    }

    /// True when the ray enters any tube within `(t_min, t_max)` (shadow rays).
    #[must_use]
    pub fn occluded(&self, ray: &Ray) -> bool {
        match self.simd_level().avx2_token() {
            Some(k) => k.run(|| self.occluded_in(k, ray)),
            None => self.occluded_in(Portable, ray),
        }
    }

    #[inline(always)]
    fn occluded_in(&self, lanes: impl Lanes, ray: &Ray) -> bool {
        let quick = QuickRay::new(ray);
        let mut last = u32::MAX;
        self.bvh.any_leaf_in(lanes, ray, |prims| {
            self.candidates(lanes, &quick, prims, ray.t_max, &mut last).any(|seg| {
                #[cfg(fiberlab_stats)]
                crate::bvh::stats::add(10, 1);
                let hit = self.intersect_segment(seg, ray, ray.t_max).is_some();
                #[cfg(fiberlab_stats)]
                crate::bvh::stats::add(11, u64::from(hit));
                hit
            })
        })
    }

    /// Calls `each` with every tube entry along the ray within `(t_min, t_max)`, each segment
    /// once, in no particular order (the counting walk of dual scattering).
    pub fn each_entry(&self, ray: &Ray, mut each: impl FnMut(&CurveHit)) {
        self.each_entry_until(ray, |hit| {
            each(hit);
            false
        });
    }

    /// [`CurveSet::each_entry`] that stops as soon as `each` returns true (true then): the
    /// counting walk of dual scattering with its cut-off. The leaves are visited in no order
    /// (the any-hit walk, no sorting of children), so the entries reported before the stop are
    /// an arbitrary subset. Does not allocate once each thread's list of reported segments
    /// has grown.
    pub fn each_entry_until(&self, ray: &Ray, each: impl FnMut(&CurveHit) -> bool) -> bool {
        match self.simd_level().avx2_token() {
            Some(k) => k.run(|| self.each_entry_until_in(k, ray, each)),
            None => self.each_entry_until_in(Portable, ray, each),
        }
    }

    #[inline(always)]
    fn each_entry_until_in(&self, lanes: impl Lanes, ray: &Ray, mut each: impl FnMut(&CurveHit) -> bool) -> bool {
        thread_local! {
            static SEEN: std::cell::Cell<Vec<u32>> = const { std::cell::Cell::new(Vec::new()) };
        }
        let quick = QuickRay::new(ray);
        let mut last = u32::MAX;
        // A segment split into pieces sits in several leaves: remember the ones reported.
        let mut seen = SEEN.take();
        seen.clear();
        let stopped = self.bvh.any_leaf_in(lanes, ray, |prims| {
            for seg in self.candidates(lanes, &quick, prims, ray.t_max, &mut last) {
                if seen.contains(&seg) {
                    continue;
                }
                if let Some(hit) = self.intersect_segment(seg, ray, ray.t_max) {
                    seen.push(seg);
                    if each(&hit) {
                        return true;
                    }
                }
            }
            false
        });
        SEEN.set(seen);
        stopped
    }

    /// Calls `each(p0, p1, radius)` for every segment (axis ends and tube radius).
    pub fn each_segment(&self, mut each: impl FnMut(DVec3, DVec3, f64)) {
        for s in &self.segments {
            each(s.p0.as_dvec3(), s.p1().as_dvec3(), f64::from(s.radius));
        }
    }

    /// The segments of a leaf that pass the `f32` pre-test for hits before `t_max`, in leaf
    /// order, skipping the segment tested just before (`last`, updated).
    #[inline(always)]
    fn candidates<'a>(
        &'a self,
        lanes: impl Lanes,
        quick: &QuickRay,
        prims: &'a [u32],
        t_max: f64,
        last: &mut u32,
    ) -> impl Iterator<Item = u32> + 'a {
        let mut mask = quick.may_hit(lanes, &self.segments, prims, t_max);
        if prims.first() == Some(last) {
            mask &= !1;
        }
        *last = prims.last().copied().unwrap_or(*last);
        prims.iter().enumerate().filter(move |&(k, _)| mask & (1 << k) != 0).map(|(_, &seg)| seg)
    }

    /// Nearest tube entry by testing every segment (the reference for the BVH).
    #[must_use]
    pub fn intersect_brute_force(&self, ray: &Ray) -> Option<CurveHit> {
        let mut best: Option<CurveHit> = None;
        for i in 0..self.segments.len() {
            let t_max = best.map_or(ray.t_max, |b| b.t);
            if let Some(h) = self.intersect_segment(i as u32, ray, t_max) {
                best = Some(h);
            }
        }
        best
    }

    /// Entry of `ray` into segment `index` with `t_min < t < t_max`, in `f64`.
    fn intersect_segment(&self, index: u32, ray: &Ray, t_max: f64) -> Option<CurveHit> {
        let s = &self.segments[index as usize];
        let (p0, a) = (s.p0.as_dvec3(), s.axis.as_dvec3());
        let (r, len) = (f64::from(s.radius), f64::from(s.length));
        let d_perp = ray.d - a * ray.d.dot(a);
        let aa = d_perp.length_squared();
        if aa < 1e-24 {
            return None; // along the axis: grazes the (open) tube end-on
        }
        let oc = ray.o - p0;
        let oc_perp = oc - a * oc.dot(a);
        // Closest approach of the ray to the axis line, computed as a vector for precision.
        let t_c = -oc_perp.dot(d_perp) / aa;
        let q = oc_perp + d_perp * t_c;
        let q2 = q.length_squared();
        if q2 >= r * r {
            return None;
        }
        let t = t_c - ((r * r - q2) / aa).sqrt();
        if !(t > ray.t_min && t < t_max) {
            return None;
        }
        let p = ray.at(t);
        let (n0, n1) = (s.n0.as_dvec3(), s.n1.as_dvec3());
        if (p - p0).dot(n0) < 0.0 || (p - p0 - a * len).dot(n1) > 0.0 {
            return None;
        }
        let frac = ((p - p0).dot(a) / len).clamp(0.0, 1.0);
        let tangent = (n0 * (1.0 - frac) + n1 * frac).normalize();
        let w = -d_perp / aa.sqrt();
        let v = w.cross(a);
        let h = (q.dot(v) / r).clamp(-1.0, 1.0);
        let [v0, v1] = s.v.map(|x| f64::from(x) / f64::from(u16::MAX));
        Some(CurveHit { t, p, tangent, v: v0 + (v1 - v0) * frac, h, radius: r, strand: s.strand, segment: index })
    }
}

/// A ray in `f32` for the conservative pre-test of a leaf's segments ([`Lanes::near_axis`]).
struct QuickRay(RayF32);

impl QuickRay {
    fn new(ray: &Ray) -> Self {
        Self(RayF32::new(ray.o, ray.d, ray.t_min, ray.t_max))
    }

    /// Bit `k` clear only when the ray certainly does not enter the tube of segment `prims[k]`
    /// before `t_max` ([`Lanes::near_axis`]: all of a leaf's segments in one pass of eight
    /// lanes, or in passes of four).
    #[inline(always)]
    fn may_hit(&self, lanes: impl Lanes, segments: &[Segment], prims: &[u32], t_max: f64) -> u32 {
        debug_assert!((1..=8).contains(&prims.len()), "a leaf holds 1 to 8 primitives");
        // A short leaf repeats its last segment; those lanes are masked off.
        let last = prims.len() - 1;
        let ray = RayF32 { t_max: t_max as f32, ..self.0 };
        lanes.near_axis(&ray, |k| segments[prims[k.min(last)] as usize].head(), prims.len())
    }
}

/// Weights of the four control points of a cubic span at parameter `t` ∈ [0, 1].
/// The strands `(number, root point)` in the order of their roots along a Morton (Z-order)
/// curve over the roots' box, 21 bits an axis; equal codes in the order given. Returns the
/// numbers.
fn spatial_order(roots: &[(u32, [f32; 3])]) -> Vec<u32> {
    let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
    for (_, p) in roots {
        for a in 0..3 {
            lo[a] = lo[a].min(p[a]);
            hi[a] = hi[a].max(p[a]);
        }
    }
    const CELLS: f64 = (1u64 << 21) as f64;
    // The bits of `x` (21) spread to every third bit.
    let spread = |x: u64| {
        let mut x = x & 0x1f_ffff;
        x = (x | x << 32) & 0x1f_0000_0000_ffff;
        x = (x | x << 16) & 0x1f_0000_ff00_00ff;
        x = (x | x << 8) & 0x100f_00f0_0f00_f00f;
        x = (x | x << 4) & 0x10c3_0c30_c30c_30c3;
        (x | x << 2) & 0x1249_2492_4924_9249
    };
    let code = |p: &[f32; 3]| {
        (0..3).fold(0u64, |c, a| {
            let extent = f64::from(hi[a]) - f64::from(lo[a]);
            let u = if extent > 0.0 { (f64::from(p[a]) - f64::from(lo[a])) / extent } else { 0.0 };
            c | spread((u * CELLS).clamp(0.0, CELLS - 1.0) as u64) << a
        })
    };
    let mut keyed: Vec<(u64, u32)> = roots.iter().enumerate().map(|(i, (_, p))| (code(p), i as u32)).collect();
    keyed.sort_unstable();
    keyed.iter().map(|&(_, i)| roots[i as usize].0).collect()
}

fn cubic_weights(basis: CubicBasis, t: f64) -> [f64; 4] {
    let s = 1.0 - t;
    match basis {
        CubicBasis::Bezier => [s * s * s, 3.0 * s * s * t, 3.0 * s * t * t, t * t * t],
        CubicBasis::BSpline => [
            s * s * s / 6.0,
            (3.0 * t * t * t - 6.0 * t * t + 4.0) / 6.0,
            (-3.0 * t * t * t + 3.0 * t * t + 3.0 * t + 1.0) / 6.0,
            t * t * t / 6.0,
        ],
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_random::Lcg;
    use proptest::prelude::*;

    fn random_strands(seed: u64, n: usize) -> Vec<(Vec<DVec3>, Vec<f64>)> {
        let mut g = Lcg(seed);
        (0..n)
            .map(|_| {
                let mut p = g.vec() * 2.0 - 1.0;
                let mut dir = (g.vec() - 0.5).normalize();
                let k = 2 + (g.next() * 10.0) as usize;
                let r0 = 0.005 + 0.02 * g.next();
                let mut pts = vec![p];
                let mut rad = vec![r0];
                for j in 1..k {
                    dir = (dir + (g.vec() - 0.5) * 0.8).normalize();
                    p += dir * (0.05 + 0.3 * g.next());
                    pts.push(p);
                    rad.push(r0 * (1.0 - 0.5 * j as f64 / k as f64));
                }
                (pts, rad)
            })
            .collect()
    }

    /// The closest hit and the any-hit query through the tree against testing every segment,
    /// on every instruction set this CPU has (whose hits must be the same, field for field);
    /// returns the number of rays that hit. Overlapping segments can tie: the distance is
    /// compared with brute force, not which of the tied segments is reported.
    fn check_against_brute_force(set: &mut CurveSet, rays: &[Ray], what: &str) -> usize {
        let mut hits = 0;
        let mut first: Option<Vec<Option<CurveHit>>> = None;
        for level in SimdLevel::available() {
            set.set_simd_level(level);
            let found: Vec<Option<CurveHit>> = rays.iter().map(|ray| set.intersect(ray)).collect();
            if let Some(first) = &first {
                assert!(first == &found, "{what}: {} differs from the portable form", level.name());
            }
            hits = 0;
            for (ray, a) in rays.iter().zip(&found) {
                let b = set.intersect_brute_force(ray);
                assert_eq!(a.map(|h| h.t), b.map(|h| h.t), "{what}, {}: ray {ray:?}", level.name());
                assert_eq!(set.occluded(ray), b.is_some(), "{what}, {}: ray {ray:?}", level.name());
                if let Some(h) = b {
                    let short = Ray { t_max: h.t * 0.999_999, ..*ray };
                    assert_eq!(set.occluded(&short), set.intersect_brute_force(&short).is_some());
                }
                hits += usize::from(b.is_some());
            }
            first.get_or_insert(found);
        }
        hits
    }

    #[test]
    fn bvh_agrees_with_brute_force_on_random_scenes() {
        for seed in 0..4 {
            let strands = random_strands(seed, 300);
            let mut set = CurveSet::from_polylines(strands.iter().map(|(p, r)| (p.as_slice(), r.as_slice())));
            assert!(set.bvh.oriented_node_count() > 0, "the test must cover oriented nodes");
            let mut g = Lcg(seed + 100);
            let rays: Vec<Ray> = (0..3000)
                .map(|_| {
                    let o = (g.vec() - 0.5) * 4.0;
                    let target = (g.vec() - 0.5) * 1.5;
                    Ray::new(o, (target - o).normalize())
                })
                .collect();
            let hits = check_against_brute_force(&mut set, &rays, &format!("seed {seed}"));
            assert!(hits > 100, "too few hits ({hits}) to be a test");
        }
    }

    /// `each_entry` reports exactly the segments whose tube the ray enters (every segment tested
    /// on its own), each once.
    #[test]
    fn each_entry_reports_every_entered_tube_once() {
        let strands = random_strands(11, 300);
        let set = CurveSet::from_polylines(strands.iter().map(|(p, r)| (p.as_slice(), r.as_slice())));
        let mut g = Lcg(12);
        let mut entries = 0;
        for _ in 0..2000 {
            let o = (g.vec() - 0.5) * 4.0;
            let ray = Ray::new(o, ((g.vec() - 0.5) * 1.5 - o).normalize());
            let mut reported = Vec::new();
            set.each_entry(&ray, |hit| reported.push(hit.segment));
            reported.sort_unstable();
            let expected: Vec<u32> = (0..set.segment_count() as u32)
                .filter(|&i| set.intersect_segment(i, &ray, ray.t_max).is_some())
                .collect();
            assert_eq!(reported, expected, "{ray:?}");
            entries += expected.len();
        }
        assert!(entries > 500, "too few entries ({entries}) to be a test");
    }

    /// Segment sets that stress the tree and the leaf tests: many parallel strands side by
    /// side (full leaves of near-identical boxes), strands crossing at one point, degenerate
    /// strands (zero-length segments, sharp reversals), and huge and tiny radii in one set;
    /// rays aimed at the strands, along them and at random.
    #[test]
    fn bvh_agrees_with_brute_force_on_adversarial_sets() {
        let mut g = Lcg(77);
        let straight = |p: DVec3, d: DVec3, n: usize, r: f64| {
            let pts: Vec<DVec3> = (0..=n).map(|k| p + d * (k as f64 / n as f64)).collect();
            let rad = vec![r; n + 1];
            (pts, rad)
        };
        let parallel: Vec<_> =
            (0..200).map(|i| straight(DVec3::new(0.004 * f64::from(i), 0.0, 0.0), DVec3::Y, 8, 0.002)).collect();
        let crossing: Vec<_> = (0..100)
            .map(|i| {
                let a = std::f64::consts::PI * f64::from(i) / 100.0;
                let d = DVec3::new(a.cos(), a.sin(), 0.01 * f64::from(i % 7));
                straight(-d, 2.0 * d, 6, 0.003)
            })
            .collect();
        let degenerate: Vec<_> = (0..100)
            .map(|_| {
                let p = (g.vec() - 0.5) * 2.0;
                let q = p + (g.vec() - 0.5) * 0.2;
                // Repeated points, a reversal onto itself, a collinear run.
                (vec![p, p, q, p, q, q, 2.0 * q - p], vec![0.01; 7])
            })
            .collect();
        let radii: Vec<_> = (0..150)
            .map(|i| {
                let r = [1e-7, 1e-4, 0.5, 3.0][i % 4];
                let p = (g.vec() - 0.5) * 10.0;
                straight(p, (g.vec() - 0.5) * 4.0, 3, r)
            })
            .collect();
        // Thin diagonal strands packed a few radii apart: eight pieces a segment, full leaves
        // (the generator's widths on a head, scaled up).
        let dir = DVec3::new(1.0, 0.8, 0.6).normalize();
        let thin: Vec<_> = (0..300)
            .map(|i| {
                let p = DVec3::new(f64::from(i % 20), f64::from(i / 20), 0.0) * 0.0006;
                straight(p, dir * 0.5, 4, 0.0002)
            })
            .collect();
        // Very short and very long diagonal segments mixed: shorter than their radius (one
        // piece) and a thousand radii per piece (eight pieces a segment, the most).
        let lengths: Vec<_> = (0..200)
            .map(|i| {
                let p = (g.vec() - 0.5) * 4.0;
                let d = (g.vec() - 0.5).normalize_or(DVec3::X) * [1e-5, 1e-3, 0.3, 40.0][i % 4];
                straight(p, d, 2, 0.004)
            })
            .collect();
        for (what, strands) in [
            ("lengths", lengths),
            ("parallel", parallel),
            ("crossing", crossing),
            ("degenerate", degenerate),
            ("radii", radii),
            ("thin", thin),
        ] {
            let mut set = CurveSet::from_polylines(strands.iter().map(|(p, r)| (p.as_slice(), r.as_slice())));
            let mut rays = Vec::new();
            for k in 0..3000 {
                let (pts, _) = &strands[k % strands.len()];
                let target = pts[k % pts.len()] + (g.vec() - 0.5) * 0.01;
                let o = match k % 3 {
                    0 => target + (g.vec() - 0.5).normalize() * 3.0,
                    // Along the strand's own segment (parallel to its axis).
                    1 => target - (pts[1] - pts[0]).normalize_or(DVec3::X) * 2.0,
                    _ => (g.vec() - 0.5) * 12.0,
                };
                if let Some(d) = (target - o).try_normalize() {
                    rays.push(Ray::new(o, d));
                }
            }
            let hits = check_against_brute_force(&mut set, &rays, what);
            assert!(hits > 100, "{what}: too few hits ({hits}) to be a test");
        }
    }

    /// The tube set of `strands` with its tree built in clusters of at most `cluster_max`
    /// segments, each segment in at most `max_pieces` pieces.
    fn clustered(strands: &[(Vec<DVec3>, Vec<f64>)], cluster_max: usize, max_pieces: usize) -> CurveSet {
        let (segments, count) = CurveSet::segments_of(strands.iter().map(|(p, r)| (p.as_slice(), r.as_slice())), 0);
        CurveSet::from_segments_in(segments, count, cluster_max, max_pieces)
    }

    /// Closest hit and any hit of `set` against brute force for `rays` rays from a box of
    /// half-size `reach` toward points of a box of half-size `aim` around `center`; returns the
    /// number of hits.
    fn check_clustered_against_brute_force(
        set: &mut CurveSet,
        seed: u64,
        rays: usize,
        reach: f64,
        (center, aim): (DVec3, f64),
    ) -> usize {
        let mut hits = 0;
        for level in SimdLevel::available() {
            set.set_simd_level(level);
            hits = check_clustered_at(set, seed, rays, reach, (center, aim));
        }
        hits
    }

    fn check_clustered_at(set: &CurveSet, seed: u64, rays: usize, reach: f64, (center, aim): (DVec3, f64)) -> usize {
        let mut g = Lcg(seed);
        let mut hits = 0;
        for _ in 0..rays {
            let o = (g.vec() - 0.5) * 2.0 * reach;
            let target = center + (g.vec() - 0.5) * 2.0 * aim;
            let ray = Ray::new(o, (target - o).normalize());
            let b = set.intersect_brute_force(&ray);
            assert_eq!(set.intersect(&ray).map(|h| h.t), b.map(|h| h.t), "seed {seed} ray {ray:?}");
            assert_eq!(set.occluded(&ray), b.is_some(), "seed {seed} ray {ray:?}");
            if let Some(h) = b {
                let short = Ray { t_max: h.t * 0.999_999, ..ray };
                assert_eq!(set.occluded(&short), set.intersect_brute_force(&short).is_some());
            }
            hits += usize::from(b.is_some());
        }
        hits
    }

    /// The clustered build (a tree over the segments' boxes down to clusters, then one over
    /// each cluster's pieces) against brute force, on hair-like and adversarial sets.
    #[test]
    fn clustered_bvh_agrees_with_brute_force_on_adversarial_sets() {
        let mut g = Lcg(7);
        let line = |a: DVec3, b: DVec3, r: f64| (vec![a, b], vec![r, r]);
        type Strands = Vec<(Vec<DVec3>, Vec<f64>)>;
        // Each set with the box that its rays aim at.
        let mut sets: Vec<(&str, Strands, (DVec3, f64))> =
            vec![("hair-like", random_strands(11, 300), (DVec3::ZERO, 0.8))];
        // Parallel diagonal strands packed closer than their radii.
        let dir = DVec3::new(1.0, 0.7, 0.4).normalize();
        sets.push((
            "parallel",
            (0..400)
                .map(|i| {
                    let off = DVec3::new((i % 20) as f64, (i / 20) as f64, 0.0) * 0.015 - 0.15;
                    let (a, b) = (off - dir, off + dir);
                    (vec![a, (a + b) * 0.5 + off * 0.1, b], vec![0.01; 3])
                })
                .collect(),
            (DVec3::ZERO, 0.3),
        ));
        // Strands crossing near one point in random directions.
        sets.push((
            "crossing",
            (0..400)
                .map(|_| {
                    let d = (g.vec() - 0.5).normalize();
                    let c = (g.vec() - 0.5) * 0.02;
                    line(c - d, c + d, 0.004)
                })
                .collect(),
            (DVec3::ZERO, 0.05),
        ));
        // Coincident copies of one segment, zero-length segments and repeated points.
        let p = DVec3::new(0.1, -0.2, 0.3);
        let mut degenerate: Vec<_> = (0..200).map(|_| line(p, p + DVec3::new(0.3, 0.2, 0.1), 0.02)).collect();
        degenerate.extend((0..100).map(|_| (vec![p, p, p + DVec3::X * 0.2, p + DVec3::X * 0.2], vec![0.01; 4])));
        degenerate.extend((0..100).map(|i| line(DVec3::splat(i as f64 * 1e-3), DVec3::splat(i as f64 * 1e-3), 0.05)));
        sets.push(("degenerate", degenerate, (p + DVec3::new(0.15, 0.1, 0.05), 0.12)));
        // Huge and tiny radii mixed.
        sets.push((
            "radii",
            (0..400)
                .map(|i| {
                    let a = (g.vec() - 0.5) * 2.0;
                    let b = a + (g.vec() - 0.5) * 0.8;
                    line(a, b, if i % 7 == 0 { 0.3 } else { 1e-4 + 1e-3 * g.next() })
                })
                .collect(),
            (DVec3::ZERO, 0.8),
        ));
        for (name, strands, aim) in &sets {
            // Dense heads' one piece a segment (DENSE_PIECES) and sparse sets' pieces.
            for (cluster_max, max_pieces) in [
                (2, MAX_PIECES),
                (5, MAX_PIECES),
                (64, MAX_PIECES),
                (usize::MAX, MAX_PIECES),
                (5, 1),
                (64, 1),
                (usize::MAX, 1),
            ] {
                let mut set = clustered(strands, cluster_max, max_pieces);
                let seed = cluster_max as u64 % 1000 + max_pieces as u64;
                let hits = check_clustered_against_brute_force(&mut set, seed, 2000, 2.0, *aim);
                assert!(hits > 100, "{name}, {max_pieces} pieces: too few hits ({hits}) to be a test");
            }
        }
    }

    /// Independent check of t, h and the frame against a single straight cylinder computed in
    /// closed form in the cylinder's own coordinates.
    #[test]
    fn straight_cylinder_hit_offset_and_frame() {
        let pts = [DVec3::new(0.0, -5.0, 0.0), DVec3::new(0.0, 5.0, 0.0)];
        let rad = [0.5, 0.5];
        let set = CurveSet::from_polylines([(&pts[..], &rad[..])]);
        // Ray along −z at x = 0.3: enters at z = sqrt(0.25 − 0.09) = 0.4.
        let ray = Ray::new(DVec3::new(0.3, 1.0, 10.0), DVec3::new(0.0, 0.0, -1.0));
        let hit = set.intersect(&ray).unwrap();
        assert!((hit.t - 9.6).abs() < 1e-12);
        assert!((hit.v - 0.6).abs() < 1e-6);
        let f = hit.frame(ray.d);
        assert!((f.u - DVec3::Y).length() < 1e-12);
        assert!((f.w - DVec3::Z).length() < 1e-12, "w toward the viewer");
        // v = w × u = z × y = −x, so an offset toward +x is a negative h.
        assert!((hit.h + 0.6).abs() < 1e-12, "h = {}", hit.h);
        let wo = f.to_local(-ray.d);
        assert!(wo.y.abs() < 1e-12 && wo.z > 0.0);
    }

    proptest! {
        /// Reflecting the ray off the true cylinder normal at the hit gives the R-path azimuth
        /// φ_i − φ_o = −2 asin h (`docs/theory/conventions.md`, "Exit azimuth", in pbrt's convention) and θ_i = −θ_o.
        #[test]
        fn mirror_reflection_matches_phi_of_h(
            ox in -1.0f64..1.0, oz in -1.0f64..1.0, dy in -0.9f64..0.9, angle in 0.0f64..std::f64::consts::TAU, off in -0.99f64..0.99
        ) {
            // Positions are stored as f32: use representable coordinates for the reference axis.
            let (ox, oz) = (f64::from(ox as f32), f64::from(oz as f32));
            let pts = [DVec3::new(ox, -50.0, oz), DVec3::new(ox, 50.0, oz)];
            let rad = [0.2, 0.2];
            let set = CurveSet::from_polylines([(&pts[..], &rad[..])]);
            let dir_perp = DVec3::new(angle.cos(), 0.0, angle.sin());
            let d = (dir_perp * (1.0 - dy * dy).sqrt() + DVec3::Y * dy).normalize();
            let side = DVec3::Y.cross(dir_perp);
            let o = DVec3::new(ox, 0.0, oz) - d * 5.0 + side * (off * 0.2);
            let ray = Ray::new(o, d);
            let hit = set.intersect(&ray).unwrap();
            let axis_point = DVec3::new(ox, hit.p.y, oz);
            let n = (hit.p - axis_point).normalize();
            let wi = d - 2.0 * d.dot(n) * n;
            let f = hit.frame(d);
            let (wi_l, wo_l) = (f.to_local(wi), f.to_local(-d));
            let phi_i = wi_l.z.atan2(wi_l.y);
            let phi_o = wo_l.z.atan2(wo_l.y);
            let expected = -2.0 * hit.h.asin();
            prop_assert!((fiberlab_math::wrap_pi(phi_i - phi_o - expected)).abs() < 1e-7);
            prop_assert!((wi_l.x + wo_l.x).abs() < 1e-9);
            // Radii are stored as f32: relative error ~1e-8.
            prop_assert!((hit.h.abs() - off.abs()).abs() < 1e-6);
        }
    }

    #[test]
    fn degenerate_strands_are_skipped() {
        let one = [DVec3::ZERO];
        let dup = [DVec3::ZERO, DVec3::ZERO, DVec3::X];
        let nan = [DVec3::ZERO, DVec3::splat(f64::NAN)];
        let ok = [DVec3::Y, DVec3::Y * 2.0];
        let set = CurveSet::from_polylines([
            (&one[..], &[0.1][..]),
            (&dup[..], &[0.1; 3][..]),
            (&nan[..], &[0.1; 2][..]),
            (&ok[..], &[0.0; 2][..]),
        ]);
        // The duplicate point's zero-length segment and the zero-radius strand are dropped.
        assert_eq!(set.segment_count(), 1);
        assert!(set.intersect(&Ray::new(DVec3::new(0.5, 0.0, 5.0), -DVec3::Z)).is_some());
    }

    /// The roots' Morton order: the corners of a cube in the order of x + 2y + 4z whatever the
    /// order given, and roots of equal code in the order given.
    #[test]
    fn spatial_order_follows_the_morton_curve() {
        let corner = |c: u32| [(c & 1) as f32, (c >> 1 & 1) as f32, (c >> 2 & 1) as f32];
        let mut roots: Vec<(u32, [f32; 3])> = [3u32, 6, 0, 5, 7, 1, 2, 4].iter().map(|&c| (7 - c, corner(c))).collect();
        roots.push((100, corner(5)));
        assert_eq!(spatial_order(&roots), [7, 6, 5, 4, 3, 2, 100, 1, 0]);
    }

    /// A set of more than `ONE_TREE_MAX` segments from `f32` strands: the segments of the
    /// strands in file order, field for field, each with its strand's number in file order
    /// (skipped strands not counted), but stored strand by strand in the roots' spatial order.
    #[test]
    fn large_sets_keep_their_strand_numbers_in_spatial_order() {
        let mut strands = random_strands(17, 55_000);
        strands[10].0[1] = DVec3::NAN;
        strands[20].0.truncate(1);
        strands[20].1.truncate(1);
        let points: Vec<[f32; 3]> =
            strands.iter().flat_map(|(p, _)| p.iter().map(|q| q.as_vec3().to_array())).collect();
        let radii: Vec<f64> = strands.iter().flat_map(|(_, r)| r.iter().map(|&x| f64::from(x as f32))).collect();
        let mut start = 0;
        let ranges: Vec<_> = strands
            .iter()
            .map(|(p, _)| {
                start += p.len();
                start - p.len()..start
            })
            .collect();
        let tubes = CurveSet::tubes_of_f32_strands(&points, &ranges, |i| radii[i]);
        let widened: Vec<Vec<DVec3>> =
            ranges.iter().map(|r| points[r.clone()].iter().map(|p| Vec3::from(*p).as_dvec3()).collect()).collect();
        let (expected, count) =
            CurveSet::segments_of(widened.iter().zip(&ranges).map(|(p, r)| (&p[..], &radii[r.clone()])), 0);
        assert!(expected.len() > ONE_TREE_MAX, "{} segments", expected.len());
        assert_eq!((tubes.strands, tubes.segments.len()), (count, expected.len()));
        let fields = |s: &Segment| {
            (
                s.strand,
                s.v,
                s.head().map(f32::to_bits),
                s.n0.to_array().map(f32::to_bits),
                s.n1.to_array().map(f32::to_bits),
            )
        };
        let mut got: Vec<_> = tubes.segments.iter().map(fields).collect();
        let stored: Vec<u32> = got.iter().map(|f| f.0).collect();
        got.sort_unstable();
        assert!(got == expected.iter().map(fields).collect::<Vec<_>>(), "the same segments");
        // Strand by strand, not in file order, and consecutive strands' roots near each other.
        let mut runs = stored.clone();
        runs.dedup();
        assert_eq!(runs.len(), count, "each strand's segments are consecutive");
        assert!(!runs.is_sorted(), "spatial order, not file order");
        let roots: Vec<Vec3> = {
            let mut first = vec![Vec3::ZERO; count];
            for s in expected.iter().rev() {
                first[s.strand as usize] = s.p0;
            }
            first
        };
        let mean_step = |order: &[u32]| {
            order.windows(2).map(|w| roots[w[0] as usize].distance(roots[w[1] as usize])).sum::<f32>()
                / order.len() as f32
        };
        let file_order: Vec<u32> = (0..count as u32).collect();
        assert!(mean_step(&runs) < 0.2 * mean_step(&file_order), "{} {}", mean_step(&runs), mean_step(&file_order));
    }

    #[test]
    fn mitered_joint_is_watertight() {
        // A bent strand; rays aimed at the outer side of the joint must hit.
        let pts = [DVec3::new(0.0, -1.0, 0.0), DVec3::ZERO, DVec3::new(1.0, 1.0, 0.0).normalize()];
        let rad = [0.1; 3];
        let set = CurveSet::from_polylines([(&pts[..], &rad[..])]);
        let outer = DVec3::new(-1.0, 0.41, 0.0).normalize() * 0.099;
        for k in 0..50 {
            let z = -0.09 + 0.18 * k as f64 / 49.0;
            let target = DVec3::new(outer.x, outer.y, z * 0.3);
            let o = target + DVec3::new(-3.0, 0.0, 0.0);
            let ray = Ray::new(o, (target - o).normalize());
            assert!(set.intersect(&ray).is_some(), "gap at z = {z}");
        }
    }

    #[test]
    fn cubic_curves_interpolate_like_the_basis() {
        // A Bézier with collinear control points is the straight segment itself.
        let c = [DVec3::ZERO, DVec3::X, DVec3::X * 2.0, DVec3::X * 3.0];
        let r = [0.1; 4];
        let set = CurveSet::from_cubic(CubicBasis::Bezier, 8, [(&c[..], &r[..])]);
        assert_eq!(set.segment_count(), 8);
        let hit = set.intersect(&Ray::new(DVec3::new(1.5, 0.0, 5.0), -DVec3::Z)).unwrap();
        assert!((hit.t - 4.9).abs() < 1e-6);
        // B-spline weights sum to one (partition of unity) for any t.
        for k in 0..=10 {
            let w = cubic_weights(CubicBasis::BSpline, k as f64 / 10.0);
            assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-14);
        }
    }
}
