//! The AVX2 forms of the kernels (eight `f32` lanes). Every function here is compiled with
//! AVX2 enabled and may only run on a CPU that has it: callers hold an [`super::Avx2`] token,
//! which only detection makes. The arithmetic mirrors the portable form operation by
//! operation (see the module above), so the results are the same bits.
//!
//! Audit: the `unsafe` blocks are unaligned loads and stores within references whose bounds
//! are checked where they are taken or fixed by construction (each block states why); the
//! arithmetic intrinsics are safe inside these `#[target_feature]` functions.

use super::{MIN_ROTATED_DIRECTION, OrientedBoxes, OrientedTerms, RayF32, SegmentHead, SlabTerms};
use core::arch::x86_64::{
    __m128i, __m256, _CMP_GE_OS, _CMP_LE_OS, _CMP_LT_OS, _mm_loadl_epi64, _mm256_add_ps, _mm256_and_ps,
    _mm256_andnot_ps, _mm256_castps_si256, _mm256_cmp_ps, _mm256_cvtepi8_epi32, _mm256_cvtepi32_ps,
    _mm256_cvtepu8_epi32, _mm256_div_ps, _mm256_loadu_ps, _mm256_loadu_si256, _mm256_max_ps, _mm256_min_ps,
    _mm256_movemask_ps, _mm256_mul_ps, _mm256_or_ps, _mm256_permute2f128_ps, _mm256_permute2x128_si256,
    _mm256_permutevar8x32_epi32, _mm256_set1_ps, _mm256_setzero_ps, _mm256_shuffle_ps, _mm256_sqrt_ps,
    _mm256_storeu_ps, _mm256_storeu_si256, _mm256_sub_ps, _mm256_unpackhi_epi32, _mm256_unpackhi_ps,
    _mm256_unpacklo_epi32, _mm256_unpacklo_ps,
};

/// Runs `f` in a function compiled with AVX2 enabled (`f` and what it calls inline into it).
#[target_feature(enable = "avx2")]
#[inline]
pub(super) fn with_avx2<R>(f: impl FnOnce() -> R) -> R {
    f()
}

/// The slab test of a node's eight children, one lane each: per axis, the near and far rows'
/// eight bytes are widened to `f32` (`vpmovzxbd` + `vcvtdq2ps`), scaled and offset, and folded
/// into `t0 = max(t0, near)` and `t1 = min(t1, far)`, the portable form's operations in its
/// order. `offsets`: [`super::RowChoice`]'s near and far row offsets per axis.
#[target_feature(enable = "avx2")]
#[inline]
pub(super) fn slab(q: &[[u8; 8]; 6], offsets: &[[usize; 2]; 3], terms: &SlabTerms) -> (u32, [f32; 8]) {
    let (hit, t0) = slab_lanes(q, offsets, terms);
    let mut entry = [0.0; 8];
    // SAFETY: `entry` is eight `f32`; no alignment requirement.
    unsafe { _mm256_storeu_ps(entry.as_mut_ptr(), t0) };
    (hit, entry)
}

/// [`slab`] with the entry distances in a register.
#[target_feature(enable = "avx2")]
#[inline]
fn slab_lanes(q: &[[u8; 8]; 6], offsets: &[[usize; 2]; 3], terms: &SlabTerms) -> (u32, __m256) {
    let bytes: *const u8 = q.as_flattened().as_ptr();
    let (step, lo, hi) = (terms.step.to_array(), terms.lo.to_array(), terms.hi.to_array());
    let mut t0 = _mm256_set1_ps(terms.t_min);
    let mut t1 = _mm256_set1_ps(terms.t_max);
    for axis in 0..3 {
        let [near, far] = offsets[axis];
        debug_assert!(near <= 40 && far <= 40);
        // SAFETY: `RowChoice::new` makes each offset `8·row` with `row < 6`, so the eight bytes
        // from it lie inside the 48 of `q`; the load has no alignment requirement.
        let (near, far) = unsafe { (_mm_loadl_epi64(bytes.add(near).cast()), _mm_loadl_epi64(bytes.add(far).cast())) };
        let s = _mm256_set1_ps(step[axis]);
        t0 = _mm256_max_ps(t0, _mm256_add_ps(_mm256_mul_ps(row(near), s), _mm256_set1_ps(lo[axis])));
        t1 = _mm256_min_ps(t1, _mm256_add_ps(_mm256_mul_ps(row(far), s), _mm256_set1_ps(hi[axis])));
    }
    let hit = _mm256_cmp_ps::<_CMP_LE_OS>(t0, _mm256_mul_ps(t1, _mm256_set1_ps(1.0 + 4.0 * f32::EPSILON)));
    (_mm256_movemask_ps(hit) as u32, t0)
}

