//! d'Eon, Francois, Hill, Letteri & Aubry 2011, *An energy-conserving hair reflectance
//! model* (Computer Graphics Forum 30(4), EGSR 2011): a far-field hair fiber with d'Eon's
//! normalized longitudinal function and the exact azimuthal integral over the fiber width,
//! tabulated. Built from the hair core ([`crate::hair`]); the shared mathematics is in
//! `docs/theory/hair.md` ("d'Eon's longitudinal function", "d'Eon's azimuthal integral"), the
//! peers' differences in `docs/theory/peer-discrepancies.md`. Equations are cited by the
//! quantity they define.
//!
//! Parameters: the registry entry (the `params` of `Registered::INFO` below) is the one table of
//! keys, units, defaults and valid ranges; `fiberlab models --model deon` prints it and the book's
//! page `docs/book/src/models/deon.md` shows it. `alpha` is given in degrees and held in radians in
//! [`DeonParams`].
//!
//! # Formula
//! Backward form (as Tungsten's `HairBcsdf`, [`crate::hair::backward_form`]): with
//! φ = φ_i − φ_o and θ_n the inclination chosen by `theta_n` (default the camera side θ_o;
//! d'Eon and Tungsten use `θ_d = (θ_o − θ_i)/2`; both agree on the specular cone),
//! `f_s(ω_i, ω_o) = [Σ_{p<p_max} M_p(θ_i, θ_o^(p))·N_p(φ; θ_n)
//!   + M_res(θ_i, θ_o)·Ā_res(θ_n)/(2π)] / cosθ_i`.
//! * `M_p`: d'Eon's normalized longitudinal function
//!   ([`crate::hair::longitudinal::Longitudinal`]) with `v_0` from β_m by Chiang 2016's map,
//!   `v_1 = v_0/4`, `v_p = 4v_0` for p ≥ 2 and the residual ([`crate::hair::roughness`]);
//!   tilt of the fixed direction `+2α, −α, −4α` for p = 0, 1, 2 and none for p ≥ 3
//!   ([`crate::hair::tilt`], physical sign).
//! * d'Eon's azimuthal term `N_p(φ; θ_n) = ½∫_{−1}^{1} A_p(h)·D(σ_n; φ − Φ(p, h)) dh`, the
//!   exact exit azimuth `Φ(p, h) = 2pγ_t − 2γ_i + pπ`, D the wrapped unit-area Gaussian
//!   ([`fiberlab_math::special::wrapped_gaussian`]), `A_0 = f`, `A_p = (1 − f)² f^{p−1} T^p`,
//!   with η′, f (exact 3D Fresnel at `cosθ_n cosγ_i`) and the chord absorption
//!   `T = exp(−σ_a·2cosγ_t/cosθ_t)` at θ_n ([`crate::hair::attenuation`]). Caustics need no
//!   special treatment. All orders p ≥ p_max are folded into a residual lobe
//!   `Ā_res = ½∫ A_{p_max}/(1 − fT) dh` with uniform azimuth, so with σ_a = 0 the lobe masses
//!   sum to 1 at every θ_n. With the default `theta_n = camera` the masses depend on ω_o
//!   only, so the camera-side furnace is exactly `Σ_p Ā_p(θ_o)` (1 when lossless) and every
//!   sample weight equals it; with `difference` (paper-literal) the masses vary with θ_i
//!   across a lobe and the lossless furnace is not 1: measured 1.000–1.005 at θ_o = 0,
//!   0.94–0.99 at θ_o = −1, 0.78–1.06 at θ_o = 1.45 (β 0.1–0.9).
//!
//! # Table (resolution and error)
//! `N_p` is tabulated at construction on `n_φ × 64` nodes in (φ ∈ [−π, π), cosθ_n ∈ [0, 1]),
//! `n_φ = clamp(⌈12π/σ_n⌉, 64, 2048)` (node spacing ≤ σ_n/6), and interpolated bilinearly.
//! Construction: the width is integrated with midpoint cells in γ_i = asin h (Φ is smooth
//! in γ_i; 1024 to 8192 cells, enough that Φ moves ≤ σ_n/4 per cell), each cell's mass
//! `½A_p cosγ_i dγ_i` deposited at `Φ(p, h)` on the φ grid by linear (cloud-in-cell)
//! weights, then convolved with D truncated at ±5σ_n (using the symmetry
//! `N_p(−φ) = N_p(φ)`) and renormalized (mass-preserving). Measured error of the
//! interpolated table against a direct 10 000-cell evaluation (tests, off-node φ and cosθ):
//! 0.5% of the lobe maximum at β_n = 0.3 and 0.9% at β_n = 0.1; the masses equal `½∫A_p dh`
//! to 2e−5 on the rows and 2e−3 between them. Construction takes 10–40 ms (β_n = 1 to 0.1).
//!
//! # Sampling
//! Lobe p from `u[0]` with weights ∝ the luminance of the lobe masses at `cosθ_n = cosθ_o`
//! (a function of ω_o only), θ_i from `M_p(·, θ_o^(p))` with `u[1], u[2]`, then φ with `u[3]`
//! by exact inversion of the CDF of the bilinearly interpolated (piecewise-linear in φ)
//! table at θ_n; the residual's azimuth is uniform. The pdf is exactly the density of the
//! samples. The weight is exactly `Σ Ā_p(θ_o)` for `theta_n = camera` and close to it for
//! `difference` (the lobe masses at the sampled θ_d differ from those at θ_o).
//!
//! # Conventions and caveats
//! * **Tilt sign** as `chiang`: `alpha > 0` puts R toward the root; pbrt-v4, Mitsuba 3 and
//!   Tungsten use the opposite sign (`docs/theory/peer-discrepancies.md`, "Tilt sign"); the
//!   orders p ≥ 3 are not tilted ("Tilt of orders beyond TRT").
//! * **Absorption path**: the chord `2cosγ_t/cosθ_t` (as Tungsten), not the path printed by
//!   Marschner 2003 and repeated by d'Eon 2011 (`docs/theory/peer-discrepancies.md`,
//!   "Printed absorption path").
//! * **Azimuthal width**: d'Eon's Gaussian σ_n is tied to Chiang's β_n at equal variance, so
//!   the two models are comparable; the paper parametrizes σ_n directly.
//! * **Non-reciprocity**: like Chiang's, this backward form conserves energy on the camera
//!   side only and is not reciprocal; `properties()` claims neither
//!   (`docs/theory/radiometry.md`, "Backward-form models").
//!
//! # Example: a lobe mass pinned by quadrature
//! The mass of lobe p at inclination θ_n is `½∫ A_p dh`. For θ_n = 0 (a table row) and
//! σ_a = 0: `A_0 = F(cosγ)` and `A_1 = (1 − F(cosγ))²`, F the unpolarized Fresnel
//! reflectance of η at incidence γ = asin h. The doctest writes Fresnel's equations out
//! and integrates with 20 000 midpoint cells in γ (dh = cosγ dγ).
//! ```
//! use fiberlab_scatter::deon_2011::{Deon, DeonParams};
//! use fiberlab_scatter::hair::absorption::Absorption;
//! use fiberlab_scatter::hair::fiber::HairFiberParams;
//! use std::f64::consts::PI;
//!
//! let eta = 1.55;
//! let lossless = HairFiberParams { absorption: Absorption::NONE, ..HairFiberParams::default() };
//! let fiber = Deon::new(DeonParams { fiber: lossless, ..DeonParams::default() })?;
//! let fresnel = |cos_i: f64| {
//!     let cos_t = (1.0 - (1.0 - cos_i * cos_i) / (eta * eta)).sqrt();
//!     let rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
//!     let rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
//!     0.5 * (rs * rs + rp * rp)
//! };
//! let n = 20_000;
//! let (mut r, mut tt) = (0.0, 0.0);
//! for k in 0..n {
//!     let gamma = -0.5 * PI + (k as f64 + 0.5) * PI / n as f64;
//!     let dh = gamma.cos() * PI / n as f64;
//!     let f = fresnel(gamma.cos());
//!     r += 0.5 * f * dh;
//!     tt += 0.5 * (1.0 - f).powi(2) * dh;
//! }
//! let (got_r, got_tt) = (fiber.lobe_mass(0, 1.0)[0], fiber.lobe_mass(1, 1.0)[0]);
//! assert!((got_r - r).abs() < 1e-4 * r, "R {got_r} vs {r}");
//! assert!((got_tt - tt).abs() < 1e-4 * tt, "TT {got_tt} vs {tt}");
//! # Ok::<(), fiberlab_scatter::deon_2011::DeonError>(())
//! ```

