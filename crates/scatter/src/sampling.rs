//! Sampling primitives shared by the models: warps from the unit square to directions,
//! and a tabulated 1D distribution with an exact density.

use fiberlab_math::DVec3;
use fiberlab_math::frame::direction_from_sin_cos;
use std::f64::consts::{PI, TAU};

/// A direction with density `cosθ/π²` per steradian (θ from the normal plane), the
/// "ideal diffuse fiber" lobe (`docs/theory/radiometry.md`, "Ideal diffuse fiber"): `sinθ` is the x-coordinate of a uniform
/// point in the unit disk (semicircle law), φ uniform.
#[must_use]
#[inline]
pub fn cos_theta_direction(u0: f64, u1: f64, phi: f64) -> DVec3 {
    let sin_theta = u0.sqrt() * (TAU * u1).cos();
    direction_from_sin_cos(sin_theta, (1.0 - sin_theta * sin_theta).max(0.0).sqrt(), phi)
}

/// Density per steradian of [`cos_theta_direction`] for a direction with `cos θ`.
#[must_use]
#[inline]
pub fn cos_theta_pdf(cos_theta: f64) -> f64 {
    cos_theta / (PI * PI)
}

/// Cosine-weighted hemisphere about `n`, with `t` a unit vector perpendicular to `n`.
#[must_use]
#[inline]
pub fn cosine_hemisphere(n: DVec3, t: DVec3, u0: f64, u1: f64) -> DVec3 {
    let r = u0.sqrt();
    let (s, c) = (TAU * u1).sin_cos();
    let b = n.cross(t);
    t * (r * c) + b * (r * s) + n * (1.0 - u0).max(0.0).sqrt()
}

/// A piecewise-constant 1D distribution on `[x0, x1]` built from a non-negative function;
/// sampling inverts its CDF and the density returned is exactly that of the samples.
#[derive(Clone, Debug)]
pub struct Tabulated1D {
    x0: f64,
    dx: f64,
    /// CDF at the cell boundaries, unnormalized (`cdf[0] = 0`, `cdf[n]` = total mass).
    cdf: Vec<f64>,
}

impl Tabulated1D {
    /// Tabulates `f` on `n` equal cells of `[x0, x1]`, integrating each cell with
    /// `sub` midpoint sub-samples.
    #[must_use]
    pub fn new(x0: f64, x1: f64, n: usize, sub: usize, f: impl Fn(f64) -> f64) -> Self {
        let dx = (x1 - x0) / n as f64;
        let mut cdf = Vec::with_capacity(n + 1);
        cdf.push(0.0);
        let mut acc = 0.0;
        for i in 0..n {
            let mut m = 0.0;
            for j in 0..sub {
                m += f(x0 + (i as f64 + (j as f64 + 0.5) / sub as f64) * dx).max(0.0);
            }
            acc += m * dx / sub as f64;
            cdf.push(acc);
        }
        Self { x0, dx, cdf }
    }

    fn cells(&self) -> usize {
        self.cdf.len() - 1
    }

    /// The domain's start `x0` and the cell width (for a copy of the table elsewhere, e.g.
    /// on the GPU).
    #[must_use]
    pub fn grid(&self) -> (f64, f64) {
        (self.x0, self.dx)
    }

    /// The unnormalized CDF at the cell boundaries (`cdf[0] = 0`, last = total mass).
    #[must_use]
    pub fn cdf_values(&self) -> &[f64] {
        &self.cdf
    }

    /// Unnormalized CDF at `x` (linear within a cell), clamped to the domain.
    #[must_use]
    pub fn cdf(&self, x: f64) -> f64 {
        let t = ((x - self.x0) / self.dx).clamp(0.0, self.cells() as f64);
        let i = (t as usize).min(self.cells() - 1);
        self.cdf[i] + (t - i as f64) * (self.cdf[i + 1] - self.cdf[i])
    }

    /// Unnormalized density at `x` (the cell's mean), zero outside the domain.
    #[must_use]
    pub fn density(&self, x: f64) -> f64 {
        let t = (x - self.x0) / self.dx;
        if !(0.0..=self.cells() as f64).contains(&t) {
            return 0.0;
        }
        let i = (t as usize).min(self.cells() - 1);
        (self.cdf[i + 1] - self.cdf[i]) / self.dx
    }

    /// Samples `x` restricted to `[a, b]` with `u ∈ [0, 1)`; returns `(x, density)` where
    /// the density is normalized over `[a, b]`. `None` if `[a, b]` has no mass.
    #[must_use]
    pub fn sample_in(&self, a: f64, b: f64, u: f64) -> Option<(f64, f64)> {
        let (ca, cb) = (self.cdf(a), self.cdf(b));
        let mass = cb - ca;
        if mass <= 0.0 {
            return None;
        }
        let target = ca + u * mass;
        // first boundary with cdf > target
        let k = self.cdf.partition_point(|&c| c <= target).clamp(1, self.cells());
        let i = k - 1;
        let cell = self.cdf[i + 1] - self.cdf[i];
        let frac = if cell > 0.0 { (target - self.cdf[i]) / cell } else { 0.5 };
        let x = (self.x0 + (i as f64 + frac) * self.dx).clamp(a, b);
        Some((x, self.density(x) / mass))
    }

    /// Density at `x` normalized over `[a, b]` (zero outside), matching [`Self::sample_in`].
    #[must_use]
    pub fn density_in(&self, a: f64, b: f64, x: f64) -> f64 {
        if x < a || x > b {
            return 0.0;
        }
        let mass = self.cdf(b) - self.cdf(a);
        if mass <= 0.0 { 0.0 } else { self.density(x) / mass }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tabulated_sampling_inverts_its_cdf() {
        let t = Tabulated1D::new(-1.0, 1.0, 64, 8, |x| 1.0 - x * x);
        assert!((t.cdf(1.0) - 4.0 / 3.0).abs() < 1e-3);
        for i in 0..50 {
            let u = (i as f64 + 0.5) / 50.0;
            let (x, pdf) = t.sample_in(-0.5, 0.8, u).unwrap();
            assert!((-0.5..=0.8).contains(&x));
            let got = (t.cdf(x) - t.cdf(-0.5)) / (t.cdf(0.8) - t.cdf(-0.5));
            assert!((got - u).abs() < 1e-12);
            assert!((pdf - t.density_in(-0.5, 0.8, x)).abs() < 1e-12);
        }
    }

    #[test]
    fn cosine_hemisphere_stays_above_the_surface() {
        let n = DVec3::new(0.0, 0.6, 0.8);
        let t = DVec3::X;
        for i in 0..100 {
            let d = cosine_hemisphere(n, t, (i as f64 + 0.5) / 100.0, 0.37 * i as f64 % 1.0);
            assert!(d.dot(n) >= 0.0 && (d.length() - 1.0).abs() < 1e-12);
        }
    }
}
