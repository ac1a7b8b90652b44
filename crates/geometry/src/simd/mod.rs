//! The inner loops of ray tracing in explicit SIMD: the slab tests of a wide BVH node (axis-aligned,
//! and oriented: the ray rotated into each child's frame) and the `f32` pre-test of a leaf's
//! segments (distance to the axis, distances along the ray, the segment's ends), each in a
//! portable form (`glam`'s four-lane `Vec4`, SSE2 on x86-64) and, on x86-64 CPUs that have it,
//! an AVX2 form chosen at
//! run time. This is the one module of the crate allowed `unsafe` (ARCHITECTURE.md, "Unsafe
//! code: one audited SIMD module").
//!
//! # Dispatch
//! A [`SimdLevel`] is chosen once, when a tree is built ([`SimdLevel::best`]: CPU feature
//! detection), and kept with it. A query dispatches once, at its start: the AVX2 form runs the
//! whole walk inside `Avx2::run`, a function compiled with AVX2 enabled into which the walk
//! and its leaf tests are inlined; the portable form runs the same generic walk with
//! `Portable`. Both implement `Lanes`. Builds need no `target-cpu` flag.
//!
//! # Same results on every path
//! Both forms do the same IEEE-754 single-precision operations in the same order, lane by lane
//! (multiply then add, never fused; `max`/`min` with the SSE operand order; exact `u8 → f32`
//! conversions; correctly rounded division and square root), so they return the same bits; the
//! tests below check this on random and adversarial inputs, and the BVH-versus-brute-force
//! tests of `bvh` and `curves` run with both levels. Images are therefore identical whichever
//! path a machine takes.

#![allow(unsafe_code)]

use glam::{Vec3, Vec4};

#[cfg(target_arch = "x86_64")]
mod avx2;

/// Which instruction set the tree walks and leaf tests use. Holding [`SimdLevel`] with AVX2
/// selected proves that the CPU supports it: the only ways to get one check the CPU.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SimdLevel(Level);

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Level {
    Portable,
    #[cfg(target_arch = "x86_64")]
    Avx2,
}

impl SimdLevel {
    /// The portable form, available everywhere.
    pub const PORTABLE: Self = Self(Level::Portable);

    /// The best level this CPU supports (detected at run time), unless the environment
    /// variable [`SIMD_ENV`](Self::SIMD_ENV) is `portable` (to measure or check the portable form
    /// on any machine).
    #[must_use]
    pub fn best() -> Self {
        if std::env::var_os(Self::SIMD_ENV).is_some_and(|v| v == "portable") {
            return Self::PORTABLE;
        }
        Self::avx2().unwrap_or(Self::PORTABLE)
    }

    /// `FIBERLAB_SIMD`: set to `portable`, trees built afterwards use the portable form.
    pub const SIMD_ENV: &'static str = "FIBERLAB_SIMD";

    /// AVX2, if this CPU supports it.
    #[must_use]
    pub fn avx2() -> Option<Self> {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            return Some(Self(Level::Avx2));
        }
        None
    }

    /// The levels this CPU supports, portable first (for tests and benchmarks).
    #[must_use]
    pub fn available() -> Vec<Self> {
        std::iter::once(Self::PORTABLE).chain(Self::avx2()).collect()
    }

    /// The level's name: `portable` or `avx2`.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self.0 {
            Level::Portable => "portable",
            #[cfg(target_arch = "x86_64")]
            Level::Avx2 => "avx2",
        }
    }

    /// The AVX2 token when this level is AVX2.
    #[must_use]
    pub(crate) fn avx2_token(self) -> Option<Avx2> {
        match self.0 {
            Level::Portable => None,
            #[cfg(target_arch = "x86_64")]
            Level::Avx2 => Some(Avx2(())),
        }
    }
}

impl Default for SimdLevel {
    /// [`SimdLevel::best`].
    fn default() -> Self {
        Self::best()
    }
}

/// The per-ray choice of the near and far box rows by axis (from the signs of the direction).
/// Rows are those of a node's quantized grid: 0–2 the children's lower corners by axis, 3–5
/// the upper ones; the near (entry) row of axis `a` is `a` when the direction component is
/// ≥ 0, else `3 + a`, and the far row the other one.
#[derive(Clone, Copy, Debug)]
pub(crate) struct RowChoice {
    /// Per axis: true when the direction component is ≥ 0.
    positive: [bool; 3],
    /// Per axis: the byte offsets of the near and far rows in the 48 bytes of the grid
    /// (`8·row`, so at most 40: always eight bytes inside it; only [`RowChoice::new`] makes
    /// them).
    offsets: [[usize; 2]; 3],
}

impl RowChoice {
    /// The rows for a ray whose direction component on axis `a` is ≥ 0 when `positive[a]`.
    pub fn new(positive: [bool; 3]) -> Self {
        let offsets = [0, 1, 2].map(|a| {
            let (near, far) = if positive[a] { (a, 3 + a) } else { (3 + a, a) };
            [8 * near, 8 * far]
        });
        Self { positive, offsets }
    }

    /// The near row of `axis` (< 3).
    #[inline(always)]
    pub fn near(&self, axis: usize) -> usize {
        axis + 3 * usize::from(!self.positive[axis])
    }

    /// The far row of `axis` (< 3).
    #[inline(always)]
    pub fn far(&self, axis: usize) -> usize {
        axis + 3 * usize::from(self.positive[axis])
    }
}

/// The inputs of one node's slab test that do not depend on the child: per axis (lanes x, y,
/// z) the plane distance per grid step and the distances of the widened grid origin on the
/// near and far side.
#[derive(Clone, Copy, Debug)]
pub(crate) struct SlabTerms {
    /// Ray distance per quantization step.
    pub step: Vec4,
    /// Distance of the grid origin, lowered by the widening (near planes).
    pub lo: Vec4,
    /// Distance of the grid origin, raised by the widening (far planes).
    pub hi: Vec4,
    /// The ray's distance interval.
    pub t_min: f32,
    /// See `t_min`.
    pub t_max: f32,
}

