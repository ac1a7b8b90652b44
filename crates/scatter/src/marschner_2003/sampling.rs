//! Importance sampling of [`Marschner`]: lobe choice, θ_h and φ, and the pdf of that
//! mixture (kept together so the sampler can be read and changed in one place).
//!
//! Given ω_r: a lobe p with probability `w_p(θ_r)` (a table over |θ_r| of the luminance of
//! `½∫A(p, h)dh` at θ_d = θ_r, plus the TRT glint mass, each enabled lobe floored at
//! [`LOBE_FLOOR`]); θ_h from `g(β_p; θ_h − α_p)` truncated to the θ_h that keep
//! `θ_i = 2θ_h − θ_r ∈ [−90°, 90°]` (exact inversion, [`fiberlab_math::special::sample_truncated_normal`]);
//! then φ from a mixture: h uniform in [−1, 1] mapped through `φ = Φ(p, asin h)` (density
//! `Σ_roots cosγ/(2|dΦ/dγ|)`, the same roots as N_p; for TRT plus an offset s with the tent
//! density `(ε − |s|)/ε²`, ε = 6°, whose density in φ is the exact second difference
//! `[G(φ + ε) − 2G(φ) + G(φ − ε)]/ε²` of `G(y) = ½∫(y − Φ(2, asin h))⁺ dh`, closed form from
//! the roots and `∫Φ dh`: without it the density is infinite on the caustic ±φ_c, which no
//! grid quadrature of the pdf resolves, and a χ² with such a grid, Mitsuba's among them,
//! rejects), and for TRT also the two wrapped glint
//! Gaussians (probability ∝ t) and a uniform component (covers eccentric η*, whose Φ the
//! sampler cannot know before φ is drawn, and the glint tails; on a circular fiber only
//! with glints, probability ∝ t). The pdf is this mixture
//! summed over all lobes: per steradian, `Σ_p w_p·½·g(β_p; θ_h − α_p)/Z_p·p_φ,p(φ)/cosθ_i`
//! (½ = dθ_h/dθ_i, Z_p the truncated mass).
//!
//! The drawn `2θ_h − θ_r` goes through the pole taper ([`crate::hair::pole_taper`]): θ_i is
//! `W⁻¹(2θ_h − θ_r)` and the θ part of the density is taken at `θ*_h = (W(θ_i) + θ_r)/2` times
//! `W′(θ_i)`. At a grazing viewer (θ_r = ±1.555) the R lobe's Gaussian is centred beyond the
//! pole and truncated there; without the taper its density in θ_i does not vanish on the fiber
//! axis and the density per steradian (÷ cosθ_i) is infinite there, which a grid about the
//! fiber normal cannot integrate (∫pdf on the 150 × 301 normal-pole grid at θ_o = 1.555, β_R =
//! 5°: 0.98699 without the taper, 0.99993 with it).

use super::{LOBE_FLOOR, Lobe, MIN_DPHI, Marschner, PairAngles};
use crate::hair::attenuation::plane_attenuation;
use crate::hair::normal_plane::{Caustic, NormalPlane, RootMode, representative};
use crate::hair::pole_taper::{taper, taper_derivative, untaper};
use crate::{MIN_COS, Sample, ScatteringFunction};
use fiberlab_math::DVec3;
use fiberlab_math::frame::{cos_theta, direction_from_sin_cos, phi, sin_theta, wrap_pi};
use fiberlab_math::special::{gaussian, normal_mass, sample_truncated_normal, wrapped_gaussian};
use std::f64::consts::{FRAC_PI_2, PI, TAU};

/// Probability of the uniform-φ component when sampling TRT on a circular fiber, times the
/// glint fade t (none without glints).
const TRT_UNIFORM_CIRCULAR: f64 = 0.05;
/// Probability of the uniform-φ component when sampling TRT on an eccentric fiber.
const TRT_UNIFORM_ECCENTRIC: f64 = 0.2;
/// Half-width ε (radians, 6°) of the tent-distributed offset added to the TRT h-map's φ: it keeps
/// the sampling density finite at the caustic, where `Σ cosγ/(2|dΦ/dγ|)` is infinite, so that
/// the pdf can be integrated on any grid (see "Sampling" in the module header).
const TRT_CAUSTIC_SMOOTHING: f64 = 6.0 * PI / 180.0;
/// Largest share of the TRT φ-sampling given to the glint Gaussians.
const TRT_GLINT_MAX: f64 = 0.8;
/// Entries (minus one) of the lobe-selection table over |θ_r| ∈ [0, π/2].
pub(super) const LOBE_TABLE_INTERVALS: usize = 64;
/// Midpoint nodes in γ for `½∫A dh` in the lobe-selection table.
const LOBE_TABLE_NODES: usize = 64;

