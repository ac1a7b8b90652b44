//! Normal-plane optics of a tube: a wall of index η (radius 1) around a concentric core of
//! relative radius κ and another index η_c — an air-filled lumen (η_c = 1), a liquid-filled one,
//! or an index-matched core (η_c = η, the medulla's boundary, where nothing happens). This
//! generalises the solid fiber's paths ([`super::normal_plane`]) to light that meets the core
//! (`docs/theory/hair.md`, "Concentric core").
//!
//! # The invariant
//! Every boundary is a cylinder parallel to the axis, so the axial component of the wave vector
//! is conserved: `sinθ = η sinθ_t = η_c sinθ_c`, and the projection on the normal plane refracts
//! with Bravais' index of each medium, `η′ = √(η² − sin²θ)/cosθ` (wall) and
//! `η′_c = √(η_c² − sin²θ)/cosθ` (core; 1 for air at every θ). In the plane, a straight segment's
//! distance from the axis `b` is unchanged by reflection at a concentric circle, and refraction
//! keeps `η′·b` fixed: a ray entering at offset h runs at `b = h/η′` in the wall and at
//! `b_c = h/η′_c` in the core. Exact 3D Snell's law is exactly this pair (axial conservation,
//! planar Snell with η′), so total internal reflection in 3D and in the plane coincide.
//!
//! # One wall pass
//! Inside the wall a ray goes from the outer surface inward and back out to it, a *wall pass*.
//! If `|b| ≥ κ` it misses the core: a straight chord, no turn. Otherwise it meets the core at the
//! 2D incidence angle `γ_k = asin(b/κ)` and
//! * reflects off it with probability `F_c` (the exact 3D Fresnel reflectance of the index ratio
//!   `η_c/η` at `cos ι = cosθ_t cosγ_k`), turning by `π − 2γ_k`, or
//! * crosses it along j ≥ 1 core chords (j − 1 reflections inside the core), with probability
//!   `(1 − F_c)²F_c^{j−1}`, turning by `2(γ_c − γ_k) + (j − 1)(2γ_c − π)`, `γ_c = asin(b_c/κ)`;
//! * when `|b_c| ≥ κ` there is total internal reflection (`F_c = 1`).
//!
//! The turns follow the signs of the outer surface, which the core resembles seen from the wall:
//! an external reflection turns the direction of travel by `π − 2γ`, a refraction by the
//! refracted minus the incident angle, a reflection from inside by `2γ_t − π` (so the solid
//! fiber's exit azimuth is `Φ(p, h) = π + 2(γ_t − γ) + (p − 1)(2γ_t − π)`, Marschner's
//! `2pγ_t − 2γ + pπ` modulo 2π; [`super::normal_plane::exit_azimuth`]). Every pass of the same
//! ray has the same b, so a path of p passes turns by `Φ(p, h)` plus the sum of its passes'
//! turns, whatever their order. The wall length of a pass is the same for all of its kinds: the
//! cortex part of [`super::attenuation::chord_lengths`]. The core is taken clear (no absorption,
//! air or water), so the kinds' probabilities sum to 1.
//!
//! [`WallPasses`] lists the kinds explicitly up to [`MAX_CORE_CHORDS`] core chords; the rest,
//! `(1 − F_c)F_c^{J}` for J = [`MAX_CORE_CHORDS`], is returned as [`WallPasses::beyond`].

use super::attenuation::chord_lengths;
use fiberlab_math::special::safe_sqrt;
use fiberlab_math::{bravais, fresnel};
use std::f64::consts::PI;

/// Core crossings listed one by one (j = 1 … J core chords); more are summed in
/// [`WallPasses::beyond`]. With an air lumen in a wall of index 1.55, the first three carry all
/// but `(1 − F_c)F_c³` ≈ 10⁻⁴ of the passes through the core at normal incidence.
pub const MAX_CORE_CHORDS: usize = 3;
/// The most kinds of wall pass: a reflection off the core and `MAX_CORE_CHORDS` crossings.
pub const MAX_PASS_KINDS: usize = 1 + MAX_CORE_CHORDS;