use crate::hair::attenuation::{chord_length, first_transmission, next_order, surface_fresnel, transmittance};
use crate::hair::backward_form::{MIN_COS, max_relative_non_reciprocity};
use crate::hair::fiber::HairFiberParams;
use crate::hair::longitudinal::Longitudinal;
use crate::hair::normal_plane::exit_azimuth;
use crate::hair::parameters;
use crate::hair::roughness::{azimuthal_sigma, lobe_variance, longitudinal_variance};
use crate::hair::tilt::{lobe_tilts, rotate};
use crate::params::{ParamKind, ParamSet, ParamSpec, Range, parameter_error};
use crate::{Field, LobeInfo, Lobes, ModelError, ModelInfo, Properties, Registered, Sample, ScatteringFunction};
use fiberlab_math::frame::{cos_theta, direction_from_sin_cos, phi, sin_theta, wrap_pi};
use fiberlab_math::special::{safe_sqrt, wrapped_gaussian};
use fiberlab_math::{DVec3, Rgb, bravais};
use std::f64::consts::{PI, TAU};
use std::sync::Arc;

/// Rows of the azimuthal table, uniform in cosθ_d ∈ [0, 1] (Tungsten also uses 64).
pub const TABLE_ROWS: usize = 64;
/// Bounds on the midpoint cells in γ_i ∈ [−π/2, π/2] that integrate over the fiber width;
/// the count is chosen so that Φ(p, h) moves by at most σ_n/4 per cell.
const MIN_WIDTH_CELLS: usize = 1024;
const MAX_WIDTH_CELLS: usize = 8192;
/// φ nodes per Gaussian standard deviation σ_n (node spacing ≤ σ_n/6).
const NODES_PER_SIGMA: f64 = 6.0;
/// Bounds on the number of φ nodes.
const MIN_PHI_NODES: usize = 64;
const MAX_PHI_NODES: usize = 2048;
/// Truncation of the Gaussian convolution kernel, in σ_n (relative tail 3.7e−6).
const KERNEL_SIGMAS: f64 = 5.0;
/// Smallest lobe mass (luminance) for which the φ distribution is sampled from the table;
/// below it the lobe carries no energy there and φ is drawn uniformly.
const MIN_MASS: f64 = 1e-300;

