//! Goldman 1997, *Fake fur rendering*: Kajiya–Kay with a directional (forward/backward)
//! factor, as a fiber scattering function (`docs/theory/radiometry.md`, "Goldman's directional
//! factor").
//!
//! Parameters: the registry entry (the `params` of `Registered::INFO` below) is the one table of
//! keys, units, defaults and valid ranges; `fiberlab models --model goldman` prints it and the
//! book's page `docs/book/src/models/goldman.md` shows it.
//!
//! # Formula
//! `κ = cos φ` (+1 backscatter, −1 straight through), `f_dir = ρ_reflect·(1 + κ)/2 +
//! ρ_transmit·(1 − κ)/2`, `f_s = f_dir(φ)·f_s^KK`. Since `∫cosφ dφ = 0`,
//! `ρ(θ_i) = ((ρ_reflect + ρ_transmit)/2)·ρ^KK(θ_i)`. Not reciprocal, not energy bounded.
//! Sampling: θ_i as Kajiya–Kay, φ from the density `(a + b·cosφ)/(2πa)` with a, b the
//! luminance of the two halves, by safeguarded Newton inversion of its CDF.

use crate::kajiya_kay_1989::{self, KajiyaKay, KajiyaKayError, KajiyaKayParams, theta_of};
use crate::params::{ParamKind, ParamSet, ParamSpec, ParameterError, Range};
use crate::{Field, LobeInfo, Lobes, ModelError, ModelInfo, Properties, Registered, Sample, ScatteringFunction};
use fiberlab_math::frame::{cos_theta, relative_phi};
use fiberlab_math::{DVec3, Rgb};
use std::f64::consts::{PI, TAU};
use thiserror::Error;

const PARAMS: [ParamSpec; 5] = [
    kajiya_kay_1989::PARAMS[kajiya_kay_1989::K_D],
    kajiya_kay_1989::PARAMS[kajiya_kay_1989::K_S],
    kajiya_kay_1989::PARAMS[kajiya_kay_1989::P],
    ParamSpec {
        key: "rho_reflect",
        kind: ParamKind::Color(Range::UNIT),
        unit: "",
        default: "1",
        doc: "weight of backward (reflected) scattering, κ = +1",
    },
    ParamSpec {
        key: "rho_transmit",
        kind: ParamKind::Color(Range::UNIT),
        unit: "",
        default: "0.5",
        doc: "weight of forward (transmitted) scattering, κ = −1",
    },
];

/// Registry entry: `goldman`.
impl Registered for Goldman {
    const INFO: ModelInfo = ModelInfo {
        name: "goldman",
        summary: "Kajiya–Kay with Goldman's forward/backward directional factor",
        citation: "Goldman 1997; docs/theory/radiometry.md",
        params: &PARAMS,
        data: None,
    };

    fn from_param_set(p: &ParamSet) -> Result<Self, ModelError> {
        Ok(Goldman::new(GoldmanParams::from_param_set(p)?)?)
    }
}

/// Parameters of [`Goldman`]: a Kajiya–Kay fiber and the directional weights.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GoldmanParams {
    /// The underlying Kajiya–Kay terms.
    pub kajiya_kay: KajiyaKayParams,
    /// Weight ρ_reflect ∈ [0, 1] of backward (reflected) scattering, κ = +1.
    pub rho_reflect: Rgb,
    /// Weight ρ_transmit ∈ [0, 1] of forward (transmitted) scattering, κ = −1.
    pub rho_transmit: Rgb,
}

impl Default for GoldmanParams {
    /// Kajiya–Kay's defaults, `ρ_reflect = 1`, `ρ_transmit = 0.5`.
    fn default() -> Self {
        Self { kajiya_kay: KajiyaKayParams::default(), rho_reflect: Rgb::ONE, rho_transmit: Rgb::splat(0.5) }
    }
}

impl GoldmanParams {
    /// Back-lit fur that glows: forward scattering stronger than backward
    /// (`ρ_reflect = 0.4`, `ρ_transmit = 1`).
    #[must_use]
    pub fn backlit() -> Self {
        Self { rho_reflect: Rgb::splat(0.4), rho_transmit: Rgb::ONE, ..Self::default() }
    }

    /// Reads the registry parameters.
    pub fn from_param_set(p: &ParamSet) -> Result<Self, ModelError> {
        Ok(Self {
            kajiya_kay: KajiyaKayParams::from_param_set(p)?,
            rho_reflect: p.color("rho_reflect")?,
            rho_transmit: p.color("rho_transmit")?,
        })
    }
}

