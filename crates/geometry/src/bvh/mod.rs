//! Rays, axis-aligned boxes and a bounding volume hierarchy (binned SAH build), with nodes
//! that box their children along the world axes or, for hair, along each child's own strands.
//!
//! The hierarchy is generic: it is built over build records — boxes, or segments with a reach
//! around them ([`BuildPrim`]) — and reports, during traversal, the indices of the records whose
//! leaves the ray reaches; the caller intersects the actual primitive and shrinks the ray's
//! `t_max`. Primitive indices are `u32`.
//!
//! Build: top-down binary tree by the surface-area heuristic with traversal cost 1 and
//! intersection cost 1 (Wald 2007, "On fast construction of SAH-based bounding volume
//! hierarchies"): 16 centroid bins on each of the three axes in one pass over the records (the
//! best of the three; binning the widest axis alone cost 2 % more render instructions on the
//! peer scene). Leaves hold at most [`MAX_LEAF`] primitives; in trees of segments, subtrees of at
//! most that many are not split ([`SEGMENT_MIN_LEAF`]). Large subtrees are built in
//! parallel (rayon); the tree is the same for any thread count.
//!
//! Layout: the binary tree is collapsed into an 8-wide tree (each node pulls up the children of
//! its largest-area interior children until it has eight; Wald et al. 2008, "Getting rid of
//! packets"). A node is one of two kinds, chosen per node by the surface-area heuristic
//! ([`CollapseInput::oriented_plan`]):
//! * axis-aligned, two 64-byte cache lines holding its eight child boxes quantized to 8 bits on
//!   the node's grid, rounded outward, as structure of arrays, so one ray tests all eight with
//!   the same instructions (two halves of four `f32` lanes, or eight AVX2 lanes where the CPU
//!   has them: [`crate::simd`]);
//! * oriented (module [`oriented`], five cache lines), where each child is boxed in its own
//!   frame, fitted to its segments: the ray is rotated per child in the same eight lanes (Woop
//!   et al. 2014, "Exploiting Local Orientation Similarity for Efficient Ray Traversal of Hair
//!   and Fur"). It is made where boxing the children each in its best frame (its own or the
//!   world's) lowers their `Σ n A` below [`ORIENTED_NODE_GAIN`] of the axis-aligned boxes'.
//!
//! Traversal visits the hit children nearest first and hands the caller a leaf at a time.
//!
//! Why eight: a walk's cost is per-visit control (ordering the hit children, stack traffic),
//! and eight children per node cut the visits by a third against four (peer scene: 25.1 → 16.7
//! per closest-hit ray, 19.7 → 13.4 per shadow ray; 19 % fewer instructions in the render, same
//! image). Most visits hit one or two children, so the closest-hit walk orders only the hit ones.
//! Near the leaves the greedy collapse would leave nodes partly filled (node memory +30 %
//! against four); instead, a child subtree that holds at most [`MAX_LEAF`] primitives (they
//! are contiguous) becomes one leaf over them rather than a mostly empty node. A leaf's
//! segments are tested eight at a time anyway, so this costs no test: segments + tree of the
//! default head 243.9 → 137.4 bytes per segment (4-wide: 204.8), 3 % fewer render
//! instructions on the peer scene, the same image.

mod flat;
mod oriented;
pub use flat::FlatBvh;

/// Walk counters for measurements (`RUSTFLAGS="--cfg fiberlab_stats"`; printed at exit).
#[cfg(fiberlab_stats)]
#[allow(missing_docs)]
pub mod stats {
    use std::sync::atomic::{AtomicU64, Ordering::Relaxed};
    pub static C: [AtomicU64; 12] = [const { AtomicU64::new(0) }; 12];
    pub const NAMES: [&str; 12] = [
        "closest rays",
        "closest aabb visits",
        "closest obb visits",
        "closest leaves",
        "closest candidates",
        "closest exact hits",
        "any rays",
        "any aabb visits",
        "any obb visits",
        "any leaves",
        "any candidates",
        "any exact hits",
    ];
    #[inline(always)]
    pub fn add(i: usize, n: u64) {
        C[i].fetch_add(n, Relaxed);
    }
    pub fn print() {
        let v: Vec<u64> = C.iter().map(|c| c.load(Relaxed)).collect();
        for (k, n) in NAMES.iter().enumerate() {
            let per = if k < 6 { v[0] } else { v[6] };
            eprintln!("{n:>22}: {:>12} ({:.2} per ray)", v[k], v[k] as f64 / per.max(1) as f64);
        }
    }
}

use crate::ray::Ray;
use crate::simd::{Lanes, Portable, RowChoice, SimdLevel, SlabTerms};
use fiberlab_math::DVec3;
use glam::{Vec3, Vec3A, Vec4};
use oriented::{OrientedChild, OrientedNode};

/// An axis-aligned box; the empty box has `min > max`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    /// Lower corner.
    pub min: DVec3,
    /// Upper corner.
    pub max: DVec3,
}

impl Aabb {
    /// The empty box (identity of [`Aabb::union`]).
    pub const EMPTY: Self = Self { min: DVec3::INFINITY, max: DVec3::NEG_INFINITY };

    /// The box around a sphere.
    #[must_use]
    pub fn sphere(c: DVec3, r: f64) -> Self {
        Self { min: c - DVec3::splat(r), max: c + DVec3::splat(r) }
    }

    /// The box around one point.
    #[must_use]
    pub fn point(p: DVec3) -> Self {
        Self { min: p, max: p }
    }

    /// Smallest box containing both.
    #[must_use]
    pub fn union(self, o: Self) -> Self {
        Self { min: self.min.min(o.min), max: self.max.max(o.max) }
    }
}

/// Subtrees with at least this many primitives on both sides are built in parallel.
const PARALLEL_BUILD_MIN: usize = 20_000;

/// Makes room in `v` for twice the `expected` final length (a function of its length now)
/// when it has room for less than that (the build of [`Bvh::build_clustered`]: each growth of
/// an over-aligned vector is a copy).
fn make_room<T>(v: &mut Vec<T>, expected: impl Fn(usize) -> usize) {
    let expected = expected(v.len());
    if v.capacity() < expected {
        v.reserve_exact(2 * expected - v.len());
    }
}

/// Most primitives in one leaf.
pub const MAX_LEAF: usize = 8;

/// A binary build node: an outward-rounded `f32` box; interior nodes have `count == 0`, their
/// first child follows them and `offset` is the second child; leaves list `count` primitives
/// from `offset`.
/// The box is stored as two `Vec3` (32 bytes a node; the build's arithmetic uses `Vec3A`).
#[derive(Clone, Copy, Debug)]
struct Node {
    min: Vec3,
    offset: u32,
    max: Vec3,
    count: u32,
}

impl Node {
    fn new(b: FBox, offset: u32, count: u32) -> Self {
        Self { min: b.min.into(), offset, max: b.max.into(), count }
    }

    fn bounds(&self) -> FBox {
        FBox { min: self.min.into(), max: self.max.into() }
    }
}

/// Children per wide node.
const WIDTH: usize = 8;

/// An 8-wide node in two 64-byte cache lines. Child boxes are quantized to 8 bits per
/// coordinate on the node's grid, rounded outward: child `k`'s lower corner on `axis` is
/// `origin[axis] + q[axis][k]·scale[axis]`, its upper corner uses `q[3 + axis][k]` (every
/// decoded box contains the exact one; the build checks this with the traversal's arithmetic).
/// `origin` and `scale` have a fourth lane 0 (one load each). `child[k]` is a [`ChildRef`];
/// bit `k` of `used` is set when slot `k` holds a child (its reference is not [`EMPTY_REF`]).
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(64))]
struct WideNode {
    origin: [f32; 4],
    scale: [f32; 4],
    q: [[u8; WIDTH]; 6],
    child: [u32; WIDTH],
    used: u32,
}

const _: () = assert!(std::mem::size_of::<WideNode>() == 128, "a wide node is two cache lines");

/// A child reference packed in a `u32`: the top 4 bits hold the leaf size (0: axis-aligned
/// interior node, [`ORIENTED`]: oriented interior node, [`EMPTY_SLOT`]: unused slot), the low 28
/// bits the node index (in the list of its kind) or the leaf's first primitive.
struct ChildRef;

/// Leaf-size value of an unused child slot.
const EMPTY_SLOT: u32 = 15;
/// Leaf-size value of a reference to an oriented node ([`OrientedNode`]).
const ORIENTED: u32 = 14;
const _: () = assert!((MAX_LEAF as u32) < ORIENTED, "leaf sizes must fit below ORIENTED");
/// The whole reference of an unused slot (leaf size [`EMPTY_SLOT`], index 0).
const EMPTY_REF: u32 = EMPTY_SLOT << 28;
/// Primitive offsets and node indices must fit below this.
const MAX_REF: u32 = 1 << 28;

impl ChildRef {
    fn pack(count: u32, index: u32) -> u32 {
        assert!(index < MAX_REF, "BVH too large: {index} ≥ 2^28 primitives or nodes");
        debug_assert!(count < EMPTY_SLOT, "leaf of {count} primitives");
        (count << 28) | index
    }

    #[inline(always)]
    fn count(r: u32) -> u32 {
        r >> 28
    }

    #[inline(always)]
    fn index(r: u32) -> u32 {
        r & (MAX_REF - 1)
    }

    /// True for a reference to an interior node of either kind.
    #[inline(always)]
    fn is_node(r: u32) -> bool {
        let c = Self::count(r);
        c == 0 || c == ORIENTED
    }

    /// `r` with node indices moved by `nodes` (axis-aligned) or `oriented`, and leaves' first
    /// primitives by `prims` (a subtree numbered from 0 appended behind others).
    fn shift(r: u32, nodes: u32, oriented: u32, prims: u32) -> u32 {
        match Self::count(r) {
            EMPTY_SLOT => r,
            0 => Self::pack(0, Self::index(r) + nodes),
            ORIENTED => Self::pack(ORIENTED, Self::index(r) + oriented),
            n => Self::pack(n, Self::index(r) + prims),
        }
    }
}

/// The wide nodes of a tree, of both kinds.
#[derive(Clone, Debug, Default, PartialEq)]
struct WideNodes {
    aabb: Vec<WideNode>,
    oriented: Vec<OrientedNode>,
}

impl WideNodes {
    /// Appends `other`, whose node references are numbered from 0 among its own nodes and whose
    /// leaves start at primitive `prims` less than their place here; returns how a reference of
    /// `other` is moved ([`ChildRef::shift`]'s arguments).
    fn append(&mut self, other: WideNodes, prims: u32) -> (u32, u32, u32) {
        let shift = (self.aabb.len() as u32, self.oriented.len() as u32, prims);
        let moved = |c: &mut [u32; WIDTH]| *c = c.map(|r| ChildRef::shift(r, shift.0, shift.1, shift.2));
        self.aabb.extend(other.aabb.into_iter().map(|mut n| {
            moved(&mut n.child);
            n
        }));
        self.oriented.extend(other.oriented.into_iter().map(|mut n| {
            moved(&mut n.child);
            n
        }));
        shift
    }

    fn bytes(&self) -> usize {
        self.aabb.len() * std::mem::size_of::<WideNode>() + self.oriented.len() * std::mem::size_of::<OrientedNode>()
    }
}

/// A pending subtree on the traversal stack: its entry distance (`f32` bits, ≥ 0, so the
/// integer order is the distance order) above its [`ChildRef`], in one `u64`.
#[derive(Clone, Copy, Default)]
struct Pending(u64);