/// For each 8-bit mask, the positions of its set bits in increasing order (then zeros).
static COMPRESS: [[u8; 8]; 256] = {
    let mut table = [[0u8; 8]; 256];
    let mut mask = 0;
    while mask < 256 {
        let (mut k, mut n) = (0, 0);
        while k < 8 {
            if mask >> k & 1 == 1 {
                table[mask][n] = k as u8;
                n += 1;
            }
            k += 1;
        }
        mask += 1;
    }
    table
};

/// [`slab`] and the hit children's keys, compressed to the front of `keys` in child order with
/// one lane permutation (from [`COMPRESS`]) of the clamped distances and of the references,
/// interleaved into 64-bit keys: no loop over the hit children.
#[target_feature(enable = "avx2")]
#[inline]
pub(super) fn slab_keys(
    q: &[[u8; 8]; 6],
    offsets: &[[usize; 2]; 3],
    terms: &SlabTerms,
    used: u32,
    child: &[u32; 8],
    keys: &mut [u64; 8],
) -> u32 {
    let (hit, t0) = slab_lanes(q, offsets, terms);
    compress_keys(hit & used & 0xFF, t0, child, keys)
}

/// The keys of the children in `mask` (< 256), entry distances `t0`, compressed to the front
/// of `keys` in child order ([`slab_keys`]); returns `mask`.
#[target_feature(enable = "avx2")]
#[inline]
fn compress_keys(mask: u32, t0: __m256, child: &[u32; 8], keys: &mut [u64; 8]) -> u32 {
    // `max(t0, 0)`: 0 for NaN and for either zero, as the portable form.
    let t = _mm256_castps_si256(_mm256_max_ps(t0, _mm256_setzero_ps()));
    // SAFETY: `COMPRESS[mask]` (mask < 256) is eight bytes and `child` eight `u32`; the loads
    // have no alignment requirement.
    let (order, refs) = unsafe {
        (
            _mm256_cvtepu8_epi32(_mm_loadl_epi64(COMPRESS[mask as usize].as_ptr().cast())),
            _mm256_loadu_si256(child.as_ptr().cast()),
        )
    };
    let (t, refs) = (_mm256_permutevar8x32_epi32(t, order), _mm256_permutevar8x32_epi32(refs, order));
    // Keys 0, 1, 4, 5 and 2, 3, 6, 7 (reference in the low half), then in order.
    let (low, high) = (_mm256_unpacklo_epi32(refs, t), _mm256_unpackhi_epi32(refs, t));
    let first = _mm256_permute2x128_si256::<0x20>(low, high);
    let second = _mm256_permute2x128_si256::<0x31>(low, high);
    // SAFETY: `keys` is eight `u64`, 64 bytes: two 32-byte stores; no alignment requirement.
    unsafe {
        _mm256_storeu_si256(keys.as_mut_ptr().cast(), first);
        _mm256_storeu_si256(keys.as_mut_ptr().add(4).cast(), second);
    }
    mask
}

/// The slab test of an oriented node's eight children, one lane each: the portable form's
/// operations on eight lanes (`|d|` and the sign by masks, as `glam`'s `abs` and `copysign`).
#[target_feature(enable = "avx2")]
#[inline]
pub(super) fn oriented(boxes: &OrientedBoxes, terms: &OrientedTerms) -> (u32, [f32; 8]) {
    let (hit, t0) = oriented_lanes(boxes, terms);
    let mut entry = [0.0; 8];
    // SAFETY: `entry` is eight `f32`; no alignment requirement.
    unsafe { _mm256_storeu_ps(entry.as_mut_ptr(), t0) };
    (hit, entry)
}

/// [`oriented`] and the hit used children's keys, as [`slab_keys`].
#[target_feature(enable = "avx2")]
#[inline]
pub(super) fn oriented_keys(
    boxes: &OrientedBoxes,
    terms: &OrientedTerms,
    used: u32,
    child: &[u32; 8],
    keys: &mut [u64; 8],
) -> u32 {
    let (hit, t0) = oriented_lanes(boxes, terms);
    compress_keys(hit & used & 0xFF, t0, child, keys)
}

