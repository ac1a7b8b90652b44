//! The density the dual-scattering bounce toward a surface is drawn from
//! ([`crate::dual_scattering::DualScattering::sample_bounce`]).
//!
//! The bounce estimates `∫ F(ω, ω_o; n(ω))·cosθ·L_s(ω) dω` over the directions ω that meet a
//! surface, where `F` is the dual-scattering function (`crate::dual_scattering`, module docs):
//! the fiber's own `f_s` (with `w = 1 − n > 0`), the broadened global lobes
//! `T_f·f_s^G(σ̄_f²)` and the backscatter lobe `d_b·f_back`. Drawn from the fiber's own sampler
//! alone (its density `p_s`), the weight `F·cosθ/p_s` is unbounded wherever the broadened or
//! the backscatter lobes reach beyond `f_s`'s (the global lobes are wider by σ̄_f, the
//! backscatter lobe sits at another shift and covers the whole back half-circle): rare, huge
//! weights — fireflies, and an image mean that at a few samples per pixel is dominated by them.
//!
//! Here ω is drawn from the mixture (one-sample MIS with the balance heuristic, i.e. the
//! mixture's density in the weight)
//!
//! `p(ω) = c_s·p_s(ω) + c_G·Σ_p w_p·q(θ; α_p, β_p² + S)/(2π cosθ) + c_B·q(θ; Δ̄_b, σ̄_b² + S)·[back]/(π cosθ)
//!  + c_U/(4π)`
//!
//! * `p_s`: the fiber's own sampler (covers `f_s` exactly);
//! * the global lobes: lobe p with probability `w_p ∝` the luminance of its energy
//!   `a_{f,p} + a_{b,p}`, θ_h from a Gaussian of the lobe's shift α_p and variance `β_p² + S`
//!   (truncated to the θ_h that keep θ in [−π/2, π/2]), `θ = W⁻¹(2θ_h − θ_o)` through the pole
//!   taper (`fiberlab_scatter::hair::pole_taper`: a finite density per steradian on the
//!   fiber axis), φ uniform on the circle — the shape of `f_s^G` (uniform in φ, energy form);
//! * the backscatter lobe: θ_h from the Gaussian of `f_back` (shift Δ̄_b, variance
//!   `σ̄_b²(1 + d_b ā_f²)² + S`), φ uniform on the back half-circle (within π/2 of φ_o);
//! * a uniform component (defensive: bounds the weight by `4πF cosθ/c_U` wherever the other
//!   components miss);
//!
//! with the table values of the viewer's mirror inclination `θ = −θ_o` (where the lobes
//! peak) and `S` a spread hint: the σ̄_f² of the light sample at this fiber plus one more
//! crossing, the spread a ray into the hair typically meets. Every quantity is fixed before
//! ω is drawn, so the density is exact; only the variance depends on how well it fits.

use fiberlab_math::frame::{cos_theta, direction_from_sin_cos, phi, sin_theta, wrap_pi};
use fiberlab_math::special::{gaussian, normal_mass, sample_truncated_normal};
use fiberlab_math::{DVec3, Rgb};
use fiberlab_scatter::ScatteringFunction;
use fiberlab_scatter::dual_scattering_tables::DualTables;
use fiberlab_scatter::hair::pole_taper::{taper, taper_derivative, untaper};
use std::f64::consts::{FRAC_PI_2, PI, TAU};

/// Probabilities of the mixture's components: the fiber's own sampler, the global lobes, the
/// backscatter lobe, uniform directions.
pub const BOUNCE_MIXTURE: [f64; 4] = [0.4, 0.3, 0.2, 0.1];

/// Most lobes a table row may separate for the global component (Chiang: 4).
const MAX_LOBES: usize = 8;

/// Smallest lobe variance used (rad²).
const MIN_VARIANCE: f64 = 1e-6;

/// A Gaussian in θ_h: shift and variance (luminance of the tables' per-channel values).
#[derive(Clone, Copy, Debug, PartialEq)]
struct HalfAngleLobe {
    shift: f64,
    sigma: f64,
}

impl HalfAngleLobe {
    fn new(shift: f64, variance: f64) -> Self {
        Self { shift, sigma: variance.max(MIN_VARIANCE).sqrt() }
    }

    /// Truncation of z = (θ_h − shift)/σ keeping θ = 2θ_h − θ_o in [−π/2, π/2], and its mass.
    fn interval(&self, theta_o: f64) -> (f64, f64, f64) {
        let zl = (0.5 * (theta_o - FRAC_PI_2) - self.shift) / self.sigma;
        let zu = (0.5 * (theta_o + FRAC_PI_2) - self.shift) / self.sigma;
        (zl, zu, normal_mass(zl, zu))
    }

