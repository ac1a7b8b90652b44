//! Normal-plane optics of a smooth circular dielectric fiber (radius 1): the projection of a
//! ray inclined by θ onto the plane perpendicular to the axis refracts as if the index were
//! Bravais' `η′ = √(η² − sin²θ)/cosθ`, so the internal angle is `γ_t = asin(h/η′)`
//! (`docs/theory/conventions.md`, "Bravais indices" and "Exit azimuth").
//!
//! * The exit azimuth of the path with p internal segments, [`exit_azimuth`], written once:
//!   `Φ(p, h) = 2pγ_t − 2γ + pπ`, γ = asin h (Marschner 2003; the same in every
//!   implementation). Φ(0, 0) = 0 is backscatter, Φ(1, 0) = π straight through.
//! * [`NormalPlane`]: for one inclination (Marschner uses θ_d, Chiang the camera-side θ_o) and
//!   index, `1/η′` in the cancellation-free form `cosθ/√(η² − sin²θ)` (finite at grazing
//!   θ, where η′ → ∞ and Φ becomes linear), `cosθ_t`, Φ and dΦ/dγ, and the roots of
//!   `Φ(p, γ) = φ` ([`RootMode::Exact`]: bracketing on the monotone pieces, split at the
//!   stationary point, and safeguarded Newton; [`RootMode::Cubic`]: Marschner 2003's
//!   approximation `γ_t ≈ (3c/π)γ − (4c/π³)γ³`, c = asin(1/η′), solved by the same bracketing,
//!   so the degenerate cubic as c → 0 needs no special case).
//! * [`Caustic`]: the TRT caustic, where dΦ(2, ·)/dh = 0: `h_c = √((4 − η′²)/3)` (exists iff
//!   η′ < 2), `φ_c = Φ(2, h_c) − 2π`, `d²Φ/dh² = 2p·h/(η′² − h²)^{3/2} − 2h/(1 − h²)^{3/2}` at h_c;
//!   above η′ = 2 the two caustics have merged at φ = 0 and fade with
//!   `t = 1 − smoothstep(2, 2 + Δη′, η′)` (Marschner 2003's glint fade; the only choice
//!   continuous with t = 1 below η′ = 2). The cubic's caustic is at its own stationary point
//!   (20.49° instead of the exact 18.62° at θ_d = 0, η = 1.55).

use fiberlab_math::bravais;
use fiberlab_math::special::{safe_sqrt, smoothstep};
use std::f64::consts::{FRAC_PI_2, PI, TAU};

/// `|Φ(p, γ) − φ|` (radians) at which the root solve stops: a few ulps of 3π.
const ROOT_TOLERANCE: f64 = 4e-15;
/// Iterations of safeguarded Newton (each either a Newton step or a bisection).
const MAX_ROOT_ITERATIONS: usize = 100;

/// Exit azimuth `Φ(p, h) = 2pγ_t − 2γ + pπ` (not wrapped) of the path with `p` internal
/// segments, from the 2D incidence angle `gamma = asin h` and the internal angle `gamma_t`.
#[must_use]
#[inline]
pub fn exit_azimuth(p: usize, gamma: f64, gamma_t: f64) -> f64 {
    let p = p as f64;
    2.0 * p * gamma_t - 2.0 * gamma + p * PI
}

/// How the exit-azimuth equation `Φ(p, γ) = φ` is solved.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RootMode {
    /// Exact Φ, bracketing + safeguarded Newton.
    Exact,
    /// Marschner 2003's cubic approximation of γ_t.
    Cubic,
}

/// The 2D problem in the normal plane for one inclination θ_d and index η: Bravais'
/// `1/η′`, the internal `cosθ_t`, and Φ with its derivatives, its roots and the TRT caustic.
#[derive(Clone, Copy, Debug)]
pub struct NormalPlane {
    eta: f64,
    cos_theta_d: f64,
    /// `1/η′ = cosθ_d/sqrt(η² − sin²θ_d)` ∈ [0, 1/η].
    inv_eta_prime: f64,
    /// `c = asin(1/η′)`, the cubic's parameter.
    c: f64,
    cos_theta_t: f64,
    mode: RootMode,
}

/// Roots γ of `Φ(p, γ) = target` in [−π/2, π/2] (at most three).
#[derive(Clone, Copy, Debug, Default)]
pub struct Roots {
    gamma: [f64; 3],
    n: usize,
}