const P_MAX_RANGE: Range = Range::closed(1.0, 16.0);
const THETA_N_CHOICES: [&str; 2] = ["camera", "difference"];

const PARAMS: [ParamSpec; 10] = [
    parameters::ETA,
    parameters::BETA_M,
    parameters::BETA_N,
    parameters::ALPHA,
    ParamSpec {
        key: "theta_n",
        kind: ParamKind::Choice(&THETA_N_CHOICES),
        unit: "",
        default: "camera",
        doc: "inclination of N_p's η′, Fresnel, absorption: camera θ_o (exact furnace) or θ_d (d'Eon/Tungsten)",
    },
    ParamSpec {
        key: "p_max",
        kind: ParamKind::Integer(P_MAX_RANGE),
        unit: "",
        default: "3",
        doc: "explicit lobes p < p_max (integer); higher orders form a uniform residual lobe",
    },
    parameters::SIGMA_A,
    parameters::EUMELANIN,
    parameters::PHEOMELANIN,
    parameters::COLOR,
];

/// Registry entry: `deon`.
impl Registered for Deon {
    const INFO: ModelInfo = ModelInfo {
        name: "deon",
        summary: "d'Eon 2011 far-field hair: d'Eon M_p, exact width-integrated N_p (tabulated), exact sampling",
        citation: "d'Eon et al. 2011",
        params: &PARAMS,
        data: None,
    };

    fn from_param_set(p: &ParamSet) -> Result<Self, ModelError> {
        Ok(Deon::new(DeonParams::from_param_set(p)?)?)
    }
}

/// Parameters of [`Deon`]: the shared hair-fiber parameters (tilt in **radians**; the
/// registry takes degrees) and the two choices of this model.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DeonParams {
    /// Index, roughnesses, tilt and absorption (as [`crate::chiang_2016::ChiangParams`]).
    pub fiber: HairFiberParams,
    /// Inclination at which `N_p` (η′, Fresnel, absorption) is evaluated.
    pub theta_n: AzimuthalInclination,
    /// Number of explicit lobes, 1 to 16; the higher orders form the residual.
    pub p_max: usize,
}

impl Default for DeonParams {
    /// The hair-fiber defaults (η = 1.55, β_m = β_n = 0.3, α = 2°, eumelanin 1.3),
    /// `theta_n = camera`, `p_max = 3`.
    fn default() -> Self {
        Self { fiber: HairFiberParams::default(), theta_n: AzimuthalInclination::Camera, p_max: 3 }
    }
}

impl DeonParams {
    /// Blond hair ([`HairFiberParams::blond`]) with the defaults of this model.
    #[must_use]
    pub fn blond() -> Self {
        Self { fiber: HairFiberParams::blond(), ..Self::default() }
    }
    /// Brown hair ([`HairFiberParams::brown`]).
    #[must_use]
    pub fn brown() -> Self {
        Self { fiber: HairFiberParams::brown(), ..Self::default() }
    }
    /// Black hair ([`HairFiberParams::black`]).
    #[must_use]
    pub fn black() -> Self {
        Self { fiber: HairFiberParams::black(), ..Self::default() }
    }

    /// Reads the registry parameters (`alpha` degrees → radians).
    pub fn from_param_set(p: &ParamSet) -> Result<Self, ModelError> {
        let theta_n = match p.choice("theta_n")? {
            "difference" => AzimuthalInclination::Difference,
            _ => AzimuthalInclination::Camera,
        };
        Ok(Self {
            fiber: HairFiberParams::from_param_set(p)?,
            theta_n,
            // An integer in [1, 16]: the parameter's kind has checked it.
            p_max: p.number("p_max")? as usize,
        })
    }
}

parameter_error! {
    /// Why a [`Deon`] fiber cannot be built: a parameter outside its range (named, with
    /// the range; angles in degrees).
    DeonError
}

/// Which inclination the azimuthal term `N_p` (η′, Fresnel, absorption) is evaluated at.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum AzimuthalInclination {
    /// The fixed camera-side θ_o (as Chiang/pbrt/Mitsuba/Cycles). The
    /// lobe masses are then functions of ω_o only: the camera-side furnace is exactly
    /// `Σ_p Ā_p(θ_o)` (1 when lossless) and every sample weight is exactly that sum.
    #[default]
    Camera,
    /// `θ_d = (θ_o − θ_i)/2` (d'Eon 2011, Tungsten). Equal to `Camera` on the specular cone;
    /// off it the lobes' masses vary with θ_i, so the lossless furnace deviates from 1
    /// (up to −22% at θ_o = 1.45 rad for β = 0.5, see the module docs) and sample weights
    /// are not exactly 1.
    Difference,
}

