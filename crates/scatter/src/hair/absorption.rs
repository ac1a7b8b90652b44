//! Where the absorption coefficient σ_a (per unit radius, RGB) of a hair fiber comes from:
//! given directly, from melanin concentrations (d'Eon et al. 2011's pigment absorption), or
//! inverted from a desired multiple-scattering colour (Chiang et al. 2016's fit, which
//! depends on the azimuthal roughness β_n). See `docs/theory/hair.md`, "Absorption".
//!
//! * Melanin: `σ_a = c_eu·(0.419, 0.697, 1.37) + c_pheo·(0.187, 0.4, 1.05)` (d'Eon 2011's
//!   eumelanin and pheomelanin tables, as pbrt-v4 uses them). Cycles uses a different table
//!   (`docs/theory/peer-discrepancies.md`, "Melanin table of Cycles").
//! * Colour: `σ_a = (ln C / (5.969 − 0.215β_n + 2.532β_n² − 10.73β_n³ + 5.574β_n⁴ +
//!   0.245β_n⁵))²` per channel (Chiang 2016's polynomial), C clamped to [10⁻⁴, 1] (ln 0 = −∞;
//!   C > 1 would square back to a positive σ_a, see "Colour outside (0, 1]" in
//!   `docs/theory/peer-discrepancies.md`).

use super::parameters::{COLOR_RANGE, MELANIN_RANGE, SIGMA_A_RANGE};
use crate::ModelError;
use crate::params::{ParamSet, ParameterError};
use fiberlab_math::Rgb;

/// Eumelanin absorption per unit radius per unit concentration, RGB (d'Eon 2011; pbrt).
pub const EUMELANIN_SIGMA_A: Rgb = Rgb::new(0.419, 0.697, 1.37);
/// Pheomelanin absorption per unit radius per unit concentration, RGB (d'Eon 2011; pbrt).
pub const PHEOMELANIN_SIGMA_A: Rgb = Rgb::new(0.187, 0.4, 1.05);
/// Default eumelanin concentration when no absorption key is given (pbrt-v4's default).
pub const DEFAULT_EUMELANIN: f64 = 1.3;
/// Smallest desired colour channel used by the colour inversion (ln 0 = −∞ otherwise).
const MIN_COLOR: f64 = 1e-4;
/// Chiang 2016's polynomial in β_n of the colour inversion, lowest order first.
const COLOR_POLY: [f64; 6] = [5.969, -0.215, 2.532, -10.73, 5.574, 0.245];

/// Where the absorption coefficient comes from.
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
    /// A desired colour C ∈ (0, 1] per channel, inverted with Chiang 2016's polynomial
    /// (depends on β_n).
    Color(Rgb),
}

impl Default for Absorption {
    /// Eumelanin 1.3 (pbrt-v4's default, a brown): [`Absorption::BROWN`].
    fn default() -> Self {
        Absorption::BROWN
    }
}

impl Absorption {
    /// Blond: eumelanin 0.3.
    pub const BLOND: Absorption = Absorption::Melanin { eumelanin: 0.3, pheomelanin: 0.0 };
    /// Brown: eumelanin 1.3 (pbrt-v4's default concentration).
    pub const BROWN: Absorption = Absorption::Melanin { eumelanin: DEFAULT_EUMELANIN, pheomelanin: 0.0 };
    /// Black: eumelanin 8.
    pub const BLACK: Absorption = Absorption::Melanin { eumelanin: 8.0, pheomelanin: 0.0 };
    /// No absorption (σ_a = 0): a lossless, white fiber.
    pub const NONE: Absorption = Absorption::SigmaA(Rgb::ZERO);

    /// Reads the absorption keys (`sigma_a`, `eumelanin`/`pheomelanin`, `color`); keys from
    /// more than one group are [`ModelError::Inconsistent`]; with none, [`Absorption::default`].
    pub fn from_param_set(p: &ParamSet) -> Result<Self, ModelError> {
        Self::from_param_set_or(p, Absorption::default())
    }

    /// [`Absorption::from_param_set`] with another absorption when no key is given (a model
    /// whose fibers are not hair, e.g. the clear wall of `hollow-fiber`).
    pub fn from_param_set_or(p: &ParamSet, default: Absorption) -> Result<Self, ModelError> {
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
            default
        })
    }

    /// Validates the values; the error names the key (`sigma_a`, `eumelanin`, `pheomelanin`
    /// or `color`) and its range.
    pub fn validate(&self) -> Result<(), ParameterError> {
        match *self {
            Absorption::SigmaA(s) => SIGMA_A_RANGE.check_rgb("sigma_a", s).map(|_| ()),
            Absorption::Melanin { eumelanin, pheomelanin } => {
                MELANIN_RANGE.check("eumelanin", eumelanin)?;
                MELANIN_RANGE.check("pheomelanin", pheomelanin).map(|_| ())
            }
            Absorption::Color(c) => COLOR_RANGE.check_rgb("color", c).map(|_| ()),
        }
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
