//! Chiang, Bitterli, Tappan & Burley 2016, *A practical and controllable hair and fur model
//! for production path tracing* (Computer Graphics Forum 35(2), Eurographics 2016), as in
//! pbrt-v4's `HairBxDF`: a near-field (h-dependent), camera-side energy-conserving, exactly
//! importance-sampled hair fiber. Built from the hair core ([`crate::hair`]); the shared
//! mathematics is in `docs/theory/hair.md`, the peers' differences in
//! `docs/theory/peer-discrepancies.md`. Equations are cited by the quantity they define.
//!
//! Parameters: the registry entry (the `params` of `Registered::INFO` below) is the one table of
//! keys, units, defaults and valid ranges; `fiberlab models --model chiang` prints it and the
//! book's page `docs/book/src/models/chiang.md` shows it. `alpha` is given in degrees and held in
//! radians in [`ChiangParams`].
//!
//! Absorption comes from exactly one of: `sigma_a`; the melanin concentrations
//! (`eumelanin` and/or `pheomelanin`, the missing one 0); or a desired `color`
//! ([`crate::hair::absorption::Absorption`]). Giving keys from two of these groups is an error. With none, eumelanin
//! 1.3 (pbrt's default, a brown).
//!
//! # Formula
//! For a camera direction `ω_o` hitting the fiber at offset `h` (γ_o = asin h), the per-hit
//! integrand of the paper's near-field model is
//! `g_h(ω_o, ω_i) = Σ_{p<3} M_p(θ_i, θ_o^(p))·A_p(θ_o, h)·N_p(φ) + M_3(θ_i, θ_o)·A_3/(2π)`,
//! a density over `ω_i` with `∫ g_h dω_i = Σ A_p`. fiberlab's convention
//! `L_r = ∫ f_s L_i cosθ_i dω_i` makes the near-field scattering function
//! `f_s(ω_i, ω_o; h) = g_h(ω_o, ω_i)/cosθ_i` ([`crate::hair::backward_form`]); its
//! h-average is the far-field `f_s`. Sign of h (pbrt's): the surface normal at the hit has
//! azimuth `φ_o − asin h`, i.e. seen from +z (φ_o = π/2), h increases toward +y; the R lobe
//! then leaves at `φ_i = φ_o − 2 asin h`.
//! * `M_p`: d'Eon et al. 2011's normalized longitudinal function
//!   ([`crate::hair::longitudinal::Longitudinal`]) with Chiang's variance map
//!   `v_0 = (0.726β_m + 0.812β_m² + 3.7β_m²⁰)²`, `v_1 = v_0/4`, `v_2 = v_3 = 4v_0`
//!   ([`crate::hair::roughness`]).
//! * `N_p(φ) = ℓ(wrap(φ − Φ(p, h)); s)/(F_ℓ(π) − F_ℓ(−π))` for p < 3, φ = φ_i − φ_o: Chiang's
//!   logistic lobe `ℓ(x; s) = e^{−|x|/s}/(s(1 + e^{−|x|/s})²)` trimmed to [−π, π], with the
//!   exact exit azimuth `Φ(p, h) = 2pγ_t − 2γ_o + pπ` ([`crate::hair::normal_plane::exit_azimuth`])
//!   and the scale `s = √(π/8)·(0.265β_n + 1.194β_n² + 5.372β_n²²)`; `N_3 = 1/(2π)`.
//! * `A_0 = f`, `A_1 = (1 − f)²T`, `A_2 = A_1 f T`, and the residual of all p ≥ 3,
//!   `A_3 = A_2 f T/(1 − f T)`; `f` the exact 3D dielectric Fresnel at `cosθ_o cosγ_o`,
//!   `T = exp(−σ_a·2cosγ_t/cosθ_t)` the chord absorption (σ_a per unit radius), all at the
//!   camera-side θ_o ([`crate::hair::attenuation::hit_attenuation`]). `Σ A_p = 1` when σ_a = 0.
//! * Cuticle tilt ([`crate::hair::tilt`]): the fixed camera-side direction of lobe p is rotated,
//!   `θ_o^(0) = θ_o + 2α`, `θ_o^(1) = θ_o − α`, `θ_o^(2) = θ_o − 4α`, `θ_o^(3) = θ_o`, so each
//!   `M_p(·, θ_o^(p))` stays normalized in θ_i. With θ positive toward the tip and α > 0 the
//!   lobe centres are `θ_i + θ_o = −2α` (R, toward the root), `+α` (TT), `+4α` (TRT).
//!
//! # Sampling
//! Lobe p from `u[0]` with weights `w_p = Y(A_p)/Σ_q Y(A_q)` (Y = Rec. 709 luminance), θ_i
//! from `M_p(·, θ_o^(p))` with `u[1], u[2]`, φ_i from the trimmed logistic (uniform for p = 3)
//! with `u[3]`. `pdf = Σ_p w_p M_p N_p` per steradian, exactly the density of the samples,
//! and the weight `f_s cosθ_i/pdf = g_h/pdf` equals `Σ A_p` whenever the `A_p` are gray
//! (in particular exactly 1 when σ_a = 0).
//!
//! # Conventions and caveats
//! * **Tilt sign**: `alpha > 0` is the physical scale angle (R toward the root).
//!   pbrt-v4, Mitsuba 3 and Tungsten rotate with the opposite sign of α, so fiberlab's
//!   `alpha = 2` is their `−2`; Cycles rotates the light-side direction instead, whose rotated
//!   `M_p` is no longer normalized (`docs/theory/peer-discrepancies.md`, "Tilt sign").
//! * **Inclination of the optics**: η′, Fresnel and absorption use the camera-side θ_o (as
//!   pbrt, Mitsuba, Cycles), not Marschner's and d'Eon's θ_d; they agree on the specular cone
//!   (`docs/theory/peer-discrepancies.md`, "Inclination used for the normal-plane optics").
//! * **Absorption units**: σ_a is per unit radius (chord `2cosγ_t/cosθ_t` of a radius-1 fiber);
//!   a physical σ in 1/m is σ_a/R (`docs/theory/peer-discrepancies.md`, "Absorption units").
//! * **Non-reciprocity and camera-side energy**: the model conserves energy on the camera side
//!   only and is not reciprocal: the light-side albedo exceeds 1 at grazing light
//!   ([`Chiang::light_side_albedo`]; σ_a = 0, β = 0.3, α = 0: 0.989 at θ_i = 0, 1.48 at 1.4
//!   rad, 10.2 at 1.55 rad) and [`Chiang::non_reciprocity`] measures the asymmetry.
//!   `properties()` claims neither property (`docs/theory/radiometry.md`, "Backward-form models").
//! * At exactly grazing light (cosθ_i = 0) `eval` divides by
//!   [`crate::hair::backward_form::MIN_COS`].
//!
//! # Example: a value pinned by the closed form
//! Lossless (σ_a = 0), untilted, at h = 0 and with ω_i = ω_o at θ = 0 (backscatter,
//! φ = 0): γ_o = γ_t = 0, `Φ(p, 0) = pπ`, Fresnel is the normal-incidence
//! `f = ((η − 1)/(η + 1))²`, and `M_p(0, 0) = I₀(1/v_p)/(2v_p sinh(1/v_p))`. The doctest writes
//! the paper's formulas out itself (I₀ by its power series, the logistic and both roughness
//! maps by hand) and compares with `eval`.
//! ```
//! use fiberlab_math::frame::direction;
//! use fiberlab_scatter::ScatteringFunction;
//! use fiberlab_scatter::chiang_2016::{Chiang, ChiangParams};
//! use fiberlab_scatter::hair::absorption::Absorption;
//! use std::f64::consts::PI;
//!
//! let (eta, beta) = (1.55f64, 0.3f64);
//! let fiber = Chiang::new(ChiangParams { alpha: 0.0, absorption: Absorption::NONE, ..ChiangParams::default() })?;
//! let w = direction(0.0, 0.5 * PI);
//! let got = fiber.eval(w, w, 0.0)[1];
//!
//! let i0 = |x: f64| (1..200).fold((1.0f64, 1.0f64), |(sum, term), k| {
//!     let term = term * (0.25 * x * x) / (k * k) as f64;
//!     (sum + term, term)
//! }).0;
//! let m = |v: f64| i0(1.0 / v) / (2.0 * v * (1.0 / v).sinh());
//! let v0 = (0.726 * beta + 0.812 * beta * beta + 3.7 * beta.powi(20)).powi(2);
//! let s = (PI / 8.0).sqrt() * (0.265 * beta + 1.194 * beta * beta + 5.372 * beta.powi(22));
//! let logistic = |x: f64| (-x.abs() / s).exp() / (s * (1.0 + (-x.abs() / s).exp()).powi(2));
//! let trim = (PI / (2.0 * s)).tanh(); // F_ℓ(π) − F_ℓ(−π)
//! let f = ((eta - 1.0) / (eta + 1.0)).powi(2);
//! let a = [f, (1.0 - f).powi(2), (1.0 - f).powi(2) * f, (1.0 - f).powi(2) * f * f / (1.0 - f)];
//! let want = m(v0) * a[0] * logistic(0.0) / trim          // R: Φ = 0
//!     + m(v0 / 4.0) * a[1] * logistic(PI) / trim          // TT: φ − Φ = −π
//!     + m(4.0 * v0) * a[2] * logistic(0.0) / trim         // TRT: φ − Φ ≡ 0
//!     + m(4.0 * v0) * a[3] / (2.0 * PI);                  // residual
//! assert!((got - want).abs() < 1e-10 * want, "{got} vs {want}");
//! # Ok::<(), fiberlab_scatter::chiang_2016::ChiangError>(())
//! ```

