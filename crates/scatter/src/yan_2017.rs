//! Fur as a double cylinder: Yan, Tseng, Jensen & Ramamoorthi 2015, *Physically-accurate fur
//! reflectance: modeling, measurement and rendering* (ACM TOG 34(6), SIGGRAPH Asia 2015), in
//! the near/far-field form of Yan, Jensen & Ramamoorthi 2017, *An efficient and practical near
//! and far field fur reflectance model* (ACM TOG 36(4), SIGGRAPH 2017). A cortex of radius 1
//! (index η, absorption σ_c^a) around a concentric medulla of relative radius κ that scatters
//! (σ_m^s, Henyey–Greenstein g) and absorbs (σ_m^a), index-matched to the cortex, under a
//! cuticle of `layers` layers. Built from the hair core ([`crate::hair`]). Equation numbers of
//! the papers are not quoted (not checked against the papers); each quantity is described.
//!
//! Parameters: the registry entry (the `params` of `Registered::INFO` below) is the one table of
//! keys, units, defaults and valid ranges; `fiberlab models --model yan-fur` prints it and the
//! book's page `docs/book/src/models/yan-fur.md` shows it. `alpha` is given in degrees and held in
//! radians in [`YanFurParams`].
//!
//! No preset: no published table of per-animal parameters has been checked here, so the
//! defaults are documented choices (a medium medulla, moderately rough), not a fit.
//!
//! # Formula (unscattered lobes R, TT, TRT; p = 0, 1, 2)
//! Backward (camera-driven) near-field form, as `chiang` ([`crate::hair::backward_form`]):
//! the camera direction ω_o hits the fiber at offset h (γ_o = asin h) and
//! `f_s(ω_i, ω_o; h) = Σ_p A_p(θ_o, h)·M_p(θ_i; θ_o)·N_p(φ; h) / cos²θ_i`, φ = φ_i − φ_o,
//! where `M_p` is a density in θ_i (∫ M_p dθ_i = 1) and `N_p` a density in φ, so that
//! `Σ_p M_p N_p / cosθ_i` is a density per steradian and the camera-side furnace
//! `∫ f_s cosθ_i dω_i` is exactly `Σ_p A_p` (the papers' `1/cos²θ_d` of Marschner's form is
//! `1/cos²θ_i` here, equal on the specular cone). Its average over h ∈ [−1, 1] is the
//! far-field `f_s` ([`YanFur::eval_far`]).
//! * **Geometry**: Bravais' η′ at the camera inclination θ_o, `sinγ_t = h/η′`, and one internal
//!   segment split between cortex and medulla by [`crate::hair::attenuation::chord_lengths`]:
//!   medulla `2√(κ² − h′²)/cosθ_t` when `|h′| = |h|/η′ < κ`, cortex the rest of the chord
//!   `2cosγ_t/cosθ_t`. All σ are per unit fiber radius.
//! * **Attenuation** (Yan 2015; exact chords): per segment `T = exp(−σ_c^a ℓ_c − (σ_m^s + σ_m^a) ℓ_m)`;
//!   `A_0 = F_l`, `A_p = (1 − F_l)² F_l^{p−1} T^p`. The medulla's extinction includes its
//!   scattering: light that scatters in the medulla leaves these lobes and belongs to the
//!   scattered lobes TT^s, TRT^s ([`YanFur::energy_budget`] gives that fraction exactly).
//! * **Cuticle**: `F_l = l·F/(1 + (l − 1)F)` with F the exact 3D dielectric Fresnel
//!   reflectance of η at `cos ι = cosθ_o cosγ_o` ([`crate::hair::attenuation::surface_fresnel`]);
//!   internal reflections have the same value.
//! * **Longitudinal** `M_p`: a Gaussian in θ_i of standard deviation `β_p = (β_m, β_m/2,
//!   3β_m/2)`, truncated to [−π/2, π/2] and renormalized, centred on the mirror of the camera
//!   inclination rotated by the lobe's tilt, `θ_c = −(θ_o + τ_p)`, `τ_p = (2α, −α, −3α)`
//!   (Marschner 2003's ratios `α_TT = −α_R/2`, `α_TRT = −3α_R/2`;
//!   [`crate::hair::tilt::marschner_ratio_tilts`]). A rotation past a pole is reflected back
//!   ([`crate::hair::tilt::rotate`]), so θ_c ∈ [−π/2, π/2] and the truncation never removes
//!   more than half a lobe.
//! * **Azimuthal** `N_p(φ; h) = D(β_n√(p + 1); φ − Φ(p, h))`, D the unit-area Gaussian wrapped
//!   on the circle ([`fiberlab_math::special::wrapped_gaussian`]), `Φ(p, h) = 2pγ_t − 2γ_o + pπ`
//!   ([`crate::hair::normal_plane::exit_azimuth`]).
//!
//! # Cuticle layers: the two meanings
//! This model's `layers` counts **interfaces** (the ports of the 2015 model): `layers = 1` is a
//! single smooth interface, the limit in which the model is an ordinary Gaussian-lobe hair
//! fiber. Yan 2017's released code counts **slabs** (two incoherent interfaces per layer),
//! stacked per polarization: [`slab_layers_reflectance`]. Stacking is associative, so a slab
//! count l equals an interface count 2l polarization by polarization
//! ([`interfaces_from_slab_layers`]); the two definitions then differ only in that the slab
//! form averages the polarizations after stacking (identical at normal incidence). At
//! η = 1.55, normal incidence: l = 0.47 gives 0.0224 (interfaces) and 0.0439 (slabs); l = 1
//! gives 0.0465 and 0.0889.
//!
//! # Colour
//! `color` C ∈ (0, 1] per channel gives σ_c^a by Yan 2017's mapping: with the medulla's
//! occlusion `m = κ^{3/2}`, `σ_c^a = (−ln C − 4mσ_m^a)/(4(1 − m))` ([`sigma_c_a_from_color`]).
//! A colour brighter than `exp(−4mσ_m^a)` would need a negative σ_c^a: it is refused, naming
//! `color`, instead of clamped. The released code also rescales and gamma-corrects C and clamps
//! C and σ_c^a; those clamps are not reproduced (they hide out-of-range input).
//!
//! # Scattered lobes TT^s, TRT^s (q = 0, 1)
//! Light that scatters in the medulla, read from the medulla's random-walk tables
//! ([`crate::hair::medulla`], built at construction for σ_s = σ_m^s κ, σ_a = σ_m^a κ per unit
//! medulla radius and g, cached process-wide). Only chords that cross the medulla
//! (`|h′| < κ`) contribute. Per density in (θ_i, φ), like the unscattered lobes:
//! `A_s,q · N(θ_t, h′/κ, φ_q) · M(θ_e, φ_q, θ_i)`, divided by cos²θ_i for `f_s`.
//! * `N` is the tables' azimuthal exit density (rad⁻¹), whose integral is the fraction of the
//!   light entering the medulla that scatters and escapes it (scattering *and* absorption
//!   inside the medulla): the scattered fraction comes from the walk itself, so Yan 2017's
//!   `(1 − T_u^p)` factor (a heuristic for it) is not needed and not used. θ_t is the refracted
//!   camera ray's inclination (`sinθ_t = −sinθ_o/η`).
//! * `φ_q` is the exit azimuth relative to the refracted entry direction:
//!   `φ_q = φ − (γ_t − γ_o) − q(π + 2γ_t)` (TRT^s first crosses the fiber unscattered and
//!   reflects once, turning by π + 2γ_t). No refraction is applied where the scattered light
//!   leaves the fiber (as in Yan 2017).
//! * `M` is the tables' longitudinal exit profile (rad⁻¹ in θ_i, normalized), entered with the
//!   camera ray's inclination `θ_e = −θ_o` and read at θ_i directly, as Yan 2017 use their
//!   table (the refraction at the cortex surface is not applied to it; light that would be
//!   trapped by total internal reflection is therefore not lost).
//! * `A_s,0 = (1 − F_l)·exp(−σ_c^a(ℓ_c/2 + (1 − κ)/cosθ_t))`: entry, half the segment's cortex
//!   to the medulla (exact chord), and Yan's radial estimate `(1 − κ)/cosθ_t` of the cortex
//!   between medulla and surface on the way out; `A_s,1 = A_s,0 · F_l T` (one unscattered
//!   segment and an internal reflection first). The exit Fresnel transmission is not applied
//!   (as in Yan 2017): all light that escapes the medulla leaves.
//! * Energy: with every absorption zero the camera-side furnace is `Σ` of the five lobe
//!   masses, which misses only the light scattered on later passes and the unscattered orders
//!   p ≥ 3, both of order F_l² (measured 1 − 5·10⁻⁴ … 1 + 4·10⁻⁶ at κ = 0.8, σ_m^s = 2;
//!   [`YanFur::energy_budget`], `tests/yan_2017.rs`).
//!
//! # Sampling
//! Lobe p from `u[0]` with probability ∝ the luminance of its mass (`A_p`, or `A_s,q·E` with
//! E the tables' escaping fraction) over the enabled lobes. R, TT, TRT: θ_i from the
//! truncated Gaussian `M_p` with `u[1]` (exact inversion,
//! [`fiberlab_math::special::sample_truncated_normal`]); φ from `N_p` with `u[3]` (a Gaussian
//! deviate wrapped onto the circle: its density is exactly the wrapped Gaussian; the deviate
//! is drawn within ±12 standard deviations). TT^s, TRT^s: φ_q with `u[3]` and then θ_i with
//! `u[1]` from the tables' inverse-CDF samplers, whose densities are exact (not the public
//! code's uniform sampling). The pdf per steradian is `Σ_p w_p (density in θ_i, φ) / cosθ_i`,
//! exactly the density of the samples, and the weight `f_s cosθ_i/pdf` equals the sum of the
//! enabled lobes' masses when the lobes are gray. Every θ_i is drawn through the pole taper
//! ([`crate::hair::pole_taper`]: within 6° of the fiber axis its density is reshaped to vanish
//! like cosθ_i, so the pdf per steradian stays finite when a lobe is centred on the axis, as
//! at grazing viewers; and R, TT, TRT draw φ uniformly instead of from `N_p` with probability
//! `1 − W′(θ_i)` (`pole_blend`, 1 on the axis), so that near the axis, where every azimuth
//! meets, the density does not depend on φ; there the weight differs from the masses).
//! `field = far` draws h uniformly with `u[2]` and returns the h-averaged pdf.
//!
//! # Conventions and caveats
//! * **Tilt sign** as `chiang`: `alpha > 0` puts R toward the root. Yan 2017's released code
//!   stores the tilt negated.
//! * **R lobe**: separable (a Gaussian in θ_i about the tilted mirror direction). Yan 2017's code
//!   uses d'Eon et al. 2014's non-separable cone for R, whose centre and width depend on φ;
//!   not implemented.
//! * **TT width**: `β_TT = β_m/2` (as the 2015 ports); Yan 2017's code keeps β_m.
//! * **Non-reciprocity**: like Chiang's, the backward form conserves energy on the camera side
//!   only; `properties()` claims neither reciprocity nor an energy bound. With `lobes=r,tt,trt`
//!   the lossless camera-side furnace is `A_0 + A_1 + A_2 < 1`: the deficit is exactly the
//!   medulla-scattered light plus the orders p ≥ 3 ([`YanFur::energy_budget`]).
//! * At exactly grazing light (cosθ_i = 0) `eval` divides by [`crate::MIN_COS`].
//!
//! # Example: a value pinned by the closed form
//! Untilted, one interface, at h = 0 and with ω_i = ω_o at θ = 0 (backscatter, φ = 0): γ_o = γ_t
//! = 0, `Φ(p, 0) = pπ`, the Fresnel reflectance is the normal-incidence `f = ((η − 1)/(η + 1))²`,
//! and the segment through the axis crosses 2(1 − κ) of cortex and 2κ of medulla, so
//! `T = exp(−2(1 − κ)σ_c^a − 2κ(σ_m^s + σ_m^a))`. With β_m = 6° the Gaussians end at least 10
//! standard deviations inside [−π/2, π/2], so their truncation is below 10⁻²².
//! ```
//! use fiberlab_math::{Rgb, frame::direction};
//! use fiberlab_scatter::ScatteringFunction;
//! use fiberlab_scatter::yan_2017::{CortexAbsorption, YanFur, YanFurParams};
//! use std::f64::consts::PI;
//!
//! let (eta, kappa, s_c, s_s, s_a) = (1.55f64, 0.6, 0.4, 1.5, 0.2);
//! let (beta, beta_n) = (6f64.to_radians(), 10f64.to_radians());
//! let fiber = YanFur::new(YanFurParams {
//!     absorption: CortexAbsorption::SigmaA(Rgb::splat(s_c)),
//!     kappa, sigma_m_s: s_s, sigma_m_a: s_a, alpha: 0.0, layers: 1.0,
//!     beta_m: beta, beta_n, lobes: [true, true, true, false, false], // R, TT, TRT only
//!     ..YanFurParams::default()
//! })?;
//! let w = direction(0.0, 0.3);
//! let got = fiber.eval(w, w, 0.0)[0];
//!
//! let g = |s: f64, x: f64| (-0.5 * (x / s).powi(2)).exp() / (s * (2.0 * PI).sqrt());
//! let wrapped = |s: f64, x: f64| (-3..=3).map(|k| g(s, x + 2.0 * PI * k as f64)).sum::<f64>();
//! let f = ((eta - 1.0) / (eta + 1.0)).powi(2);
//! let t = (-2.0 * (1.0 - kappa) * s_c - 2.0 * kappa * (s_s + s_a)).exp();
//! let want = f * g(beta, 0.0) * wrapped(beta_n, 0.0)                                     // R
//!     + (1.0 - f).powi(2) * t * g(0.5 * beta, 0.0) * wrapped(beta_n * 2f64.sqrt(), PI)    // TT
//!     + (1.0 - f).powi(2) * f * t * t * g(1.5 * beta, 0.0) * wrapped(beta_n * 3f64.sqrt(), 0.0); // TRT
//! assert!((got - want).abs() < 1e-12 * want, "{got} vs {want}");
//! # Ok::<(), fiberlab_scatter::yan_2017::YanFurError>(())
//! ```

