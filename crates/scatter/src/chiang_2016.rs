//! Chiang, Bitterli, Tappan & Burley 2016, *A practical and controllable hair and fur model
//! for production path tracing* (EGSR 2016), as in pbrt-v4's `HairBxDF`: a near-field
//! (h-dependent), energy-conserving, exactly importance-sampled hair fiber
//! (models.md §1.4, §5.1, §5.3–§5.6).
//!
//! | parameter | unit | default | range |
//! |---|---|---|---|
//! | `eta` | — | 1.55 | (1, 4] |
//! | `beta_m` | — | 0.3 | (0, 1] longitudinal roughness |
//! | `beta_n` | — | 0.3 | (0, 1] azimuthal roughness |
//! | `alpha` | degrees | 2 | [−20, 20] cuticle scale tilt |
//! | `sigma_a` | 1/radius | — | [0, ∞) per channel |
//! | `eumelanin` | — | (1.3 if no absorption key is given) | [0, 100] |
//! | `pheomelanin` | — | (0) | [0, 100] |
//! | `color` | — | — | (0, 1] per channel |
//!
//! Absorption comes from exactly one of: `sigma_a`; the melanin concentrations
//! (`eumelanin` and/or `pheomelanin`, the missing one 0); or a desired `color`. Giving keys
//! from two of these groups is an error. With none, eumelanin 1.3 (pbrt's default, a brown).
//!
//! # Formula
//! For a viewer `ω_o` hitting the fiber at offset `h` (γ_o = asin h), pbrt's per-h integrand
//! is `g_h(ω_o, ω_i) = Σ_{p<3} M_p(θ_i, θ_o^(p))·A_p(θ_o, h)·N_p(φ) + M_3(θ_i, θ_o)·A_3/(2π)`,
//! a density over `ω_i` with `∫ g_h dω_i = Σ A_p` (models.md §1.4). fiberlab's convention
//! `L_r = ∫ f_s L_i cosθ_i dω_i` makes the near-field scattering function
//! `f_s(ω_i, ω_o; h) = g_h(ω_o, ω_i)/cosθ_i`, θ the fiber inclination (not a ribbon normal);
//! its h-average is the backward-form far-field `f_s` of §1.4. Sign of h (pbrt's): the
//! surface normal at the hit has azimuth `φ_o − asin h`, i.e. seen from +z (φ_o = π/2),
//! h increases toward +y; the R lobe then leaves at `φ_i = φ_o − 2 asin h`.
//! * `M_p`: d'Eon's longitudinal term, [`crate::deon_2011::Longitudinal`] (§5.1), with
//!   `v_0 = (0.726β_m + 0.812β_m² + 3.7β_m²⁰)²`, `v_1 = v_0/4`, `v_2 = v_3 = 4v_0`
//!   (Chiang 2016; models.md §5.3).
//! * `N_p(φ) = ℓ(wrap(φ − Φ(p, h)); s)/(F_ℓ(π) − F_ℓ(−π))`, φ = φ_i − φ_o, the logistic
//!   trimmed to [−π, π], `Φ(p, h) = 2pγ_t − 2γ_o + pπ`, `s = √(π/8)·(0.265β_n + 1.194β_n² +
//!   5.372β_n²²)` (Chiang 2016; models.md §5.3); `N_3 = 1/(2π)`.
//! * `A_0 = f`, `A_1 = (1 − f)²T`, `A_2 = A_1 f T`, `A_3 = A_2 f T/(1 − f T)` (all p ≥ 3),
//!   `f` = exact 3D dielectric Fresnel at `cosθ_o cosγ_o`, `T = exp(−σ_a·2cosγ_t/cosθ_t)` the
//!   chord-length absorption (σ_a per unit radius). `Σ A_p = 1` when σ_a = 0.
//! * Cuticle tilt (§5.3): the fixed (camera-side) direction is rotated per lobe,
//!   `θ_o^(0) = θ_o + 2α`, `θ_o^(1) = θ_o − α`, `θ_o^(2) = θ_o − 4α`, `θ_o^(3) = θ_o`, so each
//!   `M_p(·, θ_o^(p))` stays normalized in θ_i. With θ positive toward the tip and α > 0 the
//!   lobe centres are `θ_i + θ_o = −2α` (R, toward the root), `+α` (TT), `+4α` (TRT): the
//!   physical sign of §5.3 (pbrt-v4/Mitsuba/Tungsten use the opposite sign of α).
//!
//! # Sampling (§5.4)
//! Lobe p from `u[0]` with weights `w_p = Y(A_p)/Σ_q Y(A_q)` (Y = Rec. 709 luminance), θ_i
//! from `M_p(·, θ_o^(p))` with `u[1], u[2]`, φ_i from the trimmed logistic (uniform for p = 3)
//! with `u[3]`. `pdf = Σ_p w_p M_p N_p` per steradian, exactly the density of the samples,
//! and the weight `f_s cosθ_i/pdf = g_h/pdf` equals `Σ A_p` whenever the `A_p` are gray
//! (in particular exactly 1 when σ_a = 0).
//!
//! # Caveats
//! The model conserves energy on the camera side only and is not reciprocal (§5.6): the
//! light-side albedo exceeds 1 at grazing light ([`Chiang::light_side_albedo`]; σ_a = 0,
//! β = 0.3, α = 0: 0.989 at θ_i = 0, 1.48 at 1.4 rad, 10.2 at 1.55 rad) and
//! [`Chiang::non_reciprocity`] measures the asymmetry. `properties()` claims neither.
//! At exactly grazing light (cosθ_i = 0) `eval` divides by `MIN_COS`.