use crate::hair::attenuation::{Hit, hit_attenuation};
use crate::hair::backward_form::{MIN_COS, max_relative_non_reciprocity};
use crate::hair::fiber::HairFiberParams;
use crate::hair::longitudinal::Longitudinal;
use crate::hair::normal_plane::exit_azimuth;
use crate::hair::parameters;
use crate::hair::roughness::{lobe_variances, logistic_scale};
use crate::hair::tilt::{lobe_tilts, rotate};
use crate::params::{ParamSet, ParamSpec, parameter_error};
use crate::{Field, LobeInfo, Lobes, ModelError, ModelInfo, Properties, Registered, Sample, ScatteringFunction};
use fiberlab_math::frame::{cos_theta, direction_from_sin_cos, phi, sin_theta, wrap_pi};
use fiberlab_math::special::{logistic, logistic_cdf, safe_sqrt};
use fiberlab_math::{DVec3, Rgb};
use std::f64::consts::{FRAC_PI_2, PI, TAU};

const PARAMS: [ParamSpec; 8] = [
    parameters::ETA,
    parameters::BETA_M,
    parameters::BETA_N,
    parameters::ALPHA,
    parameters::SIGMA_A,
    parameters::EUMELANIN,
    parameters::PHEOMELANIN,
    parameters::COLOR,
];