    /// Density per dθ of θ (drawn through the pole taper) given θ_o.
    fn density(&self, theta: f64, theta_o: f64) -> f64 {
        let slope = taper_derivative(theta);
        let (.., mass) = self.interval(theta_o);
        if slope <= 0.0 || mass <= 0.0 {
            return 0.0;
        }
        let theta_h = 0.5 * (taper(theta) + theta_o);
        0.5 * gaussian(self.sigma, theta_h - self.shift) / mass * slope
    }

    /// θ from a uniform, given θ_o; `None` when the lobe has no mass on the sphere.
    fn sample(&self, theta_o: f64, u: f64) -> Option<f64> {
        let (zl, zu, mass) = self.interval(theta_o);
        if mass <= 0.0 {
            return None;
        }
        let theta_h = self.shift + self.sigma * sample_truncated_normal(u, zl, zu);
        Some(untaper((2.0 * theta_h - theta_o).clamp(-FRAC_PI_2, FRAC_PI_2)))
    }
}

/// The mixture of one bounce (module docs), in the fiber's local frame.
#[derive(Clone, Debug)]
pub struct BounceDensity {
    theta_o: f64,
    phi_o: f64,
    global: [(f64, HalfAngleLobe); MAX_LOBES],
    lobes: usize,
    back: HalfAngleLobe,
}

impl BounceDensity {
    /// The mixture for the viewer `wo` (local) of a fiber with `tables`, backward density
    /// `d_b` and spread hint `spread` (rad²).
    #[must_use]
    pub fn new(tables: &DualTables, wo: DVec3, backward_density: f64, spread: f64) -> Self {
        let theta_o = sin_theta(wo).atan2(cos_theta(wo));
        let mirror = -theta_o;
        let (k, w) = tables.locate(mirror);
        let rows = tables.rows();
        let (r0, r1) = (&rows[k], &rows[k + 1]);
        let mix = |a: Rgb, b: Rgb| (a * (1.0 - w) + b * w).luminance();
        let mut global = [(0.0, HalfAngleLobe::new(0.0, 1.0)); MAX_LOBES];
        let mut lobes = 0;
        let mut total = 0.0;
        for (l0, l1) in r0.lobes.iter().zip(&r1.lobes).take(MAX_LOBES) {
            let energy = mix(l0.forward + l0.backward, l1.forward + l1.backward).max(0.0);
            let lobe = HalfAngleLobe::new(mix(l0.shift, l1.shift), mix(l0.variance, l1.variance) + spread);
            global[lobes] = (energy, lobe);
            total += energy;
            lobes += 1;
        }
        for g in &mut global[..lobes] {
            g.0 = if total > 0.0 { g.0 / total } else { 1.0 / lobes as f64 };
        }
        let af = mix(r0.forward, r1.forward);
        let sigma_b = mix(r0.backscatter_spread, r1.backscatter_spread) * (1.0 + backward_density * af * af);
        let back = HalfAngleLobe::new(mix(r0.backscatter_shift, r1.backscatter_shift), sigma_b * sigma_b + spread);
        Self { theta_o, phi_o: phi(wo), global, lobes, back }
    }

    /// The mixture's density per steradian at `wi` (local); `model_pdf` is the fiber's own
    /// sampler's density there.
    #[must_use]
    pub fn pdf(&self, wi: DVec3, model_pdf: f64) -> f64 {
        let [c_s, c_g, c_b, c_u] = BOUNCE_MIXTURE;
        let theta = sin_theta(wi).atan2(cos_theta(wi));
        let cos = cos_theta(wi).max(fiberlab_scatter::MIN_COS);
        let global: f64 = self.global[..self.lobes].iter().map(|(w, l)| w * l.density(theta, self.theta_o)).sum();
        let back_half = wrap_pi(phi(wi) - self.phi_o).abs() < FRAC_PI_2;
        let back = if back_half { self.back.density(theta, self.theta_o) / PI } else { 0.0 };
        c_s * model_pdf + (c_g * global / TAU + c_b * back) / cos + c_u / (4.0 * PI)
    }

    /// Draws a direction (local) from four uniforms; `model` draws from the fiber's own
    /// sampler with the uniforms it is given. `None` when the chosen component draws nothing.
    pub fn sample(&self, u: [f64; 4], model: impl FnOnce([f64; 4]) -> Option<DVec3>) -> Option<DVec3> {
        let [c_s, c_g, c_b, _] = BOUNCE_MIXTURE;
        let x = u[0];
        if x < c_s {
            return model([x / c_s, u[1], u[2], u[3]]);
        }
        if x < c_s + c_g {
            // A lobe by its weight, with x rescaled to [0, 1).
            let mut v = (x - c_s) / c_g;
            let mut chosen = self.global[self.lobes.saturating_sub(1)].1;
            for (w, l) in &self.global[..self.lobes] {
                if v < *w {
                    chosen = *l;
                    break;
                }
                v -= w;
            }
            let theta = chosen.sample(self.theta_o, u[1])?;
            let (s, c) = theta.sin_cos();
            return Some(direction_from_sin_cos(s, c, self.phi_o + PI * (2.0 * u[2] - 1.0)));
        }
        if x < c_s + c_g + c_b {
            let theta = self.back.sample(self.theta_o, u[1])?;
            let (s, c) = theta.sin_cos();
            return Some(direction_from_sin_cos(s, c, self.phi_o + FRAC_PI_2 * (2.0 * u[2] - 1.0)));
        }
        let z = 2.0 * u[1] - 1.0;
        Some(direction_from_sin_cos(z, (1.0 - z * z).max(0.0).sqrt(), TAU * u[2]))
    }
}

