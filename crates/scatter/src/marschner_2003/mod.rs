//! Marschner, Jensen, Cammarano, Worley & Hanrahan 2003, *Light scattering from human hair
//! fibers* (ACM Transactions on Graphics 22(3), SIGGRAPH 2003): the far-field R + TT + TRT
//! model with caustic glints and the first-order eccentricity correction. Built from the hair
//! core ([`crate::hair`]); the shared mathematics is in `docs/theory/hair.md`, the peers'
//! differences in `docs/theory/peer-discrepancies.md`. Equations are cited by the quantity
//! they define and by the paper's Table 1 (equation numbers are not quoted: unchecked).
//!
//! Parameters: the registry entry (the `params` of `Registered::INFO` below) is the one table of
//! keys, units, defaults and valid ranges; `fiberlab models --model marschner` prints it and the
//! book's page `docs/book/src/models/marschner.md` shows it. The formulas below write `eta` as η,
//! `sigma_a` as σ_a, `alpha_r` as α_R, `beta_r` as β_R, `k_g` as k_G, `w_c` as w_c, `delta_eta` as
//! Δη′, `delta_h_m` as Δh_M, `eccentricity` as a. `alpha_r` is given in degrees and held in radians
//! in [`MarschnerParams`].
//!
//! # Formula
//! The paper's scattering function
//! `S(ω_i, ω_r) = Σ_{p ∈ {R, TT, TRT}} M_p(θ_h)·N_p(η′(θ_d), φ) / cos²θ_d` (sr⁻¹), with
//! `θ_h = (θ_i + θ_r)/2`, `θ_d = (θ_r − θ_i)/2`, `φ = φ_r − φ_i` (0 = backscatter).
//! * Longitudinal: `M_p = k_M·g(β_p; θ_h − α_p)`, g a unit-area Gaussian, with
//!   `α_TT = −α_R/2`, `α_TRT = −3α_R/2`, `β_TT = β_R/2`, `β_TRT = 2β_R` (Table 1;
//!   [`crate::hair::longitudinal::GaussianLobes`]).
//! * Azimuthal: `N_p(φ) = Σ_{γ: Φ(p, γ) ≡ φ} A(p, h)·cosγ / (2|dΦ/dγ|)`, h = sinγ,
//!   which is the paper's `Σ A/|2 dΦ/dh|` written in γ (finite at h = ±1), with
//!   `Φ(p, γ) = 2p·asin(sinγ/η′) − 2γ + pπ`; Bravais' `η′ = sqrt(η² − sin²θ_d)/cosθ_d`
//!   enters only through `1/η′ = cosθ_d/sqrt(η² − sin²θ_d)` (finite at grazing θ_d)
//!   ([`crate::hair::normal_plane`]).
//! * Attenuation: `A(0) = F`, `A(p) = (1 − F)²·F^{p−1}·T^p`, F the dielectric Fresnel of η
//!   at `cos ι = cosθ_d·cosγ` (equal to the paper's form with both Bravais indices η′, η″;
//!   the internal reflections have the same value), and `T = exp(−σ_a·2cosγ_t/cosθ_t)`
//!   (chord length of the internal path, radius 1) ([`crate::hair::attenuation`]).
//! * TRT caustic (the paper's glints): `N_TRT = N_P·[1 − t·ĝ(φ − φ_c)]·[1 − t·ĝ(φ + φ_c)] +
//!   t·k_G·A(2, h_c)·Δh·[g(w_c; φ − φ_c) + g(w_c; φ + φ_c)]`, ĝ = g/g(0), with
//!   `h_c = sqrt((4 − η′²)/3)`, `Δh = min(Δh_M, 2·sqrt(2w_c/|d²Φ/dh²(h_c)|))`, t = 1 while
//!   η′ < 2, else `h_c = 0`, `Δh = Δh_M`, `t = 1 − smoothstep(2, 2 + Δη′, η′)`
//!   ([`crate::hair::normal_plane::Caustic`]).
//! * Eccentricity (TRT only): η replaced by
//!   `η*(φ_h) = ½[(η*₁ + η*₂) + cos(2φ_h)(η*₁ − η*₂)]`, `η*₁ = 2(η − 1)a² − η + 2`,
//!   `η*₂ = 2(η − 1)a⁻² − η + 2`, φ_h from the major axis `v` (+y).
//!
//! # Decisions
//! Where the paper and its implementations differ, the choices and their reasons are in
//! `docs/theory/marschner-2003.md` (the peers' choices in `docs/theory/peer-discrepancies.md`).
//! In short: `normalization=energy` (k_M = ½; default) or `paper` (k_M = 1, as printed), and
//! even with k_M = ½ the model is not energy conserving in general
//! ([`Properties::energy_conserving`] is false; [`albedo_table`] measures it); `roots=exact`
//! (default) or the paper's `cubic`; the 3D Fresnel at `cosθ_d·cosγ`; `absorption=chord`
//! (default) or the printed `paper` path; the glint fade `t = 1 − smoothstep(2, 2 + Δη′, η′)`;
//! η* from `cos 2φ_h = cos(φ_i + φ_r)`, so S stays symmetric for every a; `alpha_r` with the
//! paper's sign (α_R < 0: R toward the root); Table 1's mid-range defaults; `cos²θ_d` clamped
//! at [`MIN_COS_THETA_D`]², `|dΦ/dγ|` at [`MIN_DPHI`]; a ≥ 0.75, β_R ≥ 1°, |α_R| ≤ 20°.
//!
//! # Sampling
//! `sampling.rs` draws (lobe, θ_h, φ) and evaluates the matching pdf; its header
//! describes the mixture.
//!
//! Far field: `h` is ignored. η′, θ_t and Fresnel use θ_d (as the paper), not θ_r.
//!
//! # Tests (`tests.rs`)
//! Reciprocity on random pairs (circular and eccentric, both root modes); `∫N_p dφ = ½∫A dh`
//! per lobe and root mode (tanh–sinh in φ against direct h-integration); R with F ≡ 1 equals
//! `cos(φ/2)/4`; A(p, h) against a 3D refracted chord and the printed path; the exact caustic
//! against a 3D ray-traced TRT histogram (and the h-map density away from it), the worked
//! caustic values (η = 1.55: exact φ_c = 18.62°, cubic 20.49° at θ_d = 0) for both modes; the
//! cubic error table; continuity of the glint fade at η′ = 2; the R lobe's tilt toward the
//! root; albedo for both normalizations; pdf integrates to 1 (adaptively, and for TRT alone
//! on a plain grid blind to the caustic); sample ≡ pdf/eval; no NaN/Inf
//! (proptest, including θ = ±90°, θ_d → ±90°, a < 1, σ_a = 0). The χ² test of `sample`
//! against `pdf` (the variants, and each lobe alone) is in
//! `crates/scatter/tests/marschner_2003.rs`, through fiberlab-check's χ². `cargo run -p
//! fiberlab-scatter --release --example marschner_report` prints the caustic, error and albedo
//! tables.
//!
//! # Example: a value pinned by the closed form
//! R alone at θ_i = θ_r = 0 (θ_h = θ_d = 0, η′ = η) and relative azimuth φ: the single root of
//! `Φ(0, γ) = −2γ = φ` is γ = −φ/2, `|dΦ/dγ| = 2`, so `N_R = F(cos(φ/2))·cos(φ/2)/4` and
//! `S = k_M·g(β_R; −α_R)·N_R` with k_M = ½ (`normalization = energy`). The doctest writes
//! the Gaussian and Fresnel's equations out itself and compares with `eval`.
//! ```
//! use fiberlab_math::frame::direction;
//! use fiberlab_scatter::ScatteringFunction;
//! use fiberlab_scatter::marschner_2003::{Marschner, MarschnerParams};
//! use std::f64::consts::PI;
//!
//! let params = MarschnerParams { lobes: [true, false, false], ..MarschnerParams::default() };
//! let (eta, alpha_r, beta_r) = (params.eta, params.alpha_r, params.beta_r);
//! let fiber = Marschner::new(params)?;
//! let fresnel = |cos_i: f64| {
//!     let cos_t = (1.0 - (1.0 - cos_i * cos_i) / (eta * eta)).sqrt();
//!     let rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
//!     let rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
//!     0.5 * (rs * rs + rp * rp)
//! };
//! let gauss = (-0.5 * (alpha_r / beta_r).powi(2)).exp() / (beta_r * (2.0 * PI).sqrt());
//! for phi in [0.0, 0.8, 2.5] {
//!     let got = fiber.eval(direction(0.0, 0.0), direction(0.0, phi), 0.0)[0];
//!     let c = (0.5 * phi).cos();
//!     let want = 0.5 * gauss * fresnel(c) * c / 4.0;
//!     assert!((got - want).abs() < 1e-12 * want, "φ {phi}: {got} vs {want}");
//! }
//! # Ok::<(), fiberlab_scatter::marschner_2003::MarschnerError>(())
//! ```