/// Registry entry: `chiang`.
impl Registered for Chiang {
    const INFO: ModelInfo = ModelInfo {
        name: "chiang",
        summary: "Chiang 2016 / pbrt-v4 near-field hair: d'Eon M_p, logistic N_p, exact sampling",
        citation: "Chiang et al. 2016; d'Eon et al. 2011",
        params: &PARAMS,
        data: None,
    };

    fn from_param_set(p: &ParamSet) -> Result<Self, ModelError> {
        Ok(Chiang::new(ChiangParams::from_param_set(p)?)?)
    }
}

/// Parameters of [`Chiang`]: the shared hair-fiber parameters (tilt in **radians**; the
/// registry takes degrees), with presets `blond()`, `brown()`, `black()`.
pub type ChiangParams = HairFiberParams;

parameter_error! {
    /// Why a [`Chiang`] fiber cannot be built: a parameter outside its range (named, with
    /// the range; angles in degrees).
    ChiangError
}

/// Chiang 2016 near-field hair fiber.
#[derive(Clone, Debug)]
pub struct Chiang {
    params: ChiangParams,
    /// σ_a per unit radius, resolved from the absorption (the colour inversion needs β_n).
    sigma_a: Rgb,
    longitudinal: [Longitudinal; 4],
    tilt: [(f64, f64); 4],
    s: f64,
    /// `1/(F_ℓ(π) − F_ℓ(−π))`.
    logistic_norm: f64,
    /// `(F_ℓ(−π), F_ℓ(π))`, the logistic CDF at the trimmed range's ends.
    logistic_cdf_ends: (f64, f64),
}