/// The normal plane of a tube seen at one inclination θ (outside): Bravais' indices of wall and
/// core and the wall's internal `cosθ_t`.
#[derive(Clone, Copy, Debug)]
pub struct Tube {
    kappa: f64,
    /// `η_c/η`, the index ratio at the core's boundary seen from the wall.
    core_ratio: f64,
    /// `1/η′` of the wall.
    inv_eta_prime: f64,
    /// `1/η′_c` of the core.
    inv_eta_prime_core: f64,
    cos_theta_t: f64,
}

/// The kinds of wall pass of a ray at one offset: weight (probability, Fresnel only) and turn of
/// each, the weight of the crossings beyond [`MAX_CORE_CHORDS`], and the wall length.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WallPasses {
    /// Kinds listed (1 when the pass misses the core or is totally reflected by it).
    pub n: usize,
    /// Probability of each kind: `[1]` (miss), `[1]` (total internal reflection), or
    /// `[F_c, (1 − F_c)², (1 − F_c)²F_c, …]`.
    pub weight: [f64; MAX_PASS_KINDS],
    /// Turn of the direction of travel of each kind (radians, not wrapped).
    pub turn: [f64; MAX_PASS_KINDS],
    /// Probability of crossing the core along more than [`MAX_CORE_CHORDS`] chords,
    /// `(1 − F_c)F_c^J`; `Σ weight + beyond = 1`.
    pub beyond: f64,
    /// Turn of the crossings with J + 1 core chords (the first of those summed in `beyond`).
    pub beyond_turn: f64,
    /// Length of one pass in the wall (radius units, 3D: `2(√(1 − b²) − √(κ² − b²))/cosθ_t`).
    pub wall_length: f64,
    /// Whether the pass meets the core (`|b| < κ`).
    pub meets_core: bool,
}

impl Tube {
    /// The tube of wall index `eta` > 1, core radius `kappa` ∈ [0, 1) and core index
    /// `core_eta` ≥ 1, seen at inclination (`sin_theta`, `cos_theta ≥ 0`).
    #[must_use]
    pub fn new(eta: f64, kappa: f64, core_eta: f64, sin_theta: f64, cos_theta: f64) -> Self {
        // 1/η′_c = cosθ/√(η_c² − sin²θ) with η_c² − sin²θ = (η_c² − 1) + cos²θ, exact for an
        // air core (1/η′_c = 1 at every θ, also on the axis, its limit).
        let d = (core_eta * core_eta - 1.0) + cos_theta * cos_theta;
        let inv_eta_prime_core = if d > 0.0 { (cos_theta / d.sqrt()).min(1.0) } else { 1.0 };
        Self {
            kappa,
            core_ratio: core_eta / eta,
            inv_eta_prime: bravais::sin_gamma_t(1.0, eta, sin_theta, cos_theta),
            inv_eta_prime_core,
            cos_theta_t: bravais::cos_theta_t(eta, sin_theta),
        }
    }

    /// `1/η′` of the wall.
    #[must_use]
    pub fn inv_eta_prime(&self) -> f64 {
        self.inv_eta_prime
    }

    /// `1/η′_c` of the core.
    #[must_use]
    pub fn inv_eta_prime_core(&self) -> f64 {
        self.inv_eta_prime_core
    }

    /// The offsets `|h|` at which the pass structure changes, ascending, each at most 1: where
    /// total internal reflection at the core begins (`κη′_c`) and where the pass stops meeting
    /// the core (`κη′`). Between them and toward them from below, chords and angles have square-root
    /// ends; a quadrature substitutes `h = c·sinψ` on each piece ending at c.
    #[must_use]
    pub fn breakpoints(&self) -> [f64; 2] {
        let edge = |inv: f64| if self.kappa < inv { self.kappa / inv } else { 1.0 };
        let (a, b) = (edge(self.inv_eta_prime_core), edge(self.inv_eta_prime));
        [a.min(b), b]
    }