/// Why a [`Goldman`] fiber cannot be built.
#[non_exhaustive]
#[derive(Clone, Debug, Error, PartialEq)]
pub enum GoldmanError {
    /// A parameter outside its range.
    #[error(transparent)]
    Parameter(#[from] ParameterError),
    /// The Kajiya–Kay part is invalid.
    #[error(transparent)]
    KajiyaKay(#[from] KajiyaKayError),
}

impl From<GoldmanError> for ModelError {
    fn from(e: GoldmanError) -> Self {
        match e {
            GoldmanError::Parameter(p) | GoldmanError::KajiyaKay(KajiyaKayError::Parameter(p)) => p.into(),
        }
    }
}

/// Goldman's directional Kajiya–Kay fiber.
///
/// At backscatter (κ = cos φ = 1) the directional factor is ρ_reflect and straight through
/// (κ = −1) it is ρ_transmit, multiplying Kajiya–Kay's `k_d + k_s` at θ_i = θ_r = 0:
/// ```
/// use fiberlab_scatter::ScatteringFunction;
/// use fiberlab_scatter::goldman_1997::{Goldman, GoldmanParams};
/// use fiberlab_math::{Rgb, frame::direction};
/// let p = GoldmanParams { rho_reflect: Rgb::splat(0.9), rho_transmit: Rgb::splat(0.3), ..GoldmanParams::default() };
/// let f = Goldman::new(p).unwrap();
/// let back = f.eval(direction(0.0, 0.4), direction(0.0, 0.4), 0.0);
/// let through = f.eval(direction(0.0, 0.4), direction(0.0, 0.4 + std::f64::consts::PI), 0.0);
/// assert!((back[0] - 0.9 * 0.15).abs() < 1e-12 && (through[0] - 0.3 * 0.15).abs() < 1e-12);
/// ```
#[derive(Clone, Debug)]
pub struct Goldman {
    kk: KajiyaKay,
    rho_reflect: Rgb,
    rho_transmit: Rgb,
    /// Luminance mean `a` and half-difference `b` of the directional factor.
    a: f64,
    b: f64,
}

impl Goldman {
    /// Goldman's model on top of a Kajiya–Kay fiber.
    pub fn new(params: GoldmanParams) -> Result<Self, GoldmanError> {
        let GoldmanParams { kajiya_kay, rho_reflect, rho_transmit } = params;
        let kk = KajiyaKay::new(kajiya_kay)?;
        Range::UNIT.check_rgb("rho_reflect", rho_reflect)?;
        Range::UNIT.check_rgb("rho_transmit", rho_transmit)?;
        let (lr, lt) = (rho_reflect.luminance(), rho_transmit.luminance());
        Ok(Self { kk, rho_reflect, rho_transmit, a: 0.5 * (lr + lt), b: 0.5 * (lr - lt) })
    }

    /// The underlying Kajiya–Kay fiber.
    #[must_use]
    pub fn kajiya_kay(&self) -> &KajiyaKay {
        &self.kk
    }

    /// Weights `(ρ_reflect, ρ_transmit)` of backward and forward scattering.
    #[must_use]
    pub fn directional_weights(&self) -> (Rgb, Rgb) {
        (self.rho_reflect, self.rho_transmit)
    }

    /// Directional factor `f_dir(φ)`, φ = relative azimuth (0 = backscatter).
    #[must_use]
    pub fn directional(&self, phi: f64) -> Rgb {
        let k = phi.cos();
        self.rho_reflect * (0.5 * (1.0 + k)) + self.rho_transmit * (0.5 * (1.0 - k))
    }

    fn phi_pdf(&self, phi: f64) -> f64 {
        (self.a + self.b * phi.cos()) / (TAU * self.a)
    }

    /// Inverts `G(φ) = (a(φ + π) + b·sinφ)/(2πa) = u` on [−π, π] (G is monotone: a ≥ |b|).
    fn sample_phi(&self, u: f64) -> f64 {
        let target = TAU * self.a * u;
        let (mut lo, mut hi) = (-PI, PI);
        let mut x = TAU * u - PI;
        for _ in 0..100 {
            let g = self.a * (x + PI) + self.b * x.sin() - target;
            if g.abs() <= 1e-15 * self.a || hi - lo <= 1e-15 {
                break;
            }
            if g > 0.0 {
                hi = x;
            } else {
                lo = x;
            }
            let next = x - g / (self.a + self.b * x.cos());
            x = if next > lo && next < hi { next } else { 0.5 * (lo + hi) };
        }
        x
    }
}

impl ScatteringFunction for Goldman {
    fn properties(&self) -> Properties {
        Properties { reciprocal: false, energy_conserving: false, field: Field::Far, lobes: Lobes::Smooth }
    }

    fn eval(&self, wi: DVec3, wo: DVec3, h: f64) -> Rgb {
        self.directional(relative_phi(wi, wo)) * self.kk.eval(wi, wo, h)
    }

    fn pdf(&self, wi: DVec3, wo: DVec3, _h: f64) -> f64 {
        if self.a <= 0.0 {
            return 0.0;
        }
        let (ti, _, ci) = theta_of(wi);
        let (to, _, _) = theta_of(wo);
        self.kk.theta_pdf(ti, ci, to) * self.phi_pdf(relative_phi(wi, wo)) / cos_theta(wi).max(1e-8)
    }

    /// Kajiya–Kay's `diffuse` and `specular` (the θ part of the sampler is theirs).
    fn lobes(&self) -> Vec<LobeInfo> {
        crate::kajiya_kay_1989::KAJIYA_KAY_LOBES.to_vec()
    }

    fn sample(&self, wo: DVec3, h: f64, u: [f64; 4]) -> Option<Sample> {
        if self.a <= 0.0 {
            return None;
        }
        self.kk.sample_with(wo, u, self.sample_phi(u[3]), |wi| self.eval(wi, wo, h), |wi| self.pdf(wi, wo, h))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn phi_sampler_inverts_its_cdf() {
        let g = Goldman::new(GoldmanParams { rho_transmit: Rgb::splat(0.2), ..GoldmanParams::default() }).unwrap();
        for i in 0..=100 {
            let u = i as f64 / 100.0;
            let x = g.sample_phi(u);
            let cdf = (g.a * (x + PI) + g.b * x.sin()) / (TAU * g.a);
            assert!((cdf - u).abs() < 1e-9, "u {u} x {x} cdf {cdf}");
        }
    }
}