impl Chiang {
    /// A Chiang fiber; the error names the parameter out of range.
    pub fn new(params: ChiangParams) -> Result<Self, ChiangError> {
        params.validate()?;
        let HairFiberParams { beta_m, beta_n, alpha, absorption, .. } = params;
        let s = logistic_scale(beta_n);
        Ok(Self {
            params,
            sigma_a: absorption.sigma_a(beta_n),
            longitudinal: lobe_variances(beta_m).map(Longitudinal::new),
            tilt: lobe_tilts(alpha),
            s,
            logistic_norm: 1.0 / (logistic_cdf(PI, s) - logistic_cdf(-PI, s)),
            logistic_cdf_ends: (logistic_cdf(-PI, s), logistic_cdf(PI, s)),
        })
    }

    /// The parameters (radians).
    #[must_use]
    pub fn params(&self) -> &ChiangParams {
        &self.params
    }
    /// σ_a per unit radius (from the absorption; the colour inversion depends on β_n).
    #[must_use]
    pub fn sigma_a(&self) -> Rgb {
        self.sigma_a
    }
    /// Logistic scale `s` (radians).
    #[must_use]
    pub fn logistic_scale(&self) -> f64 {
        self.s
    }

    /// Everything of the fiber at one path vertex that depends on `ω_o` and `h` only: the
    /// attenuations `A_p`, the lobe weights, the tilted camera-side inclinations and the exit
    /// azimuths `Φ(p, h)`. A renderer computes it once per vertex and shares it between the
    /// light-sample evaluations and the bounce sample; [`ScatteringFunction::eval`] and
    /// [`ScatteringFunction::sample`] go through it too, so both give the same bits.
    #[must_use]
    pub fn at_vertex(&self, wo: DVec3, h: f64) -> ChiangAtVertex<'_> {
        let (sin_o, cos_o) = (sin_theta(wo), cos_theta(wo));
        let hit = hit_attenuation(self.params.eta, self.sigma_a, sin_o, cos_o, h);
        let weights = Self::lobe_weights(&hit);
        ChiangAtVertex {
            fiber: self,
            phi_o: phi(wo),
            tilted: self.tilt.map(|tau| rotate(sin_o, cos_o, tau)),
            exit: [0, 1, 2].map(|p| exit_azimuth(p, hit.gamma_o, hit.gamma_t)),
            a: hit.a,
            weights,
        }
    }

    /// Lobe-selection weights `w_p = Y(A_p)/Σ Y(A_q)`; `None` if all vanish.
    #[inline]
    fn lobe_weights(hit: &Hit) -> Option<[f64; 4]> {
        let y = hit.a.map(Rgb::luminance);
        let total: f64 = y.iter().sum();
        (total > 0.0).then(|| y.map(|x| x / total))
    }

    /// Light-side albedo `ρ(ω_i) = ∫ f̄_s(ω_i, ω_r) cosθ_r dω_r` of the h-averaged `f_s` at
    /// light inclination `theta_i` (see [`crate::hair::backward_form`]). Since each `N_p` integrates to 1,
    /// `ρ = (1/cosθ_i)∫ cos²θ_r Σ_p M_p(θ_i, θ_r^(p)) Ā_p(θ_r) dθ_r` with `Ā_p` the
    /// h-average of `A_p`; evaluated with 2048 θ cells × 64 h cells (midpoint). Exceeds 1
    /// at grazing light: the model conserves energy on the camera side only.
    #[must_use]
    pub fn light_side_albedo(&self, theta_i: f64) -> Rgb {
        let (sin_i, cos_i) = theta_i.sin_cos();
        let (n_theta, n_h) = (2048, 64);
        let dt = PI / n_theta as f64;
        let mut sum = Rgb::ZERO;
        for k in 0..n_theta {
            let (sin_r, cos_r) = (-FRAC_PI_2 + (k as f64 + 0.5) * dt).sin_cos();
            let mut a_bar = [Rgb::ZERO; 4];
            for j in 0..n_h {
                let h = -1.0 + (j as f64 + 0.5) * 2.0 / n_h as f64;
                let hit = hit_attenuation(self.params.eta, self.sigma_a, sin_r, cos_r, h);
                for (a, hit_a) in a_bar.iter_mut().zip(hit.a) {
                    *a += hit_a / n_h as f64;
                }
            }
            for (p, a) in a_bar.iter().enumerate() {
                let (so, co) = rotate(sin_r, cos_r, self.tilt[p]);
                sum += *a * (self.longitudinal[p].eval(sin_i, cos_i, so, co) * cos_r * cos_r * dt);
            }
        }
        sum / cos_i.max(MIN_COS)
    }

    /// Measured non-reciprocity of the h-averaged `f_s`: the largest
    /// `|f̄(i, r) − f̄(r, i)| / max(f̄(i, r), f̄(r, i))` (luminance) over `pairs` random
    /// direction pairs (uniform on the sphere, deterministic from `seed`), h averaged with
    /// 64 midpoint cells. 0 for a reciprocal model.
    #[must_use]
    pub fn non_reciprocity(&self, pairs: usize, seed: u64) -> f64 {
        max_relative_non_reciprocity(self, pairs, seed)
    }
}

