//! The one deterministic random stream of fiberlab's tests and of the harness.
//!
//! Every test that needs random numbers (directions, offsets, the four uniforms of
//! `ScatteringFunction::sample`) draws them from [`TestRng`], so that a seed means the same
//! thing everywhere and no test carries its own generator. The stream is PCG-64 (O'Neill
//! 2014, the `rand_pcg` crate); uniforms are `rand`'s standard `f64` in [0, 1).
//!
//! Only `fiberlab-math` types cross this API, so the scattering crate's own unit tests can use
//! it too (through the `fiberlab-check` dev-dependency) without meeting a second copy of the
//! `fiberlab-scatter` types.

use fiberlab_math::DVec3;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use std::f64::consts::TAU;

/// Deterministic uniform stream for tests: the same seed gives the same numbers on every
/// platform and in every build.
#[derive(Clone, Debug)]
pub struct TestRng(Pcg64);

impl TestRng {
    /// The stream of `seed`.
    #[must_use]
    pub fn new(seed: u64) -> Self {
        Self(Pcg64::seed_from_u64(seed))
    }

    /// Uniform in [0, 1).
    #[inline]
    pub fn uniform(&mut self) -> f64 {
        self.0.random()
    }

    /// Uniform in [`lo`, `hi`).
    #[inline]
    pub fn uniform_in(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.uniform()
    }

    /// A fiber offset `h` uniform in [−1, 1).
    #[inline]
    pub fn offset(&mut self) -> f64 {
        self.uniform_in(-1.0, 1.0)
    }

    /// The four uniforms one `ScatteringFunction::sample` call consumes.
    #[inline]
    pub fn u4(&mut self) -> [f64; 4] {
        [self.uniform(), self.uniform(), self.uniform(), self.uniform()]
    }

    /// A direction uniform on the unit sphere, in the fiber frame (`x` along the fiber):
    /// `sinθ` uniform in [−1, 1) (equal solid angle per unit `sinθ`), then φ uniform.
    #[inline]
    pub fn sphere_direction(&mut self) -> DVec3 {
        let s = self.uniform_in(-1.0, 1.0);
        let p = TAU * self.uniform();
        let c = (1.0 - s * s).max(0.0).sqrt();
        DVec3::new(s, c * p.cos(), c * p.sin())
    }

    /// The stream as a closure of uniforms in [0, 1), for code that takes `FnMut() -> f64`.
    pub fn into_uniforms(mut self) -> impl FnMut() -> f64 {
        move || self.uniform()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tolerance::{MC_SIGMAS, UNIT_LENGTH_ABS};

    #[test]
    fn same_seed_same_stream_and_different_seeds_differ() {
        let (mut a, mut b, mut c) = (TestRng::new(7), TestRng::new(7), TestRng::new(8));
        let xs: Vec<f64> = (0..100).map(|_| a.uniform()).collect();
        let ys: Vec<f64> = (0..100).map(|_| b.uniform()).collect();
        let zs: Vec<f64> = (0..100).map(|_| c.uniform()).collect();
        assert_eq!(xs, ys);
        assert_ne!(xs, zs);
        assert!(xs.iter().all(|x| (0.0..1.0).contains(x)));
    }

    #[test]
    fn moments_of_uniforms_offsets_and_directions() {
        // Mean and variance of U[0, 1) are 1/2 and 1/12; a uniform direction has zero mean and
        // E[x²] = E[y²] = E[z²] = 1/3; bounds of MC_SIGMAS standard errors.
        let n = 200_000;
        let mut rng = TestRng::new(1);
        let (mut m, mut m2, mut h2) = (0.0, 0.0, 0.0);
        let (mut d, mut d2) = (DVec3::ZERO, DVec3::ZERO);
        for _ in 0..n {
            let u = rng.uniform();
            m += u;
            m2 += u * u;
            h2 += rng.offset().powi(2);
            let w = rng.sphere_direction();
            assert!((w.length() - 1.0).abs() < UNIT_LENGTH_ABS);
            d += w;
            d2 += w * w;
        }
        let nf = n as f64;
        let se = |var: f64| MC_SIGMAS * (var / nf).sqrt();
        assert!((m / nf - 0.5).abs() < se(1.0 / 12.0));
        assert!((m2 / nf - 1.0 / 3.0).abs() < se(4.0 / 45.0));
        // h uniform on [−1, 1): E[h²] = 1/3, Var[h²] = 4/45.
        assert!((h2 / nf - 1.0 / 3.0).abs() < se(4.0 / 45.0));
        for k in 0..3 {
            assert!((d[k] / nf).abs() < se(1.0 / 3.0), "mean {d:?}");
            // E[x⁴] = 1/5 on the sphere: Var[x²] = 1/5 − 1/9.
            assert!((d2[k] / nf - 1.0 / 3.0).abs() < se(1.0 / 5.0 - 1.0 / 9.0), "second moments {d2:?}");
        }
    }
}