/// [`oriented`] with the entry distances in a register.
#[target_feature(enable = "avx2")]
#[inline]
fn oriented_lanes(boxes: &OrientedBoxes, terms: &OrientedTerms) -> (u32, __m256) {
    // SAFETY (each load): the argument is eight `f32`; no alignment requirement.
    let load = |a: &[f32; 8]| unsafe { _mm256_loadu_ps(a.as_ptr()) };
    // SAFETY (each load): the argument is eight bytes; no alignment requirement.
    let ints = |a: &[i8; 8]| _mm256_cvtepi32_ps(_mm256_cvtepi8_epi32(unsafe { _mm_loadl_epi64(a.as_ptr().cast()) }));
    let [ox, oy, oz] = terms.o.map(|x| _mm256_set1_ps(x));
    let [dx, dy, dz] = terms.d.map(|x| _mm256_set1_ps(x));
    let widen = _mm256_set1_ps(terms.widen);
    let sign = _mm256_set1_ps(-0.0);
    let mut t0 = _mm256_set1_ps(terms.t_min);
    let mut t1 = _mm256_set1_ps(terms.t_max);
    for row in 0..3 {
        let [r0, r1, r2] = [0, 1, 2].map(|c| ints(&boxes.rot[row][c]));
        let d = dot(r0, r1, r2, dx, dy, dz);
        let o = dot(r0, r1, r2, ox, oy, oz);
        // copysign(max(|d|, MIN), d)
        let magnitude = _mm256_max_ps(_mm256_andnot_ps(sign, d), _mm256_set1_ps(MIN_ROTATED_DIRECTION));
        let safe = _mm256_or_ps(_mm256_and_ps(d, sign), _mm256_andnot_ps(sign, magnitude));
        let inv = _mm256_div_ps(_mm256_set1_ps(1.0), safe);
        let t_lo = _mm256_mul_ps(_mm256_sub_ps(_mm256_sub_ps(load(&boxes.lo[row]), widen), o), inv);
        let t_hi = _mm256_mul_ps(_mm256_sub_ps(_mm256_add_ps(load(&boxes.hi[row]), widen), o), inv);
        t0 = _mm256_max_ps(t0, _mm256_min_ps(t_lo, t_hi));
        t1 = _mm256_min_ps(t1, _mm256_max_ps(t_lo, t_hi));
    }
    let hit = _mm256_cmp_ps::<_CMP_LE_OS>(t0, _mm256_mul_ps(t1, _mm256_set1_ps(1.0 + 4.0 * f32::EPSILON)));
    (_mm256_movemask_ps(hit) as u32, t0)
}

/// The eight bytes in the low half of `r` as `f32` (exact).
#[target_feature(enable = "avx2")]
#[inline]
fn row(r: __m128i) -> __m256 {
    _mm256_cvtepi32_ps(_mm256_cvtepu8_epi32(r))
}

