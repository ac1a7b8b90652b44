//! The dual-scattering integrator (Zinke, Yuksel, Weber and Keyser 2008, *Dual scattering
//! approximation for fast multiple scattering in hair*): the path tracer
//! ([`crate::integrator::radiance`]) with, at the first fiber a path reaches, one light sample
//! (sun, sky, sphere lights: its next-event estimation) shaded with the multiple-scattering
//! approximation ([`DualScattering::shade_fiber`]) instead of a shadow test and further
//! bounces; the path ends there. Ordinary surfaces (floor, meshes, spheres) are path traced as
//! before.
//!
//! # At a fiber hit, for a light direction ω_d (θ its inclination to the fiber)
//! The shadow ray toward the light is blocked by surfaces as usual; the fibers it crosses are
//! counted ([`crate::fiber_count`]: exactly, or from a density grid), `n` of them, the k-th at
//! its own inclination θ^k. Then (per colour channel; tables of
//! `fiberlab_scatter::dual_scattering_tables`, looked up at |θ|)
//! * forward transmittance `T_f = d_f ∏_k a_f(θ^k)` (d_f counted once) and spread
//!   `σ̄_f² = Σ_k β̄_f²(θ^k)`, with `a_f` the forward attenuation of a beam (the fibers on the
//!   straight line meet the light from its own direction; the paper's ā_f, which averages
//!   the light's azimuth over a half-circle, with [`ForwardAttenuation::Averaged`]);
//! * broadened single scattering `f_s^G = Σ_p c_G · g(θ_h − α_p; β_p² + σ̄_f²) · A^G_p(θ) / cos²θ_d`,
//!   with g a unit-area Gaussian in θ_h and `A^G_p` per [`GlobalAzimuth`];
//! * local backscatter, over the back half-circle (the outgoing direction on the light's side
//!   of the fiber), `f_back(σ²) = k_back · 2Ā_b g(θ_h − Δ̄_b; σ̄_b² + σ²)/(π cos²θ_d)` with
//!   `σ̄_b = (1 + d_b ā_f²)·σ̄_b⁰` (σ̄_b⁰ per [`Spread`]); Ā_b per [`BackSeries`] (default: the
//!   paper's series with one forward crossing fewer, the returning light ends at the fiber),
//!   times `1 − P_b²` for the layer behind the fiber ([`BackscatterDepth`]);
//! * `F = w·(f_s + d_b f_back(0)) + (1 − w)·T_f·(f_s^G + c_π d_b f_back(σ̄_f²))`, with the
//!   direct fraction `w = max(0, 1 − n)` (1 with nothing in front, 0 behind a whole fiber), and
//!   `c_π = π` (the paper's pseudo-code) or 1;
//! * `L += F · cosθ_i · L_d / p_light`.
//!
//! # Light off surfaces (`surface_bounce`)
//! The terms above only carry light that reaches the fiber from a light or the environment,
//! through fibers. On the head scene about half of the hair's brightness arrives off the skin
//! and the floor instead (`bench/dual_scattering/result.md`, "Surface-bounced light"). With
//! [`DualScatteringSettings::surface_bounce`] the path does not end at the fiber: it samples
//! the fiber's scattering function once ([`DualScattering::bounce`]). If that ray escapes, the
//! path ends: sky light is the dual terms' share, so nothing is counted twice. If it meets an
//! ordinary surface, the path goes on from there as a path-traced path (next-event
//! estimation, further bounces, and dual scattering again at the next fiber it meets):
//! * `Unobstructed` (`on`): only when no fiber lies in between, weighted by the sample's
//!   weight `f_s cosθ/p`; light off the skin under a thick layer mostly never arrives;
//! * `Through` (default): the fibers in between are counted as for a light sample, and the
//!   surface is shaded like a light behind them, `F(ω, ω_o; n, ∏ā_f, σ̄_f²)·cosθ/p`, with its
//!   own d_f ([`DualScatteringSettings::bounce_forward_density`], 1: the surface is an extended
//!   source).
//!
//! Emission seen directly along that ray (sphere lights) is skipped.
//!
//! # Cost
//! The counting walks are any-hit walks of the BVH that never sort children; the exact one
//! stops once `∏ ā_f` is below [`DualScatteringSettings::count_cutoff`] in every channel (the
//! light then counts as blocked). The bounce tests the surfaces first and walks the fibers
//! only up to the surface it meets.
//!
//! The constants and the disputed choices are [`DualScatteringSettings`]; their defaults are
//! the ones the slab benchmark of `bench/dual_scattering/` selected (ARCHITECTURE.md, "Dual
//! scattering").

use crate::dual_bounce::{BounceDensity, model_sampler};
use crate::fiber_count::{Crossing, DensityGrid, FiberCount, exact_crossings, exact_crossings_until};
use crate::scene::{FiberMaterialId, Hit, Scene};
use fiberlab_geometry::Ray;
use fiberlab_geometry::curves::CurveHit;
use fiberlab_geometry::shapes::sphere_hit;
use fiberlab_math::frame::cos_theta;
use fiberlab_math::{DVec3, Rgb};
use fiberlab_scatter::dual_scattering_tables::{DualTables, DualTablesError, Resolution};
use fiberlab_scatter::{Lobes, ScatteringFunction};
use std::f64::consts::PI;
use std::sync::Arc;
use thiserror::Error;

/// Which integrator renders the image.
#[derive(Clone, Debug, Default)]
pub enum Integrator {
    /// Unidirectional path tracing ([`crate::integrator::radiance`]).
    #[default]
    Path,
    /// Dual scattering at fiber hits, path tracing elsewhere.
    DualScattering(Arc<DualScattering>),
}

impl PartialEq for Integrator {
    fn eq(&self, other: &Self) -> bool {
        match (self, other) {
            (Self::Path, Self::Path) => true,
            (Self::DualScattering(a), Self::DualScattering(b)) => Arc::ptr_eq(a, b),
            _ => false,
        }
    }
}

/// The azimuthal factor of the broadened single scattering `f_s^G`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GlobalAzimuth {
    /// `A^G_p = N^G_p = a_{f,p}/π`, the mean over the forward half-circle (paper eq. 25, as
    /// Yan 2017 reproduces it), with `c_G = 1`.
    ForwardMean,
    /// `A^G_p = (a_{f,p} + a_{b,p})/(2π)` with `c_G = ½`: the lobe's whole energy spread
    /// uniformly over the circle, the ½ undoing `dθ_r = 2 dθ_h` — `∫ f_s^G cosθ_r dω_r` equals
    /// the lobe's albedo.
    Energy,
}

/// Which forward attenuation each fiber on a counted line passes on (the factors of `∏ ā_f`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ForwardAttenuation {
    /// The paper's ā_f: the light's azimuth averaged over the half-circle H, forward and
    /// backward as the fixed halves of the fiber (`averaged`).
    Averaged,
    /// `a_f^beam`: light from the line's own direction, forward the far side of it (`beam`).
    /// The fibers a straight line crosses all meet the light from that line's direction.
    Beam,
}

/// Which series the backscatter attenuation Ā_b sums (the tables' `backscatter` or
/// `backscatter_at_fiber`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BackSeries {
    /// The paper's eqs. 11–14: the returning light crosses as many fibers as it went down
    /// (`paper`).
    Paper,
    /// One crossing fewer: the last layer on the way back is the shading fiber's own, where the
    /// light ends (`at-fiber`; `fiberlab_scatter::dual_scattering_tables::backscatter_attenuation_at_fiber`).
    AtFiber,
}

/// The denominator of the backscatter spread σ̄_b (eq. 17).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Spread {
    /// The weights `ā_b + ā_b³` (a weighted mean of the two widths).
    Weighted,
    /// The printed `ā_b + ā_b³ (2β̄_f + 3β̄_b)`.
    Literal,
}

/// What becomes of light that reaches a fiber off an ordinary surface (skin, floor)
/// ([`DualScattering::bounce`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SurfaceBounce {
    /// Left out: the path ends at the first fiber.
    Off,
    /// One ray sampled from the fiber's scattering function goes on as a path if it meets a
    /// surface with no fiber in between (`on`).
    Unobstructed,
    /// As `Unobstructed`, but fibers between the fiber and the surface are counted, and the
    /// surface's light is shaded like a light's behind them: `F(ω, ω_o; n)·cosθ/p(ω)`
    /// (`through`).
    Through,
}

impl SurfaceBounce {
    /// `off`, `on` or `through`.
    pub fn parse(name: &str) -> Result<Self, String> {
        match name {
            "off" | "false" => Ok(Self::Off),
            "on" | "true" => Ok(Self::Unobstructed),
            "through" => Ok(Self::Through),
            other => Err(format!("surface_bounce: `{other}` (known: off, on, through)")),
        }
    }
}