/// Position of `x ∈ [0, 1]` between table rows: `(j0, j1, t)`.
#[inline]
fn row_position(cos_d: f64) -> (usize, usize, f64) {
    let x = cos_d.clamp(0.0, 1.0) * (TABLE_ROWS - 1) as f64;
    let j0 = (x as usize).min(TABLE_ROWS - 2);
    (j0, j0 + 1, x - j0 as f64)
}

/// The tabulated `N_p` of a [`Deon`] fiber, read-only: [`TABLE_ROWS`] rows uniform in
/// `cosθ_n ∈ [0, 1]`, `phi_nodes` nodes per row at `φ = −π + 2πk/phi_nodes` (periodic), both
/// interpolated linearly.
#[derive(Clone, Copy, Debug)]
pub struct AzimuthalTableView<'a> {
    /// Nodes per row.
    pub phi_nodes: usize,
    /// `N_p` at node k of row j of lobe p: index `(p·TABLE_ROWS + j)·phi_nodes + k`.
    pub values: &'a [Rgb],
    /// Luminance of `values`.
    pub lum: &'a [f64],
    /// Trapezoid CDF of `lum` per row: index `(p·TABLE_ROWS + j)·(phi_nodes + 1) + k`; its last
    /// entry is the lobe's luminance mass.
    pub cdf: &'a [f64],
    /// Residual mass `Ā_res` per row.
    pub residual: &'a [Rgb],
}

/// `N_p(φ; cosθ_n)` for the explicit lobes and the residual masses, tabulated.
struct AzimuthalTable {
    n_phi: usize,
    dphi: f64,
    /// `N_p` at node k of row j of lobe p: index `(p·ROWS + j)·n_phi + k`; node k is at
    /// `φ = −π + k·dphi` (periodic).
    values: Vec<Rgb>,
    /// Luminance of `values`.
    lum: Vec<f64>,
    /// Trapezoid CDF of `lum` per row: index `(p·ROWS + j)·(n_phi + 1) + k`.
    cdf: Vec<f64>,
    /// `∫ N_p dφ` per (lobe, row): index `p·ROWS + j`.
    mass: Vec<Rgb>,
    /// Residual mass `Ā_res` per row.
    residual: Vec<Rgb>,
}

impl std::fmt::Debug for AzimuthalTable {
    /// A summary (the tables themselves hold up to 10⁵ values).
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("AzimuthalTable")
            .field("phi_nodes", &self.n_phi)
            .field("rows", &TABLE_ROWS)
            .field("lobes", &self.mass.len().checked_div(TABLE_ROWS).unwrap_or(0))
            .finish()
    }
}