use crate::hair::attenuation::{chord_lengths, first_transmission, next_order, surface_fresnel};
use crate::hair::medulla::{MAX_SIGMA_A, MAX_SIGMA_S, MedullaError, MedullaParams, MedullaTables, Resolution};
use crate::hair::normal_plane::exit_azimuth;
use crate::hair::parameters::{ALPHA_RANGE, ETA, ETA_RANGE};
use crate::hair::pole_taper::{pole_blend, taper, taper_derivative, untaper};
use crate::hair::tilt::{marschner_ratio_tilts, rotate};
use crate::params::{ParamKind, ParamSet, ParamSpec, ParameterError, Range};
use crate::{
    Field, LobeInfo, Lobes, MIN_COS, ModelError, ModelInfo, Properties, Registered, Sample, ScatteringFunction,
};
use fiberlab_math::frame::{cos_theta, direction_from_sin_cos, phi, sin_theta, wrap_pi};
use fiberlab_math::special::{gaussian, normal_mass, safe_asin, safe_sqrt, sample_truncated_normal, wrapped_gaussian};
use fiberlab_math::{DVec3, Rgb, bravais};
use std::f64::consts::{FRAC_PI_2, PI, TAU};
use std::sync::Arc;
use thiserror::Error;

/// Lobe names of `lobes=`, in order: the unscattered R, TT, TRT, then the medulla-scattered
/// TT^s, TRT^s.
pub const LOBE_NAMES: [&str; 5] = ["r", "tt", "trt", "tts", "trts"];
/// σ_c^a when neither `sigma_c_a` nor `color` is given (a light brown, per unit radius).
pub const DEFAULT_SIGMA_C_A: Rgb = Rgb::new(0.3, 0.5, 0.9);
/// Valid absorption coefficients (per unit radius).
const SIGMA_RANGE: Range = Range::closed(0.0, f64::INFINITY);
/// Valid medulla scattering coefficient per unit fiber radius: σ_m^s·κ (per unit medulla
/// radius) must stay within the medulla tables' range, and κ < 1.
const SIGMA_M_S_RANGE: Range = Range::closed(0.0, MAX_SIGMA_S);
/// Valid medulla absorption coefficient per unit fiber radius (the tables' range).
const SIGMA_M_A_RANGE: Range = Range::closed(0.0, MAX_SIGMA_A);
/// Valid relative medulla radius κ.
const KAPPA_RANGE: Range = Range::closed_open(0.0, 1.0);
/// Valid Henyey–Greenstein anisotropy.
const G_RANGE: Range = Range::open(-1.0, 1.0);
/// Valid cuticle interface count.
const LAYERS_RANGE: Range = Range::open_closed(0.0, 1000.0);
/// Valid roughness standard deviations, degrees: [0.5, 60]. Toward 0 the Gaussians become
/// deltas (a width of 5e−324 degrees is 0 radians); 0.5° is the narrowest the far-field
/// quadrature and the sampler are tested at (`tests/yan_2017.rs`, `tests/finite_everywhere.rs`).
const BETA_RANGE: Range = Range::closed(0.5, 60.0);
/// Valid desired colour per channel.
const COLOR_RANGE: Range = Range::open_closed(0.0, 1.0);
/// Gauss–Legendre nodes of the far-field integration per standard deviation of the narrowest
/// azimuthal Gaussian (measured error ≤ 1e−4 relative against brute force at 4).
const FAR_NODES_PER_WIDTH: f64 = 4.0;
/// Half-width, in standard deviations, of the Gaussian deviate drawn for the azimuth.
const AZIMUTH_SAMPLE_SIGMAS: f64 = 12.0;