/// The eight children of an oriented node as the kernel reads them (structure of arrays, one
/// lane per child): child `k`'s frame, rows `rot[row][..][k]` of small integers (a rotation
/// scaled by about 127 and rounded: exact as `f32`), and its box in that frame,
/// `lo[row][k] ≤ x_row ≤ hi[row][k]` with `x = rot·p` for points `p` relative to the node's
/// centre. An unused slot holds any finite values (the caller masks it).
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub(crate) struct OrientedBoxes {
    /// `rot[row][col][k]`: row `row` of child `k`'s frame.
    pub rot: [[[i8; 8]; 3]; 3],
    /// Lower corners in the children's frames.
    pub lo: [[f32; 8]; 3],
    /// Upper corners in the children's frames.
    pub hi: [[f32; 8]; 3],
}

/// The inputs of an oriented node's test that do not depend on the child.
#[derive(Clone, Copy, Debug)]
pub(crate) struct OrientedTerms {
    /// Ray origin relative to the node's centre.
    pub o: [f32; 3],
    /// Ray direction.
    pub d: [f32; 3],
    /// How far every box is widened (in the frames' scaled units): bounds the rounding of the
    /// test.
    pub widen: f32,
    /// The ray's distance interval.
    pub t_min: f32,
    /// See `t_min`.
    pub t_max: f32,
}

/// Smallest magnitude of a rotated direction component before its reciprocal: keeps the plane
/// distances finite (a box is never missed because of it: the slab then spans ±1e30 and more).
pub(crate) const MIN_ROTATED_DIRECTION: f32 = 1e-30;

/// The first eight `f32` of a segment, as the leaf test reads them: axis start point `x, y, z`,
/// unit axis `x, y, z`, length and radius.
pub(crate) type SegmentHead = [f32; 8];

/// A ray in `f32` for the leaf pre-test.
#[derive(Clone, Copy, Debug)]
pub(crate) struct RayF32 {
    /// Origin.
    pub o: Vec3,
    /// Unit direction.
    pub d: Vec3,
    /// The distances a hit may have, `t_min < t < t_max`.
    pub t_min: f32,
    /// See `t_min`.
    pub t_max: f32,
    /// A bound on the distance between the origin in `f32` and the ray's own: 1e-6 of the
    /// origin's magnitude, ten times the rounding.
    pub origin_error: f32,
}

impl RayF32 {
    /// The ray `o + t·d`, `t_min < t < t_max`, rounded to `f32`.
    pub fn new(o: glam::DVec3, d: glam::DVec3, t_min: f64, t_max: f64) -> Self {
        let o32 = o.as_vec3();
        Self { o: o32, d: d.as_vec3(), t_min: t_min as f32, t_max: t_max as f32, origin_error: o32.length() * 1e-6 }
    }
}

/// The two kernels, in one instruction set.
pub(crate) trait Lanes: Copy {
    /// The slab test of a node's eight children: bit `k` of the mask is set when the ray's
    /// interval meets child `k`'s box, widened by the relative `4ε` of the far distance (the
    /// caller masks unused slots); also the entry distances. `q`: the node's quantized
    /// coordinates, rows 0–2 lower and 3–5 upper corners by axis, one byte per child.
    fn slab(self, q: &[[u8; 8]; 6], rows: &RowChoice, terms: &SlabTerms) -> (u32, [f32; 8]);

    /// [`Lanes::slab`], then for the hit children among `used` (bit mask of the node's slots)
    /// their traversal keys, in child order, into `keys[..m]` (`m`: the number of them; the
    /// rest of `keys` is left unspecified); returns the hit mask. A child's key is its entry
    /// distance, clamped below at 0 (`max(t, 0)`), as `f32` bits above its reference `child[k]`.
    /// The provided form makes the keys one hit child at a time (the portable form's).
    #[inline(always)]
    fn slab_keys(
        self,
        q: &[[u8; 8]; 6],
        rows: &RowChoice,
        terms: &SlabTerms,
        used: u32,
        child: &[u32; 8],
        keys: &mut [u64; 8],
    ) -> u32 {
        let (hit, t) = self.slab(q, rows, terms);
        portable_keys(hit & used, &t, child, keys)
    }

    /// The slab test of an oriented node's eight children, each in its own frame: the ray's
    /// origin and direction are rotated per child, and bit `k` of the mask is set when its
    /// interval meets child `k`'s box widened by `terms.widen` on every side (within the
    /// relative `4ε` of the far distance); also the entry distances.
    fn oriented(self, boxes: &OrientedBoxes, terms: &OrientedTerms) -> (u32, [f32; 8]);

    /// [`Lanes::oriented`], then the hit used children's keys as [`Lanes::slab_keys`] makes them.
    #[inline(always)]
    fn oriented_keys(
        self,
        boxes: &OrientedBoxes,
        terms: &OrientedTerms,
        used: u32,
        child: &[u32; 8],
        keys: &mut [u64; 8],
    ) -> u32 {
        let (hit, t) = self.oriented(boxes, terms);
        portable_keys(hit & used, &t, child, keys)
    }

    /// Bit `k` (`k < n ≤ 8`) clear only when the ray certainly does not enter the tube of
    /// segment `head(k)` within `(t_min, t_max)`: its line passes farther from the axis than
    /// the radius, or the stretch of the ray inside the (widened) infinite cylinder lies outside
    /// the distances, or outside the axis from `−2r` to `length + 2r` (a mitered end reaches at
    /// most `√3·r` beyond the axis' ends). Every bound is widened by more than the `f32`
    /// rounding of the inputs (relative 1e-5 of the origin's distance from the segment start
    /// and of the distances, far above the ~1e-7 actually incurred; 1e-6 of the origin's
    /// magnitude). A ray within 1e-6 of parallel to the axis always passes. `head` is also
    /// called for lanes `n..8` (it may repeat a segment there); their bits are cleared.
    fn near_axis(self, ray: &RayF32, head: impl Fn(usize) -> SegmentHead, n: usize) -> u32;
}

