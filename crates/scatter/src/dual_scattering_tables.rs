//! Precomputed tables of the dual scattering approximation (Zinke, Yuksel, Weber and Keyser
//! 2008, *Dual scattering approximation for fast multiple scattering in hair*, SIGGRAPH):
//! the average forward and backward attenuations ā_f(θ), ā_b(θ) and the backscatter
//! attenuation Ā_b(θ), per colour channel, as functions of the light's inclination θ
//! (Marschner's θ_i: the inclination of the incident light, not a difference angle).
//!
//! Pure math, deterministic midpoint quadrature (no Monte Carlo). Conventions are those of
//! `docs/theory/conventions.md`: θ from the fiber's normal plane, φ about the fiber axis,
//! `ω_i` toward the light, `f_s` in sr⁻¹ with the *outgoing* cosine `cosθ_r` in the albedo.
//!
//! # Definitions (per colour channel)
//! The light comes from azimuths `φ_i ∈ H = [−π/2, π/2]` (one half-circle of the fiber);
//! the backward half of outgoing azimuths is that same half `B = [−π/2, π/2]`, the forward
//! half the opposite one `F = [π/2, 3π/2]`. The paper's eqs. 6 and 12 then read
//!
//! `ā_f(θ) = (1/π) ∫_H dφ_i ∫_F dφ_r ∫_{−π/2}^{π/2} dθ_r f_s(θ, φ_i; θ_r, φ_r) cos²θ_r`
//!
//! and `ā_b` with `B` in place of `F`: the incident azimuth is *averaged* (the `1/π`) over
//! the half-circle the light can arrive from, the outgoing direction is *integrated* over
//! the forward or backward half-sphere (`cos²θ_r dθ_r dφ_r = cosθ_r dω_r`). Hence
//! `ā_f + ā_b = ρ̄(θ) = (1/π) ∫_H ρ(θ, φ_i) dφ_i`, the light-side albedo
//! `ρ = ∫ f_s cosθ_r dω_r` averaged over H — 1 for a lossless model.
//!
//! Near-field models are averaged over the offset `h ∈ [−1, 1]` (their far-field form), by
//! midpoints in `u` with `h = sin u` (smooth at the fiber's edges).
//!
//! The backscatter attenuation (paper eqs. 11, 13, 14) sums the paths with one or three
//! backward events and any even number of forward events:
//! `Ā_b = ā_b ā_f²/(1 − ā_f²) + ā_b³ ā_f²/(1 − ā_f²)³`, with `ā_f` clamped to
//! `≤ 1 −` [`MAX_FORWARD_GAP`] so that it stays finite for white hair (`ā_f → 1`), and `ā_f`,
//! `ā_b` scaled to sum to 1 where they sum to more (see [`backscatter_attenuation`]); the
//! tables keep the unscaled `ā_f`, `ā_b`.
//!
//! # Per-lobe quantities
//! The same quadrature, lobe by lobe ([`ScatteringFunction::eval_lobes`]; a model that does not
//! separate its lobes is one lobe), gives each lobe's part `a_{f,p}`, `a_{b,p}` of ā_f, ā_b, and
//! its longitudinal shift and width as the mean α_p and variance β_p² of the half angle
//! `θ_h = (θ + θ_r)/2` over the energy it scatters (weights `f_p cos²θ_r`): for a Gaussian
//! lobe in θ_h of shift α and width β (Marschner 2003) these are α and β², for Chiang 2016 and
//! d'Eon 2011 lobes they define the shift and width the far-field lobe actually has, with no
//! per-model conversion. Then (Zinke et al. 2008, §4)
//! * `ᾱ_f = Σ_p α_p a_{f,p}/Σ_p a_{f,p}`, `β̄_f² = Σ_p β_p² a_{f,p}/Σ_p a_{f,p}` (variance
//!   weighting: the mixture's second moment when the shifts coincide), same for ᾱ_b, β̄_b²;
//! * the backscatter shift Δ̄_b (eq. 16) and spread σ̄_b (eq. 17), see [`backscatter_shift`] and
//!   [`backscatter_spread`] (σ̄_b is tabulated without its density factor `1 + d_b ā_f²`, which
//!   the renderer applies);
//! * the azimuthal average for globally scattered light `N^G_p(θ) = a_{f,p}/π` (eq. 25: the mean
//!   over the forward half-circle of the lobe's azimuthal energy density).
//!
//! # Which albedo `ā_f + ā_b` is
//! The light-side albedo averaged over H. For energy-conserving models it is ≤ 1 (= 1 without
//! absorption); Chiang 2016 conserves energy on the camera side only, and its lossless
//! light-side albedo grows to ≈ 1.76 at θ = 82.5°: the tables keep that value (it is what the
//! model scatters), and the backscatter series scale the pair to sum to 1 where it exceeds 1.

use crate::{Field, Lobes, ScatteringFunction};
use fiberlab_math::frame::direction_from_sin_cos;
use fiberlab_math::{DVec3, Rgb};
use rayon::prelude::*;
use std::f64::consts::{FRAC_PI_2, PI};
use thiserror::Error;

/// `ā_f` is clamped to at most `1 − MAX_FORWARD_GAP` in the backscatter sums.
pub const MAX_FORWARD_GAP: f64 = 1e-9;

/// Why tables cannot be built.
#[non_exhaustive]
#[derive(Clone, Debug, Error, PartialEq)]
pub enum DualTablesError {
    /// The model concentrates its light on a cone (a delta in θ): it has no density that the
    /// quadrature could integrate, and no far-field lobes for dual scattering.
    #[error(
        "model has delta lobes (light on a cone, no density): dual-scattering tables need a smooth far-field model"
    )]
    DeltaLobes,
    /// A resolution of zero, or an odd number of outgoing-azimuth cells (the forward and
    /// backward halves must split on a cell boundary).
    #[error("bad resolution: {0}")]
    Resolution(String),
    /// The model returned a value that is not finite.
    #[error("the model's integral is not finite at θ = {theta_deg:.3}°")]
    NotFinite {
        /// The light inclination of the failing node, degrees.
        theta_deg: f64,
    },
}