impl ScatteringFunction for Chiang {
    fn properties(&self) -> Properties {
        Properties { reciprocal: false, energy_conserving: false, field: Field::Near, lobes: Lobes::Smooth }
    }

    fn eval(&self, wi: DVec3, wo: DVec3, h: f64) -> Rgb {
        self.at_vertex(wo, h).eval_and_pdf(wi).0
    }

    fn chord_absorption(&self) -> Option<Rgb> {
        Some(self.sigma_a)
    }

    /// Half the standard deviation of the azimuthal logistic, `πs/(2√3)`: the lobes sit at
    /// `Φ(p, h) = 2pγ_t − 2γ + pπ`, which moves twice as fast as γ for the R lobe.
    fn width_feature(&self) -> f64 {
        0.5 * std::f64::consts::PI * self.s / 3f64.sqrt()
    }

    fn pdf(&self, wi: DVec3, wo: DVec3, h: f64) -> f64 {
        self.at_vertex(wo, h).integrand_and_pdf(wi).1
    }

    fn eval_and_pdf(&self, wi: DVec3, wo: DVec3, h: f64) -> (Rgb, f64) {
        self.at_vertex(wo, h).eval_and_pdf(wi)
    }

    /// `M_p A_p N_p / cosθ_i` for p = 0, 1, 2 and the residual p ≥ 3.
    fn eval_lobes(&self, wi: DVec3, wo: DVec3, h: f64, out: &mut [Rgb]) -> bool {
        let vertex = self.at_vertex(wo, h);
        let (sin_i, cos_i) = (sin_theta(wi), cos_theta(wi));
        let dphi = phi(wi) - vertex.phi_o;
        for (p, slot) in out.iter_mut().take(4).enumerate() {
            *slot = vertex.a[p] * (vertex.m_n(p, sin_i, cos_i, dphi) / cos_i.max(MIN_COS));
        }
        true
    }

    /// `R`, `TT`, `TRT` (index p) and `TRRT+`, the residual of every order p ≥ 3.
    fn lobes(&self) -> Vec<LobeInfo> {
        ["R", "TT", "TRT", "TRRT+"].map(LobeInfo::smooth).to_vec()
    }

    fn sample(&self, wo: DVec3, h: f64, u: [f64; 4]) -> Option<Sample> {
        self.at_vertex(wo, h).sample(u)
    }
}