/// The constants and disputed choices of dual scattering.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DualScatteringSettings {
    /// How fibers toward the light are counted.
    pub count: FiberCount,
    /// Forward density factor d_f.
    pub forward_density: f64,
    /// d_f of a `Through` bounce's light, from a surface behind the fibers. The paper's d_f < 1
    /// stands for forward-scattered light that leaves the straight line to a small light; from
    /// an extended surface (skin, floor) the light scattered out of one line is made up by that
    /// scattered into it from its neighbours, so the default is 1 (`bounce_d_f`).
    pub bounce_forward_density: f64,
    /// Backward density factor d_b.
    pub backward_density: f64,
    /// `k_back`: 1 is the paper's form, ¼ makes `∫ f_back cosθ_o dω_o ≈ Ā_b`.
    pub back_scale: f64,
    /// `c_π` of the shadowed combination: true for the paper's π, false for 1.
    pub back_pi: bool,
    /// σ̄_b's denominator.
    pub spread: Spread,
    /// The factors of the transmittance product `∏ ā_f` along a counted line: `Beam`
    /// (default; each fiber on the straight line meets the light from that line's direction)
    /// or the paper's `Averaged` ā_f.
    pub forward_attenuation: ForwardAttenuation,
    /// The series of the backscatter attenuation Ā_b: `AtFiber` (default; the returning light
    /// ends at the shading fiber and does not cross its layer) or the paper's.
    pub back_series: BackSeries,
    /// `f_s^G`'s azimuthal factor.
    pub global: GlobalAzimuth,
    /// Density grid cells along the scene's longest side (grid counting).
    pub grid_resolution: usize,
    /// Grid counting: the first this many cell sizes of the ray are walked exactly (through
    /// the BVH), the grid counts only beyond. The cell's average density is wrong right at the
    /// shading point (it holds the fiber itself and, at the edge of a hair layer, fibers on the
    /// far side of it); 0 is the pure grid.
    pub grid_near_cells: f64,
    /// Light that reaches a fiber off an ordinary surface (skin, floor): unless `Off`, the path
    /// samples the fiber's scattering function once after the dual-scattering light sample; a
    /// ray that meets a surface goes on as an ordinary path from there, one that escapes ends
    /// (direct light is the dual terms'). Default `Through`: better on the head scene for
    /// every hair colour (`bench/dual_scattering/result.md`).
    pub surface_bounce: SurfaceBounce,
    /// The exact counting walk stops once the transmittance product `∏ ā_f` is below this in
    /// every channel, and the light is then taken as fully blocked (an error below this
    /// fraction of the light's unshadowed contribution, times d_f); 0 walks every fiber.
    pub count_cutoff: f64,
    /// The same cut-off for the walk of a `Through` bounce toward a surface.
    pub bounce_cutoff: f64,
    /// Russian roulette on the bounce: it is traced (surface hit, counting walk, the path
    /// beyond) with this probability and its weight divided by it, in (0, 1]; 1 always
    /// bounces. Unbiased; trades the bounce's cost for variance of the surface-bounced light.
    pub bounce_probability: f64,
    /// How deep the hair behind a fiber is taken to be for its local backscatter: the layer
    /// the camera ray meets beyond the fiber (`counted`, default) or the paper's half-space.
    /// With the at-fiber series the counted layer is the better default over the 48 floorless
    /// scenes of `scene_family` (RMS channel error 0.064 against 0.097 with the half-space; the
    /// book's chapter "Dual scattering on scenes it was not tuned on", issue 37).
    pub backscatter_depth: BackscatterDepth,
    /// How a `Through` bounce draws its direction: from the mixture of [`crate::dual_bounce`]
    /// (default) or from the fiber's own sampler alone (the earlier form, whose weight
    /// `F·cosθ/p_s` is unbounded where F's broadened lobes reach beyond f_s).
    pub bounce_sampling: BounceSampling,
    /// Whether a `Through` bounce's light gets the local backscatter term `f_back` as a
    /// light's does (`bounce_back`, default on). Off, the blond head of `head.py`, whose
    /// floor lights thick hair from below, is +5.5 % instead of +24 %, but the floor members
    /// of `scene_family` are worse (mean worst-channel error 0.072 against 0.062 at the
    /// benchmark size; back-lit dense blond 0.81 of the path tracer instead of 0.97):
    /// `bench/dual_scattering/result.md`, "The floor through thick hair".
    pub bounce_backscatter: bool,
}

/// The hair behind a fiber that its local backscatter `f_back` assumes
/// ([`DualScatteringSettings::backscatter_depth`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BackscatterDepth {
    /// A half-space of hair (the paper's Ā_b, whatever the hair is like).
    Infinite,
    /// The fibers the camera ray meets beyond the fiber, up to the next surface, counted as
    /// for a light ([`DualScattering::backscatter_depth`]): Ā_b times `1 − P_b²`.
    Counted,
}

/// How the `Through` bounce draws its direction ([`DualScatteringSettings::bounce_sampling`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BounceSampling {
    /// The mixture of the fiber's sampler and F's lobes ([`crate::dual_bounce`]).
    Mixture,
    /// The fiber's own sampler.
    Model,
}

impl Default for DualScatteringSettings {
    fn default() -> Self {
        Self {
            count: FiberCount::Exact,
            forward_density: 0.5,
            bounce_forward_density: 1.0,
            backward_density: 1.0,
            back_scale: 0.25,
            back_pi: true,
            spread: Spread::Weighted,
            forward_attenuation: ForwardAttenuation::Beam,
            back_series: BackSeries::AtFiber,
            global: GlobalAzimuth::Energy,
            grid_resolution: 64,
            grid_near_cells: 2.0,
            surface_bounce: SurfaceBounce::Through,
            count_cutoff: 1e-4,
            bounce_cutoff: 1e-2,
            bounce_probability: 1.0,
            bounce_sampling: BounceSampling::Mixture,
            backscatter_depth: BackscatterDepth::Counted,
            bounce_backscatter: true,
        }
    }
}

impl DualScatteringSettings {
    /// The settings for fiber count `fiber_count` (`exact` or `grid`) with `KEY=VALUE` options
    /// applied over the defaults, as the command line's `--dual` and Python's `dual=` give them:
    /// `d_f`, `d_b`, `k_back`, `grid`, `grid_near`, `cutoff`, `bounce_cutoff` (finite, ≥ 0),
    /// `bounce_p` (in (0, 1]), `surface_bounce` (`off`, `on`, `through`), `bounce_sampling`
    /// (`mixture`, `model`), `back_depth` (`counted`, `infinite`), `pi` and `bounce_back` (`on`, `off`),
    /// `spread` (`weighted`, `literal`), `global` (`energy`, `forward-mean`). The error names
    /// the option and what it accepts.
    pub fn from_options<S: AsRef<str>>(fiber_count: &str, options: &[S]) -> Result<Self, String> {
        let mut s = Self { count: FiberCount::parse(fiber_count)?, ..Self::default() };
        for option in options {
            let option = option.as_ref();
            let (key, value) = option.split_once('=').ok_or_else(|| format!("dual {option}: expected KEY=VALUE"))?;
            let number = || -> Result<f64, String> {
                let v: f64 = value.parse().map_err(|_| format!("dual {key}: `{value}` is not a number"))?;
                if !(v.is_finite() && v >= 0.0) {
                    return Err(format!("dual {key} = {v} must be finite and ≥ 0"));
                }
                Ok(v)
            };
            let choice = |known: &[&str]| -> Result<usize, String> {
                known
                    .iter()
                    .position(|k| *k == value)
                    .ok_or_else(|| format!("dual {key}: `{value}` (known: {})", known.join(", ")))
            };
            match key {
                "d_f" => s.forward_density = number()?,
                "bounce_d_f" => s.bounce_forward_density = number()?,
                "d_b" => s.backward_density = number()?,
                "k_back" => s.back_scale = number()?,
                "grid" => {
                    let n = number()?;
                    if !(n >= 1.0 && n.fract() == 0.0) {
                        return Err(format!("dual grid = {value}: expected a whole number of cells ≥ 1"));
                    }
                    s.grid_resolution = n as usize;
                }
                "grid_near" => s.grid_near_cells = number()?,
                "cutoff" => s.count_cutoff = number()?,
                "bounce_cutoff" => s.bounce_cutoff = number()?,
                "bounce_p" => {
                    let q = number()?;
                    if !(q > 0.0 && q <= 1.0) {
                        return Err(format!("dual bounce_p = {q} must be in (0, 1]"));
                    }
                    s.bounce_probability = q;
                }
                "surface_bounce" => s.surface_bounce = SurfaceBounce::parse(value).map_err(|e| format!("dual {e}"))?,
                "back_depth" => {
                    s.backscatter_depth =
                        [BackscatterDepth::Counted, BackscatterDepth::Infinite][choice(&["counted", "infinite"])?];
                }
                "bounce_sampling" => {
                    s.bounce_sampling =
                        [BounceSampling::Mixture, BounceSampling::Model][choice(&["mixture", "model"])?];
                }
                "pi" => s.back_pi = matches!(choice(&["on", "off", "true", "false"])?, 0 | 2),
                "bounce_back" => s.bounce_backscatter = matches!(choice(&["on", "off", "true", "false"])?, 0 | 2),
                "spread" => s.spread = [Spread::Weighted, Spread::Literal][choice(&["weighted", "literal"])?],
                "back_series" => {
                    s.back_series = [BackSeries::Paper, BackSeries::AtFiber][choice(&["paper", "at-fiber"])?];
                }
                "a_f" => {
                    s.forward_attenuation =
                        [ForwardAttenuation::Beam, ForwardAttenuation::Averaged][choice(&["beam", "averaged"])?];
                }
                "global" => {
                    s.global =
                        [GlobalAzimuth::Energy, GlobalAzimuth::ForwardMean][choice(&["energy", "forward-mean"])?];
                }
                _ => {
                    return Err(format!(
                        "dual {key}: unknown (known: d_f, bounce_d_f, d_b, k_back, pi, spread, a_f, back_series, global, grid, grid_near, \
                         surface_bounce, bounce_sampling, bounce_back, back_depth, cutoff, bounce_cutoff, bounce_p)"
                    ));
                }
            }
        }
        Ok(s)
    }
}

/// The integrator named `name` (`path` or `dual-scattering`) for `scene`; for dual
/// scattering with `settings` and tables at [`RENDER_TABLE_RESOLUTION`]. The one place the
/// command line and the Python package turn a scene file's (or a flag's) integrator name into
/// an integrator, so both render the same image.
pub fn integrator_named(
    scene: &Scene,
    name: &str,
    settings: DualScatteringSettings,
) -> Result<Integrator, IntegratorError> {
    match name {
        "path" => Ok(Integrator::Path),
        "dual-scattering" => {
            Ok(Integrator::DualScattering(Arc::new(DualScattering::new(scene, settings, &RENDER_TABLE_RESOLUTION)?)))
        }
        other => Err(IntegratorError::Unknown(other.to_string())),
    }
}