impl Pending {
    #[inline(always)]
    fn new(child: u32, t: f32) -> Self {
        Self((u64::from(t.max(0.0).to_bits()) << 32) | u64::from(child))
    }

    #[inline(always)]
    fn child(self) -> u32 {
        self.0 as u32
    }

    #[inline(always)]
    fn t(self) -> f32 {
        f32::from_bits((self.0 >> 32) as u32)
    }
}

/// A traversal stack that can push conditionally without a branch.
#[derive(Default)]
struct Stack {
    items: Vec<u64>,
    len: usize,
}

impl Stack {
    /// Makes room for `n` more pushes.
    #[inline(always)]
    fn reserve(&mut self, n: usize) {
        if self.len + n > self.items.len() {
            self.items.resize(2 * self.items.len() + n + 16, 0);
        }
    }

    /// Pushes `p` when `keep` (after [`Stack::reserve`]).
    #[inline(always)]
    fn push_if(&mut self, p: Pending, keep: bool) {
        self.items[self.len] = p.0;
        self.len += usize::from(keep);
    }

    #[inline(always)]
    fn push(&mut self, p: Pending) {
        self.reserve(1);
        self.push_if(p, true);
    }

    #[inline(always)]
    fn pop(&mut self) -> Option<Pending> {
        self.len = self.len.checked_sub(1)?;
        Some(Pending(self.items[self.len]))
    }
}

/// A bounding volume hierarchy over boxes.
#[derive(Clone, Debug)]
pub struct Bvh {
    nodes: WideNodes,
    /// The root's [`ChildRef`] ([`EMPTY_REF`] for an empty tree).
    root: u32,
    prims: Vec<u32>,
    /// The instruction set of the node tests ([`SimdLevel::best`] when built).
    simd: SimdLevel,
}

impl Default for Bvh {
    fn default() -> Self {
        Self { nodes: WideNodes::default(), root: EMPTY_REF, prims: Vec::new(), simd: SimdLevel::best() }
    }
}

fn round_down(x: f64) -> f32 {
    let f = x as f32;
    if f64::from(f) > x { f.next_down() } else { f }
}

fn round_up(x: f64) -> f32 {
    let f = x as f32;
    if f64::from(f) < x { f.next_up() } else { f }
}

/// A primitive during the build: a segment `p0 → p1` in `f32` with a reach around it (every
/// point of the primitive lies within `reach` of the segment, the rounding of the `f32` values
/// and of the box arithmetic included), and the index that traversal reports for it. A box is
/// the segment from its lower to its upper corner with no reach. Its axis-aligned box is that of
/// the two end balls; oriented boxes ([`oriented`]) follow the segment. Two SIMD lanes of four:
/// `a` = (`p0`, reach), `b` = (`p1`, index as `f32` bits, never computed with). The records
/// themselves are partitioned (sequential memory traffic, no indirection).
#[derive(Clone, Copy, Debug)]
pub struct BuildPrim {
    a: Vec4,
    b: Vec4,
}

impl BuildPrim {
    /// The record of box `b`, rounded outward to `f32`, reported as `index`.
    #[must_use]
    pub fn new(b: &Aabb, index: u32) -> Self {
        let round = |v: DVec3, f: fn(f64) -> f32| Vec3::new(f(v.x), f(v.y), f(v.z));
        Self::of(round(b.min, round_down), round(b.max, round_up), 0.0, index)
    }

    /// The record of everything within `reach` of the segment `p0 → p1`, reported as `index`.
    /// The reach is enlarged to cover rounding the ends to `f32` and the `f32` box arithmetic
    /// (a few ulps of the coordinates), and by a relative 10⁻⁶.
    #[must_use]
    pub fn segment(p0: DVec3, p1: DVec3, reach: f64, index: u32) -> Self {
        let m = p0.abs().max_element().max(p1.abs().max_element());
        let reach = reach * (1.0 + 1e-6) + 4.0 * f64::from(f32::EPSILON) * (m + reach);
        Self::of(p0.as_vec3(), p1.as_vec3(), round_up(reach), index)
    }

    fn of(p0: Vec3, p1: Vec3, reach: f32, index: u32) -> Self {
        Self { a: p0.extend(reach), b: p1.extend(f32::from_bits(index)) }
    }

    /// The index traversal reports.
    #[inline(always)]
    fn index(&self) -> u32 {
        self.b.w.to_bits()
    }

    #[inline(always)]
    fn p0(&self) -> Vec3A {
        Vec3A::from_vec4(self.a)
    }

    #[inline(always)]
    fn p1(&self) -> Vec3A {
        Vec3A::from_vec4(self.b)
    }

    #[inline(always)]
    fn reach(&self) -> f32 {
        self.a.w
    }

    /// Lower corner of the axis-aligned box.
    #[inline(always)]
    fn min(&self) -> Vec3A {
        self.p0().min(self.p1()) - Vec3A::splat(self.reach())
    }

    /// Upper corner of the axis-aligned box.
    #[inline(always)]
    fn max(&self) -> Vec3A {
        self.p0().max(self.p1()) + Vec3A::splat(self.reach())
    }

    #[inline(always)]
    fn centroid(&self) -> Vec3A {
        0.5 * (self.p0() + self.p1())
    }
}

/// An `f32` box for the build.
#[derive(Clone, Copy, Debug)]
struct FBox {
    min: Vec3A,
    max: Vec3A,
}

impl FBox {
    const EMPTY: Self = Self { min: Vec3A::INFINITY, max: Vec3A::NEG_INFINITY };

    #[inline(always)]
    fn grow(&mut self, min: Vec3A, max: Vec3A) {
        self.min = self.min.min(min);
        self.max = self.max.max(max);
    }

    #[inline(always)]
    fn union(self, o: Self) -> Self {
        Self { min: self.min.min(o.min), max: self.max.max(o.max) }
    }

    /// Half the surface area (0 for the empty box).
    fn half_area(&self) -> f32 {
        let e = (self.max - self.min).max(Vec3A::ZERO);
        e.x * e.y + e.y * e.z + e.z * e.x
    }

    /// Bounds and centroid bounds of the records.
    fn of(prims: &[BuildPrim]) -> (Self, Self) {
        let (mut b, mut c) = (Self::EMPTY, Self::EMPTY);
        for p in prims {
            b.grow(p.min(), p.max());
            let m = p.centroid();
            c.grow(m, m);
        }
        (b, c)
    }
}

struct Builder {
    nodes: Vec<Node>,
    /// Subtrees of at most this many records are leaves without a split: 2 (boxes), [`MAX_LEAF`]
    /// (segments: [`SEGMENT_MIN_LEAF`]), or the cluster size for the tree over clusters
    /// ([`Bvh::build_grouped`]).
    min_leaf: usize,
    /// Most records in one leaf: [`MAX_LEAF`], or the cluster size.
    max_leaf: usize,
}

/// Centroid bins per axis of the binned SAH build.
const BINS: usize = 16;

/// The bin of a record whose centroid is `x` bins from the first bin's start: `x` truncated,
/// 0 for NaN and below, at most the last bin. The same as `(x as usize).min(BINS − 1)` for every
/// `x`, in fewer instructions (a conversion to `i32` saturates with a few selects, one to `usize`
/// with many more): the binned build converts each record's centroid three times per level to
/// bin it and once to partition it (5.3 % of the load's instructions on the thin 10,000-strand
/// head; its CPU time did not change measurably).
#[inline(always)]
fn bin_of(x: f32) -> usize {
    (x as i32).clamp(0, BINS as i32 - 1) as usize
}

/// A split of a node's records found by binning: records whose centroid falls in a bin before
/// `bin` along `axis` go left; the two sides' boxes (their centroid boxes are made while the
/// records are partitioned: [`Split::partition`]).
#[derive(Clone, Copy, Debug)]
struct Split {
    /// `Σ n A` over both sides.
    cost: f32,
    axis: usize,
    bin: usize,
    lo: f32,
    scale: f32,
    sides: [FBox; 2],
}

impl Split {
    /// True when `p` goes left: its bin along the split's axis, as the binning computed it,
    /// is before the split's.
    #[inline(always)]
    fn goes_left(&self, p: &BuildPrim) -> bool {
        bin_of((p.centroid()[self.axis] - self.lo) * self.scale) < self.bin
    }

    /// Moves the records that go left to the front, each swapped with the first record of the
    /// right side so far; returns how many go left and both sides' centroid boxes. Without a
    /// branch on the side (where the sides interleave, it mispredicts): the side is a lane mask
    /// that selects what the two slots receive, and a right record is written back where it was.
    fn partition(&self, prims: &mut [BuildPrim]) -> (usize, [FBox; 2]) {
        let (mut lc, mut rc) = (FBox::EMPTY, FBox::EMPTY);
        let mut mid = 0;
        for i in 0..prims.len() {
            let x = prims[i];
            let c = x.centroid();
            let left = self.goes_left(&x);
            let m = glam::BVec4A::splat(left);
            let y = prims[mid];
            prims[i] = BuildPrim { a: Vec4::select(m, y.a, x.a), b: Vec4::select(m, y.b, x.b) };
            prims[mid] = BuildPrim { a: Vec4::select(m, x.a, y.a), b: Vec4::select(m, x.b, y.b) };
            mid += usize::from(left);
            let grow_l = glam::BVec3A::splat(left);
            lc = FBox {
                min: Vec3A::select(grow_l, lc.min.min(c), lc.min),
                max: Vec3A::select(grow_l, lc.max.max(c), lc.max),
            };
            rc = FBox {
                min: Vec3A::select(grow_l, rc.min, rc.min.min(c)),
                max: Vec3A::select(grow_l, rc.max, rc.max.max(c)),
            };
        }
        (mid, [lc, rc])
    }
}

/// The cheapest split of `prims` (centroid box `cb`) by binned SAH along each of the three
/// axes, in one pass over the records; `None` when the centroids do not spread or no split has
/// records on both sides.
fn binned_split(prims: &[BuildPrim], cb: FBox) -> Option<Split> {
    let extent = cb.max - cb.min;
    let spread = extent.cmpgt(Vec3A::ZERO) & extent.is_finite_mask();
    if !spread.any() {
        return None;
    }
    let scale = Vec3A::select(spread, Vec3A::splat(BINS as f32) / extent, Vec3A::ZERO);
    let (boxes, counts) =
        if prims.len() >= TWO_SETS_MIN { bins::<2>(prims, cb.min, scale) } else { bins::<1>(prims, cb.min, scale) };
    let mut best: Option<Split> = None;
    for axis in (0..3).filter(|&a| spread.test(a)) {
        let (cost, bin) = best_bin_split(&boxes[axis], &counts[axis]);
        if bin > 0 && best.is_none_or(|b| cost < b.cost) {
            let union = |b: &[FBox]| b.iter().fold(FBox::EMPTY, |a, &b| a.union(b));
            let sides = [union(&boxes[axis][..bin]), union(&boxes[axis][bin..])];
            best = Some(Split { cost, axis, bin, lo: cb.min[axis], scale: scale[axis], sides });
        }
    }
    best
}

/// Nodes of at least this many records are binned in two sets of bins ([`bins`]); below, the
/// second set's clearing and merging cost more than it saves.
const TWO_SETS_MIN: usize = 64;

