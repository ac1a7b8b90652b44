//! The AVX2 forms of the kernels (eight `f32` lanes). Every function here is compiled with
//! AVX2 enabled and may only run on a CPU that has it: callers hold an [`super::Avx2`] token,
//! which only detection makes. The arithmetic mirrors the portable form operation by
//! operation (see the module above), so the results are the same bits.
//!
//! Audit: the `unsafe` blocks are unaligned loads from references whose bounds are checked
//! where they are taken (each block states why); the arithmetic intrinsics are safe inside
//! these `#[target_feature]` functions.

use super::{LineF32, SegmentHead, SlabTerms};
use core::arch::x86_64::{
    __m128, __m256, _CMP_LT_OS, _mm_cmple_ps, _mm_loadu_si128, _mm_movemask_ps, _mm_mul_ps, _mm_set1_ps,
    _mm_shuffle_epi8, _mm_xor_ps, _mm256_add_ps, _mm256_castps256_ps128, _mm256_cmp_ps, _mm256_cvtepi32_ps,
    _mm256_cvtepu8_epi32, _mm256_div_ps, _mm256_extractf128_ps, _mm256_loadu_ps, _mm256_max_ps, _mm256_movemask_ps,
    _mm256_mul_ps, _mm256_or_ps, _mm256_permute2f128_ps, _mm256_permutevar8x32_ps, _mm256_set_m128, _mm256_set1_ps,
    _mm256_setr_epi32, _mm256_setr_ps, _mm256_shuffle_ps, _mm256_sqrt_ps, _mm256_sub_ps, _mm256_unpackhi_ps,
    _mm256_unpacklo_ps, _mm256_xor_ps,
};
use glam::Vec4;

/// Runs `f` in a function compiled with AVX2 enabled (`f` and what it calls inline into it).
#[target_feature(enable = "avx2")]
#[inline]
pub(super) fn with_avx2<R>(f: impl FnOnce() -> R) -> R {
    f()
}

/// The slab test of a node's four children, near and far planes of one axis in one pass of
/// eight lanes: lanes 0–3 carry the near planes, lanes 4–7 the far planes negated, so one
/// `max` accumulates both `t0 = max(t0, near)` and `−t1 = max(−t1, −far)` (negation is exact
/// and maps `min` to `max` lane for lane, NaN operands included).
#[target_feature(enable = "avx2")]
#[inline]
pub(super) fn slab(q: &[[u8; 4]; 6], shuffle: &[[u8; 16]; 3], terms: &SlabTerms) -> (u32, [f32; 4]) {
    let bytes: &[u8; 24] = q.as_flattened().try_into().expect("six rows of four bytes");
    let negate_high = _mm256_setr_ps(0.0, 0.0, 0.0, 0.0, -0.0, -0.0, -0.0, -0.0);
    let (step, lo, hi): (__m128, __m128, __m128) = (terms.step.into(), terms.lo.into(), terms.hi.into());
    let steps = _mm256_xor_ps(_mm256_set_m128(step, step), negate_high);
    let offsets = _mm256_xor_ps(_mm256_set_m128(hi, lo), negate_high);
    let mut acc = _mm256_xor_ps(_mm256_set_m128(_mm_set1_ps(terms.t_max), _mm_set1_ps(terms.t_min)), negate_high);
    for axis in 0..3 {
        // SAFETY: the 16 bytes from `4·axis` lie inside the 24 of `bytes` (axis ≤ 2); the load
        // has no alignment requirement.
        let raw = unsafe { _mm_loadu_si128(bytes[4 * axis..4 * axis + 16].as_ptr().cast()) };
        // SAFETY: `shuffle[axis]` is 16 bytes; no alignment requirement.
        let control = unsafe { _mm_loadu_si128(shuffle[axis].as_ptr().cast()) };
        let grid = _mm256_cvtepi32_ps(_mm256_cvtepu8_epi32(_mm_shuffle_epi8(raw, control)));
        let a = axis as i32;
        let lanes = _mm256_setr_epi32(a, a, a, a, 4 + a, 4 + a, 4 + a, 4 + a);
        let planes = _mm256_add_ps(
            _mm256_mul_ps(grid, _mm256_permutevar8x32_ps(steps, lanes)),
            _mm256_permutevar8x32_ps(offsets, lanes),
        );
        acc = _mm256_max_ps(acc, planes);
    }
    let t0 = _mm256_castps256_ps128(acc);
    let t1 = _mm_xor_ps(_mm256_extractf128_ps::<1>(acc), _mm_set1_ps(-0.0));
    let hit = _mm_cmple_ps(t0, _mm_mul_ps(t1, _mm_set1_ps(1.0 + 4.0 * f32::EPSILON)));
    (_mm_movemask_ps(hit) as u32, Vec4::from(t0).to_array())
}

