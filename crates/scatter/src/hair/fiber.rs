//! The parameters of a hair fiber shared by the Chiang and d'Eon models (index, roughnesses,
//! cuticle tilt, absorption), with presets, the registry reader and the range checks.

use super::absorption::Absorption;
use super::parameters::{ALPHA_RANGE, BETA_RANGE, ETA_RANGE};
use crate::ModelError;
use crate::params::{ParamSet, ParameterError};

/// The parameters of a hair fiber that the Chiang and d'Eon models share: index, the two
/// roughnesses, cuticle tilt (**radians**) and where the absorption comes from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HairFiberParams {
    /// Index of refraction η ∈ (1, 4].
    pub eta: f64,
    /// Longitudinal roughness β_m ∈ (0, 1].
    pub beta_m: f64,
    /// Azimuthal roughness β_n ∈ (0, 1].
    pub beta_n: f64,
    /// Cuticle tilt α, radians, in [−20°, 20°]; > 0 moves the R lobe toward the root.
    pub alpha: f64,
    /// Where σ_a comes from.
    pub absorption: Absorption,
}

impl Default for HairFiberParams {
    /// pbrt-v4's defaults: η = 1.55, β_m = β_n = 0.3, α = 2°, eumelanin 1.3 (a brown).
    fn default() -> Self {
        Self { eta: 1.55, beta_m: 0.3, beta_n: 0.3, alpha: 2f64.to_radians(), absorption: Absorption::default() }
    }
}

impl HairFiberParams {
    /// Blond hair: the defaults with eumelanin 0.3 ([`Absorption::BLOND`]).
    #[must_use]
    pub fn blond() -> Self {
        Self { absorption: Absorption::BLOND, ..Self::default() }
    }
    /// Brown hair: the defaults, eumelanin 1.3 ([`Absorption::BROWN`]).
    #[must_use]
    pub fn brown() -> Self {
        Self { absorption: Absorption::BROWN, ..Self::default() }
    }
    /// Black hair: the defaults with eumelanin 8 ([`Absorption::BLACK`]).
    #[must_use]
    pub fn black() -> Self {
        Self { absorption: Absorption::BLACK, ..Self::default() }
    }

    /// Reads the shared registry parameters (`alpha` degrees → radians).
    pub fn from_param_set(p: &ParamSet) -> Result<Self, ModelError> {
        Ok(Self {
            eta: p.number("eta")?,
            beta_m: p.number("beta_m")?,
            beta_n: p.number("beta_n")?,
            alpha: p.degrees("alpha")?,
            absorption: Absorption::from_param_set(p)?,
        })
    }

    /// Checks every value against its range (the error names the parameter; α in degrees).
    pub fn validate(&self) -> Result<(), ParameterError> {
        ETA_RANGE.check("eta", self.eta)?;
        BETA_RANGE.check("beta_m", self.beta_m)?;
        BETA_RANGE.check("beta_n", self.beta_n)?;
        ALPHA_RANGE.check_degrees("alpha", self.alpha)?;
        self.absorption.validate()
    }
}