/// Why [`integrator_named`] gives no integrator.
#[non_exhaustive]
#[derive(Clone, Debug, Error, PartialEq)]
pub enum IntegratorError {
    /// Not `path` or `dual-scattering`.
    #[error("integrator `{0}`: unknown (known: path, dual-scattering)")]
    Unknown(String),
    /// Dual scattering refused the scene.
    #[error(transparent)]
    DualScattering(#[from] DualScatteringError),
}

/// Why dual scattering cannot render a scene.
#[non_exhaustive]
#[derive(Clone, Debug, Error, PartialEq)]
pub enum DualScatteringError {
    /// The scene has no fibers.
    #[error("dual scattering needs fibers, and the scene has none (use integrator = \"path\")")]
    NoFibers,
    /// A table or grid would exceed the memory budget.
    #[error("dual scattering: {0}")]
    Memory(String),
    /// `bounce_probability` outside (0, 1].
    #[error("dual scattering: bounce probability {0} must be in (0, 1]")]
    BounceProbability(f64),
    /// A fiber material's model has no far-field form the tables can integrate.
    #[error("dual scattering: fiber material {index}: {source}")]
    Tables {
        /// Index of the fiber assembly.
        index: usize,
        /// The tables' error.
        source: DualTablesError,
    },
}

/// The tables per fiber material, the fiber counter and the settings.
#[derive(Debug)]
pub struct DualScattering {
    tables: Vec<(FiberMaterialId, DualTables)>,
    grid: Option<DensityGrid>,
    settings: DualScatteringSettings,
}

/// What the light sample at a dual-scattering fiber ([`DualScattering::shade_fiber`]) passes
/// on to the fiber's bounce.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FiberShading {
    /// Light toward the camera from the light sample, `F·cosθ_i·L/p`.
    pub radiance: Rgb,
    /// σ̄_f² met by the light sample (luminance of the channels; 0 when nothing was counted):
    /// the hint of [`DualScattering::sample_bounce`].
    pub spread_hint: f64,
    /// The backscatter's share for the hair behind the fiber
    /// ([`DualScattering::backscatter_depth`]).
    pub back_depth: Rgb,
}

/// The walk of [`DualScattering::backscatter_depth`] stops once `∏ā_f` is below this in every
/// channel: the factor `1 − P_b²` is then within 10⁻³ of 1.
pub const BACK_DEPTH_CUTOFF: f64 = 0.0316;

/// Table resolution used for rendering (32 θ nodes over (−90°, 90°), linearly interpolated).
pub const RENDER_TABLE_RESOLUTION: Resolution =
    Resolution { inclinations: 32, incident_azimuths: 4, outgoing_inclinations: 48, outgoing_azimuths: 48, offsets: 4 };

/// Per-channel unit-area Gaussian `exp(−x²/2v)/√(2πv)`.
fn gaussian(x: Rgb, variance: Rgb) -> Rgb {
    Rgb::new(
        (-x[0] * x[0] / (2.0 * variance[0])).exp() / (2.0 * PI * variance[0]).sqrt(),
        (-x[1] * x[1] / (2.0 * variance[1])).exp() / (2.0 * PI * variance[1]).sqrt(),
        (-x[2] * x[2] / (2.0 * variance[2])).exp() / (2.0 * PI * variance[2]).sqrt(),
    )
}

/// Smallest variance of a lobe at render time (rad²): keeps g finite for a table value of 0.
const MIN_VARIANCE: f64 = 1e-8;

impl DualScattering {
    /// Tables for every fiber material of `scene` (at `resolution`) and, for grid counting,
    /// the density grid. Refuses a scene without fibers and delta models.
    pub fn new(
        scene: &Scene,
        settings: DualScatteringSettings,
        resolution: &Resolution,
    ) -> Result<Self, DualScatteringError> {
        if scene.fibers().iter().all(|f| f.curves().segment_count() == 0) {
            return Err(DualScatteringError::NoFibers);
        }
        let q = settings.bounce_probability;
        if !(q > 0.0 && q <= 1.0) {
            return Err(DualScatteringError::BounceProbability(q));
        }
        let mut tables: Vec<(FiberMaterialId, DualTables)> = Vec::new();
        for (index, f) in scene.fibers().iter().enumerate() {
            if tables.iter().any(|(m, _)| *m == f.material()) {
                continue;
            }
            let model = scene.fiber_model(f.material());
            if model.properties().lobes == Lobes::Delta {
                return Err(DualScatteringError::Tables { index, source: DualTablesError::DeltaLobes });
            }
            let t =
                DualTables::new(model, resolution).map_err(|source| DualScatteringError::Tables { index, source })?;
            tables.push((f.material(), t));
        }
        let grid = match settings.count {
            FiberCount::Exact => None,
            FiberCount::Grid => DensityGrid::build(scene, settings.grid_resolution)
                .map_err(|e| DualScatteringError::Memory(e.to_string()))?,
        };
        Ok(Self { tables, grid, settings })
    }

    /// The settings.
    #[must_use]
    pub fn settings(&self) -> &DualScatteringSettings {
        &self.settings
    }

    /// The density grid (grid counting only).
    #[must_use]
    pub fn grid(&self) -> Option<&DensityGrid> {
        self.grid.as_ref()
    }

    fn tables_of(&self, material: FiberMaterialId) -> &DualTables {
        self.tables.iter().find(|(m, _)| *m == material).map_or(&self.tables[0].1, |(_, t)| t)
    }

    /// `(n, ∏ ā_f(θ^k) as exp Σ ln, Σ β̄_f²(θ^k))` over the fibers crossed by `ray`. The
    /// exact walk stops at [`DualScatteringSettings::count_cutoff`]; the product is then 0
    /// (and `n`, the spread, the partial sums so far).
    #[must_use]
    pub fn count(&self, scene: &Scene, ray: &Ray, skip: Option<(usize, u32)>, skip_distance: f64) -> (f64, Rgb, Rgb) {
        self.count_until(scene, ray, skip, skip_distance, self.settings.count_cutoff)
    }

    /// [`DualScattering::count`] with the cut-off `cutoff` (0: the whole walk).
    fn count_until(
        &self,
        scene: &Scene,
        ray: &Ray,
        skip: Option<(usize, u32)>,
        skip_distance: f64,
        cutoff: f64,
    ) -> (f64, Rgb, Rgb) {
        let (mut n, mut log_t, mut var) = (0.0, Rgb::ZERO, Rgb::ZERO);
        let beam = self.settings.forward_attenuation == ForwardAttenuation::Beam;
        let mut add = |c: Crossing| {
            let t = self.tables_of(c.material);
            let theta = c.sin_theta.asin();
            let af = if beam { t.lookup(theta, |r| r.forward_beam) } else { t.lookup(theta, |r| r.forward) };
            n += c.count;
            log_t += af.map(|a| a.clamp(1e-300, 1.0).ln()) * c.count;
            var += t.lookup(theta, |r| r.forward_variance) * c.count;
            log_t
        };
        let stopped = match &self.grid {
            Some(g) => {
                let near = ray.t_min + self.settings.grid_near_cells * g.cell();
                let near_ray = Ray { t_max: ray.t_max.min(near), ..*ray };
                let log_cut = if cutoff > 0.0 { cutoff.ln() } else { f64::NEG_INFINITY };
                let stopped = near_ray.t_max > near_ray.t_min
                    && exact_crossings_until(scene, &near_ray, skip, skip_distance, &mut |c| {
                        add(c).max_component() < log_cut
                    });
                if !stopped && ray.t_max > near {
                    g.crossings(&Ray { t_min: near.max(ray.t_min), ..*ray }, &mut |c| {
                        add(c);
                    });
                }
                stopped
            }
            None if cutoff > 0.0 => {
                let log_cut = cutoff.ln();
                exact_crossings_until(scene, ray, skip, skip_distance, &mut |c| add(c).max_component() < log_cut)
            }
            None => {
                exact_crossings(scene, ray, skip, skip_distance, &mut |c| {
                    add(c);
                });
                false
            }
        };
        (n, if stopped { Rgb::ZERO } else { log_t.exp() }, var)
    }

    /// `F(ω_i, ω_o)` (sr⁻¹, module docs) at a fiber of `material` for local directions `wi`
    /// (toward the light) and `wo`, offset `h`, behind `n` fibers with transmittance product
    /// `product` and spread `spread2`, with the whole half-space of hair behind the fiber that
    /// the paper's backscatter assumes ([`DualScattering::scattering_with_depth`] for a layer
    /// of finite depth).
    #[must_use]
    #[allow(clippy::too_many_arguments)]
    pub fn scattering(
        &self,
        scene: &Scene,
        material: FiberMaterialId,
        wi: DVec3,
        wo: DVec3,
        h: f64,
        n: f64,
        product: Rgb,
        spread2: Rgb,
    ) -> Rgb {
        self.scattering_with_depth(scene, material, wi, wo, h, n, product, spread2, Rgb::ONE)
    }

    /// [`DualScattering::scattering`] with the backscatter scaled by `back_depth`, the share
    /// `1 − P_b²` of the paper's Ā_b that a layer behind the fiber with forward transmittance
    /// product `P_b` returns ([`DualScattering::backscatter_depth`]).
    #[must_use]
    #[allow(clippy::too_many_arguments)]
    pub fn scattering_with_depth(
        &self,
        scene: &Scene,
        material: FiberMaterialId,
        wi: DVec3,
        wo: DVec3,
        h: f64,
        n: f64,
        product: Rgb,
        spread2: Rgb,
        back_depth: Rgb,
    ) -> Rgb {
        let d_f = self.settings.forward_density;
        self.scattering_with(scene, material, wi, wo, h, n, product, spread2, back_depth, d_f)
    }