const PARAMS: [ParamSpec; 13] = [
    ETA,
    ParamSpec {
        key: "sigma_c_a",
        kind: ParamKind::Color(SIGMA_RANGE),
        unit: "1/radius",
        default: "",
        doc: "cortex absorption (0.3,0.5,0.9 when neither sigma_c_a nor color is given)",
    },
    ParamSpec {
        key: "color",
        kind: ParamKind::Color(COLOR_RANGE),
        unit: "",
        default: "",
        doc: "desired colour instead of sigma_c_a: sigma_c_a = (−ln C − 4κ^1.5 σ_m^a)/(4(1 − κ^1.5))",
    },
    ParamSpec {
        key: "kappa",
        kind: ParamKind::Number(KAPPA_RANGE),
        unit: "",
        default: "0.5",
        doc: "medulla radius / fiber radius",
    },
    ParamSpec {
        key: "sigma_m_s",
        kind: ParamKind::Number(SIGMA_M_S_RANGE),
        unit: "1/radius",
        default: "1",
        doc: "medulla scattering coefficient",
    },
    ParamSpec {
        key: "sigma_m_a",
        kind: ParamKind::Number(SIGMA_M_A_RANGE),
        unit: "1/radius",
        default: "0",
        doc: "medulla absorption coefficient",
    },
    ParamSpec {
        key: "g",
        kind: ParamKind::Number(G_RANGE),
        unit: "",
        default: "0",
        doc: "Henyey–Greenstein anisotropy of the medulla",
    },
    ParamSpec {
        key: "layers",
        kind: ParamKind::Number(LAYERS_RANGE),
        unit: "",
        default: "1",
        doc: "cuticle interfaces (1 = one smooth interface; Yan 2017's slab count l is 2l here)",
    },
    ParamSpec {
        key: "alpha",
        kind: ParamKind::Number(ALPHA_RANGE),
        unit: "degrees",
        default: "3",
        doc: "cuticle tilt; > 0 moves the R lobe toward the root",
    },
    ParamSpec {
        key: "beta_m",
        kind: ParamKind::Number(BETA_RANGE),
        unit: "degrees",
        default: "10",
        doc: "longitudinal standard deviation of R (TT β/2, TRT 3β/2)",
    },
    ParamSpec {
        key: "beta_n",
        kind: ParamKind::Number(BETA_RANGE),
        unit: "degrees",
        default: "10",
        doc: "azimuthal standard deviation of R (lobe p: β·√(p+1))",
    },
    ParamSpec {
        key: "lobes",
        kind: ParamKind::Subset(&LOBE_NAMES),
        unit: "",
        default: "r,tt,trt,tts,trts",
        doc: "lobes to include (tts, trts: light scattered in the medulla, from its random-walk tables)",
    },
    ParamSpec {
        key: "field",
        kind: ParamKind::Choice(&["near", "far"]),
        unit: "",
        default: "near",
        doc: "near: value at offset h; far: averaged over h (Gauss–Legendre, h ignored)",
    },
];