/// Quadrature resolution of [`DualTables::new`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Resolution {
    /// Table nodes: midpoints of equal cells over the light inclination `(−π/2, π/2)`.
    pub inclinations: usize,
    /// Midpoint cells of the incident azimuth over H (π wide).
    pub incident_azimuths: usize,
    /// Midpoint cells of the outgoing inclination over `(−π/2, π/2)`.
    pub outgoing_inclinations: usize,
    /// Midpoint cells of the outgoing azimuth over the whole circle (even).
    pub outgoing_azimuths: usize,
    /// Midpoint cells of u with h = sin u (near-field models only).
    pub offsets: usize,
}

impl Default for Resolution {
    fn default() -> Self {
        Self { inclinations: 64, incident_azimuths: 16, outgoing_inclinations: 128, outgoing_azimuths: 128, offsets: 8 }
    }
}

/// One lobe's share of a table row (a model that does not separate its lobes, see
/// [`ScatteringFunction::eval_lobes`], is one lobe `all`).
#[derive(Clone, Debug, PartialEq)]
pub struct LobeRow {
    /// Its part of ā_f.
    pub forward: Rgb,
    /// Its part of ā_b.
    pub backward: Rgb,
    /// Its longitudinal shift α_p: the mean of θ_h = (θ + θ_r)/2 over the energy it scatters
    /// (weights `f_p cos²θ_r` of the quadrature), radians.
    pub shift: Rgb,
    /// Its longitudinal width β_p²: the variance of θ_h over the same weights, rad².
    pub variance: Rgb,
    /// Its azimuthal average for globally scattered light, `N^G_p(θ)`: the mean over the
    /// forward half-circle of its azimuthal energy density, `a_{f,p}/π` (rad⁻¹).
    pub global_azimuthal: Rgb,
}

/// One table row: the values at one light inclination.
#[derive(Clone, Debug, PartialEq)]
pub struct DualTableRow {
    /// Light inclination θ (radians).
    pub theta: f64,
    /// Average forward attenuation ā_f.
    pub forward: Rgb,
    /// Average backward attenuation ā_b.
    pub backward: Rgb,
    /// Forward attenuation of a beam, `a_f^beam`: the part of the light from one azimuth that
    /// leaves on the far side of the fiber (outgoing azimuth more than π/2 from the light's),
    /// averaged over the offsets the beam hits. What each fiber on a straight line toward the
    /// light passes on along that line, where ā_f averages the light's azimuth over H.
    pub forward_beam: Rgb,
    /// Backscatter attenuation Ā_b (eqs. 11, 13, 14).
    pub backscatter: Rgb,
    /// Ā_b without the last forward crossing of each path ([`backscatter_attenuation_at_fiber`]):
    /// the light returning from the hair behind a fiber ends at that fiber.
    pub backscatter_at_fiber: Rgb,
    /// Lobe-weighted forward shift ᾱ_f = Σ α_p a_{f,p}/Σ a_{f,p} (radians, θ_h units).
    pub forward_shift: Rgb,
    /// Lobe-weighted forward width β̄_f² = Σ β_p² a_{f,p}/Σ a_{f,p} (variance weighting).
    pub forward_variance: Rgb,
    /// Lobe-weighted backward shift ᾱ_b.
    pub backward_shift: Rgb,
    /// Lobe-weighted backward width β̄_b².
    pub backward_variance: Rgb,
    /// Mean backscatter shift Δ̄_b (eq. 16).
    pub backscatter_shift: Rgb,
    /// Backscatter spread σ̄_b (eq. 17) *without* the density factor `1 + d_b ā_f²`, with the
    /// denominator read as the weights `ā_b + ā_b³` (see [`backscatter_spread`]); radians.
    pub backscatter_spread: Rgb,
    /// The same with the paper's printed denominator `ā_b + ā_b³ (2β̄_f + 3β̄_b)`.
    pub backscatter_spread_literal: Rgb,
    /// Per-lobe parts, in the order of [`DualTables::lobe_names`].
    pub lobes: Vec<LobeRow>,
}

/// The dual-scattering tables of one model, indexed by the light's inclination.
#[derive(Clone, Debug, PartialEq)]
pub struct DualTables {
    rows: Vec<DualTableRow>,
    lobe_names: Vec<&'static str>,
    resolution: Resolution,
}

/// `ā_f`, `ā_b` as the backscatter series use them: negative values raised to 0, a pair
/// summing to more than 1 scaled to sum to 1, `ā_f ≤ 1 − MAX_FORWARD_GAP`.
fn series_attenuations(forward: f64, backward: f64) -> (f64, f64) {
    let (forward, backward) = (forward.max(0.0), backward.max(0.0));
    let total = forward + backward;
    let (forward, backward) = if total > 1.0 { (forward / total, backward / total) } else { (forward, backward) };
    (forward.min(1.0 - MAX_FORWARD_GAP), backward)
}

/// `Ā_b = ā_b ā_f²/(1 − ā_f²) + ā_b³ ā_f²/(1 − ā_f²)³` (one channel). The series it sums
/// assumes each fiber loses energy, so when `ā_f + ā_b > 1` (a model whose light-side albedo
/// exceeds 1, e.g. Chiang 2016 near grazing light) both are first scaled to sum to 1; then
/// `ā_f ≤ 1 − MAX_FORWARD_GAP`. With `ā_b ≤ 1 − ā_f` both terms stay bounded as `ā_f → 1`
/// (their limits are ½ and ⅛).
#[must_use]
pub fn backscatter_attenuation(forward: f64, backward: f64) -> f64 {
    let (af, ab) = series_attenuations(forward, backward);
    let af2 = af * af;
    let gap = 1.0 - af2;
    ab * af2 / gap + ab.powi(3) * af2 / gap.powi(3)
}