use crate::deon_2011::Longitudinal;
use crate::params::{ParamKind, ParamSet, ParamSpec, Range};
use crate::{Field, Lobes, Model, ModelError, ModelSpec, Properties, Sample, ScatteringFunction};
use fiberlab_math::frame::{cos_theta, direction_from_sin_cos, phi, sin_theta, wrap_pi};
use fiberlab_math::special::{logistic, logistic_cdf, safe_asin, safe_sqrt, sample_trimmed_logistic};
use fiberlab_math::{DVec3, Rgb, bravais, fresnel};
use std::f64::consts::{FRAC_PI_2, PI, TAU};

/// Smallest `cosθ_i` used in the `1/cosθ_i` of `f_s = g_h/cosθ_i` (grazing light).
pub const MIN_COS: f64 = 1e-8;

/// Eumelanin absorption per unit radius per unit concentration, RGB (d'Eon 2011; pbrt).
pub const EUMELANIN_SIGMA_A: Rgb = Rgb::new(0.419, 0.697, 1.37);
/// Pheomelanin absorption per unit radius per unit concentration, RGB (d'Eon 2011; pbrt).
pub const PHEOMELANIN_SIGMA_A: Rgb = Rgb::new(0.187, 0.4, 1.05);
/// Default eumelanin concentration when no absorption key is given (pbrt-v4's default).
pub const DEFAULT_EUMELANIN: f64 = 1.3;
/// Smallest desired colour channel used by the colour inversion (ln 0 = −∞ otherwise).
const MIN_COLOR: f64 = 1e-4;

/// Coefficients of Chiang 2016 (models.md §5.3): `v_0 = (c₁β_m + c₂β_m² + c₃β_m²⁰)²`.
const V0_COEFFS: (f64, f64, f64) = (0.726, 0.812, 3.7);
/// Coefficients of Chiang 2016 (models.md §5.3): `s = √(π/8)·(c₁β_n + c₂β_n² + c₃β_n²²)`.
const S_COEFFS: (f64, f64, f64) = (0.265, 1.194, 5.372);
/// Polynomial in β_n of Chiang 2016 (models.md §5.3) (σ_a from a desired colour), lowest order first.
const COLOR_POLY: [f64; 6] = [5.969, -0.215, 2.532, -10.73, 5.574, 0.245];

pub(crate) const ETA_RANGE: Range = Range::open_closed(1.0, 4.0);
pub(crate) const BETA_RANGE: Range = Range::open_closed(0.0, 1.0);
pub(crate) const ALPHA_RANGE: Range = Range::closed(-20.0, 20.0);
pub(crate) const SIGMA_A_RANGE: Range = Range::closed(0.0, f64::INFINITY);
pub(crate) const MELANIN_RANGE: Range = Range::closed(0.0, 100.0);
pub(crate) const COLOR_RANGE: Range = Range::open_closed(0.0, 1.0);