/// Registry entry: `yan-fur`.
impl Registered for YanFur {
    const INFO: ModelInfo = ModelInfo {
        name: "yan-fur",
        summary: "Yan et al. 2015/2017 fur: double cylinder with a scattering medulla, R/TT/TRT and medulla-scattered TTs/TRTs",
        citation: "Yan, Tseng, Jensen & Ramamoorthi 2015; Yan, Jensen & Ramamoorthi 2017",
        params: &PARAMS,
        data: None,
    };

    fn from_param_set(p: &ParamSet) -> Result<Self, ModelError> {
        Ok(YanFur::new(YanFurParams::from_param_set(p)?)?)
    }
}

/// Where the cortex absorption comes from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CortexAbsorption {
    /// σ_c^a per unit radius, RGB.
    SigmaA(Rgb),
    /// A desired colour C ∈ (0, 1] per channel, mapped by [`sigma_c_a_from_color`].
    Color(Rgb),
}

/// Parameters of [`YanFur`] (angles in **radians**; the registry takes degrees).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct YanFurParams {
    /// Index of refraction η ∈ (1, 4] of cortex and medulla.
    pub eta: f64,
    /// Cortex absorption.
    pub absorption: CortexAbsorption,
    /// Medulla radius / fiber radius κ ∈ [0, 1).
    pub kappa: f64,
    /// Medulla scattering coefficient σ_m^s ≥ 0 per unit radius.
    pub sigma_m_s: f64,
    /// Medulla absorption coefficient σ_m^a ≥ 0 per unit radius.
    pub sigma_m_a: f64,
    /// Henyey–Greenstein anisotropy g ∈ (−1, 1) of the medulla.
    pub g: f64,
    /// Cuticle interfaces l ∈ (0, 1000].
    pub layers: f64,
    /// Cuticle tilt α (radians) in [−20°, 20°]; > 0 moves R toward the root.
    pub alpha: f64,
    /// Longitudinal standard deviation β_m of R (radians) in (0°, 60°].
    pub beta_m: f64,
    /// Azimuthal standard deviation β_n of R (radians) in (0°, 60°].
    pub beta_n: f64,
    /// Enabled lobes, in the order of [`LOBE_NAMES`].
    pub lobes: [bool; 5],
    /// Near field (value at h) or far field (average over h).
    pub field: Field,
}

impl Default for YanFurParams {
    /// The registry defaults (see the module table).
    fn default() -> Self {
        Self {
            eta: 1.55,
            absorption: CortexAbsorption::SigmaA(DEFAULT_SIGMA_C_A),
            kappa: 0.5,
            sigma_m_s: 1.0,
            sigma_m_a: 0.0,
            g: 0.0,
            layers: 1.0,
            alpha: 3f64.to_radians(),
            beta_m: 10f64.to_radians(),
            beta_n: 10f64.to_radians(),
            lobes: [true; 5],
            field: Field::Near,
        }
    }
}

impl YanFurParams {
    /// Reads the registry parameters (degrees → radians); `sigma_c_a` and `color` together
    /// are [`ModelError::Inconsistent`].
    pub fn from_param_set(p: &ParamSet) -> Result<Self, ModelError> {
        let absorption = match (p.color_opt("sigma_c_a"), p.color_opt("color")) {
            (Some(_), Some(_)) => {
                return Err(ModelError::Inconsistent("yan-fur: give either `sigma_c_a` or `color`, not both".into()));
            }
            (Some(s), None) => CortexAbsorption::SigmaA(s),
            (None, Some(c)) => CortexAbsorption::Color(c),
            (None, None) => CortexAbsorption::SigmaA(DEFAULT_SIGMA_C_A),
        };
        let lobes = p.subset("lobes")?;
        Ok(Self {
            eta: p.number("eta")?,
            absorption,
            kappa: p.number("kappa")?,
            sigma_m_s: p.number("sigma_m_s")?,
            sigma_m_a: p.number("sigma_m_a")?,
            g: p.number("g")?,
            layers: p.number("layers")?,
            alpha: p.degrees("alpha")?,
            beta_m: p.degrees("beta_m")?,
            beta_n: p.degrees("beta_n")?,
            lobes: LOBE_NAMES.map(|n| lobes.contains(&n)),
            field: if p.choice("field")? == "far" { Field::Far } else { Field::Near },
        })
    }

    /// Checks every value against its range (the error names the parameter; angles in
    /// degrees) and resolves σ_c^a.
    pub fn validate(&self) -> Result<Rgb, ParameterError> {
        ETA_RANGE.check("eta", self.eta)?;
        KAPPA_RANGE.check("kappa", self.kappa)?;
        SIGMA_M_S_RANGE.check("sigma_m_s", self.sigma_m_s)?;
        SIGMA_M_A_RANGE.check("sigma_m_a", self.sigma_m_a)?;
        G_RANGE.check("g", self.g)?;
        LAYERS_RANGE.check("layers", self.layers)?;
        ALPHA_RANGE.check_degrees("alpha", self.alpha)?;
        BETA_RANGE.check_degrees("beta_m", self.beta_m)?;
        BETA_RANGE.check_degrees("beta_n", self.beta_n)?;
        match self.absorption {
            CortexAbsorption::SigmaA(s) => SIGMA_RANGE.check_rgb("sigma_c_a", s),
            CortexAbsorption::Color(c) => sigma_c_a_from_color(c, self.kappa, self.sigma_m_a),
        }
    }
}