impl Marschner {
    pub(super) fn lobe_table(&self) -> [[f64; 3]; LOBE_TABLE_INTERVALS + 1] {
        let mut table = [[0.0; 3]; LOBE_TABLE_INTERVALS + 1];
        for (k, row) in table.iter_mut().enumerate() {
            let theta = FRAC_PI_2 * k as f64 / LOBE_TABLE_INTERVALS as f64;
            let (s, c) = theta.sin_cos();
            let plane = self.plane(self.params.eta, s, c);
            let mut w = [0.0; 3];
            for lobe in Lobe::ALL {
                if !self.params.lobes[lobe.p()] {
                    continue;
                }
                w[lobe.p()] = self.half_attenuation_integral(&plane, lobe, LOBE_TABLE_NODES).luminance();
                if lobe == Lobe::TRT && self.params.glints {
                    let (cst, dh) = self.glint(&plane);
                    let a_c =
                        plane_attenuation(&plane, 2, cst.h_c.asin(), self.params.sigma_a, self.params.absorption, true);
                    w[2] += 2.0 * cst.t * self.params.k_g * a_c.luminance() * dh;
                }
            }
            *row = w;
        }
        table
    }

    /// Density in φ of "h uniform, φ = Φ(p, asin h)": `Σ_roots cosγ/(2|dΦ/dγ|)` (rad⁻¹).
    pub(super) fn h_map_density(plane: &NormalPlane, lobe: Lobe, phi: f64) -> f64 {
        let p = lobe.p();
        plane
            .roots(p, representative(p, phi))
            .iter()
            .map(|g| g.cos() / (2.0 * plane.phi_and_derivative(p, g).1.abs().max(MIN_DPHI)))
            .sum()
    }

    /// `∫_0^{sinγ} Φ(p, asin h) dh` in closed form for this fiber's root mode (exact:
    /// `∫asin(kh)dh = h·asin(kh) + √(1 − k²h²)/k`, written without the 1/k; cubic: Φ is a
    /// polynomial in γ and `dh = cosγ dγ`).
    fn phi_primitive(&self, plane: &NormalPlane, p: usize, gamma: f64) -> f64 {
        let (pf, (h, c)) = (p as f64, gamma.sin_cos());
        match self.params.roots {
            RootMode::Exact => {
                let k = plane.inv_eta_prime();
                let kh = k * h;
                let inner = h * kh.asin() - k * h * h / (1.0 + (1.0 - kh * kh).max(0.0).sqrt());
                2.0 * pf * inner - 2.0 * (h * gamma + c - 1.0) + pf * PI * h
            }
            RootMode::Cubic => {
                let pc = pf * plane.inv_eta_prime().asin();
                let (a, b) = (-8.0 * pc / (PI * PI * PI), 6.0 * pc / PI - 2.0);
                let g = gamma;
                let t1 = g * h + c - 1.0;
                let t3 = g * g * g * h + 3.0 * g * g * c - 6.0 * g * h - 6.0 * c + 6.0;
                a * t3 + b * t1 + pf * PI * h
            }
        }
    }

    /// The monotone pieces of `Φ(p, ·)` on γ ∈ [−π/2, π/2] (split at its stationary point),
    /// each with Φ and [`Self::phi_primitive`] at its ends: what
    /// [`Self::h_map_second_primitive`] needs of a plane whatever y is.
    fn monotone_pieces(&self, plane: &NormalPlane, p: usize) -> ([MonotonePiece; 3], usize) {
        let piece = |g0: f64, g1: f64| MonotonePiece {
            gamma: (g0, g1),
            phi: (plane.phi_and_derivative(p, g0).0, plane.phi_and_derivative(p, g1).0),
            primitive: (self.phi_primitive(plane, p, g0), self.phi_primitive(plane, p, g1)),
        };
        match plane.stationary(p) {
            Some(g) => ([piece(-FRAC_PI_2, -g), piece(-g, g), piece(g, FRAC_PI_2)], 3),
            None => {
                let whole = piece(-FRAC_PI_2, FRAC_PI_2);
                ([whole, whole, whole], 1)
            }
        }
    }