/// The leaf pre-test on eight segments at once: the eight heads are loaded as rows and
/// transposed into structure of arrays (three unpack/shuffle stages), then the portable form's
/// operations run on eight lanes.
#[target_feature(enable = "avx2")]
#[inline]
pub(super) fn near_axis(line: &LineF32, heads: &[SegmentHead; 8]) -> u32 {
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
    // 8×8 transpose (column 6, the length, is not needed).
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
    let radius = _mm256_permute2f128_ps::<0x31>(s[3], s[7]);

    let ox = _mm256_sub_ps(_mm256_set1_ps(line.o.x), px);
    let oy = _mm256_sub_ps(_mm256_set1_ps(line.o.y), py);
    let oz = _mm256_sub_ps(_mm256_set1_ps(line.o.z), pz);
    let (dx, dy, dz) = (_mm256_set1_ps(line.d.x), _mm256_set1_ps(line.d.y), _mm256_set1_ps(line.d.z));
    let d_along = dot(dx, dy, dz, ax, ay, az);
    let ux = _mm256_sub_ps(dx, _mm256_mul_ps(ax, d_along));
    let uy = _mm256_sub_ps(dy, _mm256_mul_ps(ay, d_along));
    let uz = _mm256_sub_ps(dz, _mm256_mul_ps(az, d_along));
    let o_along = dot(ox, oy, oz, ax, ay, az);
    let wx = _mm256_sub_ps(ox, _mm256_mul_ps(ax, o_along));
    let wy = _mm256_sub_ps(oy, _mm256_mul_ps(ay, o_along));
    let wz = _mm256_sub_ps(oz, _mm256_mul_ps(az, o_along));
    let aa = dot(ux, uy, uz, ux, uy, uz);
    let t = _mm256_div_ps(dot(wx, wy, wz, ux, uy, uz), _mm256_max_ps(aa, _mm256_set1_ps(1e-30)));
    let qx = _mm256_sub_ps(wx, _mm256_mul_ps(ux, t));
    let qy = _mm256_sub_ps(wy, _mm256_mul_ps(uy, t));
    let qz = _mm256_sub_ps(wz, _mm256_mul_ps(uz, t));
    let reach = _mm256_add_ps(_mm256_set1_ps(1.0), _mm256_sqrt_ps(dot(ox, oy, oz, ox, oy, oz)));
    let slack = _mm256_add_ps(radius, _mm256_mul_ps(reach, _mm256_set1_ps(1e-5)));
    let near = _mm256_or_ps(
        _mm256_cmp_ps::<_CMP_LT_OS>(dot(qx, qy, qz, qx, qy, qz), _mm256_mul_ps(slack, slack)),
        _mm256_cmp_ps::<_CMP_LT_OS>(aa, _mm256_set1_ps(1e-12)),
    );
    _mm256_movemask_ps(near) as u32
}

/// `(x·a + y·b) + z·c` lane by lane, in the portable form's order.
#[target_feature(enable = "avx2")]
#[inline]
fn dot(x: __m256, y: __m256, z: __m256, a: __m256, b: __m256, c: __m256) -> __m256 {
    _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(x, a), _mm256_mul_ps(y, b)), _mm256_mul_ps(z, c))
}