    /// [`DualScattering::scattering_with_depth`] with the forward density factor `d_f`.
    #[allow(clippy::too_many_arguments)]
    fn scattering_with(
        &self,
        scene: &Scene,
        material: FiberMaterialId,
        wi: DVec3,
        wo: DVec3,
        h: f64,
        n: f64,
        product: Rgb,
        spread2: Rgb,
        back_depth: Rgb,
        d_f: f64,
    ) -> Rgb {
        let s = &self.settings;
        let t = self.tables_of(material);
        let theta_i = wi.x.clamp(-1.0, 1.0).asin();
        let theta_o = wo.x.clamp(-1.0, 1.0).asin();
        let theta_h = 0.5 * (theta_i + theta_o);
        let cos_d = (0.5 * (theta_o - theta_i)).cos().max(1e-4);
        let inv_cos2 = 1.0 / (cos_d * cos_d);
        let back_half = wi.y * wo.y + wi.z * wo.z > 0.0;
        let (k, w) = t.locate(theta_i);
        let rows = t.rows();
        let (r0, r1) = (&rows[k], &rows[k + 1]);
        let mix = |a: Rgb, b: Rgb| a * (1.0 - w) + b * w;
        let af = mix(r0.forward, r1.forward);
        let f_back = |extra: Rgb| -> Rgb {
            if !back_half {
                return Rgb::ZERO;
            }
            let base = match s.spread {
                Spread::Weighted => mix(r0.backscatter_spread, r1.backscatter_spread),
                Spread::Literal => mix(r0.backscatter_spread_literal, r1.backscatter_spread_literal),
            };
            let sigma = base * (af * af * s.backward_density + Rgb::ONE);
            let variance = (sigma * sigma + extra).map(|v| v.max(MIN_VARIANCE));
            let shift = mix(r0.backscatter_shift, r1.backscatter_shift);
            let ab = match s.back_series {
                BackSeries::Paper => mix(r0.backscatter, r1.backscatter),
                BackSeries::AtFiber => mix(r0.backscatter_at_fiber, r1.backscatter_at_fiber),
            } * back_depth;
            ab * gaussian(Rgb::splat(theta_h) - shift, variance) * (s.back_scale * 2.0 / PI * inv_cos2)
        };
        let direct = (1.0 - n).max(0.0);
        let mut total = Rgb::ZERO;
        if direct > 0.0 {
            let f_s = scene.fiber_model(material).eval(wi, wo, h);
            total += (f_s + f_back(Rgb::ZERO) * s.backward_density) * direct;
        }
        if direct < 1.0 {
            let mut f_g = Rgb::ZERO;
            for (l0, l1) in r0.lobes.iter().zip(&r1.lobes) {
                let (amplitude, c_g) = match s.global {
                    GlobalAzimuth::ForwardMean => (mix(l0.global_azimuthal, l1.global_azimuthal), 1.0),
                    GlobalAzimuth::Energy => {
                        (mix(l0.forward + l0.backward, l1.forward + l1.backward) / (2.0 * PI), 0.5)
                    }
                };
                let variance = (mix(l0.variance, l1.variance) + spread2).map(|v| v.max(MIN_VARIANCE));
                let shift = mix(l0.shift, l1.shift);
                f_g += amplitude * gaussian(Rgb::splat(theta_h) - shift, variance) * (c_g * inv_cos2);
            }
            let c_pi = if s.back_pi { PI } else { 1.0 };
            let t_f = product * d_f;
            total += t_f * (f_g + f_back(spread2) * (c_pi * s.backward_density)) * (1.0 - direct);
        }
        total
    }

    /// Light leaving the fiber hit `fiber` (of `material`, seen along `ray_d`) toward the
    /// camera, from one light sample (`u_pick`, `u_light`): [`DualScattering::scattering`] for
    /// the sampled light direction, `F·cosθ_i·L/p`; and the spread σ̄_f² (luminance of the
    /// channels; 0 when nothing was counted) the light sample met, the hint of
    /// [`DualScattering::sample_bounce`]. Adds the shadow ray to `rays`. The path tracer calls
    /// this at the first fiber a path reaches.
    #[must_use]
    #[allow(clippy::too_many_arguments)]
    pub fn shade_fiber(
        &self,
        scene: &Scene,
        fiber: &CurveHit,
        material: FiberMaterialId,
        ray_d: DVec3,
        u_pick: f64,
        u_light: [f64; 2],
        rays: &mut u64,
    ) -> FiberShading {
        let back_depth = self.backscatter_depth(scene, fiber, material, ray_d, rays);
        let mut shading = FiberShading { radiance: Rgb::ZERO, spread_hint: 0.0, back_depth };
        let p = fiber.p;
        let eps = 1e-9 * (1.0 + p.abs().max_element());
        let picker = scene.light_picker();
        let Some((emitter, select)) = picker.pick(u_pick) else { return shading };
        let Some(ls) = scene.sample_emitter(emitter, p, u_light) else { return shading };
        if ls.radiance.is_black() {
            return shading;
        }
        let t_max = if ls.distance.is_finite() { ls.distance * (1.0 - 1e-9) - eps } else { f64::INFINITY };
        let shadow = Ray { o: p, d: ls.wi, t_min: eps, t_max };
        *rays += 1;
        if !surfaces_unoccluded(scene, &shadow) {
            return shading;
        }
        let assembly = scene.fibers().iter().position(|f| f.material() == material);
        let skip = assembly.map(|a| (a, fiber.strand));
        let (n, product, spread2) = self.count(scene, &shadow, skip, 4.0 * fiber.radius);
        let frame = fiber.frame(ray_d);
        let (wi, wo) = (frame.to_local(ls.wi), frame.to_local(-ray_d));
        let f = self.scattering_with_depth(scene, material, wi, wo, fiber.h, n, product, spread2, back_depth);
        let cos_i = (1.0 - wi.x * wi.x).max(0.0).sqrt();
        shading.radiance = f * ls.radiance * (cos_i / (select * ls.pdf));
        shading.spread_hint = spread2.luminance().max(0.0);
        shading
    }

    /// The share `1 − P_b²` of the paper's backscatter Ā_b that the hair behind the fiber
    /// returns (per channel; 1 with [`BackscatterDepth::Infinite`]). Ā_b sums the paths that
    /// go `i ≥ 1` fibers deep by forward scattering, scatter back and return:
    /// `Ā_1 = ā_b Σ_{i≥1} ā_f^{2i}`; a layer of `n_b` fibers keeps the terms `i ≤ n_b`,
    /// `ā_b ā_f²(1 − ā_f^{2n_b})/(1 − ā_f²)`, i.e. the factor `1 − P_b²` with
    /// `P_b = ∏ ā_f` over the layer (applied to the three-bounce term too). The layer is
    /// what the camera ray meets beyond the fiber up to the next surface, counted as toward
    /// a light (each fiber at its own inclination); the walk stops once `P_b` is below
    /// [`BACK_DEPTH_CUTOFF`] in every channel (then the factor is 1). Adds the ray to `rays`.
    pub fn backscatter_depth(
        &self,
        scene: &Scene,
        fiber: &CurveHit,
        material: FiberMaterialId,
        ray_d: DVec3,
        rays: &mut u64,
    ) -> Rgb {
        if self.settings.backscatter_depth == BackscatterDepth::Infinite {
            return Rgb::ONE;
        }
        let p = fiber.p;
        let eps = 1e-9 * (1.0 + p.abs().max_element());
        let mut ray = Ray { o: p, d: ray_d, t_min: eps, t_max: f64::INFINITY };
        *rays += 1;
        if let Some(Hit::Surface { t, .. }) = scene.intersect_surfaces(&ray) {
            ray.t_max = t;
        }
        let assembly = scene.fibers().iter().position(|f| f.material() == material);
        let skip = assembly.map(|a| (a, fiber.strand));
        let (_, product, _) = self.count_until(scene, &ray, skip, 4.0 * fiber.radius, BACK_DEPTH_CUTOFF);
        (Rgb::ONE - product * product).map(|v| v.clamp(0.0, 1.0))
    }

    /// The bounce's direction at the dual-scattering fiber `fiber` (seen along `ray_d`), from
    /// four uniforms: with `Through`, from the mixture of [`crate::dual_bounce`] (the fiber's
    /// own sampler, the broadened global lobes, the backscatter lobe and uniform directions,
    /// `spread_hint` the σ̄_f² of the light sample), otherwise from the fiber's own sampler.
    /// Returns the direction (world), its density per steradian, and `f_s·cosθ/p` (the weight
    /// of `Unobstructed`).
    #[must_use]
    pub fn sample_bounce(
        &self,
        scene: &Scene,
        fiber: &CurveHit,
        material: FiberMaterialId,
        ray_d: DVec3,
        spread_hint: f64,
        u: [f64; 4],
    ) -> Option<(DVec3, f64, Rgb)> {
        let model = scene.fiber_model(material);
        let frame = fiber.frame(ray_d);
        let wo = frame.to_local(-ray_d);
        if self.settings.surface_bounce != SurfaceBounce::Through
            || self.settings.bounce_sampling == BounceSampling::Model
        {
            let s = model.sample(wo, fiber.h, u)?;
            return Some((frame.to_world(s.wi).normalize(), s.pdf, s.weight));
        }
        let t = self.tables_of(material);
        let hint = spread_hint + t.lookup(wo.x.clamp(-1.0, 1.0).asin(), |r| r.forward_variance).luminance();
        let density = BounceDensity::new(t, wo, self.settings.backward_density, hint.max(0.0));
        let wi = density.sample(u, model_sampler(model, wo, fiber.h))?;
        let (f, model_pdf) = model.eval_and_pdf(wi, wo, fiber.h);
        let pdf = density.pdf(wi, model_pdf);
        (pdf > 0.0 && pdf.is_finite()).then(|| (frame.to_world(wi).normalize(), pdf, f * (cos_theta(wi) / pdf)))
    }
}