/// The portable form: four `Vec4` lanes.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Portable;

impl Lanes for Portable {
    /// Two halves of four lanes, children 0–3 then 4–7, each with the operations of the AVX2
    /// form's eight lanes in the same order.
    #[inline(always)]
    fn slab(self, q: &[[u8; 8]; 6], rows: &RowChoice, terms: &SlabTerms) -> (u32, [f32; 8]) {
        let (step, lo, hi) = (terms.step.to_array(), terms.lo.to_array(), terms.hi.to_array());
        let mut mask = 0;
        let mut entry = [0.0; 8];
        for half in 0..2 {
            let row = |r: usize| {
                let q = &q[r][4 * half..4 * half + 4];
                Vec4::new(f32::from(q[0]), f32::from(q[1]), f32::from(q[2]), f32::from(q[3]))
            };
            let mut t0 = Vec4::splat(terms.t_min);
            let mut t1 = Vec4::splat(terms.t_max);
            for axis in 0..3 {
                let s = Vec4::splat(step[axis]);
                let near = row(rows.near(axis)) * s + Vec4::splat(lo[axis]);
                let far = row(rows.far(axis)) * s + Vec4::splat(hi[axis]);
                t0 = t0.max(near);
                t1 = t1.min(far);
            }
            record_half(t0, t1, half, &mut mask, &mut entry);
        }
        (mask, entry)
    }

    /// Two halves of four lanes, children 0–3 then 4–7, each with the operations of the AVX2
    /// form's eight lanes in the same order.
    #[inline(always)]
    fn oriented(self, boxes: &OrientedBoxes, terms: &OrientedTerms) -> (u32, [f32; 8]) {
        let [ox, oy, oz] = terms.o.map(Vec4::splat);
        let [dx, dy, dz] = terms.d.map(Vec4::splat);
        let widen = Vec4::splat(terms.widen);
        let mut mask = 0;
        let mut entry = [0.0; 8];
        for half in 0..2 {
            let lanes = |a: &[f32; 8]| Vec4::from_slice(&a[4 * half..4 * half + 4]);
            let ints = |a: &[i8; 8]| {
                let a = &a[4 * half..4 * half + 4];
                Vec4::new(f32::from(a[0]), f32::from(a[1]), f32::from(a[2]), f32::from(a[3]))
            };
            let mut t0 = Vec4::splat(terms.t_min);
            let mut t1 = Vec4::splat(terms.t_max);
            for row in 0..3 {
                let [r0, r1, r2] = [0, 1, 2].map(|c| ints(&boxes.rot[row][c]));
                let d = r0 * dx + r1 * dy + r2 * dz;
                let o = r0 * ox + r1 * oy + r2 * oz;
                let inv = Vec4::ONE / d.abs().max(Vec4::splat(MIN_ROTATED_DIRECTION)).copysign(d);
                let t_lo = (lanes(&boxes.lo[row]) - widen - o) * inv;
                let t_hi = (lanes(&boxes.hi[row]) + widen - o) * inv;
                t0 = t0.max(t_lo.min(t_hi));
                t1 = t1.min(t_lo.max(t_hi));
            }
            record_half(t0, t1, half, &mut mask, &mut entry);
        }
        (mask, entry)
    }

    #[inline(always)]
    fn near_axis(self, ray: &RayF32, head: impl Fn(usize) -> SegmentHead, n: usize) -> u32 {
        let mut mask = 0;
        for chunk in 0..n.div_ceil(4) {
            let h = [head(4 * chunk), head(4 * chunk + 1), head(4 * chunk + 2), head(4 * chunk + 3)];
            let gather = |i: usize| Vec4::new(h[0][i], h[1][i], h[2][i], h[3][i]);
            let near = near_axis_lanes(ray, std::array::from_fn(gather));
            let lanes = (1u32 << (n - 4 * chunk).min(4)) - 1;
            mask |= (near & lanes) << (4 * chunk);
        }
        mask
    }
}

/// The hit bits (`t0 ≤ t1` within the relative `4ε` of the far distance) and entry distances of
/// lanes `4·half .. 4·half + 4`, for the portable node tests.
#[inline(always)]
fn record_half(t0: Vec4, t1: Vec4, half: usize, mask: &mut u32, entry: &mut [f32; 8]) {
    *mask |= t0.cmple(t1 * (1.0 + 4.0 * f32::EPSILON)).bitmask() << (4 * half);
    entry[4 * half..4 * half + 4].copy_from_slice(&t0.to_array());
}

/// The keys of the children in `mask` (child order) into `keys[..m]`, one hit child at a time;
/// returns `mask`.
#[inline(always)]
fn portable_keys(mask: u32, t: &[f32; 8], child: &[u32; 8], keys: &mut [u64; 8]) -> u32 {
    let (mut bits, mut m) = (mask, 0);
    while bits != 0 {
        let k = bits.trailing_zeros() as usize;
        bits &= bits - 1;
        // `max` with the SSE operand order (0 when `t` is NaN or a zero of either sign).
        let t = if t[k] > 0.0 { t[k] } else { 0.0 };
        keys[m] = (u64::from(t.to_bits()) << 32) | u64::from(child[k]);
        m += 1;
    }
    mask
}