mod sampling;
mod tables;
#[cfg(test)]
mod tests;

use sampling::LOBE_TABLE_INTERVALS;
pub use tables::*;

use crate::hair::attenuation::{PathLength, plane_attenuation};
use crate::hair::longitudinal::GaussianLobes;
use crate::hair::normal_plane::{Caustic, NormalPlane, RootMode, representative};
use crate::hair::parameters::ETA_RANGE;
use crate::params::{ParamKind, ParamSet, ParamSpec, ParameterError, Range};
use crate::{Field, LobeInfo, Lobes, ModelError, ModelInfo, Properties, Registered, Sample, ScatteringFunction};
use fiberlab_math::frame::{cos_theta, phi, sin_theta, wrap_pi};
use fiberlab_math::special::gaussian;
use fiberlab_math::{DVec3, Rgb};
use std::f64::consts::{FRAC_PI_2, PI};
use std::sync::Arc;
use thiserror::Error;

/// Smallest `cosθ_d` used in the `1/cos²θ_d` of S (reached only at θ_r = −θ_i = ±90°).
pub const MIN_COS_THETA_D: f64 = 1e-6;
/// Smallest `|dΦ/dγ|` in `N_p`: the density is infinite exactly on a caustic.
pub const MIN_DPHI: f64 = 1e-12;
/// `eval` skips a lobe whose θ_h lies more than this many β_p from α_p: its Gaussian is
/// below e^{−72} ≈ 5·10⁻³² of its peak (the pdf never skips; it must match `sample`).
pub const LOBE_CUTOFF_SIGMAS: f64 = 12.0;
/// Minimum share of the lobe-selection probability given to each enabled lobe.
pub const LOBE_FLOOR: f64 = 0.02;