/// [`backscatter_attenuation`] with one forward crossing fewer per path:
/// `ā_b ā_f/(1 − ā_f²) + ā_b³ ā_f/(1 − ā_f²)³`. The paper's series lets the light returning
/// from `i` layers deep cross `i` fibers on the way back up; the last of those is the layer of
/// the shading fiber itself, where the light ends (it is scattered by that fiber, which is
/// what `f_back` describes), so the returning light crosses `i − 1`: `ā_f^{2i−1}`, the paper's
/// sum divided by ā_f. Bounded as ā_f → 1 (limits ½ and ⅛ as for the paper's form) and 0 for
/// ā_f = 0 (nothing goes deeper than the first layer).
#[must_use]
pub fn backscatter_attenuation_at_fiber(forward: f64, backward: f64) -> f64 {
    let (af, ab) = series_attenuations(forward, backward);
    let gap = 1.0 - af * af;
    ab * af / gap + ab.powi(3) * af / gap.powi(3)
}

/// Mean backscatter shift (eq. 16, one channel):
/// `Δ̄_b = ᾱ_b (1 − 2ā_b²/(1 − ā_f²)²) + ᾱ_f (2(1 − ā_f²)² + 4ā_f² ā_b²)/(1 − ā_f²)³`, with the
/// attenuations prepared as for [`backscatter_attenuation`].
#[must_use]
pub fn backscatter_shift(forward: f64, backward: f64, forward_shift: f64, backward_shift: f64) -> f64 {
    let (af, ab) = series_attenuations(forward, backward);
    let af2 = af * af;
    let gap = 1.0 - af2;
    backward_shift * (1.0 - 2.0 * ab * ab / (gap * gap))
        + forward_shift * (2.0 * gap * gap + 4.0 * af2 * ab * ab) / gap.powi(3)
}

/// Backscatter spread (eq. 17, one channel) without the density factor `1 + d_b ā_f²`:
/// `(ā_b √(2β̄_f² + β̄_b²) + ā_b³ √(2β̄_f² + 3β̄_b²)) / D`, with `D = ā_b + ā_b³` (`literal`
/// false: a weighted mean of the one- and three-bounce widths) or the printed
/// `D = ā_b + ā_b³ (2β̄_f + 3β̄_b)` (`literal` true). Tends to `√(2β̄_f² + β̄_b²)` as `ā_b → 0`.
#[must_use]
pub fn backscatter_spread(backward: f64, forward_variance: f64, backward_variance: f64, literal: bool) -> f64 {
    let ab = backward.max(0.0);
    let (vf, vb) = (forward_variance.max(0.0), backward_variance.max(0.0));
    let one = (2.0 * vf + vb).sqrt();
    let three = (2.0 * vf + 3.0 * vb).sqrt();
    if ab < 1e-12 {
        return one;
    }
    let ab3 = ab.powi(3);
    let denominator = if literal { ab + ab3 * (2.0 * vf.sqrt() + 3.0 * vb.sqrt()) } else { ab + ab3 };
    (ab * one + ab3 * three) / denominator
}

/// Why tables read from elsewhere (a file) are not usable.
#[non_exhaustive]
#[derive(Clone, Debug, Error, PartialEq)]
pub enum DualTablesInvalid {
    /// Fewer than two rows, or rows not in increasing θ inside (−π/2, π/2).
    #[error("dual-scattering tables need at least 2 rows in increasing θ inside (−90°, 90°)")]
    Rows,
    /// A value that is not finite, or a negative attenuation or variance.
    #[error("dual-scattering table value `{quantity}` is {value} at θ = {theta_deg:.3}°")]
    Value {
        /// Which quantity.
        quantity: &'static str,
        /// Its value.
        value: f64,
        /// Row inclination, degrees.
        theta_deg: f64,
    },
    /// A row whose lobe count differs from the lobe names.
    #[error("dual-scattering table row at θ = {theta_deg:.3}° has {got} lobes, expected {want}")]
    LobeCount {
        /// Row inclination, degrees.
        theta_deg: f64,
        /// Lobes in the row.
        got: usize,
        /// Lobe names.
        want: usize,
    },
}

impl DualTables {
    /// Tables of `f` by midpoint quadrature at `resolution`; refuses delta models.
    pub fn new(f: &(impl ScatteringFunction + ?Sized), resolution: &Resolution) -> Result<Self, DualTablesError> {
        Self::new_until(f, resolution, &std::sync::atomic::AtomicBool::new(false))
    }

