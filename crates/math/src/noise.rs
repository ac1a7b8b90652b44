//! Value noise: a smooth pseudo-random field in `[−1, 1]` for procedural textures (figured
//! maple) and pattern variation (woven cloth), deterministic for a seed.
//!
//! # Formula
//! `n(x, y) = Σ_o a_o·v(2^o x, 2^o y) / Σ_o a_o` with `a_o = 2^−o`, where `v` interpolates
//! values hashed from the integer lattice (`seed`, cell, octave) with the quintic fade
//! `6t⁵ − 15t⁴ + 10t³`, so the field is continuous with its first two derivatives.

use crate::split_mix::mix64;

/// Value noise at `(x, y)` with `octaves` octaves (at least one).
#[must_use]
pub fn value_noise(seed: u64, x: f64, y: f64, octaves: u32) -> f64 {
    let lattice = |i: i64, j: i64, o: u32| {
        let h = mix64(
            seed ^ mix64((i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ mix64(j as u64 ^ (u64::from(o) << 40))),
        );
        ((h >> 11) as f64 + 0.5) / (1u64 << 53) as f64 * 2.0 - 1.0
    };
    let fade = |t: f64| t * t * t * (t * (t * 6.0 - 15.0) + 10.0);
    let (mut sum, mut norm, mut amplitude, mut frequency) = (0.0, 0.0, 1.0, 1.0);
    for o in 0..octaves.max(1) {
        let (px, py) = (x * frequency, y * frequency);
        let (i, j) = (px.floor(), py.floor());
        let (sx, sy) = (fade(px - i), fade(py - j));
        let (i, j) = (i as i64, j as i64);
        let bottom = lattice(i, j, o) + (lattice(i + 1, j, o) - lattice(i, j, o)) * sx;
        let top = lattice(i, j + 1, o) + (lattice(i + 1, j + 1, o) - lattice(i, j + 1, o)) * sx;
        sum += amplitude * (bottom + (top - bottom) * sy);
        norm += amplitude;
        amplitude *= 0.5;
        frequency *= 2.0;
    }
    sum / norm
}

#[cfg(test)]
mod tests {
    use super::*;

    /// In range, deterministic, equal to the lattice value at lattice points (one octave),
    /// continuous across cell edges, and roughly zero-mean over many cells.
    #[test]
    fn value_noise_is_a_smooth_bounded_field() {
        let mut mean = 0.0;
        for k in 0..10_000 {
            let (x, y) = (k as f64 * 0.731, k as f64 * 0.377);
            let v = value_noise(7, x, y, 3);
            assert!((-1.0..=1.0).contains(&v));
            assert_eq!(v, value_noise(7, x, y, 3));
            mean += v / 10_000.0;
        }
        assert!(mean.abs() < 0.05, "mean {mean}");
        for k in 0..100 {
            let x = f64::from(k) + 1.0;
            let (below, above) = (value_noise(3, x - 1e-9, 0.4, 1), value_noise(3, x + 1e-9, 0.4, 1));
            assert!((below - above).abs() < 1e-6, "jump at x = {x}: {below} {above}");
        }
        assert_ne!(value_noise(1, 0.5, 0.5, 1), value_noise(2, 0.5, 0.5, 1), "the seed matters");
    }
}