impl AzimuthalTable {
    fn new(eta: f64, sigma_a: Rgb, sigma_n: f64, lobes: usize) -> Self {
        let n_phi = ((NODES_PER_SIGMA * TAU / sigma_n).ceil() as usize).clamp(MIN_PHI_NODES, MAX_PHI_NODES);
        let dphi = TAU / n_phi as f64;
        // Convolution kernel: (offset in nodes, weight), normalized to unit mass.
        let half = (KERNEL_SIGMAS * sigma_n / dphi).ceil() as isize;
        let mut kernel: Vec<(isize, f64)> = if 2 * half + 1 >= n_phi as isize {
            (0..n_phi as isize).map(|j| (j, wrapped_gaussian(sigma_n, j as f64 * dphi))).collect()
        } else {
            (-half..=half).map(|j| (j, wrapped_gaussian(sigma_n, j as f64 * dphi))).collect()
        };
        let total: f64 = kernel.iter().map(|(_, w)| w * dphi).sum();
        kernel.iter_mut().for_each(|(_, w)| *w /= total);

        let mut values = vec![Rgb::ZERO; lobes * TABLE_ROWS * n_phi];
        let mut mass = vec![Rgb::ZERO; lobes * TABLE_ROWS];
        let mut residual = vec![Rgb::ZERO; TABLE_ROWS];
        let mut deposit = vec![Rgb::ZERO; lobes * n_phi];
        // |dΦ/dγ_i| = |2p·dγ_t/dγ_i − 2| ≤ 2 + 2p/η.
        let max_slope = 2.0 + 2.0 * (lobes - 1) as f64 / eta;
        let width_cells = ((4.0 * PI * max_slope / sigma_n).ceil() as usize).clamp(MIN_WIDTH_CELLS, MAX_WIDTH_CELLS);
        let dgamma = PI / width_cells as f64;
        let cells: Vec<(f64, f64, f64)> = (0..width_cells)
            .map(|m| {
                let gamma_i = -0.5 * PI + (m as f64 + 0.5) * dgamma;
                let (h, cos_gamma_i) = gamma_i.sin_cos();
                (gamma_i, h, cos_gamma_i)
            })
            .collect();
        for row in 0..TABLE_ROWS {
            let cos_d = row as f64 / (TABLE_ROWS - 1) as f64;
            let sin_d = safe_sqrt(1.0 - cos_d * cos_d);
            let cos_theta_t = bravais::cos_theta_t(eta, sin_d);
            deposit.iter_mut().for_each(|d| *d = Rgb::ZERO);
            for &(gamma_i, h, cos_gamma_i) in &cells {
                let half_dh = 0.5 * cos_gamma_i * dgamma;
                let f = surface_fresnel(eta, cos_d, cos_gamma_i);
                let sin_gamma_t = bravais::sin_gamma_t(h, eta, sin_d, cos_d);
                let cos_gamma_t = safe_sqrt(1.0 - sin_gamma_t * sin_gamma_t);
                let gamma_t = sin_gamma_t.clamp(-1.0, 1.0).asin();
                let t = transmittance(sigma_a, chord_length(cos_gamma_t, cos_theta_t));
                let mut a = Rgb::splat(f);
                for p in 0..lobes {
                    if p == 1 {
                        a = first_transmission(f, t);
                    } else if p > 1 {
                        a = next_order(a, f, t);
                    }
                    // Cloud-in-cell deposit of the cell's mass at Φ(p, h).
                    let x = (wrap_pi(exit_azimuth(p, gamma_i, gamma_t)) + PI) / dphi;
                    let k = (x.floor() as usize).min(n_phi - 1);
                    let frac = (x - k as f64).clamp(0.0, 1.0);
                    deposit[p * n_phi + k] += a * (half_dh * (1.0 - frac));
                    deposit[p * n_phi + (k + 1) % n_phi] += a * (half_dh * frac);
                }
                // Σ_{p ≥ lobes} A_p = A_lobes/(1 − fT), A_lobes the next order.
                let next = if lobes == 1 { first_transmission(f, t) } else { next_order(a, f, t) };
                let ft = t * f;
                for c in 0..3 {
                    if ft[c] < 1.0 {
                        residual[row].0[c] += next[c] / (1.0 - ft[c]) * half_dh;
                    }
                }
            }
            for p in 0..lobes {
                let src = &deposit[p * n_phi..(p + 1) * n_phi];
                let base = (p * TABLE_ROWS + row) * n_phi;
                // N_p(−φ) = N_p(φ) (Φ(p, −h) ≡ −Φ(p, h), A even in h, symmetric cells):
                // convolve for φ ≤ 0 (nodes k ≤ n/2) and mirror node k to n − k.
                for i in 0..=n_phi / 2 {
                    let mut acc = Rgb::ZERO;
                    for &(j, w) in &kernel {
                        let k = (i as isize - j).rem_euclid(n_phi as isize) as usize;
                        acc += src[k] * w;
                    }
                    values[base + i] = acc;
                }
                for i in n_phi / 2 + 1..n_phi {
                    values[base + i] = values[base + n_phi - i];
                }
                let mut row_mass = Rgb::ZERO;
                for v in &values[base..base + n_phi] {
                    row_mass += *v * dphi;
                }
                mass[p * TABLE_ROWS + row] = row_mass;
            }
        }
        let lum: Vec<f64> = values.iter().map(|v| v.luminance()).collect();
        let mut cdf = Vec::with_capacity(lobes * TABLE_ROWS * (n_phi + 1));
        for r in 0..lobes * TABLE_ROWS {
            let l = &lum[r * n_phi..(r + 1) * n_phi];
            let mut acc = 0.0;
            cdf.push(0.0);
            for k in 0..n_phi {
                acc += 0.5 * (l[k] + l[(k + 1) % n_phi]) * dphi;
                cdf.push(acc);
            }
        }
        Self { n_phi, dphi, values, lum, cdf, mass, residual }
    }

    /// Position of φ (any real) between nodes: `(k0, k1, t)`.
    #[inline]
    fn phi_position(&self, phi: f64) -> (usize, usize, f64) {
        let x = (wrap_pi(phi) + PI) / self.dphi;
        let k = (x as usize).min(self.n_phi - 1);
        (k, (k + 1) % self.n_phi, (x - k as f64).clamp(0.0, 1.0))
    }

    /// Bilinearly interpolated `N_p` (RGB) and its luminance.
    #[inline]
    fn value(&self, p: usize, (j0, j1, t): (usize, usize, f64), (k0, k1, s): (usize, usize, f64)) -> (Rgb, f64) {
        let (a, b) = ((p * TABLE_ROWS + j0) * self.n_phi, (p * TABLE_ROWS + j1) * self.n_phi);
        let va = self.values[a + k0] * (1.0 - s) + self.values[a + k1] * s;
        let vb = self.values[b + k0] * (1.0 - s) + self.values[b + k1] * s;
        let la = self.lum[a + k0] * (1.0 - s) + self.lum[a + k1] * s;
        let lb = self.lum[b + k0] * (1.0 - s) + self.lum[b + k1] * s;
        (va * (1.0 - t) + vb * t, la * (1.0 - t) + lb * t)
    }