const SIGMA_RANGE: Range = Range { min: 0.0, max: f64::INFINITY, min_inclusive: true, max_inclusive: false };
const ALPHA_RANGE: Range = Range::closed(-20.0, 20.0);
const BETA_RANGE: Range = Range::closed(1.0, 20.0);
const K_G_RANGE: Range = Range::closed(0.0, 10.0);
const W_C_RANGE: Range = Range::closed(1.0, 45.0);
const DELTA_ETA_RANGE: Range = Range::closed(0.01, 2.0);
const DELTA_H_RANGE: Range = Range::open_closed(0.0, 2.0);
const ECCENTRICITY_RANGE: Range = Range::closed(0.75, 1.0);
const LOBE_NAMES: [&str; 3] = ["r", "tt", "trt"];

const PARAMS: [ParamSpec; 14] = [
    ParamSpec {
        key: "eta",
        kind: ParamKind::Number(ETA_RANGE),
        unit: "",
        default: "1.55",
        doc: "index of refraction η",
    },
    ParamSpec {
        key: "sigma_a",
        kind: ParamKind::Color(SIGMA_RANGE),
        unit: "1/radius",
        default: "0.2,0.3,0.5",
        doc: "absorption coefficient σ_a per unit fiber radius (r,g,b)",
    },
    ParamSpec {
        key: "alpha_r",
        kind: ParamKind::Number(ALPHA_RANGE),
        unit: "degrees",
        default: "-7.5",
        doc: "longitudinal shift α_R of R (negative: toward the root); α_TT = −α_R/2, α_TRT = −3α_R/2",
    },
    ParamSpec {
        key: "beta_r",
        kind: ParamKind::Number(BETA_RANGE),
        unit: "degrees",
        default: "7.5",
        doc: "longitudinal width β_R of R (std in θ_h); β_TT = β_R/2, β_TRT = 2β_R",
    },
    ParamSpec { key: "k_g", kind: ParamKind::Number(K_G_RANGE), unit: "", default: "2.5", doc: "glint scale k_G" },
    ParamSpec {
        key: "w_c",
        kind: ParamKind::Number(W_C_RANGE),
        unit: "degrees",
        default: "15",
        doc: "azimuthal width w_c of the caustic glints",
    },
    ParamSpec {
        key: "delta_eta",
        kind: ParamKind::Number(DELTA_ETA_RANGE),
        unit: "",
        default: "0.3",
        doc: "fade range Δη′ over which the caustics merge above η′ = 2",
    },
    ParamSpec {
        key: "delta_h_m",
        kind: ParamKind::Number(DELTA_H_RANGE),
        unit: "",
        default: "0.5",
        doc: "caustic intensity limit Δh_M",
    },
    ParamSpec {
        key: "eccentricity",
        kind: ParamKind::Number(ECCENTRICITY_RANGE),
        unit: "",
        default: "1",
        doc: "axis ratio a of the cross-section (1 = circular); first-order correction of TRT",
    },
    ParamSpec {
        key: "roots",
        kind: ParamKind::Choice(&["exact", "cubic"]),
        unit: "",
        default: "exact",
        doc: "solve Φ(p, h) = φ exactly or with the paper's cubic approximation",
    },
    ParamSpec {
        key: "glints",
        kind: ParamKind::Choice(&["on", "off"]),
        unit: "",
        default: "on",
        doc: "TRT caustic treatment (glints)",
    },
    ParamSpec {
        key: "normalization",
        kind: ParamKind::Choice(&["energy", "paper"]),
        unit: "",
        default: "energy",
        doc: "k_M of M_p: energy = ½ (albedo ≤ 1), paper = 1 (as printed)",
    },
    ParamSpec {
        key: "absorption",
        kind: ParamKind::Choice(&["chord", "paper"]),
        unit: "",
        default: "chord",
        doc: "internal path length: chord 2cosγ_t/cosθ_t, or the paper's printed 2(1 + cos2γ_t)/cosθ_t",
    },
    ParamSpec {
        key: "lobes",
        kind: ParamKind::Subset(&LOBE_NAMES),
        unit: "",
        default: "r,tt,trt",
        doc: "which lobes to include",
    },
];