/// Boxes and counts of `prims` in [`BINS`] bins along each axis (bins from `lo`, `scale` bins
/// per unit), filled as `SETS` sets by turns and then merged: consecutive records (pieces of one
/// segment, segments of one strand) often fall in the same bin, and with one set each update
/// waits for the previous one's store. The merged bins are the same whatever `SETS` (a union of
/// boxes is exact in any order).
#[inline(always)]
fn bins<const SETS: usize>(prims: &[BuildPrim], lo: Vec3A, scale: Vec3A) -> ([[FBox; BINS]; 3], [[u32; BINS]; 3]) {
    let mut boxes = [[[FBox::EMPTY; BINS]; 3]; SETS];
    let mut counts = [[[0u32; BINS]; 3]; SETS];
    let last = Vec3A::splat((BINS - 1) as f32);
    let mut add = |set: usize, p: &BuildPrim| {
        let (min, max, c) = (p.min(), p.max(), p.centroid());
        // As `Split::goes_left` computes it, lane by lane.
        let k = ((c - lo) * scale).min(last);
        for axis in 0..3 {
            let k = bin_of(k[axis]);
            boxes[set][axis][k].grow(min, max);
            counts[set][axis][k] += 1;
        }
    };
    let mut runs = prims.chunks_exact(SETS);
    for run in &mut runs {
        for (set, p) in run.iter().enumerate() {
            add(set, p);
        }
    }
    for p in runs.remainder() {
        add(0, p);
    }
    let (mut b, mut n) = (boxes[0], counts[0]);
    for (bs, ns) in boxes[1..].iter().zip(&counts[1..]) {
        for axis in 0..3 {
            for k in 0..BINS {
                b[axis][k] = b[axis][k].union(bs[axis][k]);
                n[axis][k] += ns[axis][k];
            }
        }
    }
    (b, n)
}

/// The cheapest split between bins by the surface-area heuristic: its cost `Σ n A` and the
/// first bin of the right side (0: no split has records on both sides).
///
/// Only the non-empty bins are swept: a split just after an empty bin has the sides (and so
/// the cost) of the split before it, and of equal costs the first is kept, so the result is that
/// of sweeping every bin. Most nodes are small (8 to 64 records near the leaves) and fill few of
/// the bins, and this per-node sweep was a sixth of the binary build's time.
fn best_bin_split(bin_box: &[FBox; BINS], bin_count: &[u32; BINS]) -> (f32, usize) {
    // The non-empty bins, in order.
    let mut full = [0usize; BINS];
    let mut m = 0;
    for (i, &n) in bin_count.iter().enumerate() {
        full[m] = i;
        m += usize::from(n > 0);
    }
    // The right side of the split before full bin `j` (bins from full[j] on).
    let mut right_area = [0.0f32; BINS];
    let mut right_count = [0u32; BINS];
    let (mut acc, mut n) = (FBox::EMPTY, 0);
    for j in (1..m).rev() {
        acc = acc.union(bin_box[full[j]]);
        n += bin_count[full[j]];
        right_area[j] = acc.half_area();
        right_count[j] = n;
    }
    let (mut best_cost, mut best_split) = (f32::INFINITY, 0);
    let (mut acc, mut n) = (FBox::EMPTY, 0);
    for j in 1..m {
        acc = acc.union(bin_box[full[j - 1]]);
        n += bin_count[full[j - 1]];
        let cost = acc.half_area() * n as f32 + right_area[j] * right_count[j] as f32;
        if cost < best_cost {
            best_cost = cost;
            // The first bin after the left side's last full one: where the full sweep splits.
            best_split = full[j - 1] + 1;
        }
    }
    (best_cost, best_split)
}

impl Builder {
    fn push_node(&mut self, b: FBox) -> usize {
        self.nodes.push(Node::new(b, 0, 0));
        self.nodes.len() - 1
    }

    /// Builds the subtree over `prims` (which starts at `first` in the final order), whose
    /// box and centroid box are `bounds` and `cb`: binned SAH along all three axes (traversal
    /// cost 1, intersection cost 1 per record).
    fn build(&mut self, prims: &mut [BuildPrim], first: usize, bounds: FBox, cb: FBox) {
        let node = self.push_node(bounds);
        let count = prims.len() as u32;
        let leaf = |nodes: &mut Vec<Node>| {
            nodes[node].offset = first as u32;
            nodes[node].count = count;
        };
        if prims.len() <= self.min_leaf {
            return leaf(&mut self.nodes);
        }
        let Some(split) = binned_split(prims, cb) else {
            // The centroids do not spread, or all fall in one bin: a leaf, or halves by the
            // median centroid along the widest axis.
            if prims.len() <= self.max_leaf {
                return leaf(&mut self.nodes);
            }
            let (mid, axis) = (prims.len() / 2, (cb.max - cb.min).max_position());
            prims.select_nth_unstable_by(mid, |a, b| a.centroid()[axis].total_cmp(&b.centroid()[axis]));
            return self.split_children(node, prims, mid, first);
        };
        let split_cost = 1.0 + split.cost / bounds.half_area().max(f32::MIN_POSITIVE);
        if split_cost >= prims.len() as f32 && prims.len() <= self.max_leaf {
            return leaf(&mut self.nodes);
        }
        let (mid, [lc, rc]) = split.partition(prims);
        debug_assert!(mid > 0 && mid < prims.len(), "a split with records on both sides");
        let [lb, rb] = split.sides;
        self.split_children_with(node, prims, mid, first, [(lb, lc), (rb, rc)]);
    }

    /// Splits at `mid` and builds both sides (their boxes computed here).
    fn split_children(&mut self, node: usize, prims: &mut [BuildPrim], mid: usize, first: usize) {
        let (left, right) = prims.split_at(mid);
        self.split_children_with(node, prims, mid, first, [FBox::of(left), FBox::of(right)]);
    }

    /// Splits at `mid` and builds both sides, given each side's box and centroid box.
    fn split_children_with(
        &mut self,
        node: usize,
        prims: &mut [BuildPrim],
        mid: usize,
        first: usize,
        [(lb, lc), (rb, rc)]: [(FBox, FBox); 2],
    ) {
        let (left, right) = prims.split_at_mut(mid);
        if left.len().min(right.len()) < PARALLEL_BUILD_MIN {
            self.build(left, first, lb, lc);
            self.nodes[node].offset = self.nodes.len() as u32;
            self.build(right, first + mid, rb, rc);
            return;
        }
        // Large subtrees are built in parallel: the left one in place (it follows its parent),
        // the right one into its own node list, then appended with its interior-node offsets
        // shifted (the result does not depend on the thread count).
        let mut right_builder = Builder { nodes: Vec::new(), ..*self };
        rayon::join(|| self.build(left, first, lb, lc), || right_builder.build(right, first + mid, rb, rc));
        self.nodes[node].offset = self.nodes.len() as u32;
        self.append(right_builder.nodes);
    }

    /// Appends a subtree built at index 0, shifting its interior nodes' child offsets.
    fn append(&mut self, nodes: Vec<Node>) {
        let base = self.nodes.len() as u32;
        self.nodes.extend(nodes.into_iter().map(|mut n| {
            if n.count == 0 {
                n.offset += base;
            }
            n
        }));
    }
}

/// Up to this many items are built as one tree; more are split into clusters of at most this
/// many ([`Bvh::build_grouped`]). 2^14 segments are up to 131k pieces (4 MB of build records):
/// against 2^18, the 5M-segment thin head's load took 12 % less CPU time (a cluster's records
/// stay in the cache while it is built) and held less memory besides the tree (ARCHITECTURE.md,
/// issue 42); the tree over clusters is binned over whole segments' boxes a few levels further
/// down, where a cluster spans 1/300 of a head (smaller sets of segments are one tree:
/// `ONE_TREE_MAX` in `curves.rs`).
pub const CLUSTER_MAX: usize = 1 << 14;

/// What [`Bvh::build_grouped_in`] calls for each cluster: append the records of the pieces of
/// the items with these indices, in order (a cluster's items at once, so that the caller can
/// fetch what it makes them from before it computes: `CurveSet` gathers its segments).
pub(crate) type Pieces<'a> = dyn Fn(&[u32], &mut Vec<BuildPrim>) + Sync + 'a;

/// How a cluster joins the tree over clusters: as one child slot of a wide node (its root), or,
/// where the collapse above opens the cluster's root, as its root's two children.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Joint {
    Root,
    Children,
}

/// A child slot: the box and the [`ChildRef`] (unused: [`EMPTY_REF`]).
type Slot = (FBox, u32);

/// The unused slot.
const NO_SLOT: Slot = (FBox::EMPTY, EMPTY_REF);

/// A tree over one cluster's records (or over all): its wide nodes and primitive offsets
/// numbered from 0, its box and the slots it joins the tree above with (one for
/// [`Joint::Root`], the root's two children for [`Joint::Children`]; a leaf root is one slot).
struct SubTree {
    bounds: FBox,
    nodes: WideNodes,
    prims: Vec<u32>,
    slots: [Slot; 2],
}

/// Which boxes a tree's nodes may use.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Boxes {
    /// Axis-aligned boxes only (for primitives of any shape).
    Aligned,
    /// Axis-aligned boxes and, where the surface-area heuristic prefers them, boxes oriented
    /// along the primitives' segments ([`BuildPrim::segment`], module [`oriented`]); subtrees of
    /// at most [`SEGMENT_MIN_LEAF`] segments are not split.
    Oriented,
}

/// In a tree of segments ([`Boxes::Oriented`]), subtrees of at most this many records are
/// leaves without a split: the leaf pre-test takes a leaf's segments eight at a time, so a
/// leaf of eight costs about what a leaf of two does, while splitting below eight made most of
/// the binary nodes, most of the binning work and, through the collapse, more and smaller wide
/// nodes. Measured on thin strands (10,000 generated strands of 15 segments at the generator's
/// widths, 1.19M pieces; ARCHITECTURE.md, "Issue 42"): segments + tree 209.7 → 168.1 bytes per
/// segment, build CPU time −40 %, render instructions +1.5 %. Trees of boxes keep splitting
/// down to 2 (their leaves are tested one box at a time).
const SEGMENT_MIN_LEAF: usize = MAX_LEAF;

impl SubTree {
    /// Builds the tree over `records` (consumed); `None` when there are none.
    fn build(mut records: Vec<BuildPrim>, joint: Joint, boxes: Boxes) -> Option<Self> {
        if records.is_empty() {
            return None;
        }
        let min_leaf = if boxes == Boxes::Oriented { SEGMENT_MIN_LEAF } else { 2 };
        let mut b = Builder { nodes: Vec::with_capacity(2 * records.len() / 3 + 1), min_leaf, max_leaf: MAX_LEAF };
        let (bounds, cb) = FBox::of(&records);
        b.build(&mut records, 0, bounds, cb);
        let prims = records.iter().map(BuildPrim::index).collect();
        if boxes == Boxes::Aligned {
            records = Vec::new();
        }
        let binary = b.nodes;
        let input = CollapseInput { binary: &binary, records: &records, leaf: &plain_leaf };
        let mut nodes = WideNodes::default();
        // The slot of the binary subtree at `i` (spanning `i..end`), its wide nodes appended.
        let mut slot = |i: usize, end: usize| -> Slot {
            let r = if binary[i].count > 0 { plain_leaf(&binary[i]) } else { collapse(&input, i, end, &mut nodes) };
            (binary[i].bounds(), r)
        };
        let slots = if joint == Joint::Root || binary[0].count > 0 {
            [slot(0, binary.len()), NO_SLOT]
        } else {
            let right = binary[0].offset as usize;
            [slot(1, right), slot(right, binary.len())]
        };
        Some(Self { bounds, nodes, prims, slots })
    }
}

