//! Reproducible pseudo-random numbers for the unit tests of the tree and the curves (a 64-bit
//! linear congruential generator: fixed sequences, no dependency).

use fiberlab_math::DVec3;

/// A generator seeded by its state.
pub(crate) struct Lcg(pub u64);

impl Lcg {
    /// Uniform in [0, 1).
    pub fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((self.0 >> 11) as f64) / (1u64 << 53) as f64
    }

    /// Uniform in the unit cube [0, 1)³.
    pub fn vec(&mut self) -> DVec3 {
        DVec3::new(self.next(), self.next(), self.next())
    }
}