/// Why a [`YanFur`] fiber cannot be built.
#[non_exhaustive]
#[derive(Clone, Debug, Error, PartialEq)]
pub enum YanFurError {
    /// A parameter outside its range (named, with the range; angles in degrees).
    #[error(transparent)]
    Parameter(#[from] ParameterError),
    /// `lobes` enables no lobe.
    #[error("yan-fur: `lobes` must name at least one of r, tt, trt, tts, trts")]
    NoLobe,
    /// The medulla tables could not be built.
    #[error("yan-fur: medulla tables: {0}")]
    Medulla(#[from] MedullaError),
}

impl From<YanFurError> for ModelError {
    fn from(e: YanFurError) -> Self {
        match e {
            YanFurError::Parameter(p) => p.into(),
            other => ModelError::Inconsistent(other.to_string()),
        }
    }
}

/// Yan 2017's colour → cortex absorption: `σ_c^a = (−ln C − 4mσ_m^a)/(4(1 − m))`, `m = κ^{3/2}`,
/// per channel, for C ∈ (0, 1] and κ ∈ [0, 1). A channel brighter than `exp(−4mσ_m^a)` (which
/// would need σ_c^a < 0) is an error naming `color` with the valid range.
pub fn sigma_c_a_from_color(color: Rgb, kappa: f64, sigma_m_a: f64) -> Result<Rgb, ParameterError> {
    COLOR_RANGE.check_rgb("color", color)?;
    let m = kappa * kappa.sqrt();
    let brightest = (-4.0 * m * sigma_m_a).exp();
    let allowed = Range::open_closed(0.0, brightest);
    for i in 0..3 {
        if !allowed.contains(color[i]) {
            return Err(ParameterError::OutOfRange {
                key: "color",
                value: color[i],
                range: format!("{allowed} per channel (the medulla's absorption sigma_m_a alone darkens to this)"),
            });
        }
    }
    Ok(color.map(|c| ((-c.ln() - 4.0 * m * sigma_m_a) / (4.0 * (1.0 - m))).max(0.0)))
}

/// Reflectance of a cuticle of `layers` interfaces each reflecting `f` (incoherent stack,
/// Stokes' relation): `l·f/(1 + (l − 1)f)`; `layers = 1` gives `f`.
#[must_use]
#[inline]
pub fn cuticle_reflectance(layers: f64, f: f64) -> f64 {
    let d = 1.0 + (layers - 1.0) * f;
    if d > 0.0 { (layers * f / d).clamp(0.0, 1.0) } else { 0.0 }
}

/// Yan 2017's released definition of the cuticle reflectance: per polarization (s, p) the
/// reflectance R of one interface of index `eta` at incidence `cos_i` makes a slab of two
/// incoherent interfaces, `2R/(1 + R)`, `layers` slabs are stacked as in
/// [`cuticle_reflectance`], and the polarizations are averaged.
#[must_use]
pub fn slab_layers_reflectance(layers: f64, eta: f64, cos_i: f64) -> f64 {
    let cos_i = cos_i.clamp(0.0, 1.0);
    let sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    let cos_t = safe_sqrt(1.0 - sin2_t);
    let rs = ((cos_i - eta * cos_t) / (cos_i + eta * cos_t)).powi(2);
    let rp = ((eta * cos_i - cos_t) / (eta * cos_i + cos_t)).powi(2);
    let slab = |r: f64| 2.0 * r / (1.0 + r);
    0.5 * (cuticle_reflectance(layers, slab(rs)) + cuticle_reflectance(layers, slab(rp)))
}

/// The interface count of this model equivalent to Yan 2017's slab count: `2l` (exact per
/// polarization, see [`slab_layers_reflectance`]).
#[must_use]
pub fn interfaces_from_slab_layers(slab_layers: f64) -> f64 {
    2.0 * slab_layers
}

/// Where the light entering at one camera hit goes (lossless: the fields sum to 1 per channel).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EnergyBudget {
    /// `A_p` of R, TT, TRT.
    pub lobes: [Rgb; 3],
    /// Fraction that scatters in the medulla, on every pass (what scattered lobes of every
    /// order would carry, absorption inside the medulla after scattering included).
    pub scattered: Rgb,
    /// Masses `A_s·E` of the TT^s and TRT^s lobes (E the tables' escaping fraction; zero
    /// without tables): the part of `scattered` the model returns.
    pub scattered_lobes: [Rgb; 2],
    /// Unscattered orders p ≥ 3, `A_2 F_l T/(1 − F_l T)` (in neither paper's lobes).
    pub higher_orders: Rgb,
    /// The rest: absorbed in the cortex or the medulla.
    pub absorbed: Rgb,
}

/// Geometry and attenuations of one camera hit.
#[derive(Clone, Copy, Debug)]
struct FurHit {
    gamma_o: f64,
    gamma_t: f64,
    /// Layered Fresnel F_l.
    f: f64,
    /// Per-segment transmittance.
    t: Rgb,
    /// Cortex and medulla lengths of one segment.
    cortex: f64,
    core: f64,
    a: [Rgb; 3],
    /// Signed inclination of the camera ray's refracted direction (sinθ_t = −sinθ_o/η).
    theta_t: f64,
    /// The refracted chord's offset over the medulla radius, `h′/κ` (NaN when the chord
    /// misses the medulla).
    h_medulla: f64,
    /// Attenuation outside the medulla of TT^s, TRT^s (without the medulla's own N).
    a_s: [Rgb; 2],
    /// Escaping fraction of the medulla walk at (θ_t, h′/κ) (zero without tables).
    escaping: Rgb,
}

impl FurHit {
    /// Lobe masses: `A_p` for R, TT, TRT and `A_s·E` for TT^s, TRT^s.
    fn masses(&self) -> [Rgb; 5] {
        [self.a[0], self.a[1], self.a[2], self.a_s[0] * self.escaping, self.a_s[1] * self.escaping]
    }