impl Bvh {
    /// Builds the hierarchy over `bounds`; traversal reports indices into `bounds`.
    #[must_use]
    pub fn build(bounds: &[Aabb]) -> Self {
        assert!(bounds.len() < u32::MAX as usize, "too many primitives for u32 indices");
        Self::build_records(bounds.iter().enumerate().map(|(i, b)| BuildPrim::new(b, i as u32)).collect())
    }

    /// Builds the hierarchy over prepared records (consumed: their memory is freed before the
    /// wide nodes are made); traversal reports each record's index.
    #[must_use]
    pub fn build_records(records: Vec<BuildPrim>) -> Self {
        Self::build_records_with(records, Boxes::Aligned)
    }

    /// [`Bvh::build_records`] with the nodes' boxes chosen from `boxes`.
    #[must_use]
    pub fn build_records_with(records: Vec<BuildPrim>, boxes: Boxes) -> Self {
        assert!(records.len() < u32::MAX as usize, "too many primitives for u32 indices");
        SubTree::build(records, Joint::Root, boxes).map_or_else(Self::default, Self::from_one)
    }

    /// Builds the hierarchy over the records that `pieces(index, out)` appends to `out` for
    /// the index of each of `items` (several tight boxes per shape, say; they must lie inside
    /// the item's box), in clusters: a binned-SAH tree over the
    /// items' own boxes down to subtrees of at most [`CLUSTER_MAX`] items, then for each such
    /// cluster, in parallel, its items' pieces are made and built into a subtree on their own
    /// (see `ARCHITECTURE.md`). Only one cluster's pieces exist at a time per thread; up to
    /// [`CLUSTER_MAX`] items this is [`Bvh::build_records`] over all the pieces.
    #[must_use]
    pub fn build_grouped(items: Vec<BuildPrim>, pieces: impl Fn(u32, &mut Vec<BuildPrim>) + Sync) -> Self {
        let each = |indices: &[u32], out: &mut Vec<BuildPrim>| indices.iter().for_each(|&i| pieces(i, out));
        Self::build_grouped_in(items, &each, CLUSTER_MAX, Boxes::Aligned)
    }

    /// [`Bvh::build_grouped`] with clusters of at most `cluster_max` items (≥ 2) and the
    /// clusters' nodes' boxes chosen from `boxes` (the tree over clusters is axis-aligned).
    pub(crate) fn build_grouped_in(
        items: Vec<BuildPrim>,
        pieces: &Pieces<'_>,
        cluster_max: usize,
        boxes: Boxes,
    ) -> Self {
        assert!(cluster_max >= 2, "clusters need at least two items");
        assert!(items.len() < u32::MAX as usize, "too many primitives for u32 indices");
        if items.len() <= cluster_max {
            let mut records = Vec::with_capacity(8 * items.len());
            let indices: Vec<u32> = items.iter().map(BuildPrim::index).collect();
            drop(items);
            pieces(&indices, &mut records);
            return Self::build_records_with(records, boxes);
        }
        Self::build_clustered(items, pieces, cluster_max, boxes)
    }

    /// A hierarchy of one subtree.
    fn from_one(t: SubTree) -> Self {
        let root = t.slots[0].1;
        if ChildRef::is_node(root) {
            return Self { nodes: t.nodes, root, prims: t.prims, simd: SimdLevel::best() };
        }
        // A single leaf: one wide node holding it.
        let leaf = Node::new(t.bounds, 0, ChildRef::count(root));
        let nodes = WideNodes { aabb: vec![WideNode::new(&[(&leaf, root)])], oriented: Vec::new() };
        Self { nodes, root: ChildRef::pack(0, 0), prims: t.prims, simd: SimdLevel::best() }
    }

    /// The clustered build of [`Bvh::build_grouped`] (more than `cluster_max` items).
    fn build_clustered(mut items: Vec<BuildPrim>, pieces: &Pieces<'_>, cluster_max: usize, boxes: Boxes) -> Self {
        use rayon::prelude::*;
        // The top tree over the items, whose leaves are the clusters (item ranges, in order).
        // It keeps the items' boxes: they hold their pieces', so they hold the clusters'.
        let mut builder = Builder { nodes: Vec::new(), min_leaf: cluster_max, max_leaf: cluster_max };
        let (bounds, cb) = FBox::of(&items);
        builder.build(&mut items, 0, bounds, cb);
        let top = builder.nodes;
        // Only the items' order is needed from here on.
        let order: Vec<u32> = items.iter().map(BuildPrim::index).collect();
        drop(items);
        let clusters: Vec<(u32, u32)> = top.iter().filter(|n| n.count > 0).map(|n| (n.offset, n.count)).collect();
        let items_total = order.len();
        let cluster_of = |leaf: &Node| clusters.partition_point(|&(first, _)| first < leaf.offset);
        // Its wide nodes come first (the root is node 0), then each cluster's, in cluster
        // order. A first pass of its collapse decides how each cluster joins it (this does not
        // depend on the clusters' contents) and counts its wide nodes.
        let mut joints = vec![Joint::Root; clusters.len()];
        let mut top_nodes = Vec::new();
        collapse_top(&top, 0, top.len(), &cluster_of, &mut joints, None, &mut top_nodes);
        let mut nodes = WideNodes { aabb: top_nodes.clone(), oriented: Vec::new() };
        let mut prims = Vec::new();
        // Each cluster's slots, moved to their place in the whole tree.
        let mut slots = Vec::with_capacity(clusters.len());
        // Clusters are built in parallel a few at a time and appended in order, so that only
        // those few exist apart from the whole tree.
        let batch = rayon::current_num_threads();
        for (k, group) in clusters.chunks(batch).enumerate() {
            let subtrees: Vec<Option<SubTree>> = group
                .par_iter()
                .zip(&joints[k * batch..])
                .map(|(&(first, count), &joint)| {
                    // Room for up to 8 pieces an item: only the memory written is committed.
                    let mut records = Vec::with_capacity(8 * count as usize);
                    pieces(&order[first as usize..(first + count) as usize], &mut records);
                    SubTree::build(records, joint, boxes)
                })
                .collect();
            for t in subtrees {
                let Some(t) = t else {
                    slots.push([NO_SLOT; 2]);
                    continue;
                };
                assert!(prims.len() + t.prims.len() < u32::MAX as usize, "too many primitives for u32 indices");
                let (a, o, p) = nodes.append(t.nodes, prims.len() as u32);
                slots.push(t.slots.map(|(b, r)| (b, ChildRef::shift(r, a, o, p))));
                prims.extend_from_slice(&t.prims);
            }
            // The lists' room, from the clusters built so far extrapolated to all of them. The
            // wide nodes are over-aligned (64 bytes), and such a vector grows by copying: for a
            // moment it is held twice (the 5M-segment head's oriented nodes are 270 MB). So room
            // is made early and twice the extrapolation, and only when the extrapolation
            // outgrows it; room not written to is never committed (ARCHITECTURE.md, issue 42).
            let done: usize = clusters[..((k + 1) * batch).min(clusters.len())]
                .iter()
                .map(|&(_, c)| c as usize)
                .sum::<usize>()
                .max(1);
            let expected = |len: usize| (len as f64 * (items_total as f64 / done as f64) * 1.05) as usize;
            make_room(&mut nodes.aabb, expected);
            make_room(&mut nodes.oriented, expected);
            make_room(&mut prims, expected);
        }
        drop(order);
        top_nodes.clear();
        collapse_top(&top, 0, top.len(), &cluster_of, &mut joints, Some(&slots), &mut top_nodes);
        let count = top_nodes.len();
        nodes.aabb[..count].copy_from_slice(&top_nodes);
        Self { nodes, root: ChildRef::pack(0, 0), prims, simd: SimdLevel::best() }
    }

    /// The instruction set the walks use.
    #[must_use]
    pub fn simd_level(&self) -> SimdLevel {
        self.simd
    }

    /// Makes the walks use `level` (every level gives the same results; for tests and
    /// benchmarks). A [`SimdLevel`] other than the portable one exists only where the CPU has it.
    pub fn set_simd_level(&mut self, level: SimdLevel) {
        self.simd = level;
    }

    /// Replaces every primitive index `p` in the leaves by `f(p)`: traversal then reports
    /// `f(p)` (e.g. the shape that a piece belongs to).
    pub fn map_prims(&mut self, f: impl Fn(u32) -> u32) {
        for p in &mut self.prims {
            *p = f(*p);
        }
    }

    /// Number of nodes.
    #[must_use]
    pub fn node_count(&self) -> usize {
        self.nodes.aabb.len() + self.nodes.oriented.len()
    }

    /// Number of oriented nodes (of [`Bvh::node_count`]).
    #[must_use]
    pub fn oriented_node_count(&self) -> usize {
        self.nodes.oriented.len()
    }

    /// Heap bytes used by nodes and primitive indices.
    #[must_use]
    pub fn bytes(&self) -> usize {
        self.nodes.bytes() + self.prims.len() * 4
    }

    /// Walks the leaves the ray reaches, nearest-first by box entry, calling
    /// `hit(prim, t_max)` for each primitive; `hit` returns `Some(t)` to shrink `t_max` to `t`.
    /// Returns the final `t_max` (the ray's own if nothing was hit).
    pub fn traverse(&self, ray: &Ray, mut hit: impl FnMut(u32, f64) -> Option<f64>) -> f64 {
        self.traverse_leaves(ray, |prims, mut t_max| {
            let mut shrunk = None;
            for &prim in prims {
                if let Some(t) = hit(prim, t_max) {
                    t_max = t_max.min(t);
                    shrunk = Some(t_max);
                }
            }
            shrunk
        })
    }

    /// [`Bvh::traverse`] a leaf at a time: `hit(prims, t_max)` gets each reached leaf's
    /// primitives (at most [`MAX_LEAF`]) and returns `Some(t)` to shrink `t_max` to `t`.
    pub fn traverse_leaves(&self, ray: &Ray, hit: impl FnMut(&[u32], f64) -> Option<f64>) -> f64 {
        match self.simd.avx2_token() {
            Some(k) => k.run(|| self.traverse_leaves_in(k, ray, hit)),
            None => self.traverse_leaves_in(Portable, ray, hit),
        }
    }