/// Registry entry: `marschner`.
impl Registered for Marschner {
    const INFO: ModelInfo = ModelInfo {
        name: "marschner",
        summary: "Marschner et al. 2003 hair: R, TT, TRT with caustic glints and eccentricity",
        citation: "Marschner et al. 2003",
        params: &PARAMS,
        data: None,
    };

    fn from_param_set(p: &ParamSet) -> Result<Self, ModelError> {
        Ok(Marschner::new(MarschnerParams::from_param_set(p)?)?)
    }
}

/// A scattering path: p = number of internal segments.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Lobe {
    /// Surface reflection, p = 0.
    R = 0,
    /// Transmission–transmission, p = 1.
    TT = 1,
    /// Transmission–reflection–transmission, p = 2.
    TRT = 2,
}

impl Lobe {
    /// The three lobes in order of p.
    pub const ALL: [Lobe; 3] = [Lobe::R, Lobe::TT, Lobe::TRT];

    /// The path index p (0, 1, 2).
    #[must_use]
    pub fn p(self) -> usize {
        self as usize
    }
}

/// The constant k_M of `M_p = k_M·g(β_p; θ_h − α_p)` (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Normalization {
    /// k_M = ½: energy-consistent (albedo ≈ Σ∫N_p dφ for narrow lobes).
    Energy,
    /// k_M = 1: as printed in the paper (albedo ≈ 2Σ∫N_p dφ).
    Paper,
}

impl Normalization {
    /// The constant k_M.
    #[must_use]
    pub fn k_m(self) -> f64 {
        match self {
            Self::Energy => 0.5,
            Self::Paper => 1.0,
        }
    }
}

/// Parameters of [`Marschner`]; angles in **radians** (the registry takes degrees).
#[derive(Clone, Debug, PartialEq)]
pub struct MarschnerParams {
    /// Index of refraction η.
    pub eta: f64,
    /// Absorption coefficient σ_a per unit radius, per channel.
    pub sigma_a: Rgb,
    /// Longitudinal shift α_R of R, radians (negative: toward the root).
    pub alpha_r: f64,
    /// Longitudinal width β_R of R, radians.
    pub beta_r: f64,
    /// Glint scale k_G.
    pub k_g: f64,
    /// Azimuthal glint width w_c, radians.
    pub w_c: f64,
    /// Caustic fade range Δη′.
    pub delta_eta: f64,
    /// Caustic intensity limit Δh_M.
    pub delta_h_m: f64,
    /// Axis ratio a ≤ 1 of the cross-section.
    pub eccentricity: f64,
    /// Root solver.
    pub roots: RootMode,
    /// TRT caustic treatment on/off.
    pub glints: bool,
    /// k_M.
    pub normalization: Normalization,
    /// Internal path length used for absorption (the key `absorption`).
    pub absorption: PathLength,
    /// Enabled lobes, indexed by p.
    pub lobes: [bool; 3],
}