/// Parameter table shared with [`crate::deon_2011`].
pub(crate) const PARAMS: [ParamSpec; 8] = [
    ParamSpec { key: "eta", kind: ParamKind::Number(ETA_RANGE), unit: "", default: "1.55", doc: "index of refraction" },
    ParamSpec {
        key: "beta_m",
        kind: ParamKind::Number(BETA_RANGE),
        unit: "",
        default: "0.3",
        doc: "longitudinal roughness",
    },
    ParamSpec {
        key: "beta_n",
        kind: ParamKind::Number(BETA_RANGE),
        unit: "",
        default: "0.3",
        doc: "azimuthal roughness",
    },
    ParamSpec {
        key: "alpha",
        kind: ParamKind::Number(ALPHA_RANGE),
        unit: "degrees",
        default: "2",
        doc: "cuticle scale tilt; > 0 moves the R lobe toward the root",
    },
    ParamSpec {
        key: "sigma_a",
        kind: ParamKind::Color(SIGMA_A_RANGE),
        unit: "1/radius",
        default: "",
        doc: "absorption coefficient (exclusive with melanin and color)",
    },
    ParamSpec {
        key: "eumelanin",
        kind: ParamKind::Number(MELANIN_RANGE),
        unit: "",
        default: "",
        doc: "eumelanin concentration (1.3 when no absorption key is given)",
    },
    ParamSpec {
        key: "pheomelanin",
        kind: ParamKind::Number(MELANIN_RANGE),
        unit: "",
        default: "",
        doc: "pheomelanin concentration",
    },
    ParamSpec {
        key: "color",
        kind: ParamKind::Color(COLOR_RANGE),
        unit: "",
        default: "",
        doc: "desired multiple-scattering colour; σ_a by Chiang's inversion (depends on beta_n)",
    },
];

/// Registry entry: `chiang`.
pub const SPEC: ModelSpec = ModelSpec {
    name: "chiang",
    summary: "Chiang 2016 / pbrt-v4 near-field hair: d'Eon M_p, logistic N_p, exact sampling",
    citation: "Chiang et al. 2016; d'Eon et al. 2011; models.md §5",
    params: &PARAMS,
    data: None,
    build: |p: &ParamSet| {
        Ok(Chiang::new(
            p.number("eta")?,
            p.number("beta_m")?,
            p.number("beta_n")?,
            p.number("alpha")?,
            Absorption::from_params(p)?,
        )?
        .into())
    },
};

/// Where the absorption coefficient comes from (models.md §5.3).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Absorption {
    /// σ_a per unit radius, RGB.
    SigmaA(Rgb),
    /// Melanin concentrations: `σ_a = c_eu·EUMELANIN_SIGMA_A + c_pheo·PHEOMELANIN_SIGMA_A`.
    Melanin {
        /// Eumelanin concentration.
        eumelanin: f64,
        /// Pheomelanin concentration.
        pheomelanin: f64,
    },
    /// A desired colour C ∈ (0, 1] per channel, inverted with Chiang 2016 (models.md §5.3) (depends
    /// on β_n): `σ_a = (ln C / (5.969 − 0.215β_n + 2.532β_n² − 10.73β_n³ + 5.574β_n⁴ +
    /// 0.245β_n⁵))²`, C clamped to [1e−4, 1].
    Color(Rgb),
}

impl Default for Absorption {
    /// Eumelanin 1.3 (pbrt-v4's default).
    fn default() -> Self {
        Absorption::Melanin { eumelanin: DEFAULT_EUMELANIN, pheomelanin: 0.0 }
    }
}