    /// [`Bvh::traverse_leaves`] with the node tests in `lanes` (the caller has dispatched).
    #[inline(always)]
    pub(crate) fn traverse_leaves_in<L: Lanes>(
        &self,
        lanes: L,
        ray: &Ray,
        mut hit: impl FnMut(&[u32], f64) -> Option<f64>,
    ) -> f64 {
        if self.root == EMPTY_REF {
            return ray.t_max;
        }
        let slabs = Slabs::new(ray);
        with_stack(|stack| {
            let mut t_max = ray.t_max;
            let mut node = self.root;
            #[cfg(fiberlab_stats)]
            stats::add(0, 1);
            loop {
                #[cfg(fiberlab_stats)]
                stats::add(if ChildRef::count(node) == 0 { 1 } else { 2 }, 1);
                // The hit children's (distance, child) keys onto the stack ([`Pending`]), then
                // ordered there nearest on top (most visits hit one or two children: those take
                // no sort); go on with the nearest.
                stack.reserve(WIDTH);
                let base = stack.len;
                let keys: &mut [u64; WIDTH] =
                    (&mut stack.items[base..base + WIDTH]).try_into().expect("room for a node's children");
                let index = ChildRef::index(node) as usize;
                let mask = if ChildRef::count(node) == 0 {
                    slabs.enter_keys(lanes, &self.nodes.aabb[index], t_max, keys)
                } else {
                    slabs.enter_oriented_keys(lanes, &self.nodes.oriented[index], t_max, keys)
                };
                let m = mask.count_ones() as usize;
                if m == 2 {
                    (keys[0], keys[1]) = (keys[0].max(keys[1]), keys[0].min(keys[1]));
                } else if m > 2 {
                    sort_farthest_first(&mut keys[..m]);
                }
                stack.len = base + m;
                let mut next = if m != 0 { stack.pop() } else { None };
                // Intersect leaves as they come, until the next interior node.
                loop {
                    let p = match next.take() {
                        Some(p) => p,
                        // The nearest pending entry that the ray can still reach.
                        None => loop {
                            match stack.pop() {
                                Some(p) if f64::from(p.t()) <= t_max * (1.0 + 4.0 * f64::from(f32::EPSILON)) => {
                                    break p;
                                }
                                Some(_) => {}
                                None => return t_max,
                            }
                        },
                    };
                    if ChildRef::is_node(p.child()) {
                        node = p.child();
                        break;
                    }
                    let (count, index) = (ChildRef::count(p.child()) as usize, ChildRef::index(p.child()) as usize);
                    #[cfg(fiberlab_stats)]
                    stats::add(3, 1);
                    if let Some(t) = hit(&self.prims[index..index + count], t_max) {
                        t_max = t_max.min(t);
                    }
                }
            }
        })
    }

    /// True when `hit(prim)` returns true for some primitive whose leaf the ray reaches
    /// (any-hit query for shadow rays; stops at the first hit).
    pub fn any(&self, ray: &Ray, mut hit: impl FnMut(u32) -> bool) -> bool {
        self.any_leaf(ray, |prims| prims.iter().any(|&p| hit(p)))
    }

    /// [`Bvh::any`] a leaf at a time: true when `hit(prims)` is true for some reached leaf.
    pub fn any_leaf(&self, ray: &Ray, hit: impl FnMut(&[u32]) -> bool) -> bool {
        match self.simd.avx2_token() {
            Some(k) => k.run(|| self.any_leaf_in(k, ray, hit)),
            None => self.any_leaf_in(Portable, ray, hit),
        }
    }

    /// [`Bvh::any_leaf`] with the node tests in `lanes` (the caller has dispatched).
    #[inline(always)]
    pub(crate) fn any_leaf_in<L: Lanes>(&self, lanes: L, ray: &Ray, mut hit: impl FnMut(&[u32]) -> bool) -> bool {
        if self.root == EMPTY_REF {
            return false;
        }
        let slabs = Slabs::new(ray);
        with_stack(|stack| {
            let mut node = self.root;
            #[cfg(fiberlab_stats)]
            stats::add(6, 1);
            loop {
                #[cfg(fiberlab_stats)]
                stats::add(if ChildRef::count(node) == 0 { 7 } else { 8 }, 1);
                let index = ChildRef::index(node) as usize;
                let (mask, child) = if ChildRef::count(node) == 0 {
                    let n = &self.nodes.aabb[index];
                    (slabs.enter(lanes, n, ray.t_max).0, &n.child)
                } else {
                    let n = &self.nodes.oriented[index];
                    (slabs.enter_oriented(lanes, n, ray.t_max), &n.child)
                };
                let mut bits = mask;
                while bits != 0 {
                    let k = bits.trailing_zeros() as usize;
                    bits &= bits - 1;
                    if ChildRef::is_node(child[k]) {
                        stack.push(Pending::new(child[k], 0.0));
                        continue;
                    }
                    let (count, index) = (ChildRef::count(child[k]) as usize, ChildRef::index(child[k]) as usize);
                    #[cfg(fiberlab_stats)]
                    stats::add(9, 1);
                    if hit(&self.prims[index..index + count]) {
                        return true;
                    }
                }
                match stack.pop() {
                    Some(p) => node = p.child(),
                    None => return false,
                }
            }
        })
    }
}

/// Orders pending entries by decreasing key (insertion sort: at most [`WIDTH`] of them).
#[inline(always)]
fn sort_farthest_first(items: &mut [u64]) {
    for i in 1..items.len() {
        let x = items[i];
        let mut j = i;
        while j > 0 && items[j - 1] < x {
            items[j] = items[j - 1];
            j -= 1;
        }
        items[j] = x;
    }
}

thread_local! {
    /// Each thread's traversal stack, kept between queries so traversal never allocates once
    /// warmed up (taken out of the cell during a query; a nested query starts a fresh one).
    static STACK: std::cell::Cell<Stack> = const { std::cell::Cell::new(Stack { items: Vec::new(), len: 0 }) };
}

/// Runs `f` with this thread's (empty) traversal stack.
#[inline]
fn with_stack<R>(f: impl FnOnce(&mut Stack) -> R) -> R {
    let mut stack = STACK.take();
    stack.len = 0;
    let r = f(&mut stack);
    STACK.set(stack);
    r
}

/// A ray prepared for slab tests against quantized `f32` boxes: per axis, which box row
/// (lower or upper corner) the ray meets first, and the inverse direction.
struct Slabs {
    /// Direction in `f32` (oriented nodes rotate it per child).
    d: Vec3,
    /// Origin, inverse direction and `|inv|` by axis in lanes x, y, z (w: 0).
    o: Vec4,
    inv: Vec4,
    inv_abs: Vec4,
    /// Box widening in scene units for the `f32` origin, off by up to half an ulp of |o|.
    slack: f32,
    /// The rows of `WideNode::q` holding the near (entry) and far planes per axis.
    rows: RowChoice,
    t_min: f32,
}

/// Smallest direction component magnitude used for the slab reciprocals: keeps them finite
/// (a box is never missed because of it: the slab then spans ±3e37 in ray distance).
const MIN_DIRECTION: f64 = 1e-30;

impl Slabs {
    fn new(ray: &Ray) -> Self {
        let d = ray.d.map(|c| if c.abs() < MIN_DIRECTION { MIN_DIRECTION.copysign(c) } else { c });
        let inv = d.recip().as_vec3();
        Self {
            d: ray.d.as_vec3(),
            o: ray.o.as_vec3().extend(0.0),
            inv: inv.extend(0.0),
            inv_abs: inv.abs().extend(0.0),
            slack: (ray.o.abs().max_element() as f32) * f32::EPSILON * 4.0,
            rows: RowChoice::new([0, 1, 2].map(|a| inv[a] >= 0.0)),
            t_min: ray.t_min as f32 - 1e-6,
        }
    }

    /// Which of the node's eight children the ray enters within `(t_min, t_max)` (bit mask)
    /// and the entry distances (one lane per child: [`Lanes::slab`]). A plane's distance is
    /// `q·(scale·inv) + (origin − o)·inv`; each box is widened by the origin's slack plus a few
    /// ulps of the terms, which bounds the rounding of that sum.
    #[inline(always)]
    fn enter(&self, lanes: impl Lanes, n: &WideNode, t_max: f64) -> (u32, [f32; WIDTH]) {
        let (hit, t0) = lanes.slab(&n.q, &self.rows, &self.terms(n, t_max));
        (hit & n.used, t0)
    }

    /// The slab test's per-axis terms of node `n` for all three axes at once (lanes x, y, z;
    /// w is 0).
    #[inline(always)]
    fn terms(&self, n: &WideNode, t_max: f64) -> SlabTerms {
        let scale = Vec4::from_array(n.scale);
        let offset = Vec4::from_array(n.origin) - self.o;
        let step = scale * self.inv;
        let base = offset * self.inv;
        let widen = (Vec4::splat(self.slack) + (offset.abs() + scale * 256.0) * (4.0 * f32::EPSILON)) * self.inv_abs;
        SlabTerms { step, lo: base - widen, hi: base + widen, t_min: self.t_min, t_max: t_max as f32 }
    }

    /// Which of the oriented node's children the ray enters within `(t_min, t_max)` (bit
    /// mask, unused slots cleared).
    #[inline(always)]
    fn enter_oriented(&self, lanes: impl Lanes, n: &OrientedNode, t_max: f64) -> u32 {
        let terms = n.terms(self.o.truncate(), self.d, self.slack, self.t_min, t_max as f32);
        lanes.oriented(&n.boxes, &terms).0 & n.used
    }

    /// [`Slabs::enter_oriented`] with the hit children's keys, as [`Slabs::enter_keys`].
    #[inline(always)]
    fn enter_oriented_keys(&self, lanes: impl Lanes, n: &OrientedNode, t_max: f64, keys: &mut [u64; WIDTH]) -> u32 {
        let terms = n.terms(self.o.truncate(), self.d, self.slack, self.t_min, t_max as f32);
        lanes.oriented_keys(&n.boxes, &terms, n.used, &n.child, keys)
    }

    /// [`Slabs::enter`] with the hit children's [`Pending`] keys in `keys[..m]` (child order;
    /// `m`: the number of bits of the returned mask).
    #[inline(always)]
    fn enter_keys(&self, lanes: impl Lanes, n: &WideNode, t_max: f64, keys: &mut [u64; WIDTH]) -> u32 {
        lanes.slab_keys(&n.q, &self.rows, &self.terms(n, t_max), n.used, &n.child, keys)
    }
}

impl WideNode {
    /// The decoded coordinate `row` (0–2 lower, 3–5 upper corner, by axis) of child `k`.
    #[inline(always)]
    fn decode(n: &WideNode, row: usize, k: usize) -> f32 {
        n.origin[row % 3] + f32::from(n.q[row][k]) * n.scale[row % 3]
    }

    /// A node over up to [`WIDTH`] binary-tree boxes with their child references (an unused
    /// one, [`EMPTY_REF`], leaves its slot unused).
    fn new(children: &[(&Node, u32)]) -> Self {
        assert!(children.len() <= WIDTH, "{} children for a wide node", children.len());
        let mut n = Self { origin: [0.0; 4], scale: [0.0; 4], q: [[0; WIDTH]; 6], child: [EMPTY_REF; WIDTH], used: 0 };
        for axis in 0..3 {
            let lo = children.iter().map(|c| clamp_finite(c.0.min[axis])).fold(f32::INFINITY, f32::min);
            let hi = children.iter().map(|c| clamp_finite(c.0.max[axis])).fold(f32::NEG_INFINITY, f32::max);
            n.origin[axis] = lo;
            let mut scale = (hi - lo) / 255.0;
            while lo + 255.0 * scale < hi {
                scale = scale.next_up();
            }
            n.scale[axis] = scale;
        }
        for (k, (b, child)) in children.iter().enumerate() {
            n.child[k] = *child;
            n.used |= u32::from(*child != EMPTY_REF) << k;
            for axis in 0..3 {
                let (lo, hi) = (clamp_finite(b.min[axis]), clamp_finite(b.max[axis]));
                let scale = n.scale[axis];
                let grid = |x: f32| if scale > 0.0 { (x - n.origin[axis]) / scale } else { 0.0 };
                n.q[axis][k] = grid(lo).floor().clamp(0.0, 255.0) as u8;
                while n.q[axis][k] > 0 && Self::decode(&n, axis, k) > lo {
                    n.q[axis][k] -= 1;
                }
                n.q[3 + axis][k] = grid(hi).ceil().clamp(0.0, 255.0) as u8;
                while n.q[3 + axis][k] < 255 && Self::decode(&n, 3 + axis, k) < hi {
                    n.q[3 + axis][k] += 1;
                }
                debug_assert!(Self::decode(&n, axis, k) <= lo && Self::decode(&n, 3 + axis, k) >= hi);
            }
        }
        n
    }
}