impl Roots {
    fn push(&mut self, g: f64) {
        if self.n < 3 {
            self.gamma[self.n] = g;
            self.n += 1;
        }
    }
    /// The roots found.
    pub fn iter(&self) -> impl Iterator<Item = f64> + '_ {
        self.gamma[..self.n].iter().copied()
    }
}

/// The TRT caustic (Marschner 2003's glints) of one [`NormalPlane`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Caustic {
    /// Offset h_c ≥ 0 of the caustic (0 when η′ ≥ 2).
    pub h_c: f64,
    /// Azimuth φ_c = Φ(2, h_c) − 2π, radians.
    pub phi_c: f64,
    /// `d²Φ/dh²` at h_c (0 when η′ ≥ 2).
    pub d2phi_dh2: f64,
    /// Fade t ∈ [0, 1].
    pub t: f64,
}

impl NormalPlane {
    /// The normal-plane problem for index `eta` at `sinθ_d`, `cosθ_d ≥ 0`.
    #[must_use]
    pub fn new(eta: f64, sin_theta_d: f64, cos_theta_d: f64, mode: RootMode) -> Self {
        // 1/η′ = sinγ_t at h = 1, in the cancellation-free form (finite at cosθ_d = 0).
        let inv_eta_prime = bravais::sin_gamma_t(1.0, eta, sin_theta_d, cos_theta_d);
        Self {
            eta,
            cos_theta_d,
            inv_eta_prime,
            c: inv_eta_prime.asin(),
            cos_theta_t: bravais::cos_theta_t(eta, sin_theta_d),
            mode,
        }
    }

    /// The index η of this plane.
    #[must_use]
    pub fn eta(&self) -> f64 {
        self.eta
    }

    /// `cosθ_d ≥ 0`, the inclination's cosine.
    #[must_use]
    pub fn cos_theta_d(&self) -> f64 {
        self.cos_theta_d
    }

    /// `1/η′ = sinγ_t at h = 1`, in [0, 1/η].
    #[must_use]
    pub fn inv_eta_prime(&self) -> f64 {
        self.inv_eta_prime
    }

    /// `cosθ_t` inside the fiber (Snell along the axis, `sinθ_t = sinθ_d/η`).
    #[must_use]
    pub fn cos_theta_t(&self) -> f64 {
        self.cos_theta_t
    }

    /// Bravais' η′ (+∞ at θ_d = ±90°).
    #[must_use]
    pub fn eta_prime(&self) -> f64 {
        1.0 / self.inv_eta_prime
    }

    /// Internal angle γ_t = asin(sinγ/η′) (exact).
    #[must_use]
    pub fn gamma_t(&self, gamma: f64) -> f64 {
        (gamma.sin() * self.inv_eta_prime).asin()
    }

    /// `Φ(p, γ)` (not reduced mod 2π) and `dΦ/dγ` with this plane's root mode.
    #[must_use]
    pub fn phi_and_derivative(&self, p: usize, gamma: f64) -> (f64, f64) {
        let pf = p as f64;
        match self.mode {
            RootMode::Exact => {
                let (s, c) = gamma.sin_cos();
                let st = s * self.inv_eta_prime;
                let phi = exit_azimuth(p, gamma, st.asin());
                let d = 2.0 * pf * self.inv_eta_prime * c / safe_sqrt(1.0 - st * st) - 2.0;
                (phi, d)
            }
            RootMode::Cubic => {
                let (a, b) = self.cubic_coefficients(p);
                (a * gamma * gamma * gamma + b * gamma + pf * PI, 3.0 * a * gamma * gamma + b)
            }
        }
    }

    /// `(a, b)` of `Φ̂(p, γ) = aγ³ + bγ + pπ`: `a = −8pc/π³`, `b = 6pc/π − 2`.
    fn cubic_coefficients(&self, p: usize) -> (f64, f64) {
        let pc = p as f64 * self.c;
        (-8.0 * pc / (PI * PI * PI), 6.0 * pc / PI - 2.0)
    }