impl Default for MarschnerParams {
    /// Table 1 mid-range values (see the module header).
    fn default() -> Self {
        Self {
            eta: 1.55,
            sigma_a: Rgb::new(0.2, 0.3, 0.5),
            alpha_r: (-7.5f64).to_radians(),
            beta_r: 7.5f64.to_radians(),
            k_g: 2.5,
            w_c: 15f64.to_radians(),
            delta_eta: 0.3,
            delta_h_m: 0.5,
            eccentricity: 1.0,
            roots: RootMode::Exact,
            glints: true,
            normalization: Normalization::Energy,
            absorption: PathLength::Chord,
            lobes: [true; 3],
        }
    }
}

impl MarschnerParams {
    /// A dark, strongly absorbing fiber (σ_a = 2, 2.5, 3 per radius: TT and TRT nearly
    /// vanish, the R highlight dominates); everything else the defaults.
    #[must_use]
    pub fn dark() -> Self {
        Self { sigma_a: Rgb::new(2.0, 2.5, 3.0), ..Self::default() }
    }

    /// The paper as printed: `normalization = paper` (k_M = 1), `absorption = paper` (the
    /// printed path length), the cubic root approximation; everything else the defaults.
    #[must_use]
    pub fn paper_literal() -> Self {
        Self {
            roots: RootMode::Cubic,
            normalization: Normalization::Paper,
            absorption: PathLength::Paper,
            ..Self::default()
        }
    }

    /// Reads the registry parameters (degrees → radians).
    pub fn from_param_set(p: &ParamSet) -> Result<Self, ModelError> {
        let lobes = p.subset("lobes")?;
        Ok(Self {
            eta: p.number("eta")?,
            sigma_a: p.color("sigma_a")?,
            alpha_r: p.degrees("alpha_r")?,
            beta_r: p.degrees("beta_r")?,
            k_g: p.number("k_g")?,
            w_c: p.degrees("w_c")?,
            delta_eta: p.number("delta_eta")?,
            delta_h_m: p.number("delta_h_m")?,
            eccentricity: p.number("eccentricity")?,
            roots: if p.choice("roots")? == "cubic" { RootMode::Cubic } else { RootMode::Exact },
            glints: p.switch("glints")?,
            normalization: if p.choice("normalization")? == "paper" {
                Normalization::Paper
            } else {
                Normalization::Energy
            },
            absorption: if p.choice("absorption")? == "paper" { PathLength::Paper } else { PathLength::Chord },
            lobes: LOBE_NAMES.map(|n| lobes.contains(&n)),
        })
    }
}