impl DualScattering {
    /// The bounce of `surface_bounce` at the dual-scattering fiber `fiber` (seen along
    /// `ray_d`): the direction `wi` sampled from the fiber's scattering function with density
    /// `pdf` and weight `weight` (`f_s·cosθ/p`). Returns the surface the ray meets and the
    /// path's new weight factor, or `None` when the path ends: the ray escapes (the dual terms
    /// have the lights), meets no surface, or, with `Unobstructed`, meets a fiber first. With
    /// `Through`, the fibers up to the surface are counted as toward a light and the factor is
    /// `F(ω_i, ω_o; n, ∏ā_f, σ̄_f²)·cosθ_i/p` ([`DualScattering::scattering`]), which with
    /// nothing in between and `d_b = 0` is `weight`. Adds the ray to `rays`.
    #[must_use]
    #[allow(clippy::too_many_arguments)]
    pub fn bounce(
        &self,
        scene: &Scene,
        fiber: &CurveHit,
        material: FiberMaterialId,
        ray_d: DVec3,
        wi: DVec3,
        pdf: f64,
        weight: Rgb,
        back_depth: Rgb,
        rays: &mut u64,
    ) -> Option<(Hit, Rgb)> {
        let p = fiber.p;
        let eps = 1e-9 * (1.0 + p.abs().max_element());
        let mut ray = Ray { o: p, d: wi, t_min: eps, t_max: f64::INFINITY };
        *rays += 1;
        let hit = scene.intersect_surfaces(&ray)?;
        let Hit::Surface { t, .. } = hit else { return None };
        ray.t_max = t;
        match self.settings.surface_bounce {
            SurfaceBounce::Off => None,
            SurfaceBounce::Unobstructed => {
                (!scene.fibers().iter().any(|f| f.curves().occluded(&ray))).then_some((hit, weight))
            }
            SurfaceBounce::Through => {
                if pdf <= 0.0 {
                    return None;
                }
                let assembly = scene.fibers().iter().position(|f| f.material() == material);
                let skip = assembly.map(|a| (a, fiber.strand));
                let (n, product, spread2) =
                    self.count_until(scene, &ray, skip, 4.0 * fiber.radius, self.settings.bounce_cutoff);
                if n > 0.0 && product.is_black() {
                    return None;
                }
                let frame = fiber.frame(ray_d);
                let (wi_l, wo_l) = (frame.to_local(wi), frame.to_local(-ray_d));
                let d_f = self.settings.bounce_forward_density;
                let back_depth = if self.settings.bounce_backscatter { back_depth } else { Rgb::ZERO };
                let f =
                    self.scattering_with(scene, material, wi_l, wo_l, fiber.h, n, product, spread2, back_depth, d_f);
                let cos_i = (1.0 - wi_l.x * wi_l.x).max(0.0).sqrt();
                let factor = f * (cos_i / pdf);
                (!factor.is_black() && factor.is_finite()).then_some((hit, factor))
            }
        }
    }
}