    /// `G(y) = ½∫(y − Φ(p, asin h))⁺ dh` over h ∈ [−1, 1]: the second primitive in φ of the
    /// h-map's density in Φ's own (unreduced) range, exact from the roots of `Φ = y` on each
    /// monotone piece of Φ ([`Self::monotone_pieces`]) and [`Self::phi_primitive`].
    fn h_map_second_primitive(&self, plane: &NormalPlane, p: usize, pieces: &[MonotonePiece], y: f64) -> f64 {
        let roots = plane.roots(p, y);
        let mut sum = 0.0;
        for piece in pieces {
            let ((g0, g1), (f0, f1), (p0, p1)) = (piece.gamma, piece.phi, piece.primitive);
            // The part [ga, gb] of the piece where Φ ≤ y, with the primitive at its ends.
            let ((ga, pa), (gb, pb)) = if y >= f0.max(f1) {
                ((g0, p0), (g1, p1))
            } else if y <= f0.min(f1) {
                continue;
            } else {
                // The root on this piece (the nearest, should rounding put it just outside).
                let distance = |r: f64| (g0 - r).max(r - g1).max(0.0);
                let r = roots.iter().min_by(|a, b| distance(*a).total_cmp(&distance(*b)));
                let r = r.map_or(0.5 * (g0 + g1), |r| r.clamp(g0, g1));
                let at_root = (r, self.phi_primitive(plane, p, r));
                if f1 > f0 { ((g0, p0), at_root) } else { (at_root, (g1, p1)) }
            };
            sum += y * (gb.sin() - ga.sin()) - (pb - pa);
        }
        0.5 * sum
    }

    /// Density in φ of the TRT h-map smoothed by a tent of half-width ε =
    /// [`TRT_CAUSTIC_SMOOTHING`]: `φ = Φ(2, asin h) + s`, h uniform and s with density
    /// `(ε − |s|)/ε²`. It is the second difference `[G(x + ε) − 2G(x) + G(x − ε)]/ε²` of
    /// [`Self::h_map_second_primitive`] (summed over the images x ± 2π), so it is exact, and
    /// it is bounded and continuously differentiable where the plain h-map density is
    /// infinite (the caustics ±φ_c and their merge at η′ = 2).
    fn smoothed_trt_density(&self, plane: &NormalPlane, phi: f64) -> f64 {
        let e = TRT_CAUSTIC_SMOOTHING;
        let x = representative(2, phi);
        let (pieces, n) = self.monotone_pieces(plane, 2);
        let g = |y: f64| self.h_map_second_primitive(plane, 2, &pieces[..n], y);
        let d2 = |y: f64| g(y + e) - 2.0 * g(y) + g(y - e);
        // Φ(2, ·) takes values in [π, 3π]: only the images of x within ε of that range count
        // (G is linear beyond it, where the second difference vanishes).
        let sum: f64 = [x - TAU, x, x + TAU].iter().filter(|&&y| y + e > PI && y - e < 3.0 * PI).map(|&y| d2(y)).sum();
        (sum / (e * e)).max(0.0)
    }

    /// Lobe-selection probabilities given θ_r (sum 1 over enabled lobes).
    fn lobe_weights(&self, theta_r: f64) -> [f64; 3] {
        let x = (theta_r.abs() / FRAC_PI_2).min(1.0) * LOBE_TABLE_INTERVALS as f64;
        let k = (x as usize).min(LOBE_TABLE_INTERVALS - 1);
        let f = x - k as f64;
        let mut w = [0.0; 3];
        for (p, wp) in w.iter_mut().enumerate() {
            *wp = (1.0 - f) * self.lobe_table[k][p] + f * self.lobe_table[k + 1][p];
        }
        let total: f64 = w.iter().sum();
        let mut sum = 0.0;
        for (p, wp) in w.iter_mut().enumerate() {
            if self.params.lobes[p] {
                *wp = wp.max(LOBE_FLOOR * total).max(f64::MIN_POSITIVE);
                sum += *wp;
            }
        }
        w.map(|x| x / sum)
    }