/// `x` wrapped to (−π, π] by whole turns, for the relative azimuths of the lobes (at most a few
/// turns from the range): cheaper than a remainder; far or non-finite input goes to
/// [`wrap_pi`].
#[inline]
fn wrap_few_turns(x: f64) -> f64 {
    if x.is_nan() || x.abs() >= 8.0 * PI {
        return wrap_pi(x);
    }
    let mut y = x;
    while y > PI {
        y -= TAU;
    }
    while y <= -PI {
        y += TAU;
    }
    y
}

/// A [`Chiang`] fiber prepared at one path vertex (fixed `ω_o`, `h`) by [`Chiang::at_vertex`]:
/// evaluates and samples without recomputing what depends on `ω_o` and `h` alone.
#[derive(Clone, Copy, Debug)]
pub struct ChiangAtVertex<'a> {
    fiber: &'a Chiang,
    /// `φ_o`, the camera direction's azimuth.
    phi_o: f64,
    /// `(sinθ_o^(p), cosθ_o^(p))`, the camera-side direction rotated by lobe p's tilt.
    tilted: [(f64, f64); 4],
    /// `Φ(p, h)` for p < 3.
    exit: [f64; 3],
    /// `A_p` at this hit.
    a: [Rgb; 4],
    /// Lobe-selection weights; `None` when every `A_p` vanishes.
    weights: Option<[f64; 4]>,
}