    /// The kinds of wall pass of a ray entering at offset `h` ∈ [−1, 1].
    #[must_use]
    pub fn passes(&self, h: f64) -> WallPasses {
        let b = h * self.inv_eta_prime;
        let wall_length = chord_lengths(b, self.cos_theta_t, self.kappa).cortex;
        let mut out = WallPasses {
            n: 1,
            weight: [1.0, 0.0, 0.0, 0.0],
            turn: [0.0; MAX_PASS_KINDS],
            beyond: 0.0,
            beyond_turn: 0.0,
            wall_length,
            meets_core: false,
        };
        if b.abs() >= self.kappa {
            return out;
        }
        out.meets_core = true;
        if self.core_ratio == 1.0 {
            return out; // an index-matched core: straight through, as a miss
        }
        let sin_k = b / self.kappa;
        let gamma_k = sin_k.asin();
        out.turn[0] = PI - 2.0 * gamma_k;
        let sin_c = h * self.inv_eta_prime_core / self.kappa;
        if sin_c.abs() >= 1.0 {
            return out; // total internal reflection: one kind, weight 1
        }
        let cos_iota = self.cos_theta_t * safe_sqrt(1.0 - sin_k * sin_k);
        let f = fresnel::dielectric(cos_iota, self.core_ratio);
        if f >= 1.0 {
            return out;
        }
        let gamma_c = sin_c.asin();
        let (cross, inside) = (2.0 * (gamma_c - gamma_k), 2.0 * gamma_c - PI);
        out.n = MAX_PASS_KINDS;
        out.weight[0] = f;
        let mut w = (1.0 - f) * (1.0 - f);
        for j in 1..=MAX_CORE_CHORDS {
            out.weight[j] = w;
            out.turn[j] = cross + (j - 1) as f64 * inside;
            w *= f;
        }
        out.beyond = (1.0 - f) * f.powi(MAX_CORE_CHORDS as i32);
        out.beyond_turn = cross + MAX_CORE_CHORDS as f64 * inside;
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hair::normal_plane::exit_azimuth;
    use fiberlab_math::DVec3;
    use fiberlab_math::frame::wrap_pi;

    /// A 2D ray in the normal plane (x, y), traced independently of the formulas above: circle
    /// intersections, vector Snell's law with the given Bravais indices, mirror reflection.
    struct Ray2 {
        p: (f64, f64),
        d: (f64, f64),
    }

    fn dot(a: (f64, f64), b: (f64, f64)) -> f64 {
        a.0 * b.0 + a.1 * b.1
    }

    impl Ray2 {
        /// Distance to the circle of radius r ahead (the far root from inside, the near one from
        /// outside), if any.
        fn to_circle(&self, r: f64, inside: bool) -> Option<f64> {
            let b = dot(self.p, self.d);
            let c = dot(self.p, self.p) - r * r;
            let disc = b * b - c;
            if disc < 0.0 {
                return None;
            }
            let t = if inside { -b + disc.sqrt() } else { -b - disc.sqrt() };
            (t > 1e-12).then_some(t)
        }
        fn advance(&mut self, t: f64) {
            self.p = (self.p.0 + t * self.d.0, self.p.1 + t * self.d.1);
        }
        /// Unit normal at the current point facing against the direction of travel.
        fn facing_normal(&self) -> (f64, f64) {
            let r = dot(self.p, self.p).sqrt();
            let n = (self.p.0 / r, self.p.1 / r);
            if dot(n, self.d) > 0.0 { (-n.0, -n.1) } else { n }
        }
        fn reflect(&mut self) {
            let n = self.facing_normal();
            let k = 2.0 * dot(self.d, n);
            self.d = (self.d.0 - k * n.0, self.d.1 - k * n.1);
        }
        /// Refract from index n1 to n2; false under total internal reflection.
        fn refract(&mut self, n1: f64, n2: f64) -> bool {
            let n = self.facing_normal();
            let cos_i = -dot(self.d, n);
            let r = n1 / n2;
            let k = 1.0 - r * r * (1.0 - cos_i * cos_i);
            if k < 0.0 {
                return false;
            }
            let c = r * cos_i - k.sqrt();
            self.d = (r * self.d.0 + c * n.0, r * self.d.1 + c * n.1);
            true
        }
    }

    /// The exit azimuth relative to the light, `angle(ω_o) − angle(ω_i)` with ω_i = −d₀, of a
    /// ray entering at offset h and taking the given events. `script` lists for each wall
    /// pass the core event: `None` for a pass that must miss the core, `Some(j)` for j core
    /// chords (0 = reflect off the core).
    fn traced_exit(h: f64, ep: f64, epc: f64, kappa: f64, script: &[Option<usize>]) -> f64 {
        // Light travels along −y; offset h along +x… chosen so that R leaves at Φ = −2γ.
        let mut ray = Ray2 { p: (h, 5.0), d: (0.0, -1.0) };
        let t = ray.to_circle(1.0, false).unwrap();
        ray.advance(t);
        if script.is_empty() {
            ray.reflect();
        } else {
            assert!(ray.refract(1.0, ep));
            for (k, event) in script.iter().enumerate() {
                if k > 0 {
                    ray.reflect(); // internal reflection at the outer surface
                }
                match (ray.to_circle(kappa, false), event) {
                    (None, None) => {}
                    (Some(t), Some(j)) => {
                        ray.advance(t);
                        if *j == 0 {
                            ray.reflect();
                        } else {
                            assert!(ray.refract(ep, epc), "TIR where a crossing was scripted");
                            for c in 0..*j {
                                if c > 0 {
                                    ray.reflect();
                                }
                                let t = ray.to_circle(kappa, true).unwrap();
                                ray.advance(t);
                            }
                            assert!(ray.refract(epc, ep));
                        }
                    }
                    (hit, e) => panic!("script {e:?} but core hit {hit:?}"),
                }
                let t = ray.to_circle(1.0, true).unwrap();
                ray.advance(t);
            }
            assert!(ray.refract(ep, 1.0));
        }
        let angle = |v: (f64, f64)| v.1.atan2(v.0);
        wrap_pi(angle(ray.d) - angle((0.0, 1.0)))
    }

    /// Every kind of pass, combined over one and two passes, turns the ray by the exit azimuth
    /// of the solid fiber plus the sum of the kinds' turns, as an independent 2D trace finds.
    #[test]
    fn pass_turns_match_a_traced_ray() {
        let mut checked = 0;
        for &(eta, core_eta, theta) in &[(1.55, 1.0, 0.0), (1.55, 1.0, 0.7), (1.5, 1.33, 0.3), (1.4, 1.8, -0.5)] {
            let (s, c) = f64::sin_cos(theta);
            let ep = bravais::eta_prime(eta, s, c);
            let epc = bravais::eta_prime(core_eta, s, c);
            for &kappa in &[0.3, 0.5, 0.8] {
                let tube = Tube::new(eta, kappa, core_eta, s, c);
                assert!((tube.inv_eta_prime_core() - 1.0 / epc).abs() < 1e-14);
                for k in 0..40 {
                    let h = -0.99 + 1.98 * (k as f64 + 0.5) / 40.0;
                    let passes = tube.passes(h);
                    let (gamma, gamma_t) = (h.asin(), (h / ep).asin());
                    // R
                    let got = wrap_pi(exit_azimuth(0, gamma, gamma_t));
                    assert!((wrap_pi(got - traced_exit(h, ep, epc, kappa, &[]))).abs() < 1e-10);
                    let kinds: Vec<Option<usize>> =
                        if passes.meets_core { (0..passes.n).map(Some).collect() } else { vec![None] };
                    for (a, &ka) in kinds.iter().enumerate() {
                        let want = traced_exit(h, ep, epc, kappa, &[ka]);
                        let got = exit_azimuth(1, gamma, gamma_t) + passes.turn[a];
                        assert!(wrap_pi(got - want).abs() < 1e-9, "h {h} κ {kappa} kind {ka:?}: {got} vs {want}");
                        for (b, &kb) in kinds.iter().enumerate() {
                            let want = traced_exit(h, ep, epc, kappa, &[ka, kb]);
                            let got = exit_azimuth(2, gamma, gamma_t) + passes.turn[a] + passes.turn[b];
                            assert!(wrap_pi(got - want).abs() < 1e-9, "h {h} {ka:?} {kb:?}: {got} vs {want}");
                            checked += 1;
                        }
                    }
                    if passes.n == MAX_PASS_KINDS {
                        let want = traced_exit(h, ep, epc, kappa, &[Some(MAX_CORE_CHORDS + 1)]);
                        let got = exit_azimuth(1, gamma, gamma_t) + passes.beyond_turn;
                        assert!(wrap_pi(got - want).abs() < 1e-9);
                    }
                }
            }
        }
        assert!(checked > 1000, "{checked}");
    }

    /// Where the trace finds total internal reflection at the core, the passes have one kind
    /// (a reflection of weight 1); where it finds a crossing, the weights are Fresnel's of a
    /// 3D ray refracted into the wall and meeting the core, computed with vectors (no Bravais
    /// index): they sum to 1 with `beyond`.
    #[test]
    fn weights_are_3d_fresnel_at_the_core_and_sum_to_one() {
        let (eta, core_eta) = (1.55, 1.0);
        let mut tir = 0;
        let mut crossing = 0;
        for &theta in &[0.0f64, 0.6, -1.2] {
            let (s, c) = theta.sin_cos();
            for &kappa in &[0.4, 0.7] {
                let tube = Tube::new(eta, kappa, core_eta, s, c);
                for k in 0..50 {
                    let h = -0.98 + 1.96 * (k as f64 + 0.5) / 50.0;
                    let p = tube.passes(h);
                    let total: f64 = p.weight[..p.n].iter().sum::<f64>() + p.beyond;
                    assert!((total - 1.0).abs() < 1e-14, "{total}");
                    // 3D: incoming along −y inclined by θ toward +x (the axis), entering at
                    // offset h; refract with vector Snell into the wall.
                    let d0 = DVec3::new(-s, -c, 0.0);
                    let n0 = DVec3::new(0.0, (1.0 - h * h).sqrt(), -h);
                    let r = 1.0 / eta;
                    let ci = -d0.dot(n0);
                    let d = d0 * r + n0 * (r * ci - (1.0 - r * r * (1.0 - ci * ci)).sqrt());
                    // Closest approach to the axis in the (y, z) plane.
                    let (py, pz, dy, dz) = (n0.y, n0.z, d.y, d.z);
                    let a = dy * dy + dz * dz;
                    let t_mid = -(py * dy + pz * dz) / a;
                    let b = ((py + t_mid * dy).powi(2) + (pz + t_mid * dz).powi(2)).sqrt();
                    assert_eq!(b < kappa, p.meets_core, "h {h} κ {kappa} θ {theta}");
                    if !p.meets_core {
                        continue;
                    }
                    // The point on the core, its normal, the 3D incidence cosine.
                    let t = t_mid - ((kappa * kappa - b * b) / a).sqrt();
                    let q = DVec3::new(0.0, py + t * dy, pz + t * dz) / kappa;
                    let cos_iota = -d.dot(q);
                    let f = fresnel::dielectric(cos_iota, core_eta / eta);
                    if f >= 1.0 {
                        assert_eq!((p.n, p.weight[0]), (1, 1.0));
                        tir += 1;
                    } else {
                        assert!((p.weight[0] - f).abs() < 1e-12, "{} vs {f}", p.weight[0]);
                        assert!((p.weight[1] - (1.0 - f).powi(2)).abs() < 1e-12);
                        crossing += 1;
                    }
                }
            }
        }
        assert!(tir > 10 && crossing > 10, "{tir} {crossing}");
    }

    /// An index-matched core (η_c = η) transmits everything straight through: one kind of
    /// weight 1 and turn 0, the solid fiber's pass; and a nearly matched one tends to it.
    #[test]
    fn an_index_matched_core_changes_nothing() {
        let (s, c) = 0.4f64.sin_cos();
        let tube = Tube::new(1.55, 0.6, 1.55, s, c);
        for k in 0..21 {
            let p = tube.passes(-1.0 + 0.1 * k as f64);
            assert_eq!((p.n, p.weight[0], p.turn[0], p.beyond), (1, 1.0, 0.0, 0.0), "{p:?}");
        }
        let near = Tube::new(1.55, 0.6, 1.55 - 1e-9, s, c).passes(0.3);
        assert!(near.weight[1] > 1.0 - 1e-12 && near.turn[1].abs() < 1e-6, "{near:?}");
        let bp = tube.breakpoints();
        assert!((bp[0] - bp[1]).abs() < 1e-15);
    }
}