/// Why a [`Marschner`] fiber cannot be built.
#[non_exhaustive]
#[derive(Clone, Debug, Error, PartialEq)]
pub enum MarschnerError {
    /// A parameter outside its range (named, with the range; angles in degrees).
    #[error(transparent)]
    Parameter(#[from] ParameterError),
    /// `lobes` enables no lobe.
    #[error("marschner: `lobes` must name at least one of r, tt, trt")]
    NoLobes,
}

impl From<MarschnerError> for ModelError {
    fn from(e: MarschnerError) -> Self {
        match e {
            MarschnerError::Parameter(p) => p.into(),
            MarschnerError::NoLobes => ModelError::Inconsistent(e.to_string()),
        }
    }
}

/// Angles of a direction pair used by S.
#[derive(Clone, Copy, Debug)]
struct PairAngles {
    theta_i: f64,
    theta_r: f64,
    theta_h: f64,
    sin_theta_d: f64,
    cos_theta_d: f64,
    /// φ = φ_r − φ_i wrapped (0 = backscatter).
    phi: f64,
    /// `cos 2φ_h = cos(φ_i + φ_r)`.
    cos_2phi_h: f64,
}

impl PairAngles {
    fn new(wi: DVec3, wr: DVec3) -> Self {
        let theta_i = sin_theta(wi).atan2(cos_theta(wi));
        let theta_r = sin_theta(wr).atan2(cos_theta(wr));
        let (phi_i, phi_r) = (phi(wi), phi(wr));
        let (sin_theta_d, cos_theta_d) = (0.5 * (theta_r - theta_i)).sin_cos();
        Self {
            theta_i,
            theta_r,
            theta_h: 0.5 * (theta_i + theta_r),
            sin_theta_d,
            cos_theta_d,
            phi: wrap_pi(phi_r - phi_i),
            cos_2phi_h: (phi_i + phi_r).cos(),
        }
    }
}

/// The Marschner 2003 hair fiber.
#[derive(Clone, Debug)]
pub struct Marschner {
    params: MarschnerParams,
    /// α_p, β_p (radians) and k_M.
    lobes: GaussianLobes,
    /// η*₁, η*₂ of the eccentricity correction.
    eta_star: (f64, f64),
    /// False only in tests (Fresnel ≡ 1).
    fresnel: bool,
    /// Unnormalized lobe-selection weights at |θ_r| = kπ/(2·LOBE_TABLE_INTERVALS) (shared
    /// between clones; keeps [`Model`] small).
    lobe_table: Arc<[[f64; 3]; LOBE_TABLE_INTERVALS + 1]>,
}

impl Marschner {
    /// Calls `each(p, M_p N_p / cos²θ_d)` for every enabled lobe within its cut-off.
    fn each_lobe(&self, wi: DVec3, wo: DVec3, mut each: impl FnMut(usize, Rgb)) {
        let angles = PairAngles::new(wi, wo);
        let mut circular: Option<NormalPlane> = None;
        let c = angles.cos_theta_d.max(MIN_COS_THETA_D);
        let inv_c2 = 1.0 / (c * c);
        for lobe in Lobe::ALL {
            let p = lobe.p();
            if !self.params.lobes[p]
                || (angles.theta_h - self.lobes.alpha[p]).abs() > LOBE_CUTOFF_SIGMAS * self.lobes.beta[p]
            {
                continue;
            }
            let m = self.longitudinal(lobe, angles.theta_h);
            let n = if lobe == Lobe::TRT && self.params.eccentricity < 1.0 {
                self.azimuthal_at(lobe, angles.sin_theta_d, angles.cos_theta_d, angles.phi, angles.cos_2phi_h)
            } else {
                let plane = *circular
                    .get_or_insert_with(|| self.plane(self.params.eta, angles.sin_theta_d, angles.cos_theta_d));
                self.azimuthal_in(&plane, lobe, angles.phi)
            };
            each(p, n * (m * inv_c2));
        }
    }

    /// Validates the parameters and precomputes the lobe constants and sampling table; the
    /// error names the parameter and its range (angles in degrees).
    pub fn new(params: MarschnerParams) -> Result<Self, MarschnerError> {
        ETA_RANGE.check("eta", params.eta)?;
        SIGMA_RANGE.check_rgb("sigma_a", params.sigma_a)?;
        ALPHA_RANGE.check_degrees("alpha_r", params.alpha_r)?;
        BETA_RANGE.check_degrees("beta_r", params.beta_r)?;
        K_G_RANGE.check("k_g", params.k_g)?;
        W_C_RANGE.check_degrees("w_c", params.w_c)?;
        DELTA_ETA_RANGE.check("delta_eta", params.delta_eta)?;
        DELTA_H_RANGE.check("delta_h_m", params.delta_h_m)?;
        ECCENTRICITY_RANGE.check("eccentricity", params.eccentricity)?;
        if !params.lobes.iter().any(|&l| l) {
            return Err(MarschnerError::NoLobes);
        }
        let (eta, a) = (params.eta, params.eccentricity);
        let eta_star = (2.0 * (eta - 1.0) * a * a - eta + 2.0, 2.0 * (eta - 1.0) / (a * a) - eta + 2.0);
        let mut m = Self {
            lobes: GaussianLobes::new(params.alpha_r, params.beta_r, params.normalization.k_m()),
            eta_star,
            fresnel: true,
            lobe_table: Arc::new([[0.0; 3]; LOBE_TABLE_INTERVALS + 1]),
            params,
        };
        m.lobe_table = Arc::new(m.lobe_table());
        Ok(m)
    }

    /// The parameters (radians).
    #[must_use]
    pub fn params(&self) -> &MarschnerParams {
        &self.params
    }

    /// The longitudinal lobes: α_p, β_p (radians) and k_M.
    #[must_use]
    pub fn gaussian_lobes(&self) -> &GaussianLobes {
        &self.lobes
    }

    /// The eccentricity correction's indices `(η*₁, η*₂)` (both η for a circular fiber).
    #[must_use]
    pub fn eccentric_indices(&self) -> (f64, f64) {
        self.eta_star
    }