impl ChiangAtVertex<'_> {
    /// `(g_h(ω_o, ω_i), pdf(ω_i))`: the per-h integrand (sr⁻¹, Σ_p M_p A_p N_p) and the
    /// sampling density per steradian (Σ_p w_p M_p N_p).
    #[inline]
    fn integrand_and_pdf(&self, wi: DVec3) -> (Rgb, f64) {
        self.integrand_and_pdf_at(sin_theta(wi), cos_theta(wi), phi(wi) - self.phi_o)
    }

    /// [`Self::integrand_and_pdf`] at the light direction given by `sinθ_i`, `cosθ_i` and the
    /// relative azimuth `φ = φ_i − φ_o` (any angle within a few turns).
    #[inline]
    fn integrand_and_pdf_at(&self, sin_i: f64, cos_i: f64, dphi: f64) -> (Rgb, f64) {
        let Some(w) = &self.weights else { return (Rgb::ZERO, 0.0) };
        let (mut g, mut pdf) = (Rgb::ZERO, 0.0);
        for (p, w_p) in w.iter().enumerate() {
            let mn = self.m_n(p, sin_i, cos_i, dphi);
            g += self.a[p] * mn;
            pdf += w_p * mn;
        }
        debug_assert!(g.is_finite() && pdf.is_finite());
        (g, pdf)
    }

    /// `M_p N_p` of lobe `p` at the light direction (`sinθ_i`, `cosθ_i`, relative azimuth
    /// `φ = φ_i − φ_o`): `N_p` is the trimmed logistic of wrap(φ − Φ(p, h)) for p < 3 and
    /// uniform for p = 3.
    #[inline]
    fn m_n(&self, p: usize, sin_i: f64, cos_i: f64, dphi: f64) -> f64 {
        let fiber = self.fiber;
        let (so, co) = self.tilted[p];
        let m = fiber.longitudinal[p].eval(sin_i, cos_i, so, co);
        let n = if p < 3 {
            logistic(wrap_few_turns(dphi - self.exit[p]), fiber.s) * fiber.logistic_norm
        } else {
            1.0 / TAU
        };
        m * n
    }

    /// `f_s(ω_i, ω_o; h)` and the density with which [`Self::sample`] draws `ω_i`.
    #[inline]
    #[must_use]
    pub fn eval_and_pdf(&self, wi: DVec3) -> (Rgb, f64) {
        let (g, pdf) = self.integrand_and_pdf(wi);
        (g / cos_theta(wi).max(MIN_COS), pdf)
    }

    /// Draws `ω_i` from four uniforms, as [`ScatteringFunction::sample`].
    #[must_use]
    pub fn sample(&self, u: [f64; 4]) -> Option<Sample> {
        let w = self.weights?;
        let fiber = self.fiber;
        // Lobe from u[0].
        let mut p = 0;
        let mut acc = w[0];
        while p < 3 && u[0] >= acc {
            p += 1;
            acc += w[p];
        }
        while w[p] == 0.0 && p > 0 {
            p -= 1;
        }
        // θ_i from M_p(·, θ_o^(p)) with u[1], u[2].
        let (so, co) = self.tilted[p];
        let sin_i = fiber.longitudinal[p].sample_sin_theta(so, co, u[1], u[2]);
        let cos_i = safe_sqrt(1.0 - sin_i * sin_i);
        // φ_i from N_p with u[3]: the trimmed logistic on [−π, π] by its inverse CDF.
        let dphi = if p < 3 {
            let (lo, hi) = fiber.logistic_cdf_ends;
            let c = lo + u[3] * (hi - lo);
            let x = fiber.s * (c.ln() - (-c).ln_1p());
            self.exit[p] + if x.is_nan() { 0.0 } else { x.clamp(-PI, PI) }
        } else {
            TAU * u[3]
        };
        let wi = direction_from_sin_cos(sin_i, cos_i, self.phi_o + dphi);
        // Evaluated at the drawn angles themselves (not re-derived from wi).
        let (g, pdf) = self.integrand_and_pdf_at(sin_i, cos_i, dphi);
        if pdf.is_nan() || pdf <= 0.0 {
            return None;
        }
        Some(Sample { wi, weight: g / pdf, pdf, delta: false, lobe: p as u8 })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fiberlab_math::frame::direction;

    /// One vertex prepared once and then used for many light directions and bounce samples
    /// gives what a fresh preparation gives each time, bit for bit, and its sample's weight
    /// is `f_s cosθ_i / pdf` of the returned direction.
    #[test]
    fn a_vertex_prepared_once_serves_every_evaluation_and_sample() {
        let fiber = Chiang::new(ChiangParams::brown()).unwrap();
        let wo = direction(0.3, 1.1);
        let h = -0.37;
        let vertex = fiber.at_vertex(wo, h);
        let mut checked = 0;
        for k in 0..64 {
            let (a, b) = (k as f64 / 64.0, ((k * 37) % 64) as f64 / 64.0);
            let wi = direction(-1.4 + 2.8 * a, TAU * b);
            assert_eq!(vertex.eval_and_pdf(wi), fiber.at_vertex(wo, h).eval_and_pdf(wi));
            let u = [a, b, (a + 0.31) % 1.0, (b + 0.77) % 1.0];
            let (s, fresh) = (vertex.sample(u), fiber.at_vertex(wo, h).sample(u));
            assert_eq!(s, fresh);
            if let Some(s) = s {
                let (f, pdf) = fiber.eval_and_pdf(s.wi, wo, h);
                assert!((s.pdf - pdf).abs() <= 1e-12 * pdf);
                let want = f * (cos_theta(s.wi) / pdf);
                for c in 0..3 {
                    assert!((s.weight[c] - want[c]).abs() <= 1e-12 * want[c].abs().max(1e-300));
                }
                checked += 1;
            }
        }
        assert!(checked > 50);
    }

    /// The loop wrap agrees with the remainder wrap to rounding and lands in (−π, π], also
    /// at the range's ends and far outside it.
    #[test]
    fn wrapping_by_whole_turns_matches_the_remainder_wrap() {
        for k in -4000..=4000 {
            let x = f64::from(k) * (7.9 * PI / 4000.0);
            let (got, want) = (wrap_few_turns(x), wrap_pi(x));
            assert!(got > -PI && got <= PI, "{x}: {got}");
            let diff = wrap_pi(got - want).abs();
            assert!(diff < 1e-14, "{x}: {got} vs {want}");
        }
        assert_eq!(wrap_few_turns(PI), PI);
        assert_eq!(wrap_few_turns(-PI), PI);
        assert!((wrap_few_turns(1e6) - wrap_pi(1e6)).abs() < 1e-9);
        assert!(wrap_few_turns(f64::INFINITY).is_nan());
    }
}