impl Absorption {
    /// Reads the absorption keys (`sigma_a`, `eumelanin`/`pheomelanin`, `color`); keys from
    /// more than one group are [`ModelError::Inconsistent`].
    pub fn from_params(p: &ParamSet) -> Result<Self, ModelError> {
        let melanin = p.is_given("eumelanin") || p.is_given("pheomelanin");
        let groups = [p.is_given("sigma_a"), melanin, p.is_given("color")];
        if groups.iter().filter(|&&g| g).count() > 1 {
            return Err(ModelError::Inconsistent(
                "give absorption by exactly one of `sigma_a`, `eumelanin`/`pheomelanin`, or `color`".into(),
            ));
        }
        Ok(if let Some(s) = p.color_opt("sigma_a") {
            Absorption::SigmaA(s)
        } else if melanin {
            Absorption::Melanin {
                eumelanin: p.number_opt("eumelanin").unwrap_or(0.0),
                pheomelanin: p.number_opt("pheomelanin").unwrap_or(0.0),
            }
        } else if let Some(c) = p.color_opt("color") {
            Absorption::Color(c)
        } else {
            Absorption::default()
        })
    }

    /// Validates the values (errors name the key and range).
    pub fn validate(&self) -> Result<(), ModelError> {
        match *self {
            Absorption::SigmaA(s) => SIGMA_A_RANGE.check_rgb("sigma_a", s).map(|_| ())?,
            Absorption::Melanin { eumelanin, pheomelanin } => {
                MELANIN_RANGE.check("eumelanin", eumelanin)?;
                MELANIN_RANGE.check("pheomelanin", pheomelanin).map(|_| ())?
            }
            Absorption::Color(c) => COLOR_RANGE.check_rgb("color", c).map(|_| ())?,
        }
        Ok(())
    }

    /// σ_a per unit radius; `beta_n` is needed only by the colour inversion.
    #[must_use]
    pub fn sigma_a(&self, beta_n: f64) -> Rgb {
        match *self {
            Absorption::SigmaA(s) => s,
            Absorption::Melanin { eumelanin, pheomelanin } => {
                EUMELANIN_SIGMA_A * eumelanin + PHEOMELANIN_SIGMA_A * pheomelanin
            }
            Absorption::Color(c) => {
                let mut poly = 0.0;
                for &k in COLOR_POLY.iter().rev() {
                    poly = poly * beta_n + k;
                }
                c.map(|ch| (ch.clamp(MIN_COLOR, 1.0).ln() / poly).powi(2))
            }
        }
    }
}

/// Longitudinal variance `v_0` of the R lobe from β_m (Chiang 2016; models.md §5.3).
#[must_use]
pub fn longitudinal_variance(beta_m: f64) -> f64 {
    let (a, b, c) = V0_COEFFS;
    (a * beta_m + b * beta_m * beta_m + c * beta_m.powi(20)).powi(2)
}

/// Logistic scale `s` of the azimuthal lobes from β_n (Chiang 2016; models.md §5.3), radians.
#[must_use]
pub fn logistic_scale(beta_n: f64) -> f64 {
    let (a, b, c) = S_COEFFS;
    (PI / 8.0).sqrt() * (a * beta_n + b * beta_n * beta_n + c * beta_n.powi(22))
}

/// Per-lobe variances `[v_R, v_TT, v_TRT, v_residual] = [v_0, v_0/4, 4v_0, 4v_0]`.
#[must_use]
pub fn lobe_variances(beta_m: f64) -> [f64; 4] {
    let v0 = longitudinal_variance(beta_m);
    [v0, 0.25 * v0, 4.0 * v0, 4.0 * v0]
}

/// The tilt rotation of the fixed direction for lobe p, as `(sin τ_p, cos τ_p)` with
/// `τ = (+2α, −α, −4α, 0)` (models.md §5.3, physical sign; α in radians).
#[must_use]
pub(crate) fn lobe_tilts(alpha: f64) -> [(f64, f64); 4] {
    [(2.0 * alpha).sin_cos(), (-alpha).sin_cos(), (-4.0 * alpha).sin_cos(), (0.0, 1.0)]
}

/// `(sin(θ + τ), |cos(θ + τ)|)` from `(sinθ, cosθ)` and `(sin τ, cos τ)`.
#[inline]
pub(crate) fn rotate(sin_t: f64, cos_t: f64, (sin_tau, cos_tau): (f64, f64)) -> (f64, f64) {
    (sin_t * cos_tau + cos_t * sin_tau, (cos_t * cos_tau - sin_t * sin_tau).abs())
}

