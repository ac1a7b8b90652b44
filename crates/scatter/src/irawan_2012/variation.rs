//! Spine shapes, per-fiber intensity variation and `u_max` noise of [`super::Irawan2012`]
//! (all off by default; see the model's module docs).

use fiberlab_math::split_mix::mix64;
use std::f64::consts::PI;

use super::pattern::{Located, YarnKind, YarnSegment};

/// The shape of a yarn's spine (the curve of its centre line in the plane of the yarn axis
/// and the normal).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Spine {
    /// Every spine a circular arc, `R = (l/2)/sin u_max` (κ ignored; the default, with which
    /// the presets are tuned).
    Circle,
    /// The paper's conic spines selected by κ (see the module docs).
    Conic,
}

/// Options of a fabric beyond its pattern, fixed at construction (all off by default; the
/// normalisation tables include them).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Variation {
    /// Spine shape.
    pub spine: Spine,
    /// Fiber strips per grid cell across the fibers for the random intensity variation (0: off).
    pub fineness: f64,
    /// Amplitude of the smooth noise added to every `u_max`, radians (0: off).
    pub umax_noise: f64,
    /// Period (lattice spacing) of that noise, in tiles of UV.
    pub umax_noise_period: f64,
}

impl Default for Variation {
    fn default() -> Self {
        Self { spine: Spine::Circle, fineness: 0.0, umax_noise: 0.0, umax_noise_period: 1.0 }
    }
}

/// Largest `u_max` after noise (radians, just under 90°) and smallest.
const UMAX_LIMITS: (f64, f64) = (0.5 * PI / 180.0, 89.5 * PI / 180.0);
/// Seeds of the hashed noises (fixed forever: a fabric looks the same in every version).
const FIBER_SEED: u64 = 0x2012_f1be;
const UMAX_SEED: u64 = 0x2012_0a45;

/// `r̂ = 1 + κ(1 + 1/tan u_max)`, the conic parameter of a spine.
#[must_use]
pub fn spine_shape(kappa: f64, u_max: f64) -> f64 {
    1.0 + kappa * (1.0 + 1.0 / u_max.tan())
}

/// Radius of curvature of a conic spine with parameter `r_hat` (ratio of the semi-axis along
/// the yarn to the one along the normal), half-chord `half`, end inclination `u_max`, at the
/// point of inclination `u` (|u| ≤ u_max). Ellipse `(A sin t, B cos t)` for `r̂ > 0` (circle
/// for `r̂ = 1`), parabola `z = −x²/(2p)` for `r̂ = 0`, hyperbola `(A sinh t, −B cosh t)` for
/// `r̂ < 0`; the parameter at inclination `u` solves `tan t = r̂ tan u` (`tanh t = |r̂| tan u`),
/// the chord fixes `A` (`A sin t_max = l/2`, `A sinh t_max = l/2`, `p tan u_max = l/2`) and
/// `B = A/|r̂|`; `R = (A² cos²t + B² sin²t)^{3/2}/(AB)` (cosh, sinh for the hyperbola),
/// `R = p(1 + tan²u)^{3/2}` for the parabola. A hyperbola needs `|r̂| tan u_max < 1` (its
/// asymptotes steeper than `u_max`), which κ > −1 guarantees: with `k = −κ ∈ (0, 1)`,
/// `|r̂| tan u_max = k − (1 − k) tan u_max < 1` (tested); the argument is still held below 1.
#[must_use]
pub fn conic_radius(r_hat: f64, half: f64, u_max: f64, u: f64) -> f64 {
    let u = u.abs().min(u_max);
    if r_hat > 0.0 {
        let t_max = (r_hat * u_max.tan()).atan();
        let a = half / t_max.sin();
        let b = a / r_hat;
        let (st, ct) = (r_hat * u.tan()).atan().sin_cos();
        (a * a * ct * ct + b * b * st * st).powf(1.5) / (a * b)
    } else if r_hat < 0.0 {
        let q = -r_hat;
        let limit = 1.0 - 1e-9;
        let t_max = (q * u_max.tan()).min(limit).atanh();
        let a = half / t_max.sinh();
        let b = a / q;
        let t = (q * u.tan()).min(limit).atanh();
        let (sh, ch) = (t.sinh(), t.cosh());
        (a * a * ch * ch + b * b * sh * sh).powf(1.5) / (a * b)
    } else {
        let p = half / u_max.tan();
        p * (1.0 + u.tan().powi(2)).powf(1.5)
    }
}

/// Uniform in (0, 1) from a hash of the integers `keys`.
fn hashed_unit(seed: u64, keys: &[i64]) -> f64 {
    let h = keys.iter().fold(mix64(seed), |h, &k| mix64(h ^ (k as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)));
    ((h >> 11) as f64 + 0.5) * (1.0 / (1u64 << 53) as f64)
}

impl Variation {
    /// The segment's `u_max` at UV `(u, v)`: plus the noise (one field for warps, one for
    /// wefts), held in `UMAX_LIMITS`.
    pub(super) fn u_max(&self, yarn: &YarnSegment, u: f64, v: f64) -> f64 {
        if self.umax_noise == 0.0 {
            return yarn.u_max;
        }
        let seed = UMAX_SEED ^ u64::from(yarn.kind == YarnKind::Weft);
        let n = fiberlab_math::noise::value_noise(seed, u / self.umax_noise_period, v / self.umax_noise_period, 1);
        (yarn.u_max + self.umax_noise * n).clamp(UMAX_LIMITS.0, UMAX_LIMITS.1)
    }

    /// The intensity factor of the fiber under the point: the fibers of a segment run at the
    /// twist ψ to its axis, so the coordinate across them is `x cos ψ − y sin ψ`; strips of
    /// width `1/fineness` cells of it are fibers, and each fiber of each segment copy gets
    /// `min(−ln ξ, 10)` (ξ uniform, hashed from the copy, the yarn id and the strip): mean
    /// `1 − e⁻¹⁰`, so the fabric's average brightness is kept.
    pub(super) fn fiber_factor(&self, at: &Located<'_>) -> f64 {
        if self.fineness == 0.0 {
            return 1.0;
        }
        let (s, c) = at.yarn.psi.sin_cos();
        let strip = ((at.x * c - at.y * s) * self.fineness).floor() as i64;
        let xi = hashed_unit(FIBER_SEED, &[at.instance[0], at.instance[1], at.id as i64, strip]);
        (-xi.ln()).min(10.0)
    }

    /// The spine's radius of curvature at inclination `u` for a segment with `u_max`.
    pub(super) fn radius(&self, yarn: &YarnSegment, u_max: f64, u: f64) -> f64 {
        let half = 0.5 * yarn.length;
        match self.spine {
            Spine::Circle => half / u_max.sin(),
            Spine::Conic => conic_radius(spine_shape(yarn.kappa, u_max), half, u_max, u),
        }
    }

    /// The side of the square of UV that the normalisation averages over: one tile, or, with
    /// the `u_max` noise on, enough tiles to hold 8×8 cells of its lattice.
    pub(super) fn extent(&self) -> f64 {
        if self.umax_noise == 0.0 { 1.0 } else { (8.0 * self.umax_noise_period).ceil().max(1.0) }
    }
}