    /// Truncation interval of z = (θ_h − α_p)/β_p keeping θ_i ∈ [−π/2, π/2], and its mass.
    fn theta_h_interval(&self, lobe: Lobe, theta_r: f64) -> (f64, f64, f64) {
        let (a, b) = (self.lobes.alpha[lobe.p()], self.lobes.beta[lobe.p()]);
        let zl = (0.5 * (theta_r - FRAC_PI_2) - a) / b;
        let zu = (0.5 * (theta_r + FRAC_PI_2) - a) / b;
        (zl, zu, normal_mass(zl, zu))
    }

    /// Probabilities (uniform, glint) of the φ-mixture components and the sampling plane's
    /// caustic; the rest goes to the h-map.
    fn phi_mixture(&self, lobe: Lobe, plane: &NormalPlane) -> (f64, f64, Caustic) {
        if lobe != Lobe::TRT {
            return (0.0, 0.0, Caustic { h_c: 0.0, phi_c: 0.0, d2phi_dh2: 0.0, t: 0.0 });
        }
        // The uniform part covers the eccentric lobe, and on a circular fiber the glint tails
        // (the glints are nonzero at every φ): without glints it would only draw directions
        // where the circular TRT is zero, samples of zero weight.
        let eccentric = self.params.eccentricity < 1.0;
        if !self.params.glints || self.params.k_g == 0.0 {
            let q_u = if eccentric { TRT_UNIFORM_ECCENTRIC } else { 0.0 };
            return (q_u, 0.0, Caustic { h_c: 0.0, phi_c: 0.0, d2phi_dh2: 0.0, t: 0.0 });
        }
        let (c, dh) = self.glint(plane);
        let q_u = if eccentric { TRT_UNIFORM_ECCENTRIC } else { TRT_UNIFORM_CIRCULAR * c.t };
        let share = self.params.k_g * dh / (self.params.k_g * dh + 0.5);
        (q_u, (1.0 - q_u) * (c.t * share).min(TRT_GLINT_MAX), c)
    }

    /// Density of `sample` per dθ_i dφ (not yet divided by cosθ_i). The θ part is the lobe's
    /// Gaussian at the tapered inclination `W(θ_i)` times `W′(θ_i)` ([`crate::hair::pole_taper`]).
    fn angular_density(&self, angles: &PairAngles) -> f64 {
        let taper_slope = taper_derivative(angles.theta_i);
        if taper_slope <= 0.0 {
            return 0.0;
        }
        let theta_h = 0.5 * (taper(angles.theta_i) + angles.theta_r);
        let w = self.lobe_weights(angles.theta_r);
        let plane = self.plane(self.params.eta, angles.sin_theta_d, angles.cos_theta_d);
        let mut q = 0.0;
        for lobe in Lobe::ALL {
            let wp = w[lobe.p()];
            if wp <= 0.0 {
                continue;
            }
            let (.., mass) = self.theta_h_interval(lobe, angles.theta_r);
            if mass <= 0.0 {
                continue;
            }
            let (a, b) = (self.lobes.alpha[lobe.p()], self.lobes.beta[lobe.p()]);
            let p_theta = 0.5 * gaussian(b, theta_h - a) / mass * taper_slope;
            if p_theta == 0.0 {
                continue;
            }
            let (q_u, q_g, c) = self.phi_mixture(lobe, &plane);
            let h_map = if lobe == Lobe::TRT {
                self.smoothed_trt_density(&plane, angles.phi)
            } else {
                Self::h_map_density(&plane, lobe, angles.phi)
            };
            let mut p_phi = (1.0 - q_u - q_g) * h_map + q_u / TAU;
            if q_g > 0.0 {
                let w_c = self.params.w_c;
                p_phi += q_g
                    * 0.5
                    * (wrapped_gaussian(w_c, angles.phi - c.phi_c) + wrapped_gaussian(w_c, angles.phi + c.phi_c));
            }
            q += wp * p_theta * p_phi;
        }
        q
    }