    /// Luminance mass `∫ N_p dφ` interpolated between rows (= the CDF totals).
    #[inline]
    fn mass_luminance(&self, p: usize, (j0, j1, t): (usize, usize, f64)) -> f64 {
        let n1 = self.n_phi + 1;
        self.cdf[(p * TABLE_ROWS + j0) * n1 + self.n_phi] * (1.0 - t)
            + self.cdf[(p * TABLE_ROWS + j1) * n1 + self.n_phi] * t
    }

    /// Residual mass interpolated between rows.
    #[inline]
    fn residual(&self, (j0, j1, t): (usize, usize, f64)) -> Rgb {
        self.residual[j0] * (1.0 - t) + self.residual[j1] * t
    }

    /// Draws φ ∈ [−π, π) from the luminance of the row-interpolated, piecewise-linear `N_p`
    /// by exact CDF inversion; uniform when the lobe has no mass there.
    fn sample_phi(&self, p: usize, (j0, j1, t): (usize, usize, f64), u: f64) -> f64 {
        let n = self.n_phi;
        let (ca, cb) = ((p * TABLE_ROWS + j0) * (n + 1), (p * TABLE_ROWS + j1) * (n + 1));
        let cdf = |k: usize| self.cdf[ca + k] * (1.0 - t) + self.cdf[cb + k] * t;
        let total = cdf(n);
        if total <= MIN_MASS {
            return -PI + TAU * u;
        }
        let target = u * total;
        let (mut lo, mut hi) = (0usize, n);
        while hi - lo > 1 {
            let mid = (lo + hi) / 2;
            if cdf(mid) <= target { lo = mid } else { hi = mid }
        }
        let k = lo;
        let (la, lb) = ((p * TABLE_ROWS + j0) * n, (p * TABLE_ROWS + j1) * n);
        let n0 = self.lum[la + k] * (1.0 - t) + self.lum[lb + k] * t;
        let n1 = self.lum[la + (k + 1) % n] * (1.0 - t) + self.lum[lb + (k + 1) % n] * t;
        let r = (target - cdf(k)).max(0.0);
        let slope = (n1 - n0) / self.dphi;
        // ∫_0^x (n0 + slope·y) dy = r, cancellation-free root.
        let x = 2.0 * r / (n0 + safe_sqrt(n0 * n0 + 2.0 * slope * r));
        let x = if x.is_finite() { x.clamp(0.0, self.dphi) } else { 0.5 * self.dphi };
        -PI + k as f64 * self.dphi + x
    }
}

/// d'Eon 2011 far-field hair fiber.
#[derive(Clone, Debug)]
pub struct Deon {
    params: DeonParams,
    /// σ_a per unit radius, resolved from the absorption.
    sigma_a: Rgb,
    p_max: usize,
    theta_n: AzimuthalInclination,
    sigma_n: f64,
    /// `M_p` for p < p_max, then the residual (index p_max).
    longitudinal: Vec<Longitudinal>,
    /// Tilt rotation `(sin τ_p, cos τ_p)` of the fixed direction, same indexing.
    tilt: Vec<(f64, f64)>,
    table: Arc<AzimuthalTable>,
}

impl Deon {
    /// A d'Eon fiber; builds the azimuthal table (a few tens of milliseconds at β_n = 0.1,
    /// less for rougher fibers). The error names the parameter out of range.
    pub fn new(params: DeonParams) -> Result<Self, DeonError> {
        let DeonParams { fiber, theta_n, p_max } = params;
        fiber.validate()?;
        let HairFiberParams { eta, beta_m, beta_n, alpha, absorption } = fiber;
        P_MAX_RANGE.check("p_max", p_max as f64)?;
        let sigma_a = absorption.sigma_a(beta_n);
        let v0 = longitudinal_variance(beta_m);
        let longitudinal = (0..=p_max).map(|p| Longitudinal::new(lobe_variance(v0, p))).collect();
        let tilts = lobe_tilts(alpha);
        let tilt = (0..=p_max).map(|p| if p < 3 && p < p_max { tilts[p] } else { (0.0, 1.0) }).collect();
        let sigma_n = azimuthal_sigma(beta_n);
        let table = Arc::new(AzimuthalTable::new(eta, sigma_a, sigma_n, p_max));
        Ok(Self { params, sigma_a, p_max, theta_n, sigma_n, longitudinal, tilt, table })
    }

    /// The parameters (radians).
    #[must_use]
    pub fn params(&self) -> &DeonParams {
        &self.params
    }
    /// σ_a per unit radius (from the absorption; the colour inversion depends on β_n).
    #[must_use]
    pub fn sigma_a(&self) -> Rgb {
        self.sigma_a
    }
    /// Number of explicit lobes.
    #[must_use]
    pub fn p_max(&self) -> usize {
        self.p_max
    }
    /// Inclination at which `N_p` is evaluated.
    #[must_use]
    pub fn azimuthal_inclination(&self) -> AzimuthalInclination {
        self.theta_n
    }
    /// Cosine of the inclination at which `N_p` is evaluated for this pair.
    #[inline]
    fn cos_theta_n(&self, sin_i: f64, cos_i: f64, sin_o: f64, cos_o: f64) -> f64 {
        match self.theta_n {
            AzimuthalInclination::Camera => cos_o,
            // cos θ_d = cos((θ_o − θ_i)/2) = sqrt((1 + cos(θ_o − θ_i))/2).
            AzimuthalInclination::Difference => safe_sqrt(0.5 * (1.0 + cos_i * cos_o + sin_i * sin_o)),
        }
    }
    /// Gaussian standard deviation σ_n of the azimuthal lobes (radians).
    #[must_use]
    pub fn azimuthal_sigma(&self) -> f64 {
        self.sigma_n
    }
    /// Number of φ nodes of the azimuthal table.
    #[must_use]
    pub fn table_phi_nodes(&self) -> usize {
        self.table.n_phi
    }