/// Geometry of one hit: `h`, `γ_o = asin h`, `γ_t` and the attenuations `A_0..A_3`.
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    /// 2D incidence angle `γ_o = asin h`.
    pub gamma_o: f64,
    /// 2D refraction angle `γ_t = asin(h/η′)`.
    pub gamma_t: f64,
    /// `A_p` for p = 0, 1, 2 and the residual p ≥ 3.
    pub a: [Rgb; 4],
}

/// Attenuations `A_p(θ_o, h)` (Chiang 2016; models.md §5.3): exact 3D Fresnel
/// at `cosθ_o cosγ_o`, chord absorption `T = exp(−σ_a·2cosγ_t/cosθ_t)`, residual
/// `A_3 = A_2 f T/(1 − f T)` with the silhouette guard (`A_3 = 0` when `f T = 1`).
#[must_use]
pub fn attenuation(eta: f64, sigma_a: Rgb, sin_o: f64, cos_o: f64, h: f64) -> Hit {
    let h = h.clamp(-1.0, 1.0);
    let cos_gamma_o = safe_sqrt(1.0 - h * h);
    let f = fresnel::dielectric(cos_o * cos_gamma_o, eta);
    let sin_gamma_t = bravais::sin_gamma_t(h, eta, sin_o, cos_o);
    let cos_gamma_t = safe_sqrt(1.0 - sin_gamma_t * sin_gamma_t);
    let cos_theta_t = bravais::cos_theta_t(eta, sin_o);
    let t = (sigma_a * (-2.0 * cos_gamma_t / cos_theta_t)).exp();
    let a1 = t * (1.0 - f) * (1.0 - f);
    let a2 = a1 * t * f;
    let ft = t * f;
    let a3 = Rgb::new(
        if ft[0] < 1.0 { a2[0] * ft[0] / (1.0 - ft[0]) } else { 0.0 },
        if ft[1] < 1.0 { a2[1] * ft[1] / (1.0 - ft[1]) } else { 0.0 },
        if ft[2] < 1.0 { a2[2] * ft[2] / (1.0 - ft[2]) } else { 0.0 },
    );
    Hit { gamma_o: h.asin(), gamma_t: safe_asin(sin_gamma_t), a: [Rgb::splat(f), a1, a2, a3] }
}

/// Exit azimuth `Φ(p, h) = 2pγ_t − 2γ_o + pπ` (models.md §1.2), not wrapped.
#[must_use]
#[inline]
pub fn exit_azimuth(p: usize, gamma_o: f64, gamma_t: f64) -> f64 {
    let p = p as f64;
    2.0 * p * gamma_t - 2.0 * gamma_o + p * PI
}

/// Parameters shared by the Chiang and d'Eon fibers, validated once at construction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HairParams {
    /// Index of refraction η.
    pub eta: f64,
    /// Longitudinal roughness β_m ∈ (0, 1].
    pub beta_m: f64,
    /// Azimuthal roughness β_n ∈ (0, 1].
    pub beta_n: f64,
    /// Cuticle tilt α (radians); > 0 moves the R lobe toward the root.
    pub alpha: f64,
    /// Absorption coefficient σ_a per unit radius.
    pub sigma_a: Rgb,
}

impl HairParams {
    /// Validates `eta`, `beta_m`, `beta_n`, `alpha_deg` (degrees) and the absorption, and
    /// resolves the absorption to σ_a (the colour inversion depends on β_n).
    pub fn new(
        eta: f64,
        beta_m: f64,
        beta_n: f64,
        alpha_deg: f64,
        absorption: &Absorption,
    ) -> Result<Self, ModelError> {
        ETA_RANGE.check("eta", eta)?;
        BETA_RANGE.check("beta_m", beta_m)?;
        BETA_RANGE.check("beta_n", beta_n)?;
        ALPHA_RANGE.check("alpha", alpha_deg)?;
        absorption.validate()?;
        Ok(Self { eta, beta_m, beta_n, alpha: alpha_deg.to_radians(), sigma_a: absorption.sigma_a(beta_n) })
    }
}