    /// Azimuth offset of scattered lobe q (0: TT^s, 1: TRT^s): the refracted entry direction,
    /// turned by an internal reflection for TRT^s.
    fn scattered_shift(&self, q: usize) -> f64 {
        (self.gamma_t - self.gamma_o) + q as f64 * (PI + 2.0 * self.gamma_t)
    }
}

/// Yan et al. 2015/2017 fur fiber: unscattered R, TT, TRT and medulla-scattered TT^s, TRT^s.
#[derive(Clone, Debug)]
pub struct YanFur {
    params: YanFurParams,
    sigma_c_a: Rgb,
    /// σ_m^s + σ_m^a.
    sigma_m_e: f64,
    /// Longitudinal standard deviations of R, TT, TRT.
    beta: [f64; 3],
    /// Azimuthal standard deviations of R, TT, TRT.
    beta_n: [f64; 3],
    tilt: [(f64, f64); 3],
    enabled: [bool; 5],
    /// The medulla's random-walk tables (σ_s = σ_m^s κ, σ_a = σ_m^a κ per unit medulla
    /// radius, g), shared process-wide; `None` when no scattered lobe is enabled or nothing
    /// scatters (κ = 0 or σ_m^s = 0).
    medulla: Option<Arc<MedullaTables>>,
    /// Gauss–Legendre nodes and weights on [−1, 1] for the far-field h-integration.
    gauss_legendre: Vec<(f64, f64)>,
}

impl YanFur {
    /// A fur fiber; the error names the parameter out of range.
    pub fn new(params: YanFurParams) -> Result<Self, YanFurError> {
        let sigma_c_a = params.validate()?;
        let enabled = params.lobes;
        if !enabled.iter().any(|&e| e) {
            return Err(YanFurError::NoLobe);
        }
        let scatters = params.kappa > 0.0 && params.sigma_m_s > 0.0;
        let medulla = if (enabled[3] || enabled[4]) && scatters {
            let k = params.kappa;
            let medium = MedullaParams::new(params.sigma_m_s * k, Rgb::splat(params.sigma_m_a * k), params.g)?;
            Some(MedullaTables::shared(&medium, &Resolution::default())?)
        } else {
            None
        };
        let (bm, bn) = (params.beta_m, params.beta_n);
        // Φ(p, ·) moves at most 2 rad per radian of γ (or of ψ), so the narrowest azimuthal
        // feature is a Gaussian β_n/2 wide in the integration variable: FAR_NODES_PER_WIDTH
        // nodes per such width over the longest piece (π).
        let n = ((FAR_NODES_PER_WIDTH * 2.0 * PI / bn).ceil() as usize).clamp(32, 4096);
        Ok(Self {
            params,
            sigma_c_a,
            sigma_m_e: params.sigma_m_s + params.sigma_m_a,
            beta: [bm, 0.5 * bm, 1.5 * bm],
            beta_n: [bn, bn * 2f64.sqrt(), bn * 3f64.sqrt()],
            tilt: marschner_ratio_tilts(params.alpha),
            enabled,
            medulla,
            gauss_legendre: fiberlab_math::quadrature::gauss_legendre(n),
        })
    }

    /// The parameters (radians).
    #[must_use]
    pub fn params(&self) -> &YanFurParams {
        &self.params
    }

    /// σ_c^a per unit radius (given, or from the colour).
    #[must_use]
    pub fn sigma_c_a(&self) -> Rgb {
        self.sigma_c_a
    }

    /// The medulla's random-walk tables of the scattered lobes (`None` when no scattered lobe
    /// is enabled or nothing scatters).
    #[must_use]
    pub fn medulla_tables(&self) -> Option<&MedullaTables> {
        self.medulla.as_deref()
    }

    /// The Gauss–Legendre nodes and weights on [−1, 1] of the far-field h-integration, per
    /// piece (see [`ScatteringFunction::eval_far`]).
    #[must_use]
    pub fn far_nodes(&self) -> &[(f64, f64)] {
        &self.gauss_legendre
    }

    fn hit(&self, sin_o: f64, cos_o: f64, h: f64) -> FurHit {
        let h = h.clamp(-1.0, 1.0);
        let eta = self.params.eta;
        let f = cuticle_reflectance(self.params.layers, surface_fresnel(eta, cos_o, safe_sqrt(1.0 - h * h)));
        let sin_gamma_t = bravais::sin_gamma_t(h, eta, sin_o, cos_o);
        let chords = chord_lengths(sin_gamma_t, bravais::cos_theta_t(eta, sin_o), self.params.kappa);
        let t = (self.sigma_c_a * -chords.cortex).exp() * (-self.sigma_m_e * chords.core).exp();
        let a1 = first_transmission(f, t);
        let cos_theta_t = bravais::cos_theta_t(eta, sin_o);
        let theta_t = (-sin_o / eta).asin();
        let kappa = self.params.kappa;
        let h_medulla = if kappa > 0.0 && sin_gamma_t.abs() < kappa { sin_gamma_t / kappa } else { f64::NAN };
        // Outside the medulla: half the segment's cortex to reach it, and (1 − κ)/cosθ_t of
        // cortex from it to the surface (Yan's radial estimate); TRT^s first crosses a whole
        // segment unscattered and reflects once.
        let outside = (self.sigma_c_a * -(0.5 * chords.cortex + (1.0 - kappa) / cos_theta_t)).exp() * (1.0 - f);
        let a_s = [outside, outside * t * f];
        let escaping = match &self.medulla {
            Some(m) if !h_medulla.is_nan() => m.escaping_fraction(theta_t, h_medulla),
            _ => Rgb::ZERO,
        };
        FurHit {
            gamma_o: h.asin(),
            gamma_t: safe_asin(sin_gamma_t),
            f,
            t,
            cortex: chords.cortex,
            core: chords.core,
            a: [Rgb::splat(f), a1, next_order(a1, f, t)],
            theta_t,
            h_medulla,
            a_s,
            escaping,
        }
    }

    /// `A_p(θ_o, h)` of R, TT, TRT for a camera at inclination `theta_o`.
    #[must_use]
    pub fn attenuation(&self, theta_o: f64, h: f64) -> [Rgb; 3] {
        let (s, c) = theta_o.sin_cos();
        self.hit(s, c.abs(), h).a
    }

    /// Where the light entering at (θ_o, h) goes: the three lobes, the part scattered in the
    /// medulla (summed over all internal segments: on each, after half the segment's cortex
    /// length, the medulla removes `σ_m^s/σ_m^e·(1 − e^{−σ_m^e ℓ_m})` of what arrives), the
    /// unscattered orders p ≥ 3, and the absorbed rest.
    #[must_use]
    pub fn energy_budget(&self, theta_o: f64, h: f64) -> EnergyBudget {
        let (s, c) = theta_o.sin_cos();
        let hit = self.hit(s, c.abs(), h);
        let ft = hit.t * hit.f;
        let per_segment = if self.sigma_m_e > 0.0 && hit.core > 0.0 {
            (self.params.sigma_m_s / self.sigma_m_e) * -(-self.sigma_m_e * hit.core).exp_m1()
        } else {
            0.0
        };
        let entering = (self.sigma_c_a * (-0.5 * hit.cortex)).exp() * per_segment * (1.0 - hit.f);
        let geometric = |x: Rgb| Rgb::new(geo(x[0], ft[0]), geo(x[1], ft[1]), geo(x[2], ft[2]));
        let scattered = geometric(entering);
        let higher_orders = geometric(hit.a[2] * ft);
        let total = hit.a[0] + hit.a[1] + hit.a[2] + scattered + higher_orders;
        let m = hit.masses();
        EnergyBudget {
            lobes: hit.a,
            scattered,
            scattered_lobes: [m[3], m[4]],
            higher_orders,
            absorbed: (Rgb::ONE - total).map(|x| x.max(0.0)),
        }
    }