    /// The stationary point γ_s ∈ (0, π/2) of Φ(p, ·), if any (a caustic).
    #[must_use]
    pub fn stationary(&self, p: usize) -> Option<f64> {
        match self.mode {
            RootMode::Exact => {
                // dΦ/dγ = 0 ⇔ cos²γ = (1 − 1/η′²)/((p² − 1)/η′²)
                if p < 2 {
                    return None;
                }
                let inv2 = self.inv_eta_prime * self.inv_eta_prime;
                let pp = (p * p - 1) as f64;
                let cos2 = (1.0 - inv2) / (pp * inv2);
                (cos2 < 1.0 && cos2 > 0.0).then(|| cos2.sqrt().acos())
            }
            RootMode::Cubic => {
                let (a, b) = self.cubic_coefficients(p);
                if p == 0 || b <= 0.0 || a >= 0.0 {
                    return None;
                }
                let g = (-b / (3.0 * a)).sqrt();
                (g < FRAC_PI_2).then_some(g)
            }
        }
    }

    /// Roots of `Φ(p, γ) = target` on [−π/2, π/2], target already in (pπ − π, pπ + π].
    #[must_use]
    pub fn roots(&self, p: usize, target: f64) -> Roots {
        let mut roots = Roots::default();
        if p == 0 {
            // Φ(0, γ) = −2γ, both modes.
            let g = -0.5 * target;
            if g.abs() <= FRAC_PI_2 {
                roots.push(g);
            }
            return roots;
        }
        let pi_p = p as f64 * PI;
        // Φ(p, γ) − pπ is odd in γ, so the end values follow from the positive side; at
        // γ = π/2 both modes give 2pc − π (the cubic interpolates γ_t there).
        let end = 2.0 * p as f64 * self.c - PI;
        match self.stationary(p) {
            None => {
                self.solve_monotone(p, target, -FRAC_PI_2, FRAC_PI_2, -end + pi_p, end + pi_p, &mut roots);
            }
            Some(gs) => {
                let mid = self.phi_and_derivative(p, gs).0 - pi_p;
                self.solve_monotone(p, target, -FRAC_PI_2, -gs, -end + pi_p, -mid + pi_p, &mut roots);
                self.solve_monotone(p, target, -gs, gs, -mid + pi_p, mid + pi_p, &mut roots);
                self.solve_monotone(p, target, gs, FRAC_PI_2, mid + pi_p, end + pi_p, &mut roots);
            }
        }
        roots
    }

    /// Safeguarded Newton for `Φ(p, γ) = target` on a piece `[lo, hi]` where Φ is monotone,
    /// with `Φ(lo) = phi_lo`, `Φ(hi) = phi_hi`.
    #[allow(clippy::too_many_arguments)]
    fn solve_monotone(&self, p: usize, target: f64, lo: f64, hi: f64, phi_lo: f64, phi_hi: f64, out: &mut Roots) {
        let (f_lo, f_hi) = (phi_lo - target, phi_hi - target);
        if f_lo == 0.0 {
            out.push(lo);
            return;
        }
        if f_hi == 0.0 {
            out.push(hi);
            return;
        }
        if (f_lo > 0.0) == (f_hi > 0.0) {
            return;
        }
        let increasing = f_hi > f_lo;
        let (mut a, mut b) = (lo, hi);
        // Regula falsi start, then Newton steps kept inside the bracket.
        let mut x = lo + (hi - lo) * f_lo / (f_lo - f_hi);
        for _ in 0..MAX_ROOT_ITERATIONS {
            let (phi, d) = self.phi_and_derivative(p, x);
            let f = phi - target;
            // |Φ − target| at the level of Φ's rounding (|Φ| ≤ 3π): x is the root to
            // ~1e−15/|Φ′|, which only matters within ~1e−14 rad of a caustic.
            if f.abs() <= ROOT_TOLERANCE {
                break;
            }
            if (f > 0.0) == increasing {
                b = x;
            } else {
                a = x;
            }
            let newton = x - f / d;
            let next = if newton > a && newton < b { newton } else { 0.5 * (a + b) };
            let step = (next - x).abs();
            x = next;
            if step <= 1e-15 * (1.0 + x.abs()) || b - a <= 1e-15 {
                break;
            }
        }
        out.push(x);
    }