    /// Lobe p's longitudinal function and the tilt rotation `(sin τ_p, cos τ_p)` of its fixed
    /// direction, for p ≤ p_max (p = p_max: the residual).
    #[must_use]
    pub fn lobe(&self, p: usize) -> (&Longitudinal, (f64, f64)) {
        (&self.longitudinal[p], self.tilt[p])
    }

    /// The azimuthal table as `eval` and `sample` read it (layouts in [`AzimuthalTableView`]).
    #[must_use]
    pub fn azimuthal_table(&self) -> AzimuthalTableView<'_> {
        let t = &self.table;
        AzimuthalTableView { phi_nodes: t.n_phi, values: &t.values, lum: &t.lum, cdf: &t.cdf, residual: &t.residual }
    }

    /// Tabulated `N_p(φ; cosθ_d)` (sr⁻¹ per radian of φ, RGB) for an explicit lobe `p < p_max`,
    /// φ = φ_i − φ_o.
    #[must_use]
    pub fn azimuthal(&self, p: usize, phi: f64, cos_theta_d: f64) -> Rgb {
        assert!(p < self.p_max, "lobe {p} is not explicit (p_max = {})", self.p_max);
        self.table.value(p, row_position(cos_theta_d), self.table.phi_position(phi)).0
    }

    /// Tabulated mass `∫ N_p dφ = ½∫A_p dh` at `cosθ_d`, for p < p_max, and for p = p_max the
    /// residual `Σ_{q ≥ p_max} ½∫A_q dh`.
    #[must_use]
    pub fn lobe_mass(&self, p: usize, cos_theta_d: f64) -> Rgb {
        assert!(p <= self.p_max, "lobe {p} does not exist (p_max = {})", self.p_max);
        let rows = row_position(cos_theta_d);
        if p < self.p_max {
            let (j0, j1, t) = rows;
            self.table.mass[p * TABLE_ROWS + j0] * (1.0 - t) + self.table.mass[p * TABLE_ROWS + j1] * t
        } else {
            self.table.residual(rows)
        }
    }

    /// Light-side albedo `ρ(ω_i) = ∫ f_s(ω_i, ω_r) cosθ_r dω_r` at light inclination
    /// `theta_i` (see [`crate::hair::backward_form`]). Since `∫ N_p dφ` is the lobe mass,
    /// `ρ = (1/cosθ_i)∫ cos²θ_r Σ_p M_p(θ_i, θ_r^(p)) Ā_p(θ_n) dθ_r`, evaluated with 2048
    /// midpoint cells. Like Chiang's, it exceeds 1 at grazing light.
    #[must_use]
    pub fn light_side_albedo(&self, theta_i: f64) -> Rgb {
        let (sin_i, cos_i) = theta_i.sin_cos();
        let n = 2048;
        let dt = PI / n as f64;
        let mut sum = Rgb::ZERO;
        for k in 0..n {
            let (sin_r, cos_r) = (-0.5 * PI + (k as f64 + 0.5) * dt).sin_cos();
            let cos_n = self.cos_theta_n(sin_i, cos_i, sin_r, cos_r);
            for p in 0..=self.p_max {
                let (so, co) = rotate(sin_r, cos_r, self.tilt[p]);
                let m = self.longitudinal[p].eval(sin_i, cos_i, so, co);
                sum += self.lobe_mass(p, cos_n) * (m * cos_r * cos_r * dt);
            }
        }
        sum / cos_i.max(MIN_COS)
    }

    /// Measured non-reciprocity `max |f(i, r) − f(r, i)| / max(f(i, r), f(r, i))` over
    /// `pairs` random direction pairs (see
    /// [`crate::hair::backward_form::max_relative_non_reciprocity`]). 0 for a reciprocal model.
    #[must_use]
    pub fn non_reciprocity(&self, pairs: usize, seed: u64) -> f64 {
        max_relative_non_reciprocity(self, pairs, seed)
    }

    /// Luminance of the lobe mass of lobe `p` (explicit or residual) at row position `rows`.
    #[inline]
    fn lobe_luminance(&self, p: usize, rows: (usize, usize, f64)) -> f64 {
        if p < self.p_max { self.table.mass_luminance(p, rows) } else { self.table.residual(rows).luminance() }
    }

    /// `(Σ_p M_p N_p, pdf)`: the backward-form integrand (f_s·cosθ_i) and the density.
    fn integrand_and_pdf(&self, wi: DVec3, wo: DVec3) -> (Rgb, f64) {
        let (sin_i, cos_i) = (sin_theta(wi), cos_theta(wi));
        let (sin_o, cos_o) = (sin_theta(wo), cos_theta(wo));
        let rows_o = row_position(cos_o);
        let total: f64 = (0..=self.p_max).map(|p| self.lobe_luminance(p, rows_o)).sum();
        if total <= 0.0 {
            return (Rgb::ZERO, 0.0);
        }
        let rows_d = row_position(self.cos_theta_n(sin_i, cos_i, sin_o, cos_o));
        let phis = self.table.phi_position(phi(wi) - phi(wo));
        let (mut g, mut pdf) = (Rgb::ZERO, 0.0);
        for p in 0..=self.p_max {
            let (so, co) = rotate(sin_o, cos_o, self.tilt[p]);
            let m = self.longitudinal[p].eval(sin_i, cos_i, so, co);
            let w = self.lobe_luminance(p, rows_o) / total;
            if p < self.p_max {
                let (n, n_lum) = self.table.value(p, rows_d, phis);
                let mass = self.table.mass_luminance(p, rows_d);
                g += n * m;
                pdf += w * m * if mass > MIN_MASS { n_lum / mass } else { 1.0 / TAU };
            } else {
                g += self.table.residual(rows_d) * (m / TAU);
                pdf += w * m / TAU;
            }
        }
        debug_assert!(g.is_finite() && pdf.is_finite());
        (g, pdf)
    }
}