    /// What every evaluation for one viewer `wo` shares, whatever h and ω_i: the viewer's
    /// inclination, its exit inclination θ_e for the medulla tables and the three lobes'
    /// longitudinal Gaussians (computed once per viewer, not once per width node).
    fn viewer(&self, wo: DVec3) -> Viewer {
        let (sin_o, cos_o) = (sin_theta(wo), cos_theta(wo));
        Viewer {
            sin_o,
            cos_o,
            phi_o: phi(wo),
            theta_e: -sin_o.atan2(cos_o),
            lobes: std::array::from_fn(|p| self.longitudinal_lobe(p, sin_o, cos_o)),
        }
    }

    /// Centre θ_c, width β_p and truncated mass of lobe p's longitudinal Gaussian.
    #[inline]
    fn longitudinal_lobe(&self, p: usize, sin_o: f64, cos_o: f64) -> (f64, f64, f64) {
        let (so, co) = rotate(sin_o, cos_o, self.tilt[p]);
        let centre = -so.atan2(co);
        let b = self.beta[p];
        (centre, b, normal_mass((-FRAC_PI_2 - centre) / b, (FRAC_PI_2 - centre) / b))
    }

    /// Lobe-selection probabilities ∝ Y(A_p) over the enabled lobes; `None` if all vanish.
    fn lobe_weights(&self, hit: &FurHit) -> Option<[f64; 5]> {
        let m = hit.masses();
        let y: [f64; 5] = std::array::from_fn(|p| if self.enabled[p] { m[p].luminance() } else { 0.0 });
        let total: f64 = y.iter().sum();
        (total > 0.0).then(|| y.map(|x| x / total))
    }

    /// `(Σ A_p M_p N_p, Σ w_p M_p N_p)`: value and sampling density per dθ_i dφ; the density's
    /// θ part is taken at the tapered `W(θ_i)` times `W′(θ_i)` (the sampler draws θ_i through
    /// the pole taper, [`crate::hair::pole_taper`]).
    fn integrand_and_pdf_at(&self, wi: DVec3, viewer: &Viewer, hit: &FurHit, w: &[f64; 5]) -> (Rgb, f64) {
        let theta_i = sin_theta(wi).atan2(cos_theta(wi));
        let (theta_star, slope, blend) = (taper(theta_i), taper_derivative(theta_i), pole_blend(theta_i));
        let dphi = phi(wi) - viewer.phi_o;
        let (mut g, mut pdf) = (Rgb::ZERO, 0.0);
        for (p, w_p) in w.iter().enumerate() {
            if !self.enabled[p] {
                continue;
            }
            if p >= 3 {
                let Some(tables) = &self.medulla else { continue };
                if hit.h_medulla.is_nan() {
                    continue;
                }
                let phi_q = wrap_pi(dphi - hit.scattered_shift(p - 3));
                let theta_e = viewer.theta_e;
                let n = tables.azimuthal(hit.theta_t, hit.h_medulla, phi_q);
                let m = tables.longitudinal(theta_e, phi_q, theta_i);
                g += hit.a_s[p - 3] * n * m;
                if *w_p > 0.0 && slope > 0.0 {
                    pdf += w_p
                        * tables.azimuth_pdf(hit.theta_t, hit.h_medulla, phi_q)
                        * tables.inclination_pdf(theta_e, phi_q, theta_star)
                        * slope;
                }
                continue;
            }
            let m = viewer.longitudinal(p, theta_i);
            let n = wrapped_gaussian(self.beta_n[p], dphi - exit_azimuth(p, hit.gamma_o, hit.gamma_t));
            g += hit.a[p] * (m * n);
            if *w_p > 0.0 && slope > 0.0 {
                let n_sampled = (1.0 - blend) * n + blend / TAU;
                pdf += w_p * viewer.longitudinal(p, theta_star) * slope * n_sampled;
            }
        }
        (g, pdf)
    }

    /// Near field: `(f_s, pdf per steradian)` at offset h.
    fn near_eval_and_pdf(&self, wi: DVec3, viewer: &Viewer, h: f64) -> (Rgb, f64) {
        let hit = self.hit(viewer.sin_o, viewer.cos_o, h);
        let Some(w) = self.lobe_weights(&hit) else { return (Rgb::ZERO, 0.0) };
        let (g, pdf) = self.integrand_and_pdf_at(wi, viewer, &hit, &w);
        let c = cos_theta(wi).max(MIN_COS);
        (g / (c * c), pdf / c)
    }

    /// The far-field `f_s(ω_i, ω_o) = ½∫_{−1}^{1} f_s(ω_i, ω_o; h) dh` (the near-field value
    /// averaged over the fiber width). Integrated by Gauss–Legendre quadrature on the pieces
    /// where the integrand is smooth: outside the medulla in γ = asin h (smooth up to h = ±1),
    /// inside it in ψ with `h′ = κ sinψ` (the medulla chord `√(κ² − h′²)` is smooth in ψ);
    /// `n = clamp(⌈8π/β_n⌉, 32, 4096)` nodes per piece (4 per standard deviation of the R lobe's
    /// azimuthal Gaussian in the integration variable).
    fn far_eval(&self, wi: DVec3, wo: DVec3) -> Rgb {
        let viewer = self.viewer(wo);
        self.far_integral(wo, |h| self.near_eval_and_pdf(wi, &viewer, h).0)
    }

    /// `½∫_{−1}^{1} f(h) dh` over the smooth pieces of the fiber seen from `wo`.
    fn far_integral(&self, wo: DVec3, f: impl Fn(f64) -> Rgb) -> Rgb {
        let (sin_o, cos_o) = (sin_theta(wo), cos_theta(wo));
        // |h′| = κ at h_b = κη′ = κ/sinγ_t(h = 1).
        let inv_eta_prime = bravais::sin_gamma_t(1.0, self.params.eta, sin_o, cos_o);
        let h_b = if self.params.kappa > 0.0 && self.params.kappa < inv_eta_prime {
            self.params.kappa / inv_eta_prime
        } else {
            1.0
        };
        let mut sum = Rgb::ZERO;
        let gamma_b = h_b.min(1.0).asin();
        // Inside: h = h_b sinψ, ψ ∈ [−π/2, π/2] (when the medulla is hit at all).
        let inner = |lo: f64, hi: f64, sum: &mut Rgb, map: &dyn Fn(f64) -> (f64, f64)| {
            let (mid, half) = (0.5 * (hi + lo), 0.5 * (hi - lo));
            for &(x, w) in &self.gauss_legendre {
                let (h, dh) = map(mid + half * x);
                *sum += f(h) * (w * half * dh);
            }
        };
        if h_b < 1.0 {
            inner(-FRAC_PI_2, FRAC_PI_2, &mut sum, &|psi: f64| (h_b * psi.sin(), h_b * psi.cos()));
            inner(gamma_b, FRAC_PI_2, &mut sum, &|g: f64| (g.sin(), g.cos()));
            inner(-FRAC_PI_2, -gamma_b, &mut sum, &|g: f64| (g.sin(), g.cos()));
        } else {
            inner(-FRAC_PI_2, FRAC_PI_2, &mut sum, &|g: f64| (g.sin(), g.cos()));
        }
        sum * 0.5
    }