    /// The TRT caustic; `delta_eta` is the fade range Δη′ above η′ = 2.
    #[must_use]
    pub fn caustic(&self, delta_eta: f64) -> Caustic {
        let eta_prime = self.eta_prime();
        match self.stationary(2) {
            Some(gc) => {
                let h_c = gc.sin();
                let phi_c = self.phi_and_derivative(2, gc).0 - TAU;
                let d2phi_dh2 = match self.mode {
                    RootMode::Exact => {
                        // d²Φ/dh² = 2p·h/(η′² − h²)^{3/2} − 2h/(1 − h²)^{3/2}, p = 2
                        let hi = h_c * self.inv_eta_prime;
                        let inv3 = self.inv_eta_prime.powi(3);
                        let (a, b) = (1.0 - hi * hi, 1.0 - h_c * h_c);
                        4.0 * h_c * inv3 / (a * a.sqrt()) - 2.0 * h_c / (b * b.sqrt())
                    }
                    RootMode::Cubic => {
                        // Φ̂''(γ)/cos²γ with Φ̂'' = 6aγ, a = −16c/π³
                        let (a, _) = self.cubic_coefficients(2);
                        6.0 * a * gc / gc.cos().powi(2)
                    }
                };
                Caustic { h_c, phi_c, d2phi_dh2, t: 1.0 }
            }
            // No stationary point (η′ ≥ 2): the caustics have merged at φ = 0 and fade out.
            None => {
                Caustic { h_c: 0.0, phi_c: 0.0, d2phi_dh2: 0.0, t: 1.0 - smoothstep(2.0, 2.0 + delta_eta, eta_prime) }
            }
        }
    }
}

/// The representative of φ modulo 2π in (pπ − π, pπ + π], where Φ(p, ·) takes its values.
#[must_use]
pub fn representative(p: usize, phi: f64) -> f64 {
    match p {
        0 => phi,
        1 => {
            if phi > 0.0 {
                phi
            } else {
                phi + TAU
            }
        }
        _ => phi + TAU,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every root returned solves `Φ(p, γ) = target`, written out independently as
    /// `2p·asin(sinγ/η′) − 2γ + pπ`, and the roots found are all there are (counted by sign
    /// changes on a fine grid).
    #[test]
    fn roots_solve_the_exit_azimuth_and_none_is_missed() {
        for &(eta, theta) in &[(1.55, 0.0), (1.55, 0.7), (1.3, 1.2), (2.5, 0.2)] {
            let (s, c) = f64::sin_cos(theta);
            let plane = NormalPlane::new(eta, s, c, RootMode::Exact);
            let ep = (eta * eta - s * s).sqrt() / c;
            let phi = |p: usize, g: f64| 2.0 * p as f64 * (g.sin() / ep).asin() - 2.0 * g + p as f64 * PI;
            for p in 0..3 {
                for k in 0..40 {
                    let target = representative(p, -PI + (k as f64 + 0.37) * TAU / 40.0);
                    let roots: Vec<f64> = plane.roots(p, target).iter().collect();
                    for &g in &roots {
                        assert!((phi(p, g) - target).abs() < 1e-12, "p {p} target {target}: γ {g}");
                    }
                    let n = 100_003; // not commensurate with the targets: no node falls on a root
                    let grid = |j: usize| -FRAC_PI_2 + PI * j as f64 / n as f64;
                    let changes = (0..n).filter(|&j| (phi(p, grid(j)) - target) * (phi(p, grid(j + 1)) - target) < 0.0);
                    assert_eq!(changes.count(), roots.len(), "η {eta} θ {theta} p {p} target {target}");
                }
            }
        }
    }

    /// The TRT caustic against its closed form `h_c = √((4 − η′²)/3)` (dΦ/dh = 0) and the
    /// worked value φ_c = 18.62° at η = 1.55, θ = 0.
    #[test]
    fn caustic_matches_its_closed_form() {
        let plane = NormalPlane::new(1.55, 0.0, 1.0, RootMode::Exact);
        let c = plane.caustic(0.3);
        assert!((c.h_c - ((4.0 - 1.55f64 * 1.55) / 3.0).sqrt()).abs() < 1e-12);
        assert!((c.phi_c.to_degrees() - 18.62).abs() < 0.006 && c.t == 1.0);
        assert_eq!(exit_azimuth(0, 0.0, 0.0), 0.0);
        assert_eq!(exit_azimuth(1, 0.0, 0.0), PI);
    }
}