    /// Draws the relative azimuth φ for `lobe` given the plane (θ_d), with `u_component`
    /// choosing the mixture component and `(u2, u3)` placing φ.
    fn sample_phi(&self, lobe: Lobe, plane: &NormalPlane, u_component: f64, u2: f64, u3: f64) -> f64 {
        let (q_u, q_g, c) = self.phi_mixture(lobe, plane);
        if u_component < q_u {
            PI * (2.0 * u2 - 1.0)
        } else if u_component < q_u + q_g {
            // One of the two glint Gaussians, by Box–Muller.
            let (sign, u3) = if u3 < 0.5 { (1.0, 2.0 * u3) } else { (-1.0, 2.0 * u3 - 1.0) };
            let x = (-2.0 * (1.0 - u2).ln()).sqrt() * (TAU * u3).cos();
            wrap_pi(sign * c.phi_c + self.params.w_c * x)
        } else {
            let gamma = (2.0 * u2 - 1.0).clamp(-1.0, 1.0).asin();
            // TRT: a tent-distributed offset (inverse of its distribution function).
            let jitter = match lobe {
                Lobe::TRT if u3 < 0.5 => TRT_CAUSTIC_SMOOTHING * ((2.0 * u3).sqrt() - 1.0),
                Lobe::TRT => TRT_CAUSTIC_SMOOTHING * (1.0 - (2.0 - 2.0 * u3).sqrt()),
                _ => 0.0,
            };
            wrap_pi(plane.phi_and_derivative(lobe.p(), gamma).0 + jitter)
        }
    }

    /// The pdf of [`Self::sample_lobe`] per steradian.
    pub(super) fn sampling_pdf(&self, wi: DVec3, wo: DVec3) -> f64 {
        let q = self.angular_density(&PairAngles::new(wi, wo));
        q / cos_theta(wi).max(MIN_COS)
    }

    /// Draws ω_i given ω_r = `wo`: lobe, then θ_h, then φ (module header).
    pub(super) fn sample_lobe(&self, wo: DVec3, u: [f64; 4]) -> Option<Sample> {
        let theta_r = sin_theta(wo).atan2(cos_theta(wo));
        let w = self.lobe_weights(theta_r);
        // Lobe choice with u[0], then u[0] rescaled for the φ-component choice.
        let mut chosen = None;
        let mut acc = 0.0;
        for l in Lobe::ALL {
            let wp = w[l.p()];
            if wp <= 0.0 {
                continue;
            }
            chosen = Some((l, acc, wp));
            if u[0] < acc + wp {
                break;
            }
            acc += wp;
        }
        let (lobe, lo, wp) = chosen?;
        let u_component = ((u[0] - lo) / wp).clamp(0.0, 1.0);
        let (zl, zu, mass) = self.theta_h_interval(lobe, theta_r);
        if mass <= 0.0 {
            return None;
        }
        let z = sample_truncated_normal(u[1], zl, zu);
        let theta_h = self.lobes.alpha[lobe.p()] + self.lobes.beta[lobe.p()] * z;
        let theta_i = untaper((2.0 * theta_h - theta_r).clamp(-FRAC_PI_2, FRAC_PI_2));
        let (sd, cd) = (0.5 * (theta_r - theta_i)).sin_cos();
        let plane = self.plane(self.params.eta, sd, cd);
        let phi_rel = self.sample_phi(lobe, &plane, u_component, u[2], u[3]);
        let (si, ci) = theta_i.sin_cos();
        let wi = direction_from_sin_cos(si, ci, phi(wo) - phi_rel);
        let q = self.angular_density(&PairAngles::new(wi, wo));
        if q.is_nan() || q <= 0.0 || q.is_infinite() {
            return None;
        }
        // q is per dθ_i dφ; dω = cosθ_i dθ_i dφ, so pdf = q/cosθ_i and f·cosθ_i/pdf = f·cos²θ_i/q.
        let cos_i = cos_theta(wi);
        let weight = self.eval(wi, wo, 0.0) * (cos_i * cos_i / q);
        let pdf = q / cos_i.max(MIN_COS);
        debug_assert!(weight.is_finite() && pdf.is_finite());
        Some(Sample { wi, weight, pdf, delta: false, lobe: lobe.p() as u8 })
    }
}

/// A monotone piece [γ₀, γ₁] of `Φ(p, ·)`: Φ and its h-primitive at the ends.
#[derive(Clone, Copy)]
struct MonotonePiece {
    gamma: (f64, f64),
    phi: (f64, f64),
    primitive: (f64, f64),
}