/// The leaf pre-test on four lanes; `f`: the [`SegmentHead`] fields (segment start `x, y, z`,
/// axis `x, y, z`, length, radius).
#[inline(always)]
fn near_axis_lanes(ray: &RayF32, f: [Vec4; 8]) -> u32 {
    let [px, py, pz, ax, ay, az, length, radius] = f;
    let (ox, oy, oz) = (Vec4::splat(ray.o.x) - px, Vec4::splat(ray.o.y) - py, Vec4::splat(ray.o.z) - pz);
    let (dx, dy, dz) = (Vec4::splat(ray.d.x), Vec4::splat(ray.d.y), Vec4::splat(ray.d.z));
    let d_along = dx * ax + dy * ay + dz * az;
    let (ux, uy, uz) = (dx - ax * d_along, dy - ay * d_along, dz - az * d_along);
    let o_along = ox * ax + oy * ay + oz * az;
    let (wx, wy, wz) = (ox - ax * o_along, oy - ay * o_along, oz - az * o_along);
    let aa = ux * ux + uy * uy + uz * uz;
    // The closest approach as a vector (no cancellation between large terms).
    let t = (wx * ux + wy * uy + wz * uz) / aa.max(Vec4::splat(1e-30));
    let (qx, qy, qz) = (wx - ux * t, wy - uy * t, wz - uz * t);
    let position_error = (Vec4::ONE + (ox * ox + oy * oy + oz * oz).sqrt()) * 1e-5 + Vec4::splat(ray.origin_error);
    let wide = radius + position_error;
    let near = (qx * qx + qy * qy + qz * qz).cmplt(wide * wide);
    // The ray is inside the widened cylinder for distances around `t_c` (the closest
    // approach), and enters it at most `wide / √aa` before.
    let inverse = Vec4::ONE / aa.max(Vec4::splat(1e-30)).sqrt();
    let t_c = Vec4::ZERO - t;
    let error = (wide * 1e-5 + position_error) * inverse + t_c.abs() * 1e-5;
    let first = (t_c - wide * inverse - error).max(Vec4::splat(ray.t_min));
    let last = (t_c + error).min(Vec4::splat(ray.t_max));
    let (s_first, s_last) = (o_along + d_along * first, o_along + d_along * last);
    let margin = radius * 2.0 + wide + error;
    let within =
        first.cmple(last) & s_first.max(s_last).cmpge(Vec4::ZERO - margin) & s_first.min(s_last).cmple(length + margin);
    ((near & within) | aa.cmplt(Vec4::splat(1e-12))).bitmask()
}

/// The AVX2 form: eight lanes. A value of this type exists only on a CPU with AVX2 (it is made
/// by [`SimdLevel::avx2_token`] from a level that detection returned).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Avx2(());

impl Avx2 {
    /// Runs `f` inside a function compiled with AVX2 enabled, so that `f`'s body (a whole walk,
    /// inlined) uses AVX2 throughout and the kernels inline into it.
    #[inline(always)]
    pub fn run<R>(self, f: impl FnOnce() -> R) -> R {
        #[cfg(target_arch = "x86_64")]
        {
            // SAFETY: `self` exists only when `is_x86_feature_detected!("avx2")` returned true
            // (`SimdLevel::avx2`), so the AVX2 instructions of `with_avx2` are supported.
            unsafe { avx2::with_avx2(f) }
        }
        #[cfg(not(target_arch = "x86_64"))]
        f()
    }
}

impl Lanes for Avx2 {
    #[inline(always)]
    fn slab(self, q: &[[u8; 8]; 6], rows: &RowChoice, terms: &SlabTerms) -> (u32, [f32; 8]) {
        #[cfg(target_arch = "x86_64")]
        {
            // SAFETY: as in `Avx2::run`: this CPU has AVX2.
            unsafe { avx2::slab(q, &rows.offsets, terms) }
        }
        #[cfg(not(target_arch = "x86_64"))]
        Portable.slab(q, rows, terms)
    }

    #[inline(always)]
    fn slab_keys(
        self,
        q: &[[u8; 8]; 6],
        rows: &RowChoice,
        terms: &SlabTerms,
        used: u32,
        child: &[u32; 8],
        keys: &mut [u64; 8],
    ) -> u32 {
        #[cfg(target_arch = "x86_64")]
        {
            // SAFETY: as in `Avx2::run`: this CPU has AVX2.
            unsafe { avx2::slab_keys(q, &rows.offsets, terms, used, child, keys) }
        }
        #[cfg(not(target_arch = "x86_64"))]
        Portable.slab_keys(q, rows, terms, used, child, keys)
    }

    #[inline(always)]
    fn oriented(self, boxes: &OrientedBoxes, terms: &OrientedTerms) -> (u32, [f32; 8]) {
        #[cfg(target_arch = "x86_64")]
        {
            // SAFETY: as in `Avx2::run`: this CPU has AVX2.
            unsafe { avx2::oriented(boxes, terms) }
        }
        #[cfg(not(target_arch = "x86_64"))]
        Portable.oriented(boxes, terms)
    }

    #[inline(always)]
    fn oriented_keys(
        self,
        boxes: &OrientedBoxes,
        terms: &OrientedTerms,
        used: u32,
        child: &[u32; 8],
        keys: &mut [u64; 8],
    ) -> u32 {
        #[cfg(target_arch = "x86_64")]
        {
            // SAFETY: as in `Avx2::run`: this CPU has AVX2.
            unsafe { avx2::oriented_keys(boxes, terms, used, child, keys) }
        }
        #[cfg(not(target_arch = "x86_64"))]
        Portable.oriented_keys(boxes, terms, used, child, keys)
    }

