//! Tables of Marschner's caustic, cubic-root error and albedo, printed by `fiberlab check`
//! (`crates/check/src/reports.rs`) and `examples/marschner_report.rs`.

use super::{Marschner, MarschnerParams, Normalization};
use crate::ModelError;
use crate::hair::normal_plane::{Caustic, NormalPlane, RootMode};
use crate::radiometry::{Quadrature, albedo};
use fiberlab_math::Rgb;
use fiberlab_math::frame::wrap_pi;

// ---------------------------------------------------------------------------------------
// Tables for `fiberlab check` and the report.

/// One entry of [`cubic_azimuth_error_table`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AzimuthErrorRow {
    /// Path index p (1 = TT, 2 = TRT; R is exact in both modes).
    pub p: usize,
    /// Bravais index η′.
    pub eta_prime: f64,
    /// Offset h.
    pub h: f64,
    /// Exact exit azimuth Φ(p, h), reduced to (−π, π], radians.
    pub phi_exact: f64,
    /// Cubic approximation Φ̂(p, h), reduced to (−π, π], radians.
    pub phi_cubic: f64,
    /// `wrap(Φ̂ − Φ)`, radians.
    pub error: f64,
}

/// Exit azimuths of the exact and the cubic Φ over (η′, h), for TT and TRT.
#[must_use]
pub fn cubic_azimuth_error_table(eta_primes: &[f64], hs: &[f64]) -> Vec<AzimuthErrorRow> {
    let mut rows = Vec::with_capacity(2 * eta_primes.len() * hs.len());
    for &ep in eta_primes {
        // A plane with 1/η′ given directly: θ_d = 0 and η = η′.
        let exact = NormalPlane::new(ep, 0.0, 1.0, RootMode::Exact);
        let cubic = NormalPlane::new(ep, 0.0, 1.0, RootMode::Cubic);
        for p in 1..=2 {
            for &h in hs {
                let g = h.clamp(-1.0, 1.0).asin();
                let phi_exact = wrap_pi(exact.phi_and_derivative(p, g).0);
                let phi_cubic = wrap_pi(cubic.phi_and_derivative(p, g).0);
                rows.push(AzimuthErrorRow {
                    p,
                    eta_prime: ep,
                    h,
                    phi_exact,
                    phi_cubic,
                    error: wrap_pi(phi_cubic - phi_exact),
                });
            }
        }
    }
    rows
}

/// One entry of [`caustic_table`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CausticRow {
    /// Inclination θ_d, radians.
    pub theta_d: f64,
    /// Bravais index η′.
    pub eta_prime: f64,
    /// Exact caustic (h_c = 0, φ_c = 0 when η′ ≥ 2).
    pub exact: Caustic,
    /// The paper's cubic caustic.
    pub cubic: Caustic,
}

/// TRT caustic positions, exact and cubic, for index `eta` at the given θ_d (radians), with
/// fade range `delta_eta`.
#[must_use]
pub fn caustic_table(eta: f64, delta_eta: f64, theta_ds: &[f64]) -> Vec<CausticRow> {
    theta_ds
        .iter()
        .map(|&td| {
            let (s, c) = td.sin_cos();
            let exact = NormalPlane::new(eta, s, c.abs(), RootMode::Exact);
            let cubic = NormalPlane::new(eta, s, c.abs(), RootMode::Cubic);
            CausticRow {
                theta_d: td,
                eta_prime: exact.eta_prime(),
                exact: exact.caustic(delta_eta),
                cubic: cubic.caustic(delta_eta),
            }
        })
        .collect()
}

/// One entry of [`albedo_table`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AlbedoRow {
    /// Light inclination θ_i, radians.
    pub theta_i: f64,
    /// `ρ(θ_i) = ∫ S cosθ_r dω_r` with `normalization=energy`.
    pub energy: Rgb,
    /// The same with `normalization=paper`.
    pub paper: Rgb,
}

/// Light-side albedo `ρ(θ_i)` by quadrature ([`crate::radiometry::albedo`]) for both
/// normalizations, other parameters from `base`. Use an even number of φ cells.
pub fn albedo_table(
    base: &MarschnerParams,
    theta_is: &[f64],
    quadrature: &Quadrature,
) -> Result<Vec<AlbedoRow>, ModelError> {
    let energy = Marschner::new(MarschnerParams { normalization: Normalization::Energy, ..base.clone() })?;
    let paper = Marschner::new(MarschnerParams { normalization: Normalization::Paper, ..base.clone() })?;
    Ok(theta_is
        .iter()
        .map(|&t| {
            // φ_i = 0 puts φ = 0, where TRT's merged caustic is singular for η′ ≈ 2, on a cell
            // edge of the quadrature (an even number of φ cells has an edge at 0).
            let wi = fiberlab_math::frame::direction(t, 0.0);
            AlbedoRow { theta_i: t, energy: albedo(&energy, wi, quadrature), paper: albedo(&paper, wi, quadrature) }
        })
        .collect())
}