    /// Far field: the pdf is the h-average of the near-field pdf (sampling draws h uniformly).
    fn far_pdf(&self, wi: DVec3, wo: DVec3) -> f64 {
        let viewer = self.viewer(wo);
        self.far_integral(wo, |h| Rgb::splat(self.near_eval_and_pdf(wi, &viewer, h).1))[0]
    }

    fn sample_near(&self, wo: DVec3, h: f64, u: [f64; 4]) -> Option<(DVec3, Rgb, f64, u8)> {
        let viewer = self.viewer(wo);
        let hit = self.hit(viewer.sin_o, viewer.cos_o, h);
        let w = self.lobe_weights(&hit)?;
        let mut p = 0;
        let mut acc = w[0];
        while p < 4 && (u[0] >= acc || w[p] == 0.0) {
            p += 1;
            acc += w[p];
        }
        while w[p] == 0.0 && p > 0 {
            p -= 1;
        }
        let (theta_i, dphi) = if p >= 3 {
            // The medulla tables' exact inverse-CDF samplers: φ_q given (θ_t, h′/κ), then the
            // exit inclination given (θ_e, φ_q).
            let tables = self.medulla.as_ref()?;
            let (phi_q, _) = tables.sample_azimuth(hit.theta_t, hit.h_medulla, u[3])?;
            let (theta_i, _) = tables.sample_inclination(viewer.theta_e, phi_q, u[1])?;
            (untaper(theta_i.clamp(-FRAC_PI_2, FRAC_PI_2)), phi_q + hit.scattered_shift(p - 3))
        } else {
            let (centre, b, _) = viewer.lobes[p];
            let z = sample_truncated_normal(u[1], (-FRAC_PI_2 - centre) / b, (FRAC_PI_2 - centre) / b);
            let theta_i = untaper((centre + b * z).clamp(-FRAC_PI_2, FRAC_PI_2));
            // Near the axis, φ uniform with probability `pole_blend(θ_i)` (u[3] split in two).
            let blend = pole_blend(theta_i);
            if u[3] < blend {
                (theta_i, TAU * (u[3] / blend) - PI)
            } else {
                let v = ((u[3] - blend) / (1.0 - blend)).clamp(0.0, 1.0);
                let dev = sample_truncated_normal(v, -AZIMUTH_SAMPLE_SIGMAS, AZIMUTH_SAMPLE_SIGMAS);
                (theta_i, exit_azimuth(p, hit.gamma_o, hit.gamma_t) + self.beta_n[p] * dev)
            }
        };
        let (s, c) = theta_i.sin_cos();
        let wi = direction_from_sin_cos(s, c.max(0.0), viewer.phi_o + dphi);
        let (g, pdf) = self.integrand_and_pdf_at(wi, &viewer, &hit, &w);
        (pdf > 0.0 && pdf.is_finite()).then(|| (wi, g / pdf, pdf / cos_theta(wi).max(MIN_COS), p as u8))
    }
}

/// [`YanFur::viewer`]: what depends on ω_o alone.
struct Viewer {
    sin_o: f64,
    cos_o: f64,
    phi_o: f64,
    /// The exit inclination the medulla tables are indexed by, `−θ_o`.
    theta_e: f64,
    /// Centre θ_c, width β_p and truncated mass of the R, TT and TRT longitudinal Gaussians.
    lobes: [(f64, f64, f64); 3],
}

impl Viewer {
    /// `M_p(θ_i; θ_o)`: density in θ_i.
    #[inline]
    fn longitudinal(&self, p: usize, theta_i: f64) -> f64 {
        let (centre, b, mass) = self.lobes[p];
        gaussian(b, theta_i - centre) / mass
    }
}

/// `x/(1 − r)` for the geometric series of ratio `r ∈ [0, 1]`; 0 when r = 1 (then x = 0 too).
fn geo(x: f64, r: f64) -> f64 {
    if r < 1.0 { x / (1.0 - r) } else { 0.0 }
}

impl ScatteringFunction for YanFur {
    fn properties(&self) -> Properties {
        Properties { reciprocal: false, energy_conserving: false, field: self.params.field, lobes: Lobes::Smooth }
    }

    fn eval(&self, wi: DVec3, wo: DVec3, h: f64) -> Rgb {
        match self.params.field {
            Field::Near => self.near_eval_and_pdf(wi, &self.viewer(wo), h).0,
            Field::Far => self.eval_far(wi, wo),
        }
    }

    fn pdf(&self, wi: DVec3, wo: DVec3, h: f64) -> f64 {
        match self.params.field {
            Field::Near => self.near_eval_and_pdf(wi, &self.viewer(wo), h).1,
            Field::Far => self.far_pdf(wi, wo),
        }
    }

    fn eval_and_pdf(&self, wi: DVec3, wo: DVec3, h: f64) -> (Rgb, f64) {
        match self.params.field {
            Field::Near => self.near_eval_and_pdf(wi, &self.viewer(wo), h),
            Field::Far => (self.far_eval(wi, wo), self.far_pdf(wi, wo)),
        }
    }

    /// The width average by this model's own rule (Gauss–Legendre on the pieces where the
    /// integrand is smooth: outside and inside the medulla), whatever `field` is.
    fn eval_far(&self, wi: DVec3, wo: DVec3) -> Rgb {
        self.far_eval(wi, wo)
    }

    /// `R`, `TT`, `TRT`, and the medulla-scattered `TTs`, `TRTs` (index p of [`LOBE_NAMES`]).
    fn lobes(&self) -> Vec<LobeInfo> {
        ["R", "TT", "TRT", "TTs", "TRTs"].map(LobeInfo::smooth).to_vec()
    }

    fn sample(&self, wo: DVec3, h: f64, u: [f64; 4]) -> Option<Sample> {
        match self.params.field {
            Field::Near => {
                let (wi, weight, pdf, lobe) = self.sample_near(wo, h, u)?;
                Some(Sample { wi, weight, pdf, delta: false, lobe })
            }
            Field::Far => {
                // h uniform from u[2] (unused by the near-field sampler), then the near-field
                // sample at that h: the density is the h-average of the near-field pdfs.
                let (wi, _, _, lobe) = self.sample_near(wo, 2.0 * u[2] - 1.0, u)?;
                let (f, pdf) = self.eval_and_pdf(wi, wo, 0.0);
                (pdf > 0.0).then(|| Sample { wi, weight: f * (cos_theta(wi) / pdf), pdf, delta: false, lobe })
            }
        }
    }
}