    /// [`DualTables::new`] that starts no row once `stop` is set (a signal handler's flag):
    /// then the tables hold the rows finished, in increasing θ, with gaps where rows were
    /// left out (for writing what was done; [`DualTables::from_rows`] would refuse fewer than
    /// two).
    pub fn new_until(
        f: &(impl ScatteringFunction + ?Sized),
        resolution: &Resolution,
        stop: &std::sync::atomic::AtomicBool,
    ) -> Result<Self, DualTablesError> {
        let props = f.properties();
        if props.lobes == Lobes::Delta {
            return Err(DualTablesError::DeltaLobes);
        }
        let r = *resolution;
        if r.inclinations == 0 || r.incident_azimuths == 0 || r.outgoing_inclinations == 0 || r.offsets == 0 {
            return Err(DualTablesError::Resolution(format!("every cell count must be ≥ 1, got {r:?}")));
        }
        if r.outgoing_azimuths < 2 || !r.outgoing_azimuths.is_multiple_of(2) {
            return Err(DualTablesError::Resolution(format!(
                "outgoing_azimuths must be even and ≥ 2, got {}",
                r.outgoing_azimuths
            )));
        }
        let offsets: Vec<(f64, f64)> = if props.field == Field::Near {
            // The one width-average rule, Gauss–Legendre in γ = asin h (smooth at the edges).
            fiberlab_math::quadrature::width_nodes(r.offsets.div_ceil(4))
        } else {
            vec![(0.0, 1.0)]
        };
        let model_lobes = f.lobes();
        let mut probe = vec![Rgb::ZERO; model_lobes.len().max(1)];
        let separated = f.eval_lobes(DVec3::X, DVec3::Z, 0.0, &mut probe);
        let lobe_names: Vec<&'static str> =
            if separated { model_lobes.iter().map(|l| l.name).collect() } else { vec!["all"] };
        let dt = PI / r.inclinations as f64;
        let rows = (0..r.inclinations)
            .into_par_iter()
            .filter_map(|a| {
                if stop.load(std::sync::atomic::Ordering::Relaxed) {
                    return None;
                }
                let theta = -FRAC_PI_2 + (a as f64 + 0.5) * dt;
                let sums = half_integrals(f, theta, &r, &offsets, lobe_names.len(), separated);
                Some(row_from_sums(theta, &sums).ok_or(DualTablesError::NotFinite { theta_deg: theta.to_degrees() }))
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Self { rows, lobe_names, resolution: r })
    }

    /// Tables from rows computed elsewhere (e.g. read from a file), validated: at least two
    /// rows in increasing θ inside (−π/2, π/2), every value finite, attenuations and
    /// variances ≥ 0, each row with one entry per lobe name.
    pub fn from_rows(
        rows: Vec<DualTableRow>,
        lobe_names: Vec<&'static str>,
        resolution: Resolution,
    ) -> Result<Self, DualTablesInvalid> {
        if rows.len() < 2
            || !rows.windows(2).all(|w| w[0].theta < w[1].theta)
            || !rows.iter().all(|r| r.theta.abs() < FRAC_PI_2)
        {
            return Err(DualTablesInvalid::Rows);
        }
        for row in &rows {
            let theta_deg = row.theta.to_degrees();
            if row.lobes.len() != lobe_names.len() {
                return Err(DualTablesInvalid::LobeCount { theta_deg, got: row.lobes.len(), want: lobe_names.len() });
            }
            let nonnegative: [(&'static str, Rgb); 8] = [
                ("af", row.forward),
                ("ab", row.backward),
                ("af_beam", row.forward_beam),
                ("abar_b_at_fiber", row.backscatter_at_fiber),
                ("abar_b", row.backscatter),
                ("beta2_f", row.forward_variance),
                ("beta2_b", row.backward_variance),
                ("sigma_b", row.backscatter_spread),
            ];
            let signed: [(&'static str, Rgb); 4] = [
                ("alpha_f", row.forward_shift),
                ("alpha_b", row.backward_shift),
                ("delta_b", row.backscatter_shift),
                ("sigma_b_literal", row.backscatter_spread_literal),
            ];
            for (quantity, v) in nonnegative {
                for c in 0..3 {
                    if !(v[c].is_finite() && v[c] >= 0.0) {
                        return Err(DualTablesInvalid::Value { quantity, value: v[c], theta_deg });
                    }
                }
            }
            for (quantity, v) in signed {
                for c in 0..3 {
                    if !v[c].is_finite() {
                        return Err(DualTablesInvalid::Value { quantity, value: v[c], theta_deg });
                    }
                }
            }
        }
        Ok(Self { rows, lobe_names, resolution })
    }

    /// The rows, in increasing θ.
    #[must_use]
    pub fn rows(&self) -> &[DualTableRow] {
        &self.rows
    }

    /// The lobes the rows separate (`all` for a model that does not separate its lobes).
    #[must_use]
    pub fn lobe_names(&self) -> &[&'static str] {
        &self.lobe_names
    }

    /// The resolution the tables were built with.
    #[must_use]
    pub fn resolution(&self) -> &Resolution {
        &self.resolution
    }

    /// The row index below `|θ|`'s position and the interpolation weight toward the next
    /// row (linear in θ; clamped at the ends). Tables are even in θ (a circular fiber), so
    /// `|θ|` is looked up.
    #[must_use]
    pub fn locate(&self, theta: f64) -> (usize, f64) {
        let t = theta.abs().min(FRAC_PI_2);
        let rows = &self.rows;
        let k = rows.partition_point(|r| r.theta <= t);
        if k == 0 {
            return (0, 0.0);
        }
        if k >= rows.len() {
            return (rows.len() - 2, 1.0);
        }
        let (a, b) = (rows[k - 1].theta, rows[k].theta);
        (k - 1, ((t - a) / (b - a)).clamp(0.0, 1.0))
    }

    /// A quantity of the rows, linearly interpolated at light inclination `theta`.
    #[must_use]
    pub fn lookup(&self, theta: f64, quantity: impl Fn(&DualTableRow) -> Rgb) -> Rgb {
        let (k, w) = self.locate(theta);
        quantity(&self.rows[k]) * (1.0 - w) + quantity(&self.rows[k + 1]) * w
    }
}

/// Quadrature sums at one light inclination, per lobe: forward and backward energy, and the
/// first and second moments of θ_h over the lobe's whole energy.
struct LobeSums {
    forward: Rgb,
    /// Energy on the far side of the light's own azimuth (relative halves).
    forward_beam: Rgb,
    backward: Rgb,
    moment1: Rgb,
    moment2: Rgb,
}

/// Per-channel ratio `num/den`, 0 where `den` is 0.
fn ratio(num: Rgb, den: Rgb) -> Rgb {
    Rgb::new(
        if den[0] > 0.0 { num[0] / den[0] } else { 0.0 },
        if den[1] > 0.0 { num[1] / den[1] } else { 0.0 },
        if den[2] > 0.0 { num[2] / den[2] } else { 0.0 },
    )
}

/// The row at `theta` from the quadrature sums; `None` when a value is not finite.
fn row_from_sums(theta: f64, sums: &[LobeSums]) -> Option<DualTableRow> {
    let mut lobes = Vec::with_capacity(sums.len());
    let (mut forward, mut backward) = (Rgb::ZERO, Rgb::ZERO);
    let forward_beam = sums.iter().fold(Rgb::ZERO, |a, s| a + s.forward_beam);
    let (mut fs, mut fv, mut bs, mut bv) = (Rgb::ZERO, Rgb::ZERO, Rgb::ZERO, Rgb::ZERO);
    for s in sums {
        let total = s.forward + s.backward;
        let shift = ratio(s.moment1, total);
        let variance = (ratio(s.moment2, total) - shift * shift).map(|v| v.max(0.0));
        forward += s.forward;
        backward += s.backward;
        fs += shift * s.forward;
        fv += variance * s.forward;
        bs += shift * s.backward;
        bv += variance * s.backward;
        lobes.push(LobeRow {
            forward: s.forward,
            backward: s.backward,
            shift,
            variance,
            global_azimuthal: s.forward / PI,
        });
    }
    let (forward_shift, forward_variance) = (ratio(fs, forward), ratio(fv, forward));
    let (backward_shift, backward_variance) = (ratio(bs, backward), ratio(bv, backward));
    let per = |g: &dyn Fn(usize) -> f64| Rgb::new(g(0), g(1), g(2));
    let row = DualTableRow {
        theta,
        forward,
        backward,
        forward_beam,
        backscatter: per(&|c| backscatter_attenuation(forward[c], backward[c])),
        backscatter_at_fiber: per(&|c| backscatter_attenuation_at_fiber(forward[c], backward[c])),
        forward_shift,
        forward_variance,
        backward_shift,
        backward_variance,
        backscatter_shift: per(&|c| backscatter_shift(forward[c], backward[c], forward_shift[c], backward_shift[c])),
        backscatter_spread: per(&|c| backscatter_spread(backward[c], forward_variance[c], backward_variance[c], false)),
        backscatter_spread_literal: per(&|c| {
            backscatter_spread(backward[c], forward_variance[c], backward_variance[c], true)
        }),
        lobes,
    };
    let finite = [
        row.forward,
        row.backward,
        row.forward_beam,
        row.backscatter,
        row.backscatter_at_fiber,
        row.forward_shift,
        row.forward_variance,
        row.backward_shift,
        row.backward_variance,
        row.backscatter_shift,
        row.backscatter_spread,
        row.backscatter_spread_literal,
    ]
    .iter()
    .all(|v| v.is_finite());
    finite.then_some(row)
}

/// Per-lobe sums at light inclination `theta` (see the module documentation).
fn half_integrals(
    f: &(impl ScatteringFunction + ?Sized),
    theta: f64,
    r: &Resolution,
    offsets: &[(f64, f64)],
    lobe_count: usize,
    separated: bool,
) -> Vec<LobeSums> {
    let (st, ct) = theta.sin_cos();
    let dpi = PI / r.incident_azimuths as f64;
    let dtr = PI / r.outgoing_inclinations as f64;
    let dpr = 2.0 * PI / r.outgoing_azimuths as f64;
    let half = r.outgoing_azimuths / 2;
    let mut sums: Vec<LobeSums> = (0..lobe_count)
        .map(|_| LobeSums {
            forward: Rgb::ZERO,
            forward_beam: Rgb::ZERO,
            backward: Rgb::ZERO,
            moment1: Rgb::ZERO,
            moment2: Rgb::ZERO,
        })
        .collect();
    let mut terms = vec![Rgb::ZERO; f.lobes().len().max(lobe_count)];
    let mut values = vec![Rgb::ZERO; lobe_count];
    for i in 0..r.incident_azimuths {
        let phi_i = -FRAC_PI_2 + (i as f64 + 0.5) * dpi;
        let wi = direction_from_sin_cos(st, ct, phi_i);
        for k in 0..r.outgoing_inclinations {
            let theta_r = -FRAC_PI_2 + (k as f64 + 0.5) * dtr;
            let (sr, cr) = theta_r.sin_cos();
            let theta_h = 0.5 * (theta + theta_r);
            // (1/π)·dφ_i · cos²θ_r dθ_r dφ_r
            let weight = dpi / PI * cr * cr * dtr * dpr;
            for j in 0..r.outgoing_azimuths {
                // j < half: φ_r ∈ B = [−π/2, π/2]; j ≥ half: φ_r ∈ F = [π/2, 3π/2].
                let phi_r = -FRAC_PI_2 + (j as f64 + 0.5) * dpr;
                let wr = direction_from_sin_cos(sr, cr, phi_r);
                values.iter_mut().for_each(|v| *v = Rgb::ZERO);
                for &(h, wh) in offsets {
                    if separated {
                        f.eval_lobes(wi, wr, h, &mut terms);
                        for (v, t) in values.iter_mut().zip(&terms) {
                            *v += *t * wh;
                        }
                    } else {
                        values[0] += f.eval(wi, wr, h) * wh;
                    }
                }
                // The relative halves: φ_r more than π/2 from φ_i is the beam's far side.
                let beam_far = (phi_r - phi_i).cos() < 0.0;
                for (s, v) in sums.iter_mut().zip(&values) {
                    let e = *v * weight;
                    if j < half {
                        s.backward += e;
                    } else {
                        s.forward += e;
                    }
                    if beam_far {
                        s.forward_beam += e;
                    }
                    s.moment1 += e * theta_h;
                    s.moment2 += e * (theta_h * theta_h);
                }
            }
        }
    }
    sums
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::radiometry::{Quadrature, albedo};
    use fiberlab_math::frame::direction;

    fn small() -> Resolution {
        Resolution {
            inclinations: 6,
            incident_azimuths: 2,
            outgoing_inclinations: 160,
            outgoing_azimuths: 160,
            offsets: 24,
        }
    }

    /// Independent: the light-side albedo over the whole sphere by the radiometry module's
    /// quadrature (its own grid, midpoints in h, many of them), at one incident azimuth
    /// inside H (a circular fiber's albedo does not depend on it).
    fn averaged_albedo(f: &impl ScatteringFunction, theta: f64) -> Rgb {
        albedo(f, direction(theta, 0.3), &Quadrature { theta: 200, phi: 200, h: 400 })
    }

    #[test]
    fn lossless_diffuse_splits_in_halves_and_sums_to_one() {
        // A constant f_s scatters half of its light into each half-sphere: ā_f = ā_b = ½.
        let f = crate::build("diffuse", &[("albedo", "1")]).unwrap();
        let t = DualTables::new(&f, &small()).unwrap();
        assert_eq!(t.rows().len(), 6);
        for row in t.rows() {
            for c in 0..3 {
                assert!((row.forward[c] - 0.5).abs() < 1e-3, "θ = {}: ā_f = {}", row.theta, row.forward[c]);
                assert!((row.backward[c] - 0.5).abs() < 1e-3, "θ = {}: ā_b = {}", row.theta, row.backward[c]);
                assert!(row.backscatter[c].is_finite(), "Ā_b not finite at θ = {}", row.theta);
            }
        }
    }

    #[test]
    fn lossless_untilted_chiang_near_one_at_moderate_inclination() {
        // Chiang's light-side albedo is not exactly 1 (the model is not reciprocal; its
        // normalisation is on the camera side): 0.99–1.002 for |θ| ≤ 52.5° without tilt.
        let f = crate::build("chiang", &[("sigma_a", "0"), ("alpha", "0")]).unwrap();
        let t = DualTables::new(&f, &Resolution { inclinations: 12, ..small() }).unwrap();
        for row in t.rows().iter().filter(|r| r.theta.abs() < 1.0) {
            let sum = row.forward + row.backward;
            assert!((sum[0] - 1.0).abs() < 1.5e-2, "θ = {}: ā_f + ā_b = {}", row.theta, sum[0]);
            assert!(row.forward[0] > row.backward[0], "lossless hair scatters mostly forward");
        }
    }

    #[test]
    fn sum_matches_brute_force_albedo() {
        for (name, pairs) in [
            ("marschner", vec![("sigma_a", "0.3,0.6,1.2")]),
            ("deon", vec![("sigma_a", "0.2,0.5,1.0")]),
            ("chiang", vec![("sigma_a", "0.4,0.8,1.6")]),
        ] {
            let f = crate::build(name, &pairs).unwrap();
            let t = DualTables::new(&f, &small()).unwrap();
            // Near grazing light both quadratures are under-resolved: compare |θ| ≤ 45°.
            for row in t.rows().iter().filter(|r| r.theta.abs() < 1.0) {
                let want = averaged_albedo(&f, row.theta);
                let got = row.forward + row.backward;
                for c in 0..3 {
                    assert!((got[c] - want[c]).abs() < 2e-3, "{name} θ = {}: {} vs {}", row.theta, got[c], want[c]);
                    assert!(row.forward[c] > 0.0 && row.backward[c] > 0.0, "{name}: empty half");
                }
            }
        }
    }

    #[test]
    fn backscatter_finite_as_forward_tends_to_one() {
        // Lossless, ā_b = 1 − ā_f: Ā_b → ½ + ⅛ as ā_f → 1.
        for af in [0.999, 0.99999, 0.9999999] {
            let ab = backscatter_attenuation(af, 1.0 - af);
            assert!((ab - 0.625).abs() < 2e-3, "ā_f = {af}: Ā_b = {ab}");
        }
        // ā_f = 1 exactly (the clamp) and just above it stay finite.
        for (af, ab) in [(1.0, 0.0), (1.0 + 1e-9, 0.0), (1.0, 1e-12)] {
            let v = backscatter_attenuation(af, ab);
            assert!(v.is_finite() && (0.0..1.0).contains(&v), "({af}, {ab}): {v}");
        }
        // More than lossless (ā_f + ā_b > 1) is scaled back: (1.2, 0.8) behaves as (0.6, 0.4).
        assert!((backscatter_attenuation(1.2, 0.8) - backscatter_attenuation(0.6, 0.4)).abs() < 1e-15);
        assert!(backscatter_attenuation(2.0, 1.9).is_finite() && backscatter_attenuation(2.0, 1.9) < 1.0);
        // Closed form at a regular point: ā_f = 0.5, ā_b = 0.2.
        let want = 0.2 * 0.25 / 0.75 + 0.008 * 0.25 / 0.75_f64.powi(3);
        assert!((backscatter_attenuation(0.5, 0.2) - want).abs() < 1e-15);
    }

    #[test]
    fn backscatter_at_fiber_drops_one_crossing() {
        // The one-backward-event paths by brute force: Σ_{i≥1} ā_b ā_f^{2i−1}; the three-event
        // term is the paper's divided by ā_f, like the whole.
        for (af, ab) in [(0.5, 0.2), (0.683, 0.19), (0.1, 0.05), (0.9, 0.08)] {
            let one: f64 = (1..2000).map(|i| ab * af_pow(af, 2 * i - 1)).sum();
            let three = ab.powi(3) * af * af / (1.0 - af * af).powi(3) / af;
            let got = backscatter_attenuation_at_fiber(af, ab);
            assert!((got - (one + three)).abs() < 1e-12, "({af}, {ab}): {got} vs {}", one + three);
            assert!((got - backscatter_attenuation(af, ab) / af).abs() < 1e-12);
        }
        // Nothing goes deeper than the first layer when ā_f = 0; finite as ā_f → 1 (½ + ⅛).
        assert_eq!(backscatter_attenuation_at_fiber(0.0, 0.3), 0.0);
        for af in [0.999, 0.99999] {
            let v = backscatter_attenuation_at_fiber(af, 1.0 - af);
            assert!((v - 0.625).abs() < 3e-3, "ā_f = {af}: {v}");
        }
        assert!(backscatter_attenuation_at_fiber(2.0, 1.9).is_finite());
    }

    fn af_pow(a: f64, n: usize) -> f64 {
        a.powi(i32::try_from(n).unwrap())
    }

    #[test]
    fn beam_forward_attenuation_against_an_independent_quadrature() {
        // A constant f_s sends half its light to the far side of any azimuth.
        let f = crate::build("diffuse", &[("albedo", "1")]).unwrap();
        for row in DualTables::new(&f, &small()).unwrap().rows() {
            assert!((row.forward_beam[0] - 0.5).abs() < 2e-3, "θ = {}: {}", row.theta, row.forward_beam[0]);
        }
        // Hair: the far half of the light's own azimuth (φ_i = 0.3 here, another grid), by
        // midpoints in (θ_o, φ_o) and in h.
        let f = crate::build("chiang", &[("sigma_a", "0.4,0.8,1.6")]).unwrap();
        let t = DualTables::new(&f, &small()).unwrap();
        for row in t.rows().iter().filter(|r| r.theta.abs() < 1.0) {
            let (nt, np, nh) = (64, 64, 24);
            let phi_i = 0.3;
            let wi = direction(row.theta, phi_i);
            let mut want = Rgb::ZERO;
            for i in 0..nt {
                let to = -FRAC_PI_2 + (i as f64 + 0.5) * PI / nt as f64;
                for j in 0..np {
                    let po = phi_i + FRAC_PI_2 + (j as f64 + 0.5) * PI / np as f64;
                    let wo = direction(to, po);
                    let mut v = Rgb::ZERO;
                    for k in 0..nh {
                        v += f.eval(wi, wo, -1.0 + (k as f64 + 0.5) * 2.0 / nh as f64);
                    }
                    want += v * (to.cos() * to.cos() * (PI / nt as f64) * (PI / np as f64) / nh as f64);
                }
            }
            let total = row.forward + row.backward;
            for c in 0..3 {
                assert!(
                    (row.forward_beam[c] - want[c]).abs() < 1e-2,
                    "θ = {}: a_f^beam {} vs {}",
                    row.theta,
                    row.forward_beam[c],
                    want[c]
                );
                // Hair's light goes mostly straight on: the beam keeps more than the average.
                assert!(row.forward_beam[c] > row.forward[c] && row.forward_beam[c] < total[c]);
            }
        }
    }

    #[test]
    fn diffuse_moments_match_closed_form() {
        // Constant f_s: θ_r has density cos²θ_r/(π/2), mean 0 and E[θ_r²] = π²/12 − ½, so
        // θ_h = (θ + θ_r)/2 has mean θ/2 and variance (π²/12 − ½)/4 — in both halves.
        let f = crate::build("diffuse", &[("albedo", "1")]).unwrap();
        let t = DualTables::new(&f, &Resolution { outgoing_inclinations: 400, ..small() }).unwrap();
        let want_var = (PI * PI / 12.0 - 0.5) / 4.0;
        assert_eq!(t.lobe_names(), ["all"]);
        for row in t.rows() {
            for c in 0..3 {
                assert!((row.forward_shift[c] - 0.5 * row.theta).abs() < 1e-4, "θ = {}", row.theta);
                assert!((row.backward_shift[c] - 0.5 * row.theta).abs() < 1e-4, "θ = {}", row.theta);
                assert!((row.forward_variance[c] - want_var).abs() < 1e-4, "{} vs {want_var}", row.forward_variance[c]);
                assert!((row.backward_variance[c] - want_var).abs() < 1e-4);
                // N^G = a_f/π = 1/(2π).
                assert!((row.lobes[0].global_azimuthal[c] - 0.5 / PI).abs() < 1e-3);
            }
        }
    }

    #[test]
    fn marschner_lobes_have_their_gaussian_shifts_and_widths() {
        // Narrow Gaussians in θ_h (Marschner 2003 eq. 4 form): at light inclination near 0
        // each lobe's quadrature mean and variance of θ_h are its α_p, β_p² (the factor
        // cos²θ_r/cos²θ_d ≈ 1 across a narrow lobe).
        let f = crate::build("marschner", &[("alpha_r", "-5"), ("beta_r", "2"), ("sigma_a", "0.2")]).unwrap();
        let res = Resolution { inclinations: 3, incident_azimuths: 4, outgoing_inclinations: 720, ..small() };
        let t = DualTables::new(&f, &res).unwrap();
        assert_eq!(t.lobe_names(), ["R", "TT", "TRT"]);
        let (alpha, beta) = (-5f64.to_radians(), 2f64.to_radians());
        let want = [(alpha, beta), (-0.5 * alpha, 0.5 * beta), (-1.5 * alpha, 2.0 * beta)];
        // The row at θ = 0 (at ±60° the factor cos²θ_r/cos²θ_d tilts the wide TRT lobe).
        for row in t.rows().iter().filter(|r| r.theta.abs() < 0.1) {
            for (p, (a, b)) in want.iter().enumerate() {
                let lobe = &row.lobes[p];
                assert!((lobe.shift[0] - a).abs() < 0.15 * b, "θ = {}, lobe {p}: {} vs {a}", row.theta, lobe.shift[0]);
                assert!(
                    (lobe.variance[0] / (b * b) - 1.0).abs() < 0.1,
                    "θ = {}, lobe {p}: {} vs {}",
                    row.theta,
                    lobe.variance[0],
                    b * b
                );
            }
            // TT scatters forward, TRT backward (R, broad in azimuth, into both halves).
            assert!(row.lobes[1].forward[0] > 2.0 * row.lobes[1].backward[0], "{:?}", row.lobes[1]);
            assert!(row.lobes[2].backward[0] > 2.0 * row.lobes[2].forward[0], "{:?}", row.lobes);
        }
    }

    /// A model that hides its lobes (the default `eval_lobes`).
    struct Hidden(crate::Model);
    impl ScatteringFunction for Hidden {
        fn properties(&self) -> crate::Properties {
            self.0.properties()
        }
        fn eval(&self, wi: DVec3, wo: DVec3, h: f64) -> Rgb {
            self.0.eval(wi, wo, h)
        }
        fn pdf(&self, wi: DVec3, wo: DVec3, h: f64) -> f64 {
            self.0.pdf(wi, wo, h)
        }
        fn sample(&self, wo: DVec3, h: f64, u: [f64; 4]) -> Option<crate::Sample> {
            self.0.sample(wo, h, u)
        }
    }

    #[test]
    fn lobe_parts_sum_to_the_whole_model() {
        // The per-lobe terms of chiang and marschner add up to their `eval`: tables built from
        // the separated lobes and from the whole model have the same ā_f, ā_b.
        for name in ["chiang", "marschner"] {
            let f = crate::build::<&str, &str>(name, &[]).unwrap();
            let res =
                Resolution { inclinations: 4, outgoing_inclinations: 64, outgoing_azimuths: 64, offsets: 6, ..small() };
            let split = DualTables::new(&f, &res).unwrap();
            let whole = DualTables::new(&Hidden(f.clone()), &res).unwrap();
            assert!(split.lobe_names().len() >= 3 && whole.lobe_names() == ["all"]);
            for (a, b) in split.rows().iter().zip(whole.rows()) {
                let parts = a.lobes.iter().fold(Rgb::ZERO, |s, l| s + l.forward);
                for c in 0..3 {
                    assert!((a.forward[c] - b.forward[c]).abs() < 1e-9 * (1.0 + b.forward[c]), "{name}");
                    assert!((a.backward[c] - b.backward[c]).abs() < 1e-9 * (1.0 + b.backward[c]), "{name}");
                    assert!((parts[c] - a.forward[c]).abs() < 1e-12 + 1e-9 * a.forward[c], "{name}");
                }
            }
        }
    }

    #[test]
    fn backscatter_shift_and_spread_closed_forms_and_limits() {
        // Eq. 16 at ā_f = 0.5, ā_b = 0.2, ᾱ_f = 0.03, ᾱ_b = −0.1, by hand.
        let gap: f64 = 0.75;
        let want = -0.1 * (1.0 - 2.0 * 0.04 / (gap * gap)) + 0.03 * (2.0 * gap * gap + 4.0 * 0.25 * 0.04) / gap.powi(3);
        assert!((backscatter_shift(0.5, 0.2, 0.03, -0.1) - want).abs() < 1e-15);
        // Eq. 17 without density factor: both denominators by hand.
        let (vf, vb): (f64, f64) = (0.01, 0.04);
        let num = 0.2 * (2.0 * vf + vb).sqrt() + 0.008 * (2.0 * vf + 3.0 * vb).sqrt();
        assert!((backscatter_spread(0.2, vf, vb, false) - num / 0.208).abs() < 1e-15);
        let literal = num / (0.2 + 0.008 * (2.0 * vf.sqrt() + 3.0 * vb.sqrt()));
        assert!((backscatter_spread(0.2, vf, vb, true) - literal).abs() < 1e-15);
        // ā_b → 0: the one-backward-bounce width.
        assert!((backscatter_spread(0.0, vf, vb, false) - (2.0 * vf + vb).sqrt()).abs() < 1e-15);
        // Finite as ā_f → 1 (lossless, white hair).
        for af in [0.999, 0.99999, 1.0] {
            let d = backscatter_shift(af, 1.0 - af, 0.02, -0.08);
            assert!(d.is_finite(), "ā_f = {af}: Δ̄_b = {d}");
        }
    }

    #[test]
    fn validation_on_load_refuses_bad_tables() {
        let f = crate::build::<&str, &str>("marschner", &[]).unwrap();
        let t = DualTables::new(&f, &Resolution { inclinations: 4, ..small() }).unwrap();
        let names = t.lobe_names().to_vec();
        let ok = DualTables::from_rows(t.rows().to_vec(), names.clone(), *t.resolution());
        assert_eq!(ok.as_ref(), Ok(&t));
        let mut nan = t.rows().to_vec();
        nan[1].forward_variance = Rgb::new(0.1, f64::NAN, 0.1);
        assert!(matches!(
            DualTables::from_rows(nan, names.clone(), *t.resolution()),
            Err(DualTablesInvalid::Value { quantity: "beta2_f", .. })
        ));
        let mut short = t.rows().to_vec();
        short[2].lobes.pop();
        assert!(matches!(
            DualTables::from_rows(short, names.clone(), *t.resolution()),
            Err(DualTablesInvalid::LobeCount { .. })
        ));
        assert_eq!(DualTables::from_rows(t.rows()[..1].to_vec(), names, *t.resolution()), Err(DualTablesInvalid::Rows));
    }

    #[test]
    fn lookup_interpolates_and_is_even() {
        let f = crate::build("diffuse", &[("albedo", "0.6")]).unwrap();
        let t = DualTables::new(&f, &Resolution { inclinations: 8, ..small() }).unwrap();
        let rows = t.rows();
        let mid = 0.5 * (rows[5].theta + rows[6].theta);
        let got = t.lookup(mid, |r| r.forward_shift)[0];
        assert!((got - 0.5 * (rows[5].forward_shift[0] + rows[6].forward_shift[0])).abs() < 1e-12);
        assert_eq!(t.lookup(-mid, |r| r.forward_shift), t.lookup(mid, |r| r.forward_shift));
    }

    #[test]
    fn refuses_delta_models_and_bad_resolution() {
        let specular = crate::build::<&str, &str>("specular", &[]).unwrap();
        assert_eq!(DualTables::new(&specular, &small()), Err(DualTablesError::DeltaLobes));
        let chiang = crate::build::<&str, &str>("chiang", &[]).unwrap();
        let odd = Resolution { outgoing_azimuths: 7, ..small() };
        assert!(matches!(DualTables::new(&chiang, &odd), Err(DualTablesError::Resolution(_))));
        let zero = Resolution { inclinations: 0, ..small() };
        assert!(matches!(DualTables::new(&chiang, &zero), Err(DualTablesError::Resolution(_))));
    }
}
