//! SplitMix64 (Steele, Lea & Flood 2014, *Fast splittable pseudorandom number generators*):
//! a 64-bit counter advanced by the golden-ratio increment and passed through a bijective
//! avalanche finalizer. Small, fast, and fixed forever, so anything generated from a seed
//! (hair strands, Monte Carlo tables) is reproducible across versions, platforms and thread
//! counts. Being counter-based, independent streams are had by hashing a stream index into
//! the seed ([`SplitMix64::stream`]).

use glam::DVec3;

/// The golden-ratio increment of the counter.
const GAMMA: u64 = 0x9E37_79B9_7F4A_7C15;

/// The 64-bit finalizer of SplitMix64 (a bijective avalanche hash).
#[must_use]
#[inline]
pub fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The SplitMix64 generator.
#[derive(Clone, Debug)]
pub struct SplitMix64(u64);

impl SplitMix64 {
    /// A generator from a seed.
    #[must_use]
    pub fn new(seed: u64) -> Self {
        Self(seed)
    }
    /// Stream `index` of the family keyed by `seed`: the counter starts at a hash of both,
    /// so streams of neighbouring indices are unrelated.
    #[must_use]
    pub fn stream(seed: u64, index: u64) -> Self {
        Self(mix64(mix64(seed ^ 0xA076_1D64_78BD_642F).wrapping_add(index.wrapping_mul(GAMMA))))
    }
    /// Next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(GAMMA);
        mix64(self.0)
    }
    /// Uniform in [0, 1).
    pub fn next_f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }
    /// Uniform in the unit ball's bounding cube, centred: each component in [−1, 1).
    pub fn next_signed_vec(&mut self) -> DVec3 {
        DVec3::new(self.next_f64(), self.next_f64(), self.next_f64()) * 2.0 - 1.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn first_outputs_match_the_reference_sequence() {
        // Seed 0: the published first outputs of SplitMix64 (Vigna's reference splitmix64.c).
        let mut g = SplitMix64::new(0);
        assert_eq!(g.next_u64(), 0xE220_A839_7B1D_CDAF);
        assert_eq!(g.next_u64(), 0x6E78_9E6A_A1B9_65F4);
    }

    #[test]
    fn uniforms_have_the_right_mean_and_streams_differ() {
        let mut g = SplitMix64::new(7);
        let n = 100_000;
        let mean = (0..n).map(|_| g.next_f64()).sum::<f64>() / n as f64;
        // Standard error of the mean of U(0, 1): 1/√(12n) ≈ 9e-4.
        assert!((mean - 0.5).abs() < 5e-3, "{mean}");
        let (mut a, mut b) = (SplitMix64::stream(1, 0), SplitMix64::stream(1, 1));
        assert_ne!(a.next_u64(), b.next_u64());
    }
}