/// Chiang 2016 near-field hair fiber.
#[derive(Clone, Debug)]
pub struct Chiang {
    params: HairParams,
    longitudinal: [Longitudinal; 4],
    tilt: [(f64, f64); 4],
    s: f64,
    /// `1/(F_ℓ(π) − F_ℓ(−π))`.
    logistic_norm: f64,
}

impl Chiang {
    /// A Chiang fiber: index `eta`, roughness `beta_m`, `beta_n` ∈ (0, 1], tilt `alpha_deg`
    /// (degrees) and absorption.
    pub fn new(eta: f64, beta_m: f64, beta_n: f64, alpha_deg: f64, absorption: Absorption) -> Result<Self, ModelError> {
        let params = HairParams::new(eta, beta_m, beta_n, alpha_deg, &absorption)?;
        let s = logistic_scale(beta_n);
        Ok(Self {
            params,
            longitudinal: lobe_variances(beta_m).map(Longitudinal::new),
            tilt: lobe_tilts(params.alpha),
            s,
            logistic_norm: 1.0 / (logistic_cdf(PI, s) - logistic_cdf(-PI, s)),
        })
    }

    /// The validated parameters.
    #[must_use]
    pub fn params(&self) -> &HairParams {
        &self.params
    }
    /// Logistic scale `s` (radians).
    #[must_use]
    pub fn logistic_scale(&self) -> f64 {
        self.s
    }

    /// `N_p(φ)` for p < 3: trimmed logistic of `wrap(φ − Φ(p, h))` (Chiang 2016; models.md §5.3).
    #[inline]
    fn azimuthal(&self, p: usize, dphi: f64, hit: &Hit) -> f64 {
        let x = wrap_pi(dphi - exit_azimuth(p, hit.gamma_o, hit.gamma_t));
        logistic(x, self.s) * self.logistic_norm
    }

    /// Lobe-selection weights `w_p = Y(A_p)/Σ Y(A_q)`; `None` if all vanish.
    #[inline]
    fn lobe_weights(hit: &Hit) -> Option<[f64; 4]> {
        let y = hit.a.map(Rgb::luminance);
        let total: f64 = y.iter().sum();
        (total > 0.0).then(|| y.map(|x| x / total))
    }

    /// `(g_h(ω_o, ω_i), pdf(ω_i))`: the per-h integrand (sr⁻¹, Σ_p M_p A_p N_p) and the
    /// sampling density per steradian (Σ_p w_p M_p N_p).
    fn integrand_and_pdf(&self, wi: DVec3, wo: DVec3, h: f64) -> (Rgb, f64) {
        let hit = attenuation(self.params.eta, self.params.sigma_a, sin_theta(wo), cos_theta(wo), h);
        match Self::lobe_weights(&hit) {
            Some(w) => self.integrand_and_pdf_at(wi, wo, &hit, &w),
            None => (Rgb::ZERO, 0.0),
        }
    }

    /// [`Self::integrand_and_pdf`] with the hit's attenuations and lobe weights given.
    #[inline]
    fn integrand_and_pdf_at(&self, wi: DVec3, wo: DVec3, hit: &Hit, w: &[f64; 4]) -> (Rgb, f64) {
        let (sin_i, cos_i) = (sin_theta(wi), cos_theta(wi));
        let (sin_o, cos_o) = (sin_theta(wo), cos_theta(wo));
        let dphi = phi(wi) - phi(wo);
        let (mut g, mut pdf) = (Rgb::ZERO, 0.0);
        for (p, w_p) in w.iter().enumerate() {
            let (so, co) = rotate(sin_o, cos_o, self.tilt[p]);
            let m = self.longitudinal[p].eval(sin_i, cos_i, so, co);
            let n = if p < 3 { self.azimuthal(p, dphi, hit) } else { 1.0 / TAU };
            g += hit.a[p] * (m * n);
            pdf += w_p * m * n;
        }
        debug_assert!(g.is_finite() && pdf.is_finite());
        (g, pdf)
    }