/// Keeps box coordinates finite (an infinite or empty box becomes a huge one).
fn clamp_finite(x: f32) -> f32 {
    if x.is_nan() { 0.0 } else { x.clamp(-1e30, 1e30) }
}

/// What a binary leaf becomes in the wide tree: its primitive range ([`plain_leaf`]), or in the
/// top tree over clusters, the cluster's root.
type LeafRef<'a> = dyn Fn(&Node) -> u32 + Sync + 'a;

/// The reference of a binary leaf's own primitive range.
fn plain_leaf(b: &Node) -> u32 {
    ChildRef::pack(b.count, b.offset)
}

/// A slot while the tree over clusters is collapsed: a node of that tree (an interior node, or
/// a leaf: a cluster) and the end of its subtree, or child `side` of cluster `j`'s root.
#[derive(Clone, Copy)]
enum TopSlot {
    Node(usize, usize),
    Half(usize, usize),
}

/// [`collapse`] of the tree over clusters `top`, whose leaves (clusters, numbered by
/// `cluster_of`) can be opened as interior nodes are: into their roots' two children. Records
/// in `joints` how each cluster joins; with `slots` (each cluster's, in the whole tree) it makes
/// the wide nodes, without (the first pass) placeholders of the same number.
fn collapse_top(
    top: &[Node],
    root: usize,
    end: usize,
    cluster_of: &dyn Fn(&Node) -> usize,
    joints: &mut [Joint],
    slots: Option<&[[Slot; 2]]>,
    out: &mut Vec<WideNode>,
) -> u32 {
    let children = |i: usize, end: usize| {
        [TopSlot::Node(i + 1, top[i].offset as usize), TopSlot::Node(top[i].offset as usize, end)]
    };
    let mut open = [TopSlot::Half(0, 0); WIDTH];
    open[..2].copy_from_slice(&children(root, end));
    let mut len = 2;
    while len < WIDTH {
        // Open the node (interior or cluster) with the largest box.
        let area = |s: TopSlot| match s {
            TopSlot::Node(i, _) => top[i].bounds().half_area(),
            TopSlot::Half(..) => f32::NEG_INFINITY,
        };
        let best = (0..len)
            .filter(|&i| matches!(open[i], TopSlot::Node(..)))
            .max_by(|&a, &b| area(open[a]).total_cmp(&area(open[b])));
        let Some(i) = best else { break };
        let TopSlot::Node(n, e) = open[i] else { break };
        let [a, b] = if top[n].count == 0 {
            children(n, e)
        } else {
            let j = cluster_of(&top[n]);
            [TopSlot::Half(j, 0), TopSlot::Half(j, 1)]
        };
        open[i] = a;
        open[len] = b;
        len += 1;
    }
    let index = out.len();
    out.push(WideNode::new(&[]));
    let mut kids = [(Node::new(FBox::EMPTY, 0, 0), EMPTY_REF); WIDTH];
    for (kid, &slot) in kids.iter_mut().zip(&open[..len]) {
        let (bounds, r) = match slot {
            TopSlot::Node(n, e) if top[n].count == 0 => {
                (top[n].bounds(), ChildRef::pack(0, collapse_top(top, n, e, cluster_of, joints, slots, out)))
            }
            TopSlot::Node(n, _) => {
                let j = cluster_of(&top[n]);
                joints[j] = Joint::Root;
                slots.map_or(NO_SLOT, |s| s[j][0])
            }
            TopSlot::Half(j, side) => {
                joints[j] = Joint::Children;
                slots.map_or(NO_SLOT, |s| s[j][side])
            }
        };
        *kid = (Node::new(bounds, 0, 0), r);
    }
    let refs: Vec<(&Node, u32)> = kids[..len].iter().map(|(n, r)| (n, *r)).collect();
    out[index] = WideNode::new(&refs);
    index as u32
}

/// Binary subtrees of at least this many nodes are collapsed in parallel.
const PARALLEL_COLLAPSE_MIN: usize = 16_384;

/// What a binary tree is collapsed from: its nodes, the build records in their final order
/// (for oriented boxes; empty when the tree uses axis-aligned boxes only) and what a binary leaf
/// becomes.
struct CollapseInput<'a> {
    binary: &'a [Node],
    records: &'a [BuildPrim],
    leaf: &'a LeafRef<'a>,
}

/// Children with more primitives than this are not fitted an oriented box (over a large region
/// hair has no one direction, and the fit would cost a pass over all of them).
const ORIENTED_FIT_MAX: usize = 64;

/// An oriented node is made when boxing its children each in its own best frame lowers the
/// children's surface-area cost `Σ nₖ Aₖ` (primitives times half area) below this fraction of
/// their axis-aligned cost: the oriented test costs more per visit.
const ORIENTED_NODE_GAIN: f64 = 0.75;

impl CollapseInput<'_> {
    /// The primitives (a range of `records`) under the binary subtree at `c`.
    fn prim_range(&self, c: usize) -> std::ops::Range<usize> {
        let b = self.binary;
        let (mut first, mut last) = (c, c);
        while b[first].count == 0 {
            first += 1;
        }
        while b[last].count == 0 {
            last = b[last].offset as usize;
        }
        b[first].offset as usize..(b[last].offset + b[last].count) as usize
    }

    /// The oriented node over the binary subtrees `slots` (node and end of each), if the
    /// surface-area heuristic prefers one: its centre, radius and each child's frame and box
    /// (references left unset).
    fn oriented_plan(&self, slots: &[(usize, usize)]) -> Option<(Vec3, f32, Vec<OrientedChild>)> {
        if self.records.is_empty() {
            return None;
        }
        let ranges: Vec<std::ops::Range<usize>> = slots.iter().map(|&(c, _)| self.prim_range(c)).collect();
        if ranges.iter().all(|r| r.len() > ORIENTED_FIT_MAX) {
            return None;
        }
        let aabb = slots.iter().fold(FBox::EMPTY, |b, &(c, _)| b.union(self.binary[c].bounds()));
        let (lo, hi) = (aabb.min.as_dvec3(), aabb.max.as_dvec3());
        let center = (0.5 * (lo + hi)).as_vec3();
        let c = center.as_dvec3();
        let radius = round_up((c - lo).abs().max((hi - c).abs()).length() * (1.0 + 1e-6));
        let (mut aligned_cost, mut best_cost) = (0.0, 0.0);
        let mut children = Vec::with_capacity(slots.len());
        for (&(node, _), range) in slots.iter().zip(&ranges) {
            let b = self.binary[node].bounds();
            let (blo, bhi) = (b.min.as_dvec3() - c, b.max.as_dvec3() - c);
            let aligned_area = oriented::half_area(blo, bhi);
            let n = range.len() as f64;
            let scale = f64::from(oriented::IDENTITY[0][0]);
            let mut child =
                OrientedChild { rows: oriented::IDENTITY, lo: blo * scale, hi: bhi * scale, child: EMPTY_REF };
            let mut area = aligned_area;
            if range.len() <= ORIENTED_FIT_MAX {
                let records = &self.records[range.clone()];
                if let Some(rows) = oriented::frame_of(records) {
                    let rows = oriented::integer_rows(&rows);
                    let (olo, ohi) = oriented::bounds_in(records, &rows, c);
                    let oriented_area = oriented::scaled_half_area(&rows, olo, ohi);
                    if oriented_area < aligned_area {
                        child = OrientedChild { rows, lo: olo, hi: ohi, child: EMPTY_REF };
                        area = oriented_area;
                    }
                }
            }
            aligned_cost += n * aligned_area;
            best_cost += n * area;
            children.push(child);
        }
        (best_cost < ORIENTED_NODE_GAIN * aligned_cost).then_some((center, radius, children))
    }
}