/// The leaf pre-test on eight segments at once: the eight heads are loaded as rows and
/// transposed into structure of arrays (three unpack/shuffle stages), then the portable form's
/// operations run on eight lanes.
#[target_feature(enable = "avx2")]
#[inline]
pub(super) fn near_axis(ray: &RayF32, heads: &[SegmentHead; 8]) -> u32 {
    // SAFETY (each load): `heads[k]` is eight `f32`; no alignment requirement.
    let row = |k: usize| heads[k].as_ptr();
    let r = unsafe {
        [
            _mm256_loadu_ps(row(0)),
            _mm256_loadu_ps(row(1)),
            _mm256_loadu_ps(row(2)),
            _mm256_loadu_ps(row(3)),
            _mm256_loadu_ps(row(4)),
            _mm256_loadu_ps(row(5)),
            _mm256_loadu_ps(row(6)),
            _mm256_loadu_ps(row(7)),
        ]
    };
    // 8×8 transpose.
    let t = [
        _mm256_unpacklo_ps(r[0], r[1]),
        _mm256_unpackhi_ps(r[0], r[1]),
        _mm256_unpacklo_ps(r[2], r[3]),
        _mm256_unpackhi_ps(r[2], r[3]),
        _mm256_unpacklo_ps(r[4], r[5]),
        _mm256_unpackhi_ps(r[4], r[5]),
        _mm256_unpacklo_ps(r[6], r[7]),
        _mm256_unpackhi_ps(r[6], r[7]),
    ];
    let s = [
        _mm256_shuffle_ps::<0x44>(t[0], t[2]),
        _mm256_shuffle_ps::<0xEE>(t[0], t[2]),
        _mm256_shuffle_ps::<0x44>(t[1], t[3]),
        _mm256_shuffle_ps::<0xEE>(t[1], t[3]),
        _mm256_shuffle_ps::<0x44>(t[4], t[6]),
        _mm256_shuffle_ps::<0xEE>(t[4], t[6]),
        _mm256_shuffle_ps::<0x44>(t[5], t[7]),
        _mm256_shuffle_ps::<0xEE>(t[5], t[7]),
    ];
    let px = _mm256_permute2f128_ps::<0x20>(s[0], s[4]);
    let py = _mm256_permute2f128_ps::<0x20>(s[1], s[5]);
    let pz = _mm256_permute2f128_ps::<0x20>(s[2], s[6]);
    let ax = _mm256_permute2f128_ps::<0x20>(s[3], s[7]);
    let ay = _mm256_permute2f128_ps::<0x31>(s[0], s[4]);
    let az = _mm256_permute2f128_ps::<0x31>(s[1], s[5]);
    let length = _mm256_permute2f128_ps::<0x31>(s[2], s[6]);
    let radius = _mm256_permute2f128_ps::<0x31>(s[3], s[7]);

    let ox = _mm256_sub_ps(_mm256_set1_ps(ray.o.x), px);
    let oy = _mm256_sub_ps(_mm256_set1_ps(ray.o.y), py);
    let oz = _mm256_sub_ps(_mm256_set1_ps(ray.o.z), pz);
    let (dx, dy, dz) = (_mm256_set1_ps(ray.d.x), _mm256_set1_ps(ray.d.y), _mm256_set1_ps(ray.d.z));
    let d_along = dot(dx, dy, dz, ax, ay, az);
    let ux = _mm256_sub_ps(dx, _mm256_mul_ps(ax, d_along));
    let uy = _mm256_sub_ps(dy, _mm256_mul_ps(ay, d_along));
    let uz = _mm256_sub_ps(dz, _mm256_mul_ps(az, d_along));
    let o_along = dot(ox, oy, oz, ax, ay, az);
    let wx = _mm256_sub_ps(ox, _mm256_mul_ps(ax, o_along));
    let wy = _mm256_sub_ps(oy, _mm256_mul_ps(ay, o_along));
    let wz = _mm256_sub_ps(oz, _mm256_mul_ps(az, o_along));
    let aa = dot(ux, uy, uz, ux, uy, uz);
    let aa_floor = _mm256_max_ps(aa, _mm256_set1_ps(1e-30));
    let t = _mm256_div_ps(dot(wx, wy, wz, ux, uy, uz), aa_floor);
    let qx = _mm256_sub_ps(wx, _mm256_mul_ps(ux, t));
    let qy = _mm256_sub_ps(wy, _mm256_mul_ps(uy, t));
    let qz = _mm256_sub_ps(wz, _mm256_mul_ps(uz, t));
    let one = _mm256_set1_ps(1.0);
    let reach = _mm256_add_ps(one, _mm256_sqrt_ps(dot(ox, oy, oz, ox, oy, oz)));
    let position_error = _mm256_add_ps(_mm256_mul_ps(reach, _mm256_set1_ps(1e-5)), _mm256_set1_ps(ray.origin_error));
    let wide = _mm256_add_ps(radius, position_error);
    let near = _mm256_cmp_ps::<_CMP_LT_OS>(dot(qx, qy, qz, qx, qy, qz), _mm256_mul_ps(wide, wide));
    let inverse = _mm256_div_ps(one, _mm256_sqrt_ps(aa_floor));
    let zero = _mm256_setzero_ps();
    let t_c = _mm256_sub_ps(zero, t);
    let t_c_abs = _mm256_andnot_ps(_mm256_set1_ps(-0.0), t_c);
    let error = _mm256_add_ps(
        _mm256_mul_ps(_mm256_add_ps(_mm256_mul_ps(wide, _mm256_set1_ps(1e-5)), position_error), inverse),
        _mm256_mul_ps(t_c_abs, _mm256_set1_ps(1e-5)),
    );
    let first = _mm256_max_ps(
        _mm256_sub_ps(_mm256_sub_ps(t_c, _mm256_mul_ps(wide, inverse)), error),
        _mm256_set1_ps(ray.t_min),
    );
    let last = _mm256_min_ps(_mm256_add_ps(t_c, error), _mm256_set1_ps(ray.t_max));
    let s_first = _mm256_add_ps(o_along, _mm256_mul_ps(d_along, first));
    let s_last = _mm256_add_ps(o_along, _mm256_mul_ps(d_along, last));
    let margin = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(radius, _mm256_set1_ps(2.0)), wide), error);
    let within = _mm256_and_ps(
        _mm256_cmp_ps::<_CMP_LE_OS>(first, last),
        _mm256_and_ps(
            _mm256_cmp_ps::<_CMP_GE_OS>(_mm256_max_ps(s_first, s_last), _mm256_sub_ps(zero, margin)),
            _mm256_cmp_ps::<_CMP_LE_OS>(_mm256_min_ps(s_first, s_last), _mm256_add_ps(length, margin)),
        ),
    );
    let keep = _mm256_or_ps(_mm256_and_ps(near, within), _mm256_cmp_ps::<_CMP_LT_OS>(aa, _mm256_set1_ps(1e-12)));
    _mm256_movemask_ps(keep) as u32
}

/// `(x·a + y·b) + z·c` lane by lane, in the portable form's order.
#[target_feature(enable = "avx2")]
#[inline]
fn dot(x: __m256, y: __m256, z: __m256, a: __m256, b: __m256, c: __m256) -> __m256 {
    _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(x, a), _mm256_mul_ps(y, b)), _mm256_mul_ps(z, c))
}