    /// The sampler's unnormalized lobe-selection weights `[R, TT, TRT]` at
    /// `|θ_r| = kπ/(2n)`, k = 0..=n (n + 1 rows; linear in between), as `sample` reads them.
    #[must_use]
    pub fn sampling_lobe_table(&self) -> &[[f64; 3]] {
        &self.lobe_table[..]
    }

    fn plane(&self, eta: f64, sin_theta_d: f64, cos_theta_d: f64) -> NormalPlane {
        NormalPlane::new(eta, sin_theta_d, cos_theta_d, self.params.roots)
    }

    /// `½∫A(p, h) dh` by the midpoint rule in γ with `n` nodes (`dh = cosγ dγ`).
    fn half_attenuation_integral(&self, plane: &NormalPlane, lobe: Lobe, n: usize) -> Rgb {
        let dg = PI / n as f64;
        let mut sum = Rgb::ZERO;
        for j in 0..n {
            let g = -FRAC_PI_2 + (j as f64 + 0.5) * dg;
            sum += plane_attenuation(plane, lobe.p(), g, self.params.sigma_a, self.params.absorption, self.fresnel)
                * (g.cos() * dg);
        }
        sum * 0.5
    }

    /// The caustic of `plane` with this fiber's fade and its half-width Δh.
    fn glint(&self, plane: &NormalPlane) -> (Caustic, f64) {
        let c = plane.caustic(self.params.delta_eta);
        let dh_m = self.params.delta_h_m;
        if c.h_c > 0.0 { (c, dh_m.min(2.0 * (2.0 * self.params.w_c / c.d2phi_dh2.abs()).sqrt())) } else { (c, dh_m) }
    }

    /// Index η seen by `lobe` for `cos 2φ_h` (η* for TRT of an eccentric fiber).
    fn lobe_eta(&self, lobe: Lobe, cos_2phi_h: f64) -> f64 {
        if lobe == Lobe::TRT && self.params.eccentricity < 1.0 {
            let (e1, e2) = self.eta_star;
            0.5 * ((e1 + e2) + cos_2phi_h * (e1 - e2))
        } else {
            self.params.eta
        }
    }

    /// Longitudinal term `M_p(θ_h) = k_M·g(β_p; θ_h − α_p)` (sr⁰, per radian of θ_h).
    #[must_use]
    pub fn longitudinal(&self, lobe: Lobe, theta_h: f64) -> f64 {
        self.lobes.eval(lobe.p(), theta_h)
    }

    /// Attenuation `A(p, h)` at inclination θ_d for a circular fiber of index η.
    #[must_use]
    pub fn attenuation(&self, lobe: Lobe, h: f64, theta_d: f64) -> Rgb {
        let (s, c) = theta_d.sin_cos();
        let plane = self.plane(self.params.eta, s, c.abs());
        plane_attenuation(
            &plane,
            lobe.p(),
            h.clamp(-1.0, 1.0).asin(),
            self.params.sigma_a,
            self.params.absorption,
            self.fresnel,
        )
    }

    /// Azimuthal term `N_p(φ)` (rad⁻¹) at inclination θ_d, relative azimuth φ (0 =
    /// backscatter), and `cos 2φ_h` (only TRT of an eccentric fiber depends on it; pass 1
    /// for the major axis). Includes the glints for TRT when they are on.
    #[must_use]
    pub fn azimuthal(&self, lobe: Lobe, theta_d: f64, phi: f64, cos_2phi_h: f64) -> Rgb {
        let (s, c) = theta_d.sin_cos();
        self.azimuthal_at(lobe, s, c.abs(), wrap_pi(phi), cos_2phi_h)
    }

    fn azimuthal_at(&self, lobe: Lobe, sin_theta_d: f64, cos_theta_d: f64, phi: f64, cos_2phi_h: f64) -> Rgb {
        let plane = self.plane(self.lobe_eta(lobe, cos_2phi_h), sin_theta_d, cos_theta_d);
        self.azimuthal_in(&plane, lobe, phi)
    }