/// Collapses the binary subtree at interior node `root`, which spans binary nodes
/// `root..end` (a subtree's nodes are contiguous: the left child follows its parent, the right
/// one starts at `offset`), into wide nodes appended to `out`; returns the reference to its
/// wide node (axis-aligned or oriented, [`CollapseInput::oriented_plan`]). Wide nodes come out
/// in depth-first order; large subtrees are collapsed in parallel into their own lists, then
/// appended in that same order, so the result does not depend on the thread count.
fn collapse(input: &CollapseInput<'_>, root: usize, end: usize, out: &mut WideNodes) -> u32 {
    let binary = input.binary;
    // A binary node and the end of its subtree.
    let children = |i: usize, end: usize| [(i + 1, binary[i].offset as usize), (binary[i].offset as usize, end)];
    // A child slot's reference: a leaf; an interior node whose whole subtree holds at most
    // MAX_LEAF primitives, as one leaf over them (they are contiguous), instead of a wide node
    // that would be mostly empty; or the wide node its subtree collapses to (`sub`).
    let leaf_of = |c: usize, e: usize| -> Option<u32> {
        let b = &binary[c];
        if b.count > 0 {
            return Some((input.leaf)(b));
        }
        if e - c > 2 * MAX_LEAF - 1 {
            return None;
        }
        let leaves = binary[c..e].iter().filter(|n| n.count > 0);
        let count: u32 = leaves.clone().map(|n| n.count).sum();
        let offset = leaves.map(|n| n.offset).min()?;
        (count as usize <= MAX_LEAF).then(|| (input.leaf)(&Node { offset, count, ..*b }))
    };
    let mut slots = [(0usize, 0usize); WIDTH];
    slots[..2].copy_from_slice(&children(root, end));
    let mut len = 2;
    while len < WIDTH {
        // Open the interior child with the largest box.
        let best = (0..len).filter(|&i| binary[slots[i].0].count == 0).max_by(|&a, &b| {
            binary[slots[a].0].bounds().half_area().total_cmp(&binary[slots[b].0].bounds().half_area())
        });
        let Some(i) = best else { break };
        let [a, b] = children(slots[i].0, slots[i].1);
        slots[i] = a;
        slots[len] = b;
        len += 1;
    }
    // The node's kind is decided before its children are collapsed, so that it comes before
    // them in its list.
    let plan = input.oriented_plan(&slots[..len]);
    let this = match plan {
        None => {
            out.aabb.push(WideNode::new(&[]));
            ChildRef::pack(0, out.aabb.len() as u32 - 1)
        }
        Some((center, ..)) => {
            out.oriented.push(OrientedNode::new(center, 0.0, &[], EMPTY_REF));
            ChildRef::pack(ORIENTED, out.oriented.len() as u32 - 1)
        }
    };
    let mut refs = [EMPTY_REF; WIDTH];
    if end - root < PARALLEL_COLLAPSE_MIN {
        for (r, &(c, e)) in refs.iter_mut().zip(&slots[..len]) {
            *r = leaf_of(c, e).unwrap_or_else(|| collapse(input, c, e, out));
        }
    } else {
        use rayon::prelude::*;
        let leaves: [Option<u32>; WIDTH] =
            std::array::from_fn(|k| (k < len).then(|| leaf_of(slots[k].0, slots[k].1)).flatten());
        // The first interior child's subtree follows its parent, as in the sequential order:
        // it is collapsed in place, the others into their own lists at the same time.
        let first = (0..len).position(|k| leaves[k].is_none()).unwrap_or(len);
        let mut first_ref = EMPTY_REF;
        let ((), subtrees) = rayon::join(
            || {
                if let Some(&(c, e)) = slots.get(first).filter(|_| first < len) {
                    first_ref = collapse(input, c, e, out);
                }
            },
            || {
                slots[..len]
                    .par_iter()
                    .enumerate()
                    .map(|(k, &(c, e))| {
                        let mut v = WideNodes::default();
                        let r =
                            if k > first && leaves[k].is_none() { collapse(input, c, e, &mut v) } else { EMPTY_REF };
                        (v, r)
                    })
                    .collect::<Vec<(WideNodes, u32)>>()
            },
        );
        for (k, (r, (sub, sub_ref))) in refs.iter_mut().zip(subtrees).enumerate().take(len) {
            *r = if let Some(r) = leaves[k] {
                r
            } else if k == first {
                first_ref
            } else {
                // The subtree's wide nodes were numbered from 0: shift its references.
                let (a, o, p) = out.append(sub, 0);
                ChildRef::shift(sub_ref, a, o, p)
            };
        }
    }
    let index = ChildRef::index(this) as usize;
    match plan {
        None => {
            let kids: Vec<(&Node, u32)> = slots[..len].iter().zip(refs).map(|(&(c, _), r)| (&binary[c], r)).collect();
            out.aabb[index] = WideNode::new(&kids);
        }
        Some((center, radius, mut kids)) => {
            for (k, r) in kids.iter_mut().zip(refs) {
                k.child = r;
            }
            out.oriented[index] = OrientedNode::new(center, radius, &kids, EMPTY_REF);
        }
    }
    this
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Uniform numbers in [0, 1) from the tests' generator seeded `state`.
    fn uniforms(state: u64) -> impl FnMut() -> f64 {
        let mut g = crate::test_random::Lcg(state);
        move || g.next()
    }

    #[test]
    fn parallel_build_is_correct_and_independent_of_threads() {
        let mut rnd = uniforms(99u64);
        let n = 5 * PARALLEL_BUILD_MIN;
        let spheres: Vec<(DVec3, f64)> =
            (0..n).map(|_| (DVec3::new(rnd(), rnd(), rnd()) * 20.0 - 10.0, 0.02 + 0.05 * rnd())).collect();
        let bounds: Vec<Aabb> = spheres.iter().map(|&(c, r)| Aabb::sphere(c, r)).collect();
        let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap().install(|| Bvh::build(&bounds));
        let two = rayon::ThreadPoolBuilder::new().num_threads(2).build().unwrap().install(|| Bvh::build(&bounds));
        assert_eq!(one.prims, two.prims);
        assert_eq!(one.node_count(), two.node_count());
        assert_eq!(one.nodes, two.nodes);
        for _ in 0..200 {
            let o = DVec3::new(rnd(), rnd(), rnd()) * 24.0 - 12.0;
            let ray = Ray::new(o, (DVec3::new(rnd(), rnd(), rnd()) - 0.5).normalize());
            let brute =
                spheres.iter().filter_map(|&s| hit_sphere(&ray, s, f64::INFINITY)).fold(f64::INFINITY, f64::min);
            assert_eq!(two.traverse(&ray, |p, t_max| hit_sphere(&ray, spheres[p as usize], t_max)), brute);
        }
    }

    /// The ray's entry into the sphere `(c, r)` within `(t_min, t_max)`, in closed form.
    fn hit_sphere(ray: &Ray, (c, r): (DVec3, f64), t_max: f64) -> Option<f64> {
        let oc = ray.o - c;
        let b = oc.dot(ray.d);
        let disc = b * b - (oc.length_squared() - r * r);
        let t = -b - disc.sqrt();
        (disc >= 0.0 && t > ray.t_min && t < t_max).then_some(t)
    }

    /// The clustered build over items whose pieces are two boxes each (the halves of each
    /// sphere's box, split along x): closest and any hit against brute force, and the same
    /// tree on one and two threads.
    #[test]
    fn clustered_build_is_correct_and_independent_of_threads() {
        let mut rnd = uniforms(5u64);
        let spheres: Vec<(DVec3, f64)> =
            (0..3000).map(|_| (DVec3::new(rnd(), rnd(), rnd()) * 10.0 - 5.0, 0.02 + 0.3 * rnd())).collect();
        let boxes: Vec<Aabb> = spheres.iter().map(|&(c, r)| Aabb::sphere(c, r)).collect();
        let items = || boxes.iter().enumerate().map(|(i, b)| BuildPrim::new(b, i as u32)).collect::<Vec<_>>();
        let halves = |indices: &[u32], out: &mut Vec<BuildPrim>| {
            for &i in indices {
                let b = boxes[i as usize];
                let mid = 0.5 * (b.min.x + b.max.x);
                out.push(BuildPrim::new(&Aabb { max: DVec3::new(mid, b.max.y, b.max.z), ..b }, i));
                out.push(BuildPrim::new(&Aabb { min: DVec3::new(mid, b.min.y, b.min.z), ..b }, i));
            }
        };
        let pool = |n| rayon::ThreadPoolBuilder::new().num_threads(n).build().unwrap();
        for cluster_max in [2, 3, 17, 500, 5000] {
            let one = pool(1).install(|| Bvh::build_grouped_in(items(), &halves, cluster_max, Boxes::Aligned));
            let two = pool(2).install(|| Bvh::build_grouped_in(items(), &halves, cluster_max, Boxes::Aligned));
            assert_eq!(one.prims, two.prims);
            assert_eq!(one.nodes, two.nodes);
            assert_eq!(two.prims.len(), 2 * spheres.len());
            let mut two = two;
            for level in SimdLevel::available() {
                two.set_simd_level(level);
                for _ in 0..250 {
                    let o = DVec3::new(rnd(), rnd(), rnd()) * 14.0 - 7.0;
                    let ray = Ray::new(o, (DVec3::new(rnd(), rnd(), rnd()) - 0.5).normalize());
                    let brute = spheres
                        .iter()
                        .filter_map(|&s| hit_sphere(&ray, s, f64::INFINITY))
                        .fold(f64::INFINITY, f64::min);
                    assert_eq!(two.traverse(&ray, |p, t_max| hit_sphere(&ray, spheres[p as usize], t_max)), brute);
                    assert_eq!(
                        two.any(&ray, |p| hit_sphere(&ray, spheres[p as usize], f64::INFINITY).is_some()),
                        brute.is_finite()
                    );
                }
            }
        }
    }

    /// Segment records along random strands (consecutive records near each other, as the
    /// pieces of a strand are), some of them degenerate.
    fn strand_records(seed: u64, n: usize) -> Vec<BuildPrim> {
        let mut rnd = uniforms(seed);
        let mut p = DVec3::ZERO;
        (0..n)
            .map(|i| {
                if i % 40 == 0 {
                    p = DVec3::new(rnd(), rnd(), rnd()) * 10.0;
                }
                let d = if i % 97 == 0 { DVec3::ZERO } else { (DVec3::new(rnd(), rnd(), rnd()) - 0.5) * 0.3 };
                let r = BuildPrim::segment(p, p + d, 0.001 + 0.01 * rnd(), i as u32);
                p += d;
                r
            })
            .collect()
    }

    /// Binning in two sets filled by turns gives the same bins as one set (every record
    /// counted once, the boxes exact), for every length's remainder.
    #[test]
    fn bins_in_two_sets_equal_one_set() {
        for n in [1, 2, 3, 17, 64, 1001] {
            let records = strand_records(n as u64, n);
            let (_, cb) = FBox::of(&records);
            let extent = cb.max - cb.min;
            let scale = Vec3A::select(extent.cmpgt(Vec3A::ZERO), Vec3A::splat(BINS as f32) / extent, Vec3A::ZERO);
            let (b1, n1) = bins::<1>(&records, cb.min, scale);
            let (b2, n2) = bins::<2>(&records, cb.min, scale);
            assert_eq!(n1, n2, "{n} records");
            assert_eq!(n1.iter().map(|a| a.iter().sum::<u32>()).collect::<Vec<_>>(), vec![n as u32; 3]);
            for (a, b) in b1.iter().flatten().zip(b2.iter().flatten()) {
                assert!(a.min == b.min && a.max == b.max, "{n} records: {a:?} against {b:?}");
            }
        }
    }

    /// `bin_of` is `(x as usize).min(BINS − 1)` for every kind of `f32`.
    #[test]
    fn bin_of_truncates_and_clamps_like_the_conversion_to_usize() {
        let mut xs = vec![
            f32::NAN,
            -f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            0.0,
            -0.0,
            f32::MIN_POSITIVE,
            -f32::MIN_POSITIVE,
            1e-45,
            -1e-45,
            f32::MAX,
            f32::MIN,
            2.0e9,
            3.0e9,
            -3.0e9,
            1e19,
            2e19,
        ];
        for k in -40..=40 {
            let x = k as f32 * 0.5;
            xs.extend([x, x.next_up(), x.next_down()]);
        }
        for x in xs {
            assert_eq!(bin_of(x), (x as usize).min(BINS - 1), "{x:e}");
        }
    }

    /// The sweep over the full bins finds the split (its cost and bin) that sweeping every bin
    /// finds, on bins from sparse to full and with equal costs (the first is kept).
    #[test]
    fn sweep_of_full_bins_equals_the_sweep_of_every_bin() {
        // The sweep of every bin, as the binned build did it before.
        let every_bin = |bin_box: &[FBox; BINS], bin_count: &[u32; BINS]| -> (f32, usize) {
            let (mut right_area, mut right_count) = ([0.0f32; BINS], [0u32; BINS]);
            let (mut acc, mut n) = (FBox::EMPTY, 0);
            for i in (1..BINS).rev() {
                acc = acc.union(bin_box[i]);
                n += bin_count[i];
                right_area[i] = acc.half_area();
                right_count[i] = n;
            }
            let (mut best_cost, mut best_split) = (f32::INFINITY, 0);
            let (mut acc, mut n) = (FBox::EMPTY, 0);
            for i in 1..BINS {
                acc = acc.union(bin_box[i - 1]);
                n += bin_count[i - 1];
                if n == 0 || right_count[i] == 0 {
                    continue;
                }
                let cost = acc.half_area() * n as f32 + right_area[i] * right_count[i] as f32;
                if cost < best_cost {
                    best_cost = cost;
                    best_split = i;
                }
            }
            (best_cost, best_split)
        };
        let mut rnd = uniforms(5);
        let mut splits = 0;
        for case in 0..3000 {
            let (mut boxes, mut counts) = ([FBox::EMPTY; BINS], [0u32; BINS]);
            let fill = [0.05, 0.2, 0.5, 1.0][case % 4];
            for k in 0..BINS {
                if rnd() < fill {
                    // Every few cases, boxes of one size: equal costs.
                    let (c, e) = if case % 5 == 0 {
                        (Vec3A::new(k as f32, 0.0, 0.0), Vec3A::splat(0.5))
                    } else {
                        (Vec3A::new(rnd() as f32, rnd() as f32, rnd() as f32) * 4.0, Vec3A::splat(rnd() as f32))
                    };
                    boxes[k] = FBox { min: c - e, max: c + e };
                    counts[k] = 1 + (rnd() * 5.0) as u32;
                }
            }
            let (cost, bin) = best_bin_split(&boxes, &counts);
            let (expected_cost, expected_bin) = every_bin(&boxes, &counts);
            assert_eq!(bin, expected_bin, "case {case}");
            assert!(
                cost == expected_cost || (bin == 0 && cost.is_infinite()),
                "case {case}: {cost} against {expected_cost}"
            );
            splits += usize::from(bin > 0);
        }
        assert!(splits > 2000, "too few cases with a split ({splits})");
    }

    /// The branch-free partition moves records as the swap loop does (record for record) and
    /// returns each side's centroid box exactly.
    #[test]
    fn partition_matches_the_swap_loop_and_boxes_the_centroids() {
        for n in [9, 100, 2000] {
            let records = strand_records(7 + n as u64, n);
            let (_, cb) = FBox::of(&records);
            let split = binned_split(&records, cb).expect("records that spread");
            let mut swapped = records.clone();
            let mut mid = 0;
            for i in 0..swapped.len() {
                if split.goes_left(&swapped[i]) {
                    swapped.swap(i, mid);
                    mid += 1;
                }
            }
            let mut moved = records.clone();
            let (m, [lc, rc]) = split.partition(&mut moved);
            assert_eq!(m, mid);
            assert!(0 < m && m < n, "{n} records: a split with both sides");
            let order = |v: &[BuildPrim]| v.iter().map(BuildPrim::index).collect::<Vec<_>>();
            assert_eq!(order(&moved), order(&swapped));
            for (side, c) in [(&moved[..m], lc), (&moved[m..], rc)] {
                let (_, expected) = FBox::of(side);
                assert!(c.min == expected.min && c.max == expected.max);
            }
        }
    }

    #[test]
    fn degenerate_inputs_build_and_traverse() {
        for level in SimdLevel::available() {
            degenerate_inputs_at(level);
        }
    }

    fn degenerate_inputs_at(level: SimdLevel) {
        let build = |b: &[Aabb]| {
            let mut bvh = Bvh::build(b);
            bvh.set_simd_level(level);
            bvh
        };
        let ray = Ray::new(DVec3::new(0.0, 0.0, -5.0), DVec3::Z);
        assert_eq!(build(&[]).traverse(&ray, |_, _| Some(1.0)), f64::INFINITY);
        // Many identical boxes: every one must still be reported.
        let same = vec![Aabb::sphere(DVec3::ZERO, 1.0); 1000];
        let bvh = build(&same);
        let mut seen = vec![false; 1000];
        bvh.traverse(&ray, |p, _| {
            seen[p as usize] = true;
            None
        });
        assert!(seen.iter().all(|&s| s));
        assert!(bvh.any(&ray, |p| p == 999));
        assert!(!bvh.any(&Ray::new(DVec3::new(5.0, 5.0, -5.0), DVec3::Z), |_| true));
        // Axis-parallel rays with zero direction components.
        let flat: Vec<Aabb> = (0..100).map(|i| Aabb::sphere(DVec3::new(i as f64, 0.0, 0.0), 0.1)).collect();
        let bvh = build(&flat);
        let mut hits = Vec::new();
        bvh.traverse(&Ray::new(DVec3::new(-1.0, 0.0, 0.0), DVec3::X), |p, _| {
            hits.push(p);
            None
        });
        assert_eq!(hits.len(), 100);
    }

    /// How many wide nodes have `c` used child slots, by `c`.
    fn width_histogram(bvh: &Bvh) -> [usize; WIDTH + 1] {
        let mut h = [0; WIDTH + 1];
        for n in &bvh.nodes.aabb {
            assert_eq!(n.used, (0..WIDTH).filter(|&k| n.child[k] != EMPTY_REF).fold(0, |m, k| m | 1 << k));
            h[n.used.count_ones() as usize] += 1;
        }
        h
    }

    /// Trees over 1 to 60 spheres, whose nodes have every number of children from 1 to 8:
    /// closest and any hit against brute force on both SIMD levels.
    #[test]
    fn small_trees_of_every_width_match_brute_force() {
        let mut rnd = uniforms(777u64);
        let mut widths = [0; WIDTH + 1];
        let mut hits = 0;
        for n in 1..=60 {
            let spheres: Vec<(DVec3, f64)> =
                (0..n).map(|_| (DVec3::new(rnd(), rnd(), rnd()) * 4.0 - 2.0, 0.1 + 0.4 * rnd())).collect();
            let bounds: Vec<Aabb> = spheres.iter().map(|&(c, r)| Aabb::sphere(c, r)).collect();
            let mut bvh = Bvh::build(&bounds);
            for (w, c) in widths.iter_mut().zip(width_histogram(&bvh)) {
                *w += c;
            }
            for level in SimdLevel::available() {
                bvh.set_simd_level(level);
                for _ in 0..300 {
                    let o = DVec3::new(rnd(), rnd(), rnd()) * 8.0 - 4.0;
                    let target = DVec3::new(rnd(), rnd(), rnd()) * 3.0 - 1.5;
                    let ray = Ray::new(o, (target - o).normalize());
                    let brute = spheres
                        .iter()
                        .filter_map(|&s| hit_sphere(&ray, s, f64::INFINITY))
                        .fold(f64::INFINITY, f64::min);
                    let t = bvh.traverse(&ray, |p, t_max| hit_sphere(&ray, spheres[p as usize], t_max));
                    assert_eq!(t, brute, "{} spheres, {}", n, level.name());
                    assert_eq!(
                        bvh.any(&ray, |p| hit_sphere(&ray, spheres[p as usize], f64::INFINITY).is_some()),
                        brute.is_finite()
                    );
                    hits += usize::from(brute.is_finite());
                }
            }
        }
        assert!(widths[1..].iter().all(|&w| w > 0), "nodes of every width must occur: {widths:?}");
        assert!(hits > 5000, "too few hits ({hits}) to be a test");
    }

    #[test]
    fn finds_the_nearest_of_many_random_spheres_like_brute_force() {
        let mut rnd = uniforms(12345u64);
        let spheres: Vec<(DVec3, f64)> =
            (0..500).map(|_| (DVec3::new(rnd(), rnd(), rnd()) * 10.0 - 5.0, 0.05 + 0.3 * rnd())).collect();
        let bounds: Vec<Aabb> = spheres.iter().map(|&(c, r)| Aabb::sphere(c, r)).collect();
        let bvh = Bvh::build(&bounds);
        let mut bvh = bvh;
        for level in SimdLevel::available() {
            bvh.set_simd_level(level);
            for _ in 0..2000 {
                let o = DVec3::new(rnd(), rnd(), rnd()) * 14.0 - 7.0;
                let d = (DVec3::new(rnd(), rnd(), rnd()) - 0.5).normalize();
                let ray = Ray::new(o, d);
                let brute =
                    spheres.iter().filter_map(|&s| hit_sphere(&ray, s, f64::INFINITY)).fold(f64::INFINITY, f64::min);
                let t = bvh.traverse(&ray, |p, t_max| hit_sphere(&ray, spheres[p as usize], t_max));
                assert_eq!(t, brute, "{}", level.name());
                assert_eq!(
                    bvh.any(&ray, |p| hit_sphere(&ray, spheres[p as usize], f64::INFINITY).is_some()),
                    brute.is_finite()
                );
            }
        }
    }

    /// The leaves (first primitive, count) under the reference `r`, through nodes of both kinds.
    fn leaves_of(bvh: &Bvh, r: u32, out: &mut Vec<(usize, usize)>) {
        let (child, used) = match ChildRef::count(r) {
            0 => (bvh.nodes.aabb[ChildRef::index(r) as usize].child, bvh.nodes.aabb[ChildRef::index(r) as usize].used),
            ORIENTED => {
                let n = &bvh.nodes.oriented[ChildRef::index(r) as usize];
                (n.child, n.used)
            }
            count => return out.push((ChildRef::index(r) as usize, count as usize)),
        };
        for (k, &c) in child.iter().enumerate() {
            if used & (1 << k) != 0 {
                leaves_of(bvh, c, out);
            }
        }
    }

    /// In a tree of segments, subtrees of at most MAX_LEAF records are not split: eight segments
    /// far apart are one leaf (a tree of their boxes splits them), and in larger sets every
    /// segment is in exactly one leaf of at most MAX_LEAF, the leaves fuller than the tree of
    /// boxes makes over the same records.
    #[test]
    fn segment_trees_do_not_split_below_a_full_leaf() {
        let mut rnd = uniforms(42u64);
        let mut segments = |n: usize| -> Vec<BuildPrim> {
            (0..n)
                .map(|i| {
                    let p = DVec3::new(rnd(), rnd(), rnd()) * 10.0;
                    let d = (DVec3::new(rnd(), rnd(), rnd()) - 0.5) * 0.4;
                    BuildPrim::segment(p, p + d, 0.001 + 0.01 * rnd(), i as u32)
                })
                .collect()
        };
        let leaves = |bvh: &Bvh| {
            let mut out = Vec::new();
            leaves_of(bvh, bvh.root, &mut out);
            out
        };
        let eight = segments(MAX_LEAF);
        assert_eq!(leaves(&Bvh::build_records_with(eight.clone(), Boxes::Oriented)), vec![(0, MAX_LEAF)]);
        assert!(leaves(&Bvh::build_records_with(eight, Boxes::Aligned)).len() > 1, "boxes far apart are split");
        for n in [9, 40, 500, 5000] {
            let records = segments(n);
            let mut mean_fill = [0.0; 2];
            for (fill, boxes) in mean_fill.iter_mut().zip([Boxes::Aligned, Boxes::Oriented]) {
                let bvh = Bvh::build_records_with(records.clone(), boxes);
                let found = leaves(&bvh);
                assert!(found.iter().all(|&(_, count)| (1..=MAX_LEAF).contains(&count)), "{found:?}");
                let mut seen: Vec<u32> =
                    found.iter().flat_map(|&(first, count)| bvh.prims[first..first + count].to_vec()).collect();
                seen.sort_unstable();
                assert_eq!(seen, (0..n as u32).collect::<Vec<_>>(), "{n} records, {boxes:?}");
                *fill = n as f64 / found.len() as f64;
            }
            assert!(mean_fill[1] > mean_fill[0], "{n} records: leaves of {mean_fill:?} records on average");
        }
    }

    /// Primitives under the wide node `n` (each leaf's range checked to hold at most MAX_LEAF),
    /// asserting that no interior child holds MAX_LEAF or fewer: such a subtree is one leaf.
    fn primitives_under(bvh: &Bvh, n: u32, seen: &mut Vec<u32>) -> usize {
        let node = &bvh.nodes.aabb[n as usize];
        let mut total = 0;
        for (k, &c) in node.child.iter().enumerate() {
            if node.used & (1 << k) == 0 {
                continue;
            }
            total += match ChildRef::count(c) {
                0 => {
                    let below = primitives_under(bvh, ChildRef::index(c), seen);
                    assert!(below > MAX_LEAF, "an interior child holds only {below} primitives");
                    below
                }
                count => {
                    assert!(count as usize <= MAX_LEAF);
                    let first = ChildRef::index(c) as usize;
                    seen.extend_from_slice(&bvh.prims[first..first + count as usize]);
                    count as usize
                }
            };
        }
        total
    }

    #[test]
    fn small_subtrees_are_single_leaves_and_every_primitive_is_in_one() {
        let mut rnd = uniforms(7u64);
        for n in [9, 40, 500, 5000] {
            let bounds: Vec<Aabb> =
                (0..n).map(|_| Aabb::sphere(DVec3::new(rnd(), rnd(), rnd()) * 10.0, 0.01 + 0.3 * rnd())).collect();
            let bvh = Bvh::build(&bounds);
            let mut seen = Vec::new();
            assert_eq!(primitives_under(&bvh, 0, &mut seen), n);
            seen.sort_unstable();
            assert_eq!(seen, (0..n as u32).collect::<Vec<_>>());
        }
    }
}