/// True when no sphere or mesh blocks the ray (fibers are counted, not tested).
fn surfaces_unoccluded(scene: &Scene, ray: &Ray) -> bool {
    !(scene.spheres().iter().any(|s| sphere_hit(ray.o, ray.d, s.center(), s.radius(), ray.t_min, ray.t_max).is_some())
        || scene.meshes().iter().any(|m| m.mesh().occluded(ray)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::Camera;
    use crate::scene::SceneBuilder;
    use fiberlab_geometry::curves::CurveSet;
    use fiberlab_math::split_mix::SplitMix64;
    use fiberlab_scatter::dual_scattering_tables::DualTableRow;

    /// Uniforms in [0, 1) from a seed.
    fn uniforms(seed: u64) -> impl FnMut() -> f64 {
        let mut r = SplitMix64::new(seed);
        move || r.next_f64()
    }

    const R: f64 = 0.04;

    /// Parallel fibers along x (length 8) at `(y, z)` positions, radius R, one material.
    fn slab(positions: &[(f64, f64)], model: &str, pairs: &[(&str, &str)]) -> Scene {
        let camera = Camera::look_at(DVec3::new(0.0, 10.0, 0.0), DVec3::ZERO, DVec3::X, 10.0, 4, 4).unwrap();
        let mut b = SceneBuilder::new(camera);
        let m = b.fiber_material(fiberlab_scatter::build(model, pairs).unwrap());
        let lines: Vec<(Vec<DVec3>, Vec<f64>)> =
            positions.iter().map(|&(y, z)| (vec![DVec3::new(-4.0, y, z), DVec3::new(4.0, y, z)], vec![R, R])).collect();
        b.fibers(CurveSet::from_polylines(lines.iter().map(|(p, r)| (p.as_slice(), r.as_slice()))), m);
        b.build()
    }

    fn random_positions(seed: u64, count: usize, depth: f64, width: f64) -> Vec<(f64, f64)> {
        let mut u = uniforms(seed);
        (0..count).map(|_| (-depth * u(), width * (u() - 0.5))).collect()
    }

    /// A ray from above the slab of [`random_positions`] down through it, slightly tilted.
    fn ray_down_through_slab(u: &mut impl FnMut() -> f64) -> Ray {
        let o = DVec3::new(2.0 * (u() - 0.5), 0.5, u() - 0.5);
        let d = DVec3::new(0.5 * (u() - 0.5), -1.0, 0.3 * (u() - 0.5)).normalize();
        Ray { o, d, t_min: 0.0, t_max: f64::INFINITY }
    }

    fn small_tables() -> Resolution {
        Resolution {
            inclinations: 16,
            incident_azimuths: 4,
            outgoing_inclinations: 48,
            outgoing_azimuths: 48,
            offsets: 4,
        }
    }

    #[test]
    fn exact_count_equals_the_analytic_count_of_fibers_along_the_ray() {
        // Independent: a ray (inside the slab's length) crosses an infinite cylinder of axis x
        // exactly when its line passes within R of the axis: distance from (y, z) to the ray's
        // projection onto the y–z plane.
        let positions = random_positions(3, 400, 2.0, 3.0);
        let scene = slab(&positions, "chiang", &[]);
        let all = DualScatteringSettings { count_cutoff: 0.0, ..Default::default() };
        let dual = DualScattering::new(&scene, all, &small_tables()).unwrap();
        let mut u = uniforms(4);
        let mut total = 0.0;
        for _ in 0..200 {
            let o = DVec3::new(2.0 * (u() - 0.5), 0.5, 1.0 * (u() - 0.5));
            let d = DVec3::new(0.3 * (u() - 0.5), -1.0, 0.4 * (u() - 0.5)).normalize();
            let ray = Ray { o, d, t_min: 0.0, t_max: f64::INFINITY };
            let (n, product, _) = dual.count(&scene, &ray, None, 0.0);
            let (dy, dz) = (d.y, d.z);
            let norm = (dy * dy + dz * dz).sqrt();
            let want = positions
                .iter()
                .filter(|&&(y, z)| {
                    // Signed distance from (y, z) to the 2D line through (o.y, o.z) along (dy, dz),
                    // and the crossing must lie ahead of the origin.
                    let (py, pz) = (y - o.y, z - o.z);
                    let dist = (py * dz - pz * dy).abs() / norm;
                    dist < R && py * dy + pz * dz > 0.0
                })
                .count();
            assert_eq!(n, want as f64, "ray {o:?} {d:?}");
            total += n;
            // All crossings at about the same inclination: the product is a_f^beam(θ)^n (the default factors) within
            // the spread of the crossing angles.
            let theta = d.x.abs().asin();
            let af = dual.tables[0].1.lookup(theta, |r| r.forward_beam)[1];
            assert!((product[1] - af.powf(n)).abs() <= 0.05 * af.powf(n) + 1e-12, "{} vs {}", product[1], af.powf(n));
        }
        assert!(total > 200.0, "the rays cross fibers ({total})");
    }

    #[test]
    fn count_cutoff_drops_exactly_the_rays_below_it() {
        // Against the full walk (cut-off 0): a ray whose whole product stays at or above the
        // cut-off in some channel is counted identically; every other ray reports product 0.
        // The cut-off is the median of the full products, so both cases occur.
        let positions = random_positions(11, 600, 2.0, 3.0);
        let scene = slab(&positions, "chiang", &[("eumelanin", "0.3")]);
        let full = DualScattering::new(
            &scene,
            DualScatteringSettings { count_cutoff: 0.0, ..Default::default() },
            &small_tables(),
        )
        .unwrap();
        let mut u = uniforms(12);
        let rays: Vec<Ray> = (0..300)
            .map(|_| {
                let o = DVec3::new(2.0 * (u() - 0.5), 0.5, 1.0 * (u() - 0.5));
                let d = DVec3::new(1.6 * (u() - 0.5), -1.0, 1.6 * (u() - 0.5)).normalize();
                Ray { o, d, t_min: 0.0, t_max: f64::INFINITY }
            })
            .collect();
        let counts: Vec<(f64, Rgb, Rgb)> = rays.iter().map(|r| full.count(&scene, r, None, 0.0)).collect();
        let mut products: Vec<f64> = counts.iter().map(|c| c.1.max_component()).collect();
        products.sort_by(f64::total_cmp);
        let cutoff = products[products.len() / 2];
        assert!(cutoff > 1e-12 && cutoff < 0.5, "the rays cross fibers: median product {cutoff}");
        let cut = DualScattering::new(
            &scene,
            DualScatteringSettings { count_cutoff: cutoff, ..Default::default() },
            &small_tables(),
        )
        .unwrap();
        let (mut kept, mut dropped) = (0, 0);
        for (ray, &(n, product, spread)) in rays.iter().zip(&counts) {
            let (m, p, s) = cut.count(&scene, ray, None, 0.0);
            if product.max_component() >= cutoff {
                kept += 1;
                assert_eq!(n, m);
                for c in 0..3 {
                    assert!((p[c] / product[c] - 1.0).abs() < 1e-9 && (s[c] - spread[c]).abs() <= 1e-9 * spread[c]);
                }
            } else {
                dropped += 1;
                assert!(p.is_black() && m <= n, "{n} fibers, product {product:?}: cut walk {m}, {p:?}");
            }
        }
        assert!(kept > 100 && dropped > 100, "both cases occur: {kept} kept, {dropped} dropped");
    }

    #[test]
    fn bounce_through_counts_the_fibers_up_to_the_surface() {
        // Fiber A along x at the origin, seen from +y; below it a floor (a huge sphere, top at
        // z = −1), three fibers between A's hit point and the floor straight down, and one
        // under the floor's top (beyond the surface). A bounce straight down meets the floor
        // through exactly 3 fibers, each crossed at θ = 0: factor = F(n = 3, ā_f(0)³, 3 β̄_f²(0))
        // ·cosθ_i / p. `on` refuses the same ray (fibers in the way).
        let camera = Camera::look_at(DVec3::new(0.0, 10.0, 0.0), DVec3::ZERO, DVec3::X, 10.0, 4, 4).unwrap();
        let lines_at = |zs: &[f64], y: f64| -> Vec<Vec<DVec3>> {
            zs.iter().map(|&z| vec![DVec3::new(-4.0, y, z), DVec3::new(4.0, y, z)]).collect()
        };
        let build = |screen: &[Vec<DVec3>]| {
            let mut b = SceneBuilder::new(camera.clone());
            let m = b.fiber_material(fiberlab_scatter::build("chiang", &[("eumelanin", "0.3")]).unwrap());
            let mut lines = vec![vec![DVec3::new(-4.0, 0.0, 0.0), DVec3::new(4.0, 0.0, 0.0)]];
            lines.extend_from_slice(screen);
            b.fibers(CurveSet::from_polylines(lines.iter().map(|p| (p.as_slice(), &[R, R][..]))), m);
            let grey = b.surface_material(crate::scene::SurfaceMaterial::Lambert(Rgb::splat(0.5)));
            b.sphere(DVec3::new(0.0, 0.0, -1001.0), 1000.0, grey, None);
            b.build()
        };
        let ray_d = -DVec3::Y;
        let probe = Ray { o: DVec3::new(0.0, 2.0, 0.3 * R), d: ray_d, t_min: 0.0, t_max: f64::INFINITY };
        let Some(Hit::Fiber { hit, material }) = build(&[]).intersect(&probe) else { panic!("fiber A is hit") };
        let scene = build(&lines_at(&[-0.3, -0.5, -0.7, -1.5], hit.p.y));
        let settings = DualScatteringSettings { count_cutoff: 0.0, bounce_cutoff: 0.0, ..Default::default() };
        let dual = DualScattering::new(&scene, settings, &small_tables()).unwrap();
        // The bounce's own d_f: the expected value from F with that d_f.
        let with_bounce_d_f = DualScatteringSettings { forward_density: settings.bounce_forward_density, ..settings };
        let expected = DualScattering::new(&scene, with_bounce_d_f, &small_tables()).unwrap();
        let mut rays = 0;
        let wi = -DVec3::Z;
        let (surface, factor) = dual
            .bounce(&scene, &hit, material, ray_d, wi, 0.7, Rgb::ONE, Rgb::ONE, &mut rays)
            .expect("the floor is met");
        assert!(matches!(surface, Hit::Surface { t, .. } if (t - (1.0 + hit.p.z)).abs() < 1e-6));
        let t = &dual.tables[0].1;
        let af = t.lookup(0.0, |r| r.forward_beam);
        let var = t.lookup(0.0, |r| r.forward_variance);
        let frame = hit.frame(ray_d);
        let (wi_l, wo_l) = (frame.to_local(wi), frame.to_local(-ray_d));
        let product = Rgb::new(af[0].powi(3), af[1].powi(3), af[2].powi(3));
        let f = expected.scattering(&scene, material, wi_l, wo_l, hit.h, 3.0, product, var * 3.0);
        let want = f * ((1.0 - wi_l.x * wi_l.x).sqrt() / 0.7);
        assert!(!want.is_black());
        for c in 0..3 {
            assert!((factor[c] / want[c] - 1.0).abs() < 1e-9, "channel {c}: {} vs {}", factor[c], want[c]);
        }
        let on = DualScattering::new(
            &scene,
            DualScatteringSettings { surface_bounce: SurfaceBounce::Unobstructed, ..settings },
            &small_tables(),
        )
        .unwrap();
        assert!(on.bounce(&scene, &hit, material, ray_d, wi, 0.7, Rgb::ONE, Rgb::ONE, &mut rays).is_none());
        // Upward, nothing but sky: the path ends.
        assert!(dual.bounce(&scene, &hit, material, ray_d, DVec3::Z, 0.7, Rgb::ONE, Rgb::ONE, &mut rays).is_none());
        // `bounce_back=off`: F with no hair behind the fiber (back_depth 0). Toward the floor
        // on the camera's side of the fiber, with nothing in between, F has the local
        // backscatter, so the factor is smaller without it.
        let open = build(&[]);
        let wi = DVec3::new(0.0, 0.5, -1.0).normalize();
        let wi_l = frame.to_local(wi);
        let factor_of = |s: DualScatteringSettings| {
            let dual = DualScattering::new(&open, s, &small_tables()).unwrap();
            let mut rays = 0;
            dual.bounce(&open, &hit, material, ray_d, wi, 0.7, Rgb::ONE, Rgb::ONE, &mut rays).expect("the floor").1
        };
        let (with, without) =
            (factor_of(settings), factor_of(DualScatteringSettings { bounce_backscatter: false, ..settings }));
        let f0 =
            expected.scattering_with_depth(&open, material, wi_l, wo_l, hit.h, 0.0, Rgb::ONE, Rgb::ZERO, Rgb::ZERO);
        let want0 = f0 * ((1.0 - wi_l.x * wi_l.x).sqrt() / 0.7);
        for c in 0..3 {
            assert!((without[c] / want0[c] - 1.0).abs() < 1e-9, "channel {c}: {} vs {}", without[c], want0[c]);
            assert!(without[c] < 0.99 * with[c], "channel {c}: without backscatter {} against {}", without[c], with[c]);
        }
    }

    #[test]
    fn grid_count_matches_exact_count_on_a_random_slab() {
        // Mean count over many vertical rays: within 10 % (the grid smears the fibers over
        // its cells; the mean over rays is what the density reproduces).
        let positions = random_positions(5, 1200, 2.0, 3.0);
        let scene = slab(&positions, "chiang", &[]);
        let all = DualScatteringSettings { count_cutoff: 0.0, ..Default::default() };
        let exact = DualScattering::new(&scene, all, &small_tables()).unwrap();
        let grid = DualScattering::new(
            &scene,
            DualScatteringSettings { count: FiberCount::Grid, grid_resolution: 48, ..Default::default() },
            &small_tables(),
        )
        .unwrap();
        assert!(grid.grid().is_some_and(|g| g.bytes() > 0));
        let mut u = uniforms(6);
        let (mut a, mut b) = (0.0, 0.0);
        for _ in 0..400 {
            let ray = ray_down_through_slab(&mut u);
            a += exact.count(&scene, &ray, None, 0.0).0;
            b += grid.count(&scene, &ray, None, 0.0).0;
        }
        // Independent check of the scale: a vertical ray through a slab of area density
        // ν = N/(depth·width) crosses ν·2R·depth fibers on average.
        let analytic = 1200.0 / (2.0 * 3.0) * 2.0 * R * 2.0;
        assert!((a / 400.0 / analytic - 1.0).abs() < 0.15, "exact {} vs analytic {analytic}", a / 400.0);
        assert!((b / a - 1.0).abs() < 0.1, "grid {b} vs exact {a}");
    }

    #[test]
    fn grid_count_with_the_whole_ray_near_is_the_exact_count() {
        // The near field walked exactly, the grid beyond: a near field longer than the grid
        // leaves nothing to the grid, so the counts equal the exact walk's.
        let positions = random_positions(5, 1200, 2.0, 3.0);
        let scene = slab(&positions, "chiang", &[]);
        let all = DualScatteringSettings { count_cutoff: 0.0, ..Default::default() };
        let exact = DualScattering::new(&scene, all, &small_tables()).unwrap();
        let near = DualScatteringSettings { count: FiberCount::Grid, grid_near_cells: 1e3, ..all };
        let hybrid = DualScattering::new(&scene, near, &small_tables()).unwrap();
        let mut u = uniforms(8);
        for _ in 0..100 {
            let ray = ray_down_through_slab(&mut u);
            let (a, b) = (exact.count(&scene, &ray, None, 0.0), hybrid.count(&scene, &ray, None, 0.0));
            assert_eq!(a.0, b.0);
            for c in 0..3 {
                assert!((a.1[c] - b.1[c]).abs() <= 1e-12 * a.1[c].max(1e-300), "{a:?} vs {b:?}");
            }
        }
    }

    #[test]
    fn grid_count_near_field_removes_the_top_layer_bias() {
        // Rays leaving the top layer of a slab upward cross (almost) no fiber. The pure grid
        // counts the average density of the top cells, which holds the fibers below the start;
        // walking the first two cells exactly removes that.
        let positions = random_positions(5, 1200, 2.0, 3.0);
        let scene = slab(&positions, "chiang", &[]);
        let all = DualScatteringSettings { count_cutoff: 0.0, ..Default::default() };
        let exact = DualScattering::new(&scene, all, &small_tables()).unwrap();
        let grid_with = |near: f64| {
            let s =
                DualScatteringSettings { count: FiberCount::Grid, grid_resolution: 48, grid_near_cells: near, ..all };
            DualScattering::new(&scene, s, &small_tables()).unwrap()
        };
        let (pure, hybrid) = (grid_with(0.0), grid_with(2.0));
        let mut u = uniforms(9);
        let (mut e, mut p, mut h, mut n) = (0.0, 0.0, 0.0, 0.0);
        for &(y, z) in positions.iter().filter(|(y, _)| *y > -0.05) {
            let ray = Ray {
                o: DVec3::new(3.0 * (u() - 0.5), y + R + 1e-6, z),
                d: DVec3::Y,
                t_min: 0.0,
                t_max: f64::INFINITY,
            };
            e += exact.count(&scene, &ray, None, 0.0).0;
            p += pure.count(&scene, &ray, None, 0.0).0;
            h += hybrid.count(&scene, &ray, None, 0.0).0;
            n += 1.0;
        }
        assert!(n >= 10.0, "{n} top fibers");
        let (e, p, h) = (e / n, p / n, h / n);
        assert!(p - e > 0.1, "pure grid {p} vs exact {e}: the bias this test is about is absent");
        assert!((h - e).abs() < 0.02, "near field: {h} vs exact {e} (pure grid {p})");
    }

    #[test]
    fn with_no_fiber_in_front_the_global_term_is_single_scattering() {
        let scene = slab(&[(0.0, 0.0)], "chiang", &[("eumelanin", "0.3")]);
        let s = DualScatteringSettings { backward_density: 0.0, ..Default::default() };
        let dual = DualScattering::new(&scene, s, &small_tables()).unwrap();
        let model = scene.fiber_model(scene.fibers()[0].material());
        let mut u = uniforms(8);
        for _ in 0..50 {
            let wi = fiberlab_math::frame::direction(1.4 * (u() - 0.5), 6.0 * u());
            let wo = fiberlab_math::frame::direction(1.4 * (u() - 0.5), 6.0 * u());
            let h = 2.0 * u() - 1.0;
            let f = dual.scattering(&scene, scene.fibers()[0].material(), wi, wo, h, 0.0, Rgb::ONE, Rgb::ZERO);
            assert_eq!(f, model.eval(wi, wo, h));
        }
        // Behind fibers without backscatter and with d_f = 0, nothing arrives.
        let dark = DualScattering::new(
            &scene,
            DualScatteringSettings { backward_density: 0.0, forward_density: 0.0, ..Default::default() },
            &small_tables(),
        )
        .unwrap();
        let f =
            dark.scattering(&scene, scene.fibers()[0].material(), DVec3::Z, -DVec3::Z, 0.0, 3.0, Rgb::ONE, Rgb::ZERO);
        assert!(f.is_black());
    }

    /// `∫ F(ω_i, ω_o) cosθ_o dω_o` by midpoint quadrature in (θ_o, φ_o).
    fn outgoing_integral(dual: &DualScattering, scene: &Scene, wi: DVec3, n: f64, spread2: Rgb) -> Rgb {
        let (nt, np) = (400, 200);
        let mut sum = Rgb::ZERO;
        for i in 0..nt {
            let t = -PI / 2.0 + (i as f64 + 0.5) * PI / nt as f64;
            for j in 0..np {
                let p = (j as f64 + 0.5) * 2.0 * PI / np as f64;
                let wo = fiberlab_math::frame::direction(t, p);
                let f = dual.scattering(scene, scene.fibers()[0].material(), wi, wo, 0.0, n, Rgb::ONE, spread2);
                sum += f * (t.cos() * t.cos() * (PI / nt as f64) * (2.0 * PI / np as f64));
            }
        }
        sum
    }

    #[test]
    fn energy_of_the_backscatter_and_global_lobes() {
        // Independent quadrature of the render-time lobes against the table values:
        // with k_back = ¼, ∫ f_back cosθ_o dω_o ≈ Ā_b (the back half-circle, a narrow lobe);
        // with the energy form of f_s^G, ∫ f_s^G cosθ_o dω_o ≈ ā_f + ā_b. Lobes broaden
        // toward grazing angles and lose a little energy past ±90°: 12 % tolerance.
        let scene = slab(&[(0.0, 0.0)], "marschner", &[("beta_r", "4"), ("sigma_a", "0.3,0.6,1.2")]);
        let theta: f64 = 0.3;
        let wi = fiberlab_math::frame::direction(theta, 0.0);
        // Backscatter only: global term off (d_f = 0), shadowed (n = 1), d_b = 1; with each
        // series of Ā_b against its own table column.
        type Column = fn(&DualTableRow) -> Rgb;
        let series: [(BackSeries, Column); 2] =
            [(BackSeries::Paper, |r| r.backscatter), (BackSeries::AtFiber, |r| r.backscatter_at_fiber)];
        let mut tables = None;
        for (back_series, column) in series {
            let back = DualScattering::new(
                &scene,
                DualScatteringSettings {
                    forward_density: 0.0,
                    backward_density: 1.0,
                    back_series,
                    ..Default::default()
                },
                &small_tables(),
            )
            .unwrap();
            // f_back sits behind T_f·(…) and needs T_f ≠ 0: use the unshadowed branch (n = 0)
            // and subtract f_s instead.
            let with_back = outgoing_integral(&back, &scene, wi, 0.0, Rgb::ZERO);
            let single = {
                let none = DualScattering::new(
                    &scene,
                    DualScatteringSettings { backward_density: 0.0, ..Default::default() },
                    &small_tables(),
                )
                .unwrap();
                outgoing_integral(&none, &scene, wi, 0.0, Rgb::ZERO)
            };
            let ab = back.tables[0].1.lookup(theta, column);
            for c in 0..3 {
                let got = with_back[c] - single[c];
                assert!(
                    (got / ab[c] - 1.0).abs() < 0.12,
                    "{back_series:?} channel {c}: ∫ f_back = {got}, Ā_b = {}",
                    ab[c]
                );
            }
            tables = Some(back.tables[0].1.clone());
        }
        let t = tables.unwrap();
        let albedo = t.lookup(theta, |r| r.forward + r.backward);
        // Global only: n = 1, d_f = 1 (T_f = 1 with product 1), d_b = 0.
        let global = DualScattering::new(
            &scene,
            DualScatteringSettings { forward_density: 1.0, backward_density: 0.0, ..Default::default() },
            &small_tables(),
        )
        .unwrap();
        let g = outgoing_integral(&global, &scene, wi, 1.0, Rgb::splat(0.002));
        for c in 0..3 {
            assert!(
                (g[c] / albedo[c] - 1.0).abs() < 0.12,
                "channel {c}: ∫ f_s^G = {}, ā_f + ā_b = {}",
                g[c],
                albedo[c]
            );
        }
    }

    #[test]
    fn refuses_scenes_without_fibers_and_delta_models() {
        let camera = Camera::look_at(DVec3::new(0.0, 0.0, 5.0), DVec3::ZERO, DVec3::Y, 30.0, 4, 4).unwrap();
        let empty = SceneBuilder::new(camera).build();
        let e = DualScattering::new(&empty, DualScatteringSettings::default(), &small_tables()).unwrap_err();
        assert_eq!(e, DualScatteringError::NoFibers);
        assert!(e.to_string().contains("needs fibers"));
        let specular = slab(&[(0.0, 0.0)], "specular", &[]);
        let e = DualScattering::new(&specular, DualScatteringSettings::default(), &small_tables()).unwrap_err();
        assert!(e.to_string().contains("delta lobes"), "{e}");
    }

    #[test]
    fn options_set_each_setting_and_bad_ones_name_the_key_and_the_choices() {
        const OPTIONS: [&str; 18] = [
            "d_f=0.25",
            "bounce_d_f=0.5",
            "d_b=2",
            "k_back=1",
            "grid=32",
            "grid_near=0",
            "cutoff=0",
            "bounce_cutoff=0.5",
            "bounce_p=0.5",
            "surface_bounce=on",
            "pi=off",
            "spread=literal",
            "a_f=averaged",
            "back_series=paper",
            "global=forward-mean",
            "bounce_sampling=model",
            "back_depth=infinite",
            "bounce_back=off",
        ];
        let s = DualScatteringSettings::from_options("grid", &OPTIONS).unwrap();
        let expected = DualScatteringSettings {
            count: FiberCount::Grid,
            forward_density: 0.25,
            bounce_forward_density: 0.5,
            backward_density: 2.0,
            back_scale: 1.0,
            grid_resolution: 32,
            grid_near_cells: 0.0,
            count_cutoff: 0.0,
            bounce_cutoff: 0.5,
            bounce_probability: 0.5,
            surface_bounce: SurfaceBounce::Unobstructed,
            back_pi: false,
            spread: Spread::Literal,
            forward_attenuation: ForwardAttenuation::Averaged,
            back_series: BackSeries::Paper,
            global: GlobalAzimuth::ForwardMean,
            bounce_sampling: BounceSampling::Model,
            backscatter_depth: BackscatterDepth::Infinite,
            bounce_backscatter: false,
        };
        assert_eq!(s, expected);
        // Each option alone changes the defaults (so none is ignored or lands on another's field).
        let d = DualScatteringSettings::default();
        for option in OPTIONS {
            assert_ne!(DualScatteringSettings::from_options("exact", &[option]).unwrap(), d, "{option}");
        }
        assert_eq!(DualScatteringSettings::from_options::<&str>("exact", &[]).unwrap(), d);
        assert!(DualScatteringSettings::from_options("exact", &["pi=true"]).unwrap().back_pi);
        for (option, needles) in [
            ("d_f", &["d_f", "KEY=VALUE"][..]),
            ("d_f=x", &["d_f", "not a number"]),
            ("d_b=NaN", &["d_b", "finite"]),
            ("cutoff=-1", &["cutoff", "≥ 0"]),
            ("bounce_p=0", &["bounce_p", "(0, 1]"]),
            ("bounce_p=1.5", &["bounce_p", "(0, 1]"]),
            ("surface_bounce=maybe", &["surface_bounce", "off, on, through"]),
            ("pi=2", &["pi", "on, off"]),
            ("spread=wide", &["spread", "weighted, literal"]),
            ("a_f=mean", &["a_f", "beam, averaged"]),
            ("back_series=x", &["back_series", "paper, at-fiber"]),
            ("global=mean", &["global", "energy, forward-mean"]),
            ("bounce_sampling=best", &["bounce_sampling", "mixture, model"]),
            ("back_depth=deep", &["back_depth", "counted, infinite"]),
            ("bounce_back=maybe", &["bounce_back", "on, off"]),
            ("d_g=1", &["d_g", "unknown", "d_f"]),
        ] {
            let e = DualScatteringSettings::from_options("exact", &[option]).unwrap_err();
            assert!(needles.iter().all(|n| e.contains(n)), "{option}: {e}");
        }
        let e = DualScatteringSettings::from_options::<&str>("guess", &[]).unwrap_err();
        assert!(e.contains("guess") && e.contains("exact, grid"), "{e}");
    }

    #[test]
    fn integrators_by_name() {
        let scene = slab(&[(0.0, 0.0)], "chiang", &[]);
        let settings = DualScatteringSettings::default();
        assert_eq!(integrator_named(&scene, "path", settings), Ok(Integrator::Path));
        assert!(matches!(integrator_named(&scene, "dual-scattering", settings), Ok(Integrator::DualScattering(_))));
        let e = integrator_named(&scene, "bdpt", settings).unwrap_err();
        assert!(e.to_string().contains("bdpt") && e.to_string().contains("path, dual-scattering"), "{e}");
        let camera = Camera::look_at(DVec3::new(0.0, 0.0, 5.0), DVec3::ZERO, DVec3::Y, 30.0, 4, 4).unwrap();
        let empty = SceneBuilder::new(camera).build();
        assert_eq!(
            integrator_named(&empty, "dual-scattering", settings),
            Err(IntegratorError::DualScattering(DualScatteringError::NoFibers))
        );
        assert_eq!(integrator_named(&empty, "path", settings), Ok(Integrator::Path));
    }

    /// Mean and standard error of `n` path samples (luminance) of rays onto the fiber at the
    /// origin of `scene`, from +y, spread over the fiber's width near x = 0.
    fn fiber_radiance(scene: &Scene, integrator: &Integrator, n: u32) -> (f64, f64) {
        use crate::integrator::{RenderSettings, radiance};
        use crate::sampler::PixelSampler;
        let settings = RenderSettings { integrator: integrator.clone(), ..Default::default() };
        let (mut sum, mut sum2, mut rays) = (0.0, 0.0, 0u64);
        let mut sampler = PixelSampler::new(0, 0, 7);
        for i in 0..n {
            sampler.start(u64::from(i));
            let [a, b] = sampler.next_2d();
            let o = DVec3::new(0.04 * (a - 0.5), 2.0, 0.98 * R * (2.0 * b - 1.0));
            let l = radiance(
                scene,
                Ray { o, d: -DVec3::Y, t_min: 0.0, t_max: f64::INFINITY },
                &mut sampler,
                &settings,
                &mut rays,
            )
            .luminance();
            sum += l;
            sum2 += l * l;
        }
        let mean = sum / f64::from(n);
        (mean, ((sum2 / f64::from(n) - mean * mean).max(0.0) / f64::from(n)).sqrt())
    }

    #[test]
    fn surface_bounce_brings_the_light_off_a_wall_that_the_path_tracer_sees() {
        // One fiber along x at the origin; the sun straight above (+z) is hidden from it by a
        // black sphere, and lights a grey Lambertian floor (a huge sphere, top at z = -1). All
        // the light reaching the fiber comes off the floor: dual scattering alone gives zero,
        // with surface_bounce the path tracer's value (an independent estimate: ordinary path
        // tracing of the fiber, depth 64).
        let camera = Camera::look_at(DVec3::new(0.0, 10.0, 0.0), DVec3::ZERO, DVec3::X, 10.0, 4, 4).unwrap();
        let mut b = SceneBuilder::new(camera);
        let m = b.fiber_material(fiberlab_scatter::build("chiang", &[("eumelanin", "0.3")]).unwrap());
        let line = [DVec3::new(-4.0, 0.0, 0.0), DVec3::new(4.0, 0.0, 0.0)];
        b.fibers(CurveSet::from_polylines([(&line[..], &[R, R][..])]), m);
        let black = b.surface_material(crate::scene::SurfaceMaterial::Lambert(Rgb::ZERO));
        let grey = b.surface_material(crate::scene::SurfaceMaterial::Lambert(Rgb::splat(0.5)));
        b.sphere(DVec3::new(0.0, 0.0, 0.6), 0.2, black, None);
        b.sphere(DVec3::new(0.0, 0.0, -1001.0), 1000.0, grey, None);
        b.light(crate::light::Light::sun(DVec3::Z, 0.02, Rgb::splat(2.0)));
        let scene = b.build();
        let dual = |surface_bounce, backward_density| {
            let s = DualScatteringSettings { surface_bounce, backward_density, ..Default::default() };
            Integrator::DualScattering(Arc::new(DualScattering::new(&scene, s, &small_tables()).unwrap()))
        };
        let n = 40_000;
        let (path, path_se) = fiber_radiance(&scene, &Integrator::Path, n);
        let (on, on_se) = fiber_radiance(&scene, &dual(SurfaceBounce::Unobstructed, 1.0), n);
        let (off, _) = fiber_radiance(&scene, &dual(SurfaceBounce::Off, 1.0), n);
        assert!(path > 20.0 * path_se, "the floor lights the fiber: {path} ± {path_se}");
        assert_eq!(off, 0.0, "dual scattering without surface_bounce sees no light");
        let tolerance = 4.0 * (path_se * path_se + on_se * on_se).sqrt();
        assert!((on - path).abs() < tolerance, "surface_bounce {on} ± {on_se}, path tracer {path} ± {path_se}");
        // With no fiber between the fiber and the floor and no backscatter (d_b = 0), `through`
        // drawing from the fiber's sampler shades the floor's light with f_s·cosθ/p, the
        // sample's own weight: the same paths.
        let through_with = |bounce_sampling| {
            let s = DualScatteringSettings {
                surface_bounce: SurfaceBounce::Through,
                backward_density: 0.0,
                bounce_sampling,
                ..Default::default()
            };
            Integrator::DualScattering(Arc::new(DualScattering::new(&scene, s, &small_tables()).unwrap()))
        };
        let (through, _) = fiber_radiance(&scene, &through_with(BounceSampling::Model), n);
        assert!((through / on - 1.0).abs() < 1e-9, "through {through}, on {on}");
        // Drawn from the mixture (the default) the paths differ, the mean does not.
        let (mixture, mixture_se) = fiber_radiance(&scene, &through_with(BounceSampling::Mixture), n);
        let tolerance = 4.0 * (path_se * path_se + mixture_se * mixture_se).sqrt();
        assert!((mixture - path).abs() < tolerance, "mixture {mixture} ± {mixture_se}, path tracer {path} ± {path_se}");
        // Russian roulette on the bounce is unbiased: with probability 0.3 and weight 1/0.3
        // the same light as the path tracer's, within 4σ (more noise, same mean).
        let s = DualScatteringSettings {
            backward_density: 0.0,
            bounce_probability: 0.3,
            bounce_sampling: BounceSampling::Model,
            ..Default::default()
        };
        let roulette = Integrator::DualScattering(Arc::new(DualScattering::new(&scene, s, &small_tables()).unwrap()));
        let (rr, rr_se) = fiber_radiance(&scene, &roulette, n);
        assert!(rr_se > 1.2 * on_se, "roulette adds noise: {rr_se} vs {on_se}");
        let tolerance = 4.0 * (path_se * path_se + rr_se * rr_se).sqrt();
        assert!(
            (rr - path).abs() < tolerance,
            "bounce_probability 0.3: {rr} ± {rr_se}, path tracer {path} ± {path_se}"
        );
        for q in [0.0, -0.5, 1.5, f64::NAN] {
            let s = DualScatteringSettings { bounce_probability: q, ..Default::default() };
            assert!(matches!(
                DualScattering::new(&scene, s, &small_tables()),
                Err(DualScatteringError::BounceProbability(_))
            ));
        }

        // No double counting: with a sky and only black surfaces, the bounced rays escape or
        // meet black surfaces, so surface_bounce adds exactly nothing to the dual terms.
        let mut b = SceneBuilder::new(scene.camera().clone());
        let m = b.fiber_material(fiberlab_scatter::build("chiang", &[("eumelanin", "0.3")]).unwrap());
        b.fibers(CurveSet::from_polylines([(&line[..], &[R, R][..])]), m);
        let black = b.surface_material(crate::scene::SurfaceMaterial::Lambert(Rgb::ZERO));
        b.sphere(DVec3::new(0.0, 0.0, -1001.0), 1000.0, black, None);
        b.light(crate::light::Light::Constant { radiance: Rgb::splat(0.5) });
        let sky = b.build();
        let dual = |surface_bounce| {
            let s = DualScatteringSettings { surface_bounce, ..Default::default() };
            Integrator::DualScattering(Arc::new(DualScattering::new(&sky, s, &small_tables()).unwrap()))
        };
        let (off, _) = fiber_radiance(&sky, &dual(SurfaceBounce::Off), 4000);
        assert!(off > 0.0, "the sky lights the fiber");
        for mode in [SurfaceBounce::Unobstructed, SurfaceBounce::Through] {
            let (on, _) = fiber_radiance(&sky, &dual(mode), 4000);
            assert_eq!(on, off, "surface_bounce {mode:?} counted sky light twice");
        }
    }
}