    /// Light-side albedo `ρ(ω_i) = ∫ f̄_s(ω_i, ω_r) cosθ_r dω_r` of the h-averaged `f_s` at
    /// light inclination `theta_i` (models.md §5.6). Since each `N_p` integrates to 1,
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
                let hit = attenuation(self.params.eta, self.params.sigma_a, sin_r, cos_r, h);
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

/// `max |f̄(i, r) − f̄(r, i)| / max(f̄(i, r), f̄(r, i))` (luminance, h-averaged with 64
/// midpoint cells) over `pairs` directions uniform on the sphere (SplitMix64 from `seed`);
/// pairs where both values are below 1e−6 of the largest value seen are skipped.
#[must_use]
pub fn max_relative_non_reciprocity(f: &impl ScatteringFunction, pairs: usize, seed: u64) -> f64 {
    let mut state = seed;
    let mut uniform = move || {
        state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut sphere = move || {
        let s: f64 = 2.0 * uniform() - 1.0;
        direction_from_sin_cos(s, safe_sqrt(1.0 - s * s), TAU * uniform())
    };
    let n_h = if f.properties().field == Field::Near { 64 } else { 1 };
    let averaged = |wi: DVec3, wr: DVec3| -> f64 {
        (0..n_h).map(|j| f.eval(wi, wr, -1.0 + (j as f64 + 0.5) * 2.0 / n_h as f64).luminance()).sum::<f64>()
            / n_h as f64
    };
    let (mut worst, mut largest) = (0.0f64, 0.0f64);
    for _ in 0..pairs {
        let (a, b) = (sphere(), sphere());
        let (x, y) = (averaged(a, b), averaged(b, a));
        let m = x.max(y);
        largest = largest.max(m);
        if m > 1e-6 * largest && m > 0.0 {
            worst = worst.max((x - y).abs() / m);
        }
    }
    worst
}

impl ScatteringFunction for Chiang {
    fn properties(&self) -> Properties {
        Properties { reciprocal: false, energy_conserving: false, field: Field::Near, lobes: Lobes::Smooth }
    }

    fn eval(&self, wi: DVec3, wo: DVec3, h: f64) -> Rgb {
        let (g, _) = self.integrand_and_pdf(wi, wo, h);
        g / cos_theta(wi).max(MIN_COS)
    }

    fn pdf(&self, wi: DVec3, wo: DVec3, h: f64) -> f64 {
        self.integrand_and_pdf(wi, wo, h).1
    }

    fn eval_and_pdf(&self, wi: DVec3, wo: DVec3, h: f64) -> (Rgb, f64) {
        let (g, pdf) = self.integrand_and_pdf(wi, wo, h);
        (g / cos_theta(wi).max(MIN_COS), pdf)
    }

    fn sample(&self, wo: DVec3, h: f64, u: [f64; 4]) -> Option<Sample> {
        let (sin_o, cos_o) = (sin_theta(wo), cos_theta(wo));
        let hit = attenuation(self.params.eta, self.params.sigma_a, sin_o, cos_o, h);
        let w = Self::lobe_weights(&hit)?;
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
        let (so, co) = rotate(sin_o, cos_o, self.tilt[p]);
        let sin_i = self.longitudinal[p].sample_sin_theta(so, co, u[1], u[2]);
        let cos_i = safe_sqrt(1.0 - sin_i * sin_i);
        // φ_i from N_p with u[3].
        let dphi = if p < 3 {
            exit_azimuth(p, hit.gamma_o, hit.gamma_t) + sample_trimmed_logistic(u[3], self.s, -PI, PI)
        } else {
            TAU * u[3]
        };
        let wi = direction_from_sin_cos(sin_i, cos_i, phi(wo) + dphi);
        let (g, pdf) = self.integrand_and_pdf_at(wi, wo, &hit, &w);
        if pdf.is_nan() || pdf <= 0.0 {
            return None;
        }
        Some(Sample { wi, weight: g / pdf, pdf, delta: false })
    }
}

impl From<Chiang> for Model {
    fn from(m: Chiang) -> Self {
        Model::Chiang(m)
    }
}