    /// `N_p(φ)` in a given normal plane (its η already the lobe's), glints included.
    fn azimuthal_in(&self, plane: &NormalPlane, lobe: Lobe, phi: f64) -> Rgb {
        let plane = *plane;
        let n_p = self.azimuthal_without_glints(&plane, lobe, phi);
        if lobe != Lobe::TRT || !self.params.glints {
            return n_p;
        }
        let (cst, dh) = self.glint(&plane);
        if cst.t <= 0.0 {
            return n_p;
        }
        let w = self.params.w_c;
        let (xm, xp) = (wrap_pi(phi - cst.phi_c), wrap_pi(phi + cst.phi_c));
        let relative = |x: f64| (-0.5 * (x / w) * (x / w)).exp();
        let suppress = (1.0 - cst.t * relative(xm)) * (1.0 - cst.t * relative(xp));
        let a_c =
            plane_attenuation(&plane, 2, cst.h_c.asin(), self.params.sigma_a, self.params.absorption, self.fresnel);
        n_p * suppress + a_c * (cst.t * self.params.k_g * dh * (gaussian(w, xm) + gaussian(w, xp)))
    }

    /// `N_P(p, φ) = Σ_roots A·cosγ/(2|dΦ/dγ|)`, φ ∈ (−π, π].
    fn azimuthal_without_glints(&self, plane: &NormalPlane, lobe: Lobe, phi: f64) -> Rgb {
        let p = lobe.p();
        let mut n = Rgb::ZERO;
        for g in plane.roots(p, representative(p, phi)).iter() {
            let d = plane.phi_and_derivative(p, g).1.abs().max(MIN_DPHI);
            let a = plane_attenuation(plane, p, g, self.params.sigma_a, self.params.absorption, self.fresnel);
            n += a * (g.cos() / (2.0 * d));
        }
        n
    }
}

impl Marschner {
    /// The factor turning this model's σ_a into the chord convention's with the same
    /// attenuation at normal incidence: its path length there over the chord's (2 radii).
    fn chord_equivalent(&self) -> f64 {
        use crate::hair::attenuation::PathLength;
        self.params.absorption.length(1.0, 1.0) / PathLength::Chord.length(1.0, 1.0)
    }
}

impl ScatteringFunction for Marschner {
    /// σ_a in the chord convention: the printed path (`absorption=paper`, 4 radii at normal
    /// incidence) makes the same attenuation with twice the chord's σ_a.
    fn chord_absorption(&self) -> Option<Rgb> {
        Some(self.params.sigma_a * self.chord_equivalent())
    }

    fn sigma_a_for_chord(&self, chord: Rgb) -> Rgb {
        chord / self.chord_equivalent()
    }

    fn properties(&self) -> Properties {
        Properties {
            reciprocal: true,
            // Not claimed even for k_M = ½: shifted or wide lobes leave the cone θ_r = −θ_i,
            // where cos²θ_r/cos²θ_d ≠ 1 (ρ ≈ 1.05 at θ_i ≈ 1 rad for Table 1 values; ≈ 1.85 at
            // θ_i = 90° for narrow lobes), and glints add energy (module header).
            energy_conserving: false,
            field: Field::Far,
            lobes: Lobes::Smooth,
        }
    }

    /// `S = Σ_p M_p(θ_h)·N_p(η′(θ_d), φ)/cos²θ_d` (sr⁻¹); `h` is ignored (far field).
    fn eval(&self, wi: DVec3, wo: DVec3, _h: f64) -> Rgb {
        let mut s = Rgb::ZERO;
        self.each_lobe(wi, wo, |_, v| s += v);
        debug_assert!(s.is_finite(), "marschner eval {s:?} at {wi:?} {wo:?}");
        s
    }

    /// The `R`, `TT`, `TRT` terms of [`ScatteringFunction::eval`] (index p).
    fn eval_lobes(&self, wi: DVec3, wo: DVec3, _h: f64, out: &mut [Rgb]) -> bool {
        out.iter_mut().take(3).for_each(|v| *v = Rgb::ZERO);
        self.each_lobe(wi, wo, |p, v| {
            if let Some(slot) = out.get_mut(p) {
                *slot = v;
            }
        });
        true
    }

    fn pdf(&self, wi: DVec3, wo: DVec3, _h: f64) -> f64 {
        self.sampling_pdf(wi, wo)
    }

    /// `R`, `TT`, `TRT` (index p); the glints belong to `TRT`.
    fn lobes(&self) -> Vec<LobeInfo> {
        ["R", "TT", "TRT"].map(LobeInfo::smooth).to_vec()
    }

    fn sample(&self, wo: DVec3, _h: f64, u: [f64; 4]) -> Option<Sample> {
        self.sample_lobe(wo, u)
    }
}