impl ScatteringFunction for Deon {
    fn chord_absorption(&self) -> Option<Rgb> {
        Some(self.sigma_a())
    }

    fn properties(&self) -> Properties {
        Properties { reciprocal: false, energy_conserving: false, field: Field::Far, lobes: Lobes::Smooth }
    }

    fn eval(&self, wi: DVec3, wo: DVec3, _h: f64) -> Rgb {
        self.integrand_and_pdf(wi, wo).0 / cos_theta(wi).max(MIN_COS)
    }

    fn pdf(&self, wi: DVec3, wo: DVec3, _h: f64) -> f64 {
        self.integrand_and_pdf(wi, wo).1
    }

    fn eval_and_pdf(&self, wi: DVec3, wo: DVec3, _h: f64) -> (Rgb, f64) {
        let (g, pdf) = self.integrand_and_pdf(wi, wo);
        (g / cos_theta(wi).max(MIN_COS), pdf)
    }

    /// The explicit lobes p < p_max (`R`, `TT`, `TRT`, `TRRT`, then `p4`, `p5`, …) and the
    /// residual of the orders p ≥ p_max (`p≥3` for p_max = 3), index p.
    fn lobes(&self) -> Vec<LobeInfo> {
        const EXPLICIT: [&str; 16] =
            ["R", "TT", "TRT", "TRRT", "p4", "p5", "p6", "p7", "p8", "p9", "p10", "p11", "p12", "p13", "p14", "p15"];
        const RESIDUAL: [&str; 16] = [
            "p≥1", "p≥2", "p≥3", "p≥4", "p≥5", "p≥6", "p≥7", "p≥8", "p≥9", "p≥10", "p≥11", "p≥12", "p≥13", "p≥14",
            "p≥15", "p≥16",
        ];
        let mut lobes: Vec<LobeInfo> = EXPLICIT[..self.p_max].iter().copied().map(LobeInfo::smooth).collect();
        lobes.push(LobeInfo::smooth(RESIDUAL[self.p_max - 1]));
        lobes
    }

    fn sample(&self, wo: DVec3, _h: f64, u: [f64; 4]) -> Option<Sample> {
        let (sin_o, cos_o) = (sin_theta(wo), cos_theta(wo));
        let rows_o = row_position(cos_o);
        let total: f64 = (0..=self.p_max).map(|p| self.lobe_luminance(p, rows_o)).sum();
        if total <= 0.0 {
            return None;
        }
        // Lobe from u[0] (skipping lobes without weight).
        let target = u[0] * total;
        let (mut p, mut acc) = (0, 0.0);
        let mut chosen = None;
        while p <= self.p_max {
            let w = self.lobe_luminance(p, rows_o);
            if w > 0.0 {
                chosen = Some(p);
                acc += w;
                if target < acc {
                    break;
                }
            }
            p += 1;
        }
        let p = chosen?;
        let (so, co) = rotate(sin_o, cos_o, self.tilt[p]);
        let sin_i = self.longitudinal[p].sample_sin_theta(so, co, u[1], u[2]);
        let cos_i = safe_sqrt(1.0 - sin_i * sin_i);
        let dphi = if p < self.p_max {
            let rows_d = row_position(self.cos_theta_n(sin_i, cos_i, sin_o, cos_o));
            self.table.sample_phi(p, rows_d, u[3])
        } else {
            -PI + TAU * u[3]
        };
        let wi = direction_from_sin_cos(sin_i, cos_i, phi(wo) + dphi);
        let (g, pdf) = self.integrand_and_pdf(wi, wo);
        if pdf.is_nan() || pdf <= 0.0 {
            return None;
        }
        Some(Sample { wi, weight: g / pdf, pdf, delta: false, lobe: p as u8 })
    }
}