/// The fiber model's own sampler as [`BounceDensity::sample`] takes it.
pub fn model_sampler<'a>(
    model: &'a (impl ScatteringFunction + ?Sized),
    wo: DVec3,
    h: f64,
) -> impl FnOnce([f64; 4]) -> Option<DVec3> + 'a {
    move |u| model.sample(wo, h, u).map(|s| s.wi)
}

#[cfg(test)]
mod tests {
    use super::*;
    use fiberlab_math::split_mix::SplitMix64;
    use fiberlab_scatter::dual_scattering_tables::Resolution;

    fn tables() -> (fiberlab_scatter::Model, DualTables) {
        let model = fiberlab_scatter::build("chiang", &[("eumelanin", "0.2"), ("beta_m", "0.3")]).unwrap();
        let r = Resolution {
            inclinations: 16,
            incident_azimuths: 2,
            outgoing_inclinations: 32,
            outgoing_azimuths: 32,
            offsets: 4,
        };
        let t = DualTables::new(&model, &r).unwrap();
        (model, t)
    }

    /// The mixture's pdf integrates to 1 over the sphere (midpoint rule in (sinθ, φ), the
    /// fiber's own sampler replaced by a uniform density), and histograms of its samples agree
    /// with it cell by cell.
    #[test]
    fn the_mixture_density_is_normalized_and_is_the_density_of_its_samples() {
        let (_, t) = tables();
        for (theta_o, spread) in [(0.3, 0.0), (-1.2, 0.05), (1.5, 0.2)] {
            let wo = fiberlab_math::frame::direction(theta_o, 0.7);
            let d = BounceDensity::new(&t, wo, 1.0, spread);
            let uniform = 1.0 / (4.0 * PI);
            let (nz, np) = (400, 400);
            let mut integral = 0.0;
            for i in 0..nz {
                let t = -FRAC_PI_2 + (i as f64 + 0.5) * PI / nz as f64;
                for j in 0..np {
                    let p = (j as f64 + 0.5) * TAU / np as f64;
                    let w = fiberlab_math::frame::direction(t, p);
                    integral += d.pdf(w, uniform) * t.cos() * (PI / nz as f64) * (TAU / np as f64);
                }
            }
            assert!((integral - 1.0).abs() < 2e-3, "θ_o {theta_o}: ∫p = {integral}");
            // Samples: coarse histogram in (sinθ, φ) against the pdf's cell masses.
            let (bz, bp) = (12, 12);
            let mut counts = vec![0.0; bz * bp];
            let mut rng = SplitMix64::new(3);
            let n = 200_000;
            for _ in 0..n {
                let u = [rng.next_f64(), rng.next_f64(), rng.next_f64(), rng.next_f64()];
                let model = |v: [f64; 4]| {
                    let z = 2.0 * v[1] - 1.0;
                    Some(direction_from_sin_cos(z, (1.0 - z * z).sqrt(), TAU * v[2]))
                };
                let w = d.sample(u, model).expect("a direction");
                let a = (((w.x + 1.0) * 0.5 * bz as f64) as usize).min(bz - 1);
                let b = (((phi(w) + PI) / TAU * bp as f64) as usize).min(bp - 1);
                counts[a * bp + b] += 1.0;
            }
            for a in 0..bz {
                for b in 0..bp {
                    let mut mass = 0.0;
                    let sub = 40;
                    for i in 0..sub {
                        let z = -1.0 + (a as f64 + (i as f64 + 0.5) / sub as f64) * 2.0 / bz as f64;
                        for j in 0..sub {
                            let p = -PI + (b as f64 + (j as f64 + 0.5) / sub as f64) * TAU / bp as f64;
                            let w = direction_from_sin_cos(z, (1.0 - z * z).sqrt(), p);
                            mass += d.pdf(w, uniform);
                        }
                    }
                    let expected = mass * (2.0 / bz as f64) * (TAU / bp as f64) / (sub * sub) as f64 * n as f64;
                    let got = counts[a * bp + b];
                    assert!(
                        (got - expected).abs() <= 5.0 * expected.sqrt() + 0.02 * expected + 5.0,
                        "θ_o {theta_o}, cell ({a}, {b}): {got} samples, expected {expected}"
                    );
                }
            }
        }
    }
}