    #[inline(always)]
    fn near_axis(self, ray: &RayF32, head: impl Fn(usize) -> SegmentHead, n: usize) -> u32 {
        #[cfg(target_arch = "x86_64")]
        {
            let heads = [head(0), head(1), head(2), head(3), head(4), head(5), head(6), head(7)];
            // SAFETY: as in `Avx2::run`: this CPU has AVX2.
            let near = unsafe { avx2::near_axis(ray, &heads) };
            near & ((1u32 << n) - 1)
        }
        #[cfg(not(target_arch = "x86_64"))]
        Portable.near_axis(ray, head, n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Lcg(u64);
    impl Lcg {
        fn next(&mut self) -> f32 {
            self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((self.0 >> 40) as f32) / (1u64 << 24) as f32
        }
        fn vec(&mut self) -> Vec3 {
            Vec3::new(self.next(), self.next(), self.next())
        }
        /// A value spanning many orders of magnitude, either sign, sometimes exactly 0.
        fn wild(&mut self) -> f32 {
            let e = (self.next() * 80.0) as i32 - 40;
            let v = 2f32.powi(e) * (1.0 + self.next());
            match (self.next() * 8.0) as u32 {
                0 => 0.0,
                1..=3 => -v,
                _ => v,
            }
        }
    }

    /// Leaf pre-test inputs: hair-like, parallel, crossing, degenerate, huge and tiny radii;
    /// segment lengths from a tenth of the radius to ten units, distance intervals from short to
    /// unbounded, origins near and far from the world's origin.
    fn leaf_cases(g: &mut Lcg, case: u32) -> (RayF32, [SegmentHead; 8], usize) {
        let n = 1 + (g.next() * 8.0) as usize % 8;
        let mut heads = [[0.0; 8]; 8];
        let far = if g.next() < 0.25 { Vec3::splat(1000.0) } else { Vec3::ZERO };
        let o = (g.vec() - 0.5) * 4.0 + far;
        let d = (g.vec() - 0.5).normalize_or(Vec3::X);
        for h in &mut heads {
            let (p, a, r) = match case {
                // Hair: short segments around the unit sphere, radius ~0.002.
                0 => ((g.vec() - 0.5) * 2.0 + far, (g.vec() - 0.5).normalize_or(Vec3::Y), 0.002 * (0.5 + g.next())),
                // Parallel to the ray (the `aa` guard), or nearly.
                1 => ((g.vec() - 0.5) * 0.01 + o, (d + (g.vec() - 0.5) * 1e-6).normalize(), 0.001),
                // Crossing the ray's line at distances around the radius.
                2 => {
                    let at = o + d * (g.next() * 3.0);
                    let a = d.cross(g.vec() - 0.5).normalize_or(Vec3::Z);
                    let p = at + d.cross(a).normalize_or(Vec3::X) * (0.01 * (g.next() - 0.5) * 2.1);
                    (p - a * (g.next() * 0.05), a, 0.01)
                }
                // Degenerate axes (zero) and radii (zero).
                3 => (
                    g.vec() + far,
                    if g.next() < 0.5 { Vec3::ZERO } else { Vec3::Z },
                    if g.next() < 0.5 { 0.0 } else { 0.1 },
                ),
                // Huge and tiny magnitudes.
                _ => (
                    Vec3::new(g.wild(), g.wild(), g.wild()),
                    Vec3::new(g.wild(), g.wild(), g.wild()).normalize_or(Vec3::X),
                    g.wild().abs(),
                ),
            };
            let length = match (g.next() * 4.0) as u32 {
                0 => r * 0.1,
                1 => r * 16.0,
                2 => g.next() * 10.0,
                _ => {
                    if case == 4 {
                        g.wild().abs()
                    } else {
                        0.05 * g.next()
                    }
                }
            };
            *h = [p.x, p.y, p.z, a.x, a.y, a.z, length, r];
        }
        let t_min = if g.next() < 0.5 { 0.0 } else { 1e-4 * g.next() };
        let t_max = if g.next() < 0.3 { f32::INFINITY } else { t_min + 4.0 * g.next() };
        let origin_error = o.length() * 1e-6;
        (RayF32 { o, d, t_min, t_max, origin_error }, heads, n)
    }

    /// Where the ray enters the tube of `head` (the infinite cylinder cut by planes normal to
    /// the axis at `−√3·r` and `length + √3·r`: every mitered tube lies inside), in `f64`; `None`
    /// when it does not within `(t_min, t_max)`.
    fn enters(ray: &RayF32, h: &SegmentHead) -> Option<f64> {
        let (p, a) = (Vec3::new(h[0], h[1], h[2]).as_dvec3(), Vec3::new(h[3], h[4], h[5]).as_dvec3());
        let (o, d) = (ray.o.as_dvec3(), ray.d.as_dvec3());
        let (length, r) = (f64::from(h[6]), f64::from(h[7]));
        let a = a.normalize_or_zero();
        let u = d - a * d.dot(a);
        let w = (o - p) - a * (o - p).dot(a);
        let aa = u.length_squared();
        if aa < 1e-20 {
            return None;
        }
        let t_c = -w.dot(u) / aa;
        let q2 = (w + u * t_c).length_squared();
        if q2 >= r * r {
            return None;
        }
        let t = t_c - ((r * r - q2) / aa).sqrt();
        let s = (o + d * t - p).dot(a);
        let reach = 3f64.sqrt() * r;
        (t > f64::from(ray.t_min) && t < f64::from(ray.t_max) && s >= -reach && s <= length + reach).then_some(t)
    }

    /// The pre-test must never clear the bit of a segment whose tube the ray enters within its
    /// distances (checked in `f64`), and must clear most of those it misses.
    #[test]
    fn leaf_pre_test_keeps_every_entered_tube() {
        let mut g = Lcg(5);
        let (mut kept, mut missed, mut cleared) = (0, 0, 0);
        for i in 0..40_000 {
            let (ray, heads, n) = leaf_cases(&mut g, i % 5);
            for level in SimdLevel::available() {
                let mask = match level.avx2_token() {
                    Some(k) => k.run(|| k.near_axis(&ray, |j| heads[j], n)),
                    None => Portable.near_axis(&ray, |j| heads[j], n),
                };
                assert_eq!(mask >> n, 0, "bits beyond the leaf");
                for (k, h) in heads[..n].iter().enumerate() {
                    if enters(&ray, h).is_some() {
                        assert_ne!(mask & (1 << k), 0, "{}: entered tube dropped: {h:?} {ray:?}", level.name());
                        kept += 1;
                    } else if i % 5 != 1 {
                        missed += 1;
                        cleared += u32::from(mask & (1 << k) == 0);
                    }
                }
            }
        }
        assert!(kept > 2000, "too few entered tubes ({kept}) to be a test");
        assert!(f64::from(cleared) > 0.9 * f64::from(missed), "{cleared} of {missed} missed tubes cleared");
    }

    /// The pre-test clears tubes that the ray's line passes through outside the distances or
    /// beyond the segment's ends (a segment crossed squarely, with the interval or the segment
    /// moved away from the crossing).
    #[test]
    fn leaf_pre_test_clears_crossings_outside_the_interval_and_the_segment() {
        let r = 0.01;
        let crossing = |t_max: f32, start: f32, length: f32| {
            let ray = RayF32 { o: Vec3::ZERO, d: Vec3::X, t_min: 0.0, t_max, origin_error: 0.0 };
            // The axis runs along y through (1, 0, 0), from y = start to start + length.
            let head = [1.0, start, 0.0, 0.0, 1.0, 0.0, length, r];
            SimdLevel::available()
                .into_iter()
                .map(|level| match level.avx2_token() {
                    Some(k) => k.run(|| k.near_axis(&ray, |_| head, 1)),
                    None => Portable.near_axis(&ray, |_| head, 1),
                })
                .collect::<Vec<_>>()
        };
        for level_mask in crossing(2.0, -0.5, 1.0) {
            assert_eq!(level_mask, 1, "a plain crossing passes");
        }
        for level_mask in crossing(0.9, -0.5, 1.0) {
            assert_eq!(level_mask, 0, "a crossing beyond t_max is cleared");
        }
        for level_mask in crossing(2.0, 0.5, 1.0) {
            assert_eq!(level_mask, 0, "a crossing before the segment's start is cleared");
        }
        for level_mask in crossing(2.0, -1.5, 1.0) {
            assert_eq!(level_mask, 0, "a crossing after the segment's end is cleared");
        }
        for level_mask in crossing(2.0, 1.5 * r, 1.0) {
            assert_eq!(level_mask, 1, "a crossing within the reach of a mitered end passes");
        }
    }

    #[test]
    fn leaf_pre_test_is_the_same_on_every_level() {
        let Some(k) = SimdLevel::avx2().and_then(SimdLevel::avx2_token) else {
            eprintln!("no AVX2 on this CPU: only the portable form runs");
            return;
        };
        let mut g = Lcg(7);
        let (mut set, mut clear) = (0, 0);
        for i in 0..100_000 {
            let (ray, heads, n) = leaf_cases(&mut g, i % 5);
            let a = Portable.near_axis(&ray, |j| heads[j], n);
            let b = k.run(|| k.near_axis(&ray, |j| heads[j], n));
            assert_eq!(a, b, "case {}: {heads:?} {ray:?} n {n}", i % 5);
            set += a.count_ones();
            clear += n as u32 - a.count_ones();
        }
        assert!(set > 10_000 && clear > 10_000, "{set} set, {clear} clear: both outcomes must occur");
    }

    /// Random quantized nodes, rays and intervals, including huge and tiny terms (infinite and
    /// NaN plane distances arise from them) and rays along the axes.
    #[test]
    fn slab_test_is_the_same_on_every_level() {
        let Some(k) = SimdLevel::avx2().and_then(SimdLevel::avx2_token) else {
            eprintln!("no AVX2 on this CPU: only the portable form runs");
            return;
        };
        let mut g = Lcg(11);
        let mut hits = [0u32; 9];
        for i in 0..100_000 {
            // Child boxes with lower ≤ upper corner (in some nodes all of them large, so that
            // all eight children are hit often enough), a direction sign per axis with the
            // step's sign matching it, plane distances around the ray's interval.
            let mut q = [[0u8; 8]; 6];
            let (lower, upper) = q.split_at_mut(3);
            let large = i % 3 == 0;
            for (l, u) in lower.iter_mut().flatten().zip(upper.iter_mut().flatten()) {
                let (a, b) = ((g.next() * 256.0) as u8, (g.next() * 256.0) as u8);
                (*l, *u) = if large { (a / 8, 255 - b / 8) } else { (a.min(b), a.max(b)) };
            }
            let positive = [g.next() < 0.5, g.next() < 0.5, g.next() < 0.5];
            let rows = RowChoice::new(positive);
            let wild = i % 4 == 3;
            let mut term = |a: usize| {
                let m = if wild { g.wild().abs() } else { 0.02 * g.next() };
                if positive[a] { m } else { -m }
            };
            let step = Vec4::new(term(0), term(1), term(2), 0.0);
            let base = -step * 128.0 + Vec4::new(g.next(), g.next(), g.next(), 0.0);
            let widen = Vec4::new(g.next(), g.next(), g.next(), 0.0) * 1e-3;
            let t_min = if wild { g.wild() } else { g.next() - 0.5 };
            let t_max = if g.next() < 0.2 { f32::INFINITY } else { t_min + g.next() * 4.0 };
            let mut terms = SlabTerms { step, lo: base - widen, hi: base + widen, t_min, t_max };
            if i % 4 == 1 {
                // The far end just below a child's entry, within the test's relative 4ε.
                let (_, t) = Portable.slab(&q, &rows, &terms);
                terms.t_max = t[i / 4 % 8] * (1.0 - 3.0 * f32::EPSILON);
            }
            let (ma, ta) = Portable.slab(&q, &rows, &terms);
            let (mb, tb) = k.run(|| k.slab(&q, &rows, &terms));
            assert_eq!(ma, mb, "{q:?} {rows:?} {terms:?}");
            assert_eq!(ta.map(f32::to_bits), tb.map(f32::to_bits), "{q:?} {rows:?} {terms:?}");
            hits[ma.count_ones() as usize] += 1;
            // The keys of the hit children among the used ones, on both levels; references
            // with every bit pattern.
            let used = (g.next() * 256.0) as u32 | if i % 2 == 0 { 0xFF } else { 0 };
            let child = [0; 8].map(|_| (g.next() * 65536.0) as u32 | ((g.next() * 65536.0) as u32) << 16);
            let (mut ka, mut kb) = ([0u64; 8], [0u64; 8]);
            let sa = Portable.slab_keys(&q, &rows, &terms, used, &child, &mut ka);
            let sb = k.run(|| k.slab_keys(&q, &rows, &terms, used, &child, &mut kb));
            assert_eq!((sa, sb), (ma & used, ma & used));
            let m = sa.count_ones() as usize;
            assert_eq!(ka[..m], kb[..m], "{q:?} {rows:?} {terms:?} used {used:#x}");
        }
        assert!(hits.iter().all(|&h| h > 100), "every number of hit children must occur: {hits:?}");
    }

    /// Random oriented nodes: integer frames (some the identity, some degenerate), boxes around
    /// the origin's image, and rays with huge, tiny and zero direction components in a frame.
    fn oriented_case(g: &mut Lcg, i: usize) -> (OrientedBoxes, OrientedTerms) {
        let mut b = OrientedBoxes { rot: [[[0; 8]; 3]; 3], lo: [[0.0; 8]; 3], hi: [[0.0; 8]; 3] };
        for k in 0..8 {
            for row in 0..3 {
                for col in 0..3 {
                    b.rot[row][col][k] = match i % 5 {
                        // The identity: rotated direction components exactly zero for axis rays.
                        0 => 127 * i8::from(row == col),
                        // Small integers: degenerate (even zero) rows occur.
                        1 => (g.next() * 5.0) as i8 - 2,
                        _ => (g.next() * 254.0) as i8 - 127,
                    };
                }
                // In some nodes most boxes hold the origin's image (most children hit).
                let huge = i % 9 == 8 && (k * 7 + i / 9) % 8 < 6 + (i / 9) % 3;
                let (a, c) = if huge { (0.0, 2000.0) } else { ((g.next() - 0.5) * 400.0, g.next() * 200.0) };
                (b.lo[row][k], b.hi[row][k]) = (a - c, a + c);
            }
        }
        let wild = i % 7 == 6;
        let o = if wild { [g.wild(), g.wild(), g.wild()] } else { [0; 3].map(|_| (g.next() - 0.5) * 8.0) };
        let d = match i % 4 {
            0 => [1.0, 0.0, 0.0],
            1 => [0.0, -1.0, 0.0],
            _ => (g.vec() - 0.5).normalize_or(Vec3::Z).to_array(),
        };
        let t_min = if wild { g.wild() } else { g.next() - 0.5 };
        let t_max = if g.next() < 0.2 { f32::INFINITY } else { t_min.abs() + g.next() * 20.0 };
        (b, OrientedTerms { o, d, widen: g.next() * 0.5, t_min, t_max })
    }

    #[test]
    fn oriented_test_is_the_same_on_every_level() {
        let Some(k) = SimdLevel::avx2().and_then(SimdLevel::avx2_token) else {
            eprintln!("no AVX2 on this CPU: only the portable form runs");
            return;
        };
        let mut g = Lcg(23);
        let mut hits = [0u32; 9];
        for i in 0..100_000 {
            let (b, terms) = oriented_case(&mut g, i);
            let (ma, ta) = Portable.oriented(&b, &terms);
            let (mb, tb) = k.run(|| k.oriented(&b, &terms));
            assert_eq!(ma, mb, "{b:?} {terms:?}");
            assert_eq!(ta.map(f32::to_bits), tb.map(f32::to_bits), "{b:?} {terms:?}");
            hits[ma.count_ones() as usize] += 1;
            let used = (g.next() * 256.0) as u32 | if i % 2 == 0 { 0xFF } else { 0 };
            let child = [0; 8].map(|_| (g.next() * 65536.0) as u32 | ((g.next() * 65536.0) as u32) << 16);
            let (mut ka, mut kb) = ([0u64; 8], [0u64; 8]);
            let sa = Portable.oriented_keys(&b, &terms, used, &child, &mut ka);
            let sb = k.run(|| k.oriented_keys(&b, &terms, used, &child, &mut kb));
            assert_eq!((sa, sb), (ma & used, ma & used));
            let m = sa.count_ones() as usize;
            assert_eq!(ka[..m], kb[..m], "{b:?} {terms:?} used {used:#x}");
        }
        assert!(hits.iter().all(|&h| h > 100), "every number of hit children must occur: {hits:?}");
    }

    /// The portable oriented test against the plain definition, in `f64`: per child, the ray
    /// mapped by the child's frame, its interval in each widened slab, their intersection. The
    /// `f32` distances may differ by the rounding of the rotated terms, which grows with the
    /// condition of each dot product (bounded here per plane, with a factor 4 to spare); where
    /// the two intervals' ends are further apart than that, the decision must agree.
    #[test]
    fn portable_oriented_test_is_the_interval_intersection() {
        let mut g = Lcg(29);
        let (mut checked, mut hit) = (0, 0);
        let eps = f64::from(f32::EPSILON);
        for i in 0..20_000 {
            let (b, terms) = oriented_case(&mut g, i % 6);
            let (mask, t) = Portable.oriented(&b, &terms);
            for k in 0..8 {
                // The interval's ends and a bound on their rounding in the `f32` form.
                let (mut t0, mut t1) = ((f64::from(terms.t_min), 0.0), (f64::from(terms.t_max), 0.0));
                for row in 0..3 {
                    let r = [0, 1, 2].map(|c| f64::from(b.rot[row][c][k]));
                    let d: f64 = (0..3).map(|c| r[c] * f64::from(terms.d[c])).sum();
                    let o: f64 = (0..3).map(|c| r[c] * f64::from(terms.o[c])).sum();
                    let d_abs: f64 = (0..3).map(|c| (r[c] * f64::from(terms.d[c])).abs()).sum();
                    let o_abs: f64 = (0..3).map(|c| (r[c] * f64::from(terms.o[c])).abs()).sum();
                    let w = f64::from(terms.widen);
                    let d = if d.abs() < f64::from(MIN_ROTATED_DIRECTION) {
                        f64::from(MIN_ROTATED_DIRECTION).copysign(d)
                    } else {
                        d
                    };
                    let (lo, hi) = (f64::from(b.lo[row][k]) - w, f64::from(b.hi[row][k]) + w);
                    let (a, c) = ((lo - o) / d, (hi - o) / d);
                    // |Δt| ≲ (|Δo| + |Δ(lo − o)| + |t| |Δd|) / |d|, each a few ulps of its terms.
                    let err = |t: f64, plane: f64| {
                        16.0 * eps * (o_abs + plane.abs() + w + o.abs() + t.abs() * (d_abs + d.abs())) / d.abs()
                    };
                    let (near, far) =
                        if a <= c { ((a, err(a, lo)), (c, err(c, hi))) } else { ((c, err(c, hi)), (a, err(a, lo))) };
                    if near.0 > t0.0 {
                        t0 = near;
                    }
                    if far.0 < t1.0 {
                        t1 = far;
                    }
                }
                if t0.0.is_finite() && t0.1.is_finite() {
                    assert!((f64::from(t[k]) - t0.0).abs() <= t0.1 + 1e-6, "child {k}: {} vs {t0:?}", t[k]);
                }
                let margin = t0.1 + t1.1 + 8.0 * eps * (t0.0.abs() + t1.0.abs());
                if (t0.0 - t1.0).abs() > margin {
                    assert_eq!(mask & (1 << k) != 0, t0.0 <= t1.0, "child {k}: {t0:?} {t1:?} {b:?} {terms:?}");
                    checked += 1;
                    hit += usize::from(t0.0 <= t1.0);
                }
            }
        }
        assert!(checked > 50_000 && hit > 5_000 && checked - hit > 5_000, "{checked} checked, {hit} hits");
    }

    /// The portable keys against their definition: one per hit used child, in child order,
    /// the entry distance clamped at 0 (as `f64`: exact) above the reference.
    #[test]
    fn portable_slab_keys_are_the_hit_children_in_order() {
        let mut g = Lcg(17);
        let mut sizes = [0; 9];
        for _ in 0..10_000 {
            let mut q = [[0u8; 8]; 6];
            let (lower, upper) = q.split_at_mut(3);
            for (l, u) in lower.iter_mut().flatten().zip(upper.iter_mut().flatten()) {
                let (a, b) = ((g.next() * 256.0) as u8, (g.next() * 256.0) as u8);
                (*l, *u) = (a.min(b) / 2, 128 + a.max(b) / 2);
            }
            // Every box holds grid point 128, which the ray meets near distance `spread` on
            // each axis: from all boxes hit (spread 0) to few.
            let positive = [g.next() < 0.5, g.next() < 0.5, g.next() < 0.5];
            let rows = RowChoice::new(positive);
            let sign = |a: usize| if positive[a] { 0.01 } else { -0.01 };
            let step = Vec4::new(sign(0), sign(1), sign(2), 0.0) * (1.0 + g.next());
            let spread = 6.0 * g.next() * g.next();
            let base = -step * 128.0 + Vec4::new(g.next(), g.next(), g.next(), 0.0) * spread;
            let terms = SlabTerms { step, lo: base, hi: base, t_min: -g.next(), t_max: 0.5 + g.next() * 2.0 };
            let used = (g.next() * 256.0) as u32 | 0x81;
            let child = [0; 8].map(|_| (g.next() * 1e9) as u32);
            let mut keys = [u64::MAX; 8];
            let mask = Portable.slab_keys(&q, &rows, &terms, used, &child, &mut keys);
            let (hit, t) = Portable.slab(&q, &rows, &terms);
            assert_eq!(mask, hit & used);
            let expected: Vec<u64> = (0..8)
                .filter(|&k| mask & (1 << k) != 0)
                .map(|k| (u64::from((f64::from(t[k]).max(0.0) as f32).to_bits()) << 32) | u64::from(child[k]))
                .collect();
            assert_eq!(keys[..expected.len()], expected[..]);
            sizes[expected.len()] += 1;
        }
        assert!(sizes.iter().all(|&s| s > 0), "every number of keys must occur: {sizes:?}");
    }

    /// The portable slab test against the plain definition (interval intersection per child).
    #[test]
    fn portable_slab_test_is_the_interval_intersection() {
        let mut g = Lcg(13);
        for _ in 0..10_000 {
            let mut q = [[0u8; 8]; 6];
            for row in &mut q {
                for c in row.iter_mut() {
                    *c = (g.next() * 256.0) as u8;
                }
            }
            let positive = [g.next() < 0.5, g.next() < 0.5, g.next() < 0.5];
            let rows = RowChoice::new(positive);
            let step = Vec4::new(g.next() - 0.5, g.next() - 0.5, g.next() - 0.5, 0.0) * 0.1;
            let base = Vec4::new(g.next() - 0.5, g.next() - 0.5, g.next() - 0.5, 0.0) * 10.0;
            let terms = SlabTerms { step, lo: base, hi: base, t_min: g.next() - 0.5, t_max: 1.0 + g.next() * 5.0 };
            let (mask, t) = Portable.slab(&q, &rows, &terms);
            for k in 0..8 {
                let (mut t0, mut t1) = (f64::from(terms.t_min), f64::from(terms.t_max));
                for a in 0..3 {
                    let plane = |row: usize| f64::from(q[row][k]) * f64::from(step[a]) + f64::from(base[a]);
                    let (n, f) = if positive[a] { (a, 3 + a) } else { (3 + a, a) };
                    t0 = t0.max(plane(n));
                    t1 = t1.min(plane(f));
                }
                assert!((f64::from(t[k]) - t0).abs() < 1e-5);
                if (t0 - t1).abs() > 1e-4 {
                    assert_eq!(mask & (1 << k) != 0, t0 < t1, "child {k}");
                }
            }
        }
    }
}
