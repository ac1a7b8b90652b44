//! Fitting scattering-model parameters to measured values by weighted least squares:
//! Nelder–Mead (the `argmin` crate) on `χ² = Σ ((f_s(ω_i, ω_o) − value)/σ)²`, polished by
//! Levenberg–Marquardt steps, then uncertainties from the Gauss–Newton covariance
//! `(JᵀJ)⁻¹·χ²/dof` at the optimum.
//!
//! Each observation is one number: the luminance of `f_s` in sr⁻¹, or one of its channels
//! ([`Channel`]); near-field models are averaged over h. A colour parameter is fitted **per
//! channel** (three free numbers) when the data has channels, since then the three channels
//! are three independent measurements and the colour (e.g. the absorption `sigma_a` of a
//! hair) is what one wants to know — one scale for a fixed colour would need its hue known in
//! advance. From luminance-only data the channels cannot be told apart, and a colour is fitted
//! as one grey value (all channels equal).
//!
//! A surface model is fitted to the bins of a surface table ([`fit_surface`]): each bin's
//! value is compared with the model's average over the bin ([`surface_bins`], midpoint nodes
//! in the table's `cosθ dω` measure), the table's fixed direction taken as the light's or
//! the viewer's ([`SurfaceBin::fixed_is_viewer`]).
//!
//! An uncertainty that the covariance cannot give is an [`Uncertainty::Undefined`] with the
//! reason, and a parameter that ends on (within [`BOUND_TOLERANCE`] of) an end of its valid
//! range is reported with that end ([`AtBound`]). Pure.
#![forbid(unsafe_code)]

use argmin::core::observers::{Observe, ObserverMode};
use argmin::core::{CostFunction, Error, Executor, KV, State};
use argmin::solver::neldermead::NelderMead;
use fiberlab_math::frame::direction;
use fiberlab_math::{DVec3, Rgb};
use fiberlab_scatter::params::{ParamKind, ParamSet, Range, RawValue};
use fiberlab_scatter::{
    Field, Model, ModelError, ModelInfo, ScatteringFunction, SurfaceModel, SurfaceScattering, find, find_surface,
};
use std::fmt;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use thiserror::Error;

/// What an observation measures of `f_s`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Channel {
    /// Its Rec. 709 luminance.
    #[default]
    Luminance,
    /// One colour channel: 0 red, 1 green, 2 blue.
    Rgb(usize),
}

impl Channel {
    /// This channel of a colour.
    #[must_use]
    pub fn of(self, f: Rgb) -> f64 {
        match self {
            Channel::Luminance => f.luminance(),
            Channel::Rgb(c) => f[c.min(2)],
        }
    }
}

/// One measured value.
#[derive(Clone, Copy, Debug)]
pub struct Observation {
    /// Direction toward the light (fiber frame).
    pub wi: DVec3,
    /// Direction toward the viewer (fiber frame).
    pub wo: DVec3,
    /// Measured `f_s` (sr⁻¹) in `channel`.
    pub value: f64,
    /// Its standard error (> 0).
    pub sigma: f64,
    /// What of `f_s` was measured.
    pub channel: Channel,
}

/// `f_s` of `model` at one pair of directions, averaged over the fiber's width (8 midpoint
/// offsets h) for a near-field model: what a fit compares with a far-field measurement.
#[must_use]
pub fn width_averaged(model: &Model, wi: DVec3, wo: DVec3) -> Rgb {
    if model.properties().field == Field::Near {
        (0..8).map(|k| model.eval(wi, wo, -1.0 + (k as f64 + 0.5) / 4.0)).fold(Rgb::ZERO, |a, b| a + b) * 0.125
    } else {
        model.eval(wi, wo, 0.0)
    }
}

/// The grid on which a model is fitted to another model: θ_i and θ_r every 10° in
/// [−80°, 80°], relative azimuth every 15°, each pair with the weight `sqrt(cosθ_i cosθ_r)`
/// of a `cosθ_i cosθ_r`-weighted fit (σ ∝ 1/weight).
#[must_use]
pub fn model_grid() -> Vec<(DVec3, DVec3, f64)> {
    let mut grid = Vec::with_capacity(17 * 17 * 24);
    for i in 0..17 {
        for r in 0..17 {
            for j in 0..24 {
                let (ti, tr) = (f64::to_radians(-80.0 + 10.0 * i as f64), f64::to_radians(-80.0 + 10.0 * r as f64));
                let (wi, wo) = (direction(ti, 0.0), direction(tr, f64::to_radians(-172.5 + 15.0 * j as f64)));
                grid.push((wi, wo, (ti.cos() * tr.cos()).sqrt()));
            }
        }
    }
    grid
}

/// Why a fit could not be made.
#[non_exhaustive]
#[derive(Debug, Error)]
pub enum FitError {
    /// The starting parameters do not build a model.
    #[error("starting point: {0}")]
    Model(#[from] ModelError),
    /// Nothing to fit.
    #[error("{0}")]
    Setup(String),
    /// The optimizer failed.
    #[error("optimizer: {0}")]
    Optimizer(String),
}

/// A free parameter and its starting value: one number, or three (r, g, b) for a colour
/// fitted per channel.
#[derive(Clone, Debug, PartialEq)]
pub struct FreeParam {
    /// The parameter's key.
    pub key: String,
    /// Starting value(s).
    pub start: Vec<f64>,
}

/// How to run a fit.
#[derive(Clone, Default)]
pub struct FitOptions {
    /// Largest number of optimizer iterations.
    pub max_iters: u64,
    /// Called with the iteration number after each optimizer iteration, then with
    /// `max_iters + k` before the k-th of at most [`POLISH_ITERATIONS`] polishing steps.
    pub progress: Option<Arc<dyn Fn(u64) + Send + Sync>>,
    /// When set, the fit stops after the iteration in flight and returns the best point so
    /// far, with [`FitResult::interrupted`] (a signal handler's flag).
    pub stop: Option<&'static AtomicBool>,
}

/// A solver that also ends when [`FitOptions::stop`] is set.
struct Stoppable<S> {
    inner: S,
    stop: Option<&'static AtomicBool>,
}

impl<O, I: State, S: argmin::core::Solver<O, I>> argmin::core::Solver<O, I> for Stoppable<S> {
    fn name(&self) -> &str {
        self.inner.name()
    }

    fn init(&mut self, problem: &mut argmin::core::Problem<O>, state: I) -> Result<(I, Option<KV>), Error> {
        self.inner.init(problem, state)
    }

    fn next_iter(&mut self, problem: &mut argmin::core::Problem<O>, state: I) -> Result<(I, Option<KV>), Error> {
        self.inner.next_iter(problem, state)
    }

    fn terminate(&mut self, state: &I) -> argmin::core::TerminationStatus {
        if self.stop.is_some_and(|s| s.load(Ordering::Relaxed)) {
            return argmin::core::TerminationStatus::Terminated(argmin::core::TerminationReason::Interrupt);
        }
        self.inner.terminate(state)
    }
}

/// Why a parameter's uncertainty is undefined.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Undefined {
    /// The parameter ended on its bound: χ² is not a parabola around an optimum there.
    AtBound,
    /// The residuals do not depend on the parameter (its Jacobian column is zero).
    NoEffect,
    /// The Jacobian's columns are (nearly) dependent: the data cannot separate this
    /// parameter from the others; the condition number of the scaled `JᵀJ`.
    IllConditioned(f64),
    /// The model cannot be built on either side of the value (no difference quotient).
    NoDerivative,
}

/// A one-σ uncertainty, or why there is none.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Uncertainty {
    /// One standard deviation.
    Sigma(f64),
    /// No uncertainty can be given, for this reason.
    Undefined(Undefined),
}

impl Uncertainty {
    /// The σ, if defined.
    #[must_use]
    pub fn sigma(self) -> Option<f64> {
        match self {
            Uncertainty::Sigma(s) => Some(s),
            Uncertainty::Undefined(_) => None,
        }
    }
}

impl fmt::Display for Undefined {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Undefined::AtBound => {
                f.write_str("the value is on its bound, where χ² has no minimum to measure a curvature at")
            }
            Undefined::NoEffect => f.write_str("the data do not depend on it (its column of the Jacobian is zero)"),
            Undefined::IllConditioned(c) => write!(
                f,
                "the Jacobian is ill-conditioned (condition number {c:.1e}): the data cannot tell it apart \
                 from the other free parameters"
            ),
            Undefined::NoDerivative => f.write_str("the model cannot be evaluated on either side of the value"),
        }
    }
}

/// A fitted value within [`BOUND_TOLERANCE`] of an end of its valid range.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AtBound {
    /// The end it is on.
    pub bound: f64,
    /// True for the lower end.
    pub lower: bool,
    /// The parameter's valid range.
    pub range: Range,
}

impl fmt::Display for AtBound {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let side = if self.lower { "lower" } else { "upper" };
        write!(f, "ended on its {side} bound {:?} (valid range {})", self.bound, self.range)
    }
}

/// A value ends on its bound when it is within this fraction of the range's width (or, for
/// a range open on one side, of `max(1, |bound|)`) of the bound.
pub const BOUND_TOLERANCE: f64 = 1e-3;

/// Condition number of the scaled `JᵀJ` above which the uncertainties are not given: the
/// central differences are good to about 1e-8 relative, so beyond 1e8 the inverse is noise.
pub const MAX_CONDITION: f64 = 1e8;

/// A fitted model.
#[derive(Clone, Debug)]
pub struct FitResult {
    /// Fitted numbers: `key` for a number or a grey colour, `key[r]`, `key[g]`, `key[b]` for
    /// a colour fitted per channel.
    pub params: Vec<(String, f64)>,
    /// One-σ uncertainty of each of `params`, or why it is undefined.
    pub uncertainties: Vec<Uncertainty>,
    /// For each of `params`, the bound it ended on, if any.
    pub at_bound: Vec<Option<AtBound>>,
    /// Fitted values per parameter key: one number, or r, g, b.
    pub values: Vec<(String, Vec<f64>)>,
    /// χ² at the optimum.
    pub chi2: f64,
    /// Degrees of freedom (observations − free numbers).
    pub dof: usize,
    /// Normalized residuals `(f − value)/σ` per observation.
    pub residuals: Vec<f64>,
    /// Optimizer iterations.
    pub iterations: u64,
    /// Stopped by [`FitOptions::stop`] before it converged: the best point so far.
    pub interrupted: bool,
}

/// One free number: a parameter, or one channel of a colour parameter.
#[derive(Clone, Debug)]
struct Coordinate {
    key: &'static str,
    /// `None`: the whole parameter (a number, or a colour as grey); `Some(c)`: channel c.
    channel: Option<usize>,
    range: Range,
}

impl Coordinate {
    fn name(&self) -> String {
        match self.channel {
            None => self.key.to_string(),
            Some(c) => format!("{}[{}]", self.key, ["r", "g", "b"][c]),
        }
    }
}

/// The least-squares problem: the model's validated fixed parameters and the free
/// coordinates, whose trial values are set as numbers (never formatted to text and parsed
/// back). Generic over the model kind `M` (a fiber [`Model`] or a [`SurfaceModel`]): `build`
/// makes one from parameters, `residuals` gives its normalized residuals on the data.
struct Problem<'a, M> {
    build: &'a dyn Fn(&ParamSet) -> Result<M, ModelError>,
    base: &'a ParamSet,
    coordinates: &'a [Coordinate],
    residuals: &'a dyn Fn(&M) -> Vec<f64>,
    constraint: Option<&'a (dyn Fn(&M) -> bool + Sync)>,
}

impl<M> Clone for Problem<'_, M> {
    fn clone(&self) -> Self {
        Self { ..*self }
    }
}

impl<M> Problem<'_, M> {
    fn model_at(&self, p: &[f64]) -> Result<M, ModelError> {
        let mut params = self.base.clone();
        let mut k = 0;
        while k < self.coordinates.len() {
            let c = &self.coordinates[k];
            if c.channel.is_some() {
                let rgb = (0..3).map(|i| RawValue::Number(p[k + i])).collect();
                params.set(c.key, RawValue::List(rgb))?;
                k += 3;
            } else {
                params.set(c.key, RawValue::Number(p[k]))?;
                k += 1;
            }
        }
        (self.build)(&params)
    }

    /// Whether the constraint (if any) admits `m`.
    fn admits(&self, m: &M) -> bool {
        self.constraint.is_none_or(|admissible| admissible(m))
    }

    fn residuals(&self, m: &M) -> Vec<f64> {
        (self.residuals)(m)
    }
}

/// Normalized residuals of a fiber model on point observations.
fn fiber_residuals(data: &[Observation], m: &Model) -> Vec<f64> {
    // The channels of one direction pair follow each other: evaluate the model once for them.
    let mut last: Option<(DVec3, DVec3, Rgb)> = None;
    data.iter()
        .map(|o| {
            let f = match last {
                Some((wi, wo, f)) if wi == o.wi && wo == o.wo => f,
                _ => {
                    let f = width_averaged(m, o.wi, o.wo);
                    last = Some((o.wi, o.wo, f));
                    f
                }
            };
            (o.channel.of(f) - o.value) / o.sigma
        })
        .collect()
}

impl<M> CostFunction for Problem<'_, M> {
    type Param = Vec<f64>;
    type Output = f64;

    fn cost(&self, p: &Self::Param) -> Result<f64, Error> {
        // Parameters outside a model's valid range, or models the constraint rejects, cost
        // "infinitely" much (an extreme barrier: the simplex never steps outside).
        Ok(match self.model_at(p) {
            Ok(m) if self.admits(&m) => self.residuals(&m).iter().map(|r| r * r).sum(),
            _ => 1e300,
        })
    }
}

/// Reports each optimizer iteration to a callback.
struct IterationObserver(Arc<dyn Fn(u64) + Send + Sync>);

impl<I: State> Observe<I> for IterationObserver {
    fn observe_iter(&mut self, state: &I, _kv: &KV) -> Result<(), Error> {
        (self.0)(state.get_iter());
        Ok(())
    }
}

/// Fits the `free` parameters (with one starting value each) of the model whose other
/// parameters are `base`, in at most `max_iters` iterations: [`fit_with`] without progress.
pub fn fit(
    base: &ParamSet,
    free: &[(String, f64)],
    data: &[Observation],
    max_iters: u64,
) -> Result<FitResult, FitError> {
    let free: Vec<FreeParam> = free.iter().map(|(k, v)| FreeParam { key: k.clone(), start: vec![*v] }).collect();
    fit_with(base, &free, data, &FitOptions { max_iters, ..FitOptions::default() })
}

/// A condition every trial model of a constrained fit must meet (e.g. an energy bound):
/// `true` when the model is admissible.
pub type Constraint<'a> = &'a (dyn Fn(&Model) -> bool + Sync);

/// [`fit`] with the trial models restricted to those `constraint` admits: inadmissible
/// parameters cost as much as parameters outside the model's valid range (Nelder–Mead with
/// an extreme barrier) and the polishing steps never take them, so the result is admissible
/// whenever the starting point is (a starting point the constraint rejects is
/// [`FitError::Setup`]). The uncertainties are those of the unconstrained problem at the
/// optimum (meaningless for a parameter the constraint holds on its boundary).
pub fn fit_constrained(
    base: &ParamSet,
    free: &[(String, f64)],
    data: &[Observation],
    max_iters: u64,
    constraint: Option<Constraint>,
) -> Result<FitResult, FitError> {
    let free: Vec<FreeParam> = free.iter().map(|(k, v)| FreeParam { key: k.clone(), start: vec![*v] }).collect();
    fit_under(base, &free, data, &FitOptions { max_iters, ..FitOptions::default() }, constraint)
}

/// Fits the `free` parameters of the model whose other parameters are `base` (validated;
/// its model is `base.model()`). Free parameters are real numbers or colours; a colour is
/// fitted per channel when any observation is of a channel, else as one grey value.
pub fn fit_with(
    base: &ParamSet,
    free: &[FreeParam],
    data: &[Observation],
    options: &FitOptions,
) -> Result<FitResult, FitError> {
    fit_under(base, free, data, options, None)
}

/// [`fit_with`] under an optional constraint ([`fit_constrained`]).
fn fit_under(
    base: &ParamSet,
    free: &[FreeParam],
    data: &[Observation],
    options: &FitOptions,
    constraint: Option<Constraint>,
) -> Result<FitResult, FitError> {
    let spec = find(base.model())?;
    if spec.data.is_some() {
        return Err(FitError::Setup(format!("model `{}` is a table; it has no parameters to fit", spec.name)));
    }
    let per_channel = data.iter().any(|o| o.channel != Channel::Luminance);
    let (coordinates, start) = coordinates_of(&spec.info, base, free, per_channel)?;
    check_data(data.len(), coordinates.len(), data.iter().map(|o| (o.value, o.sigma)))?;
    let build = |p: &ParamSet| (spec.build)(p);
    let residuals = |m: &Model| fiber_residuals(data, m);
    let constraint = constraint.map(|c| c as &(dyn Fn(&Model) -> bool + Sync));
    let problem = Problem { build: &build, base, coordinates: &coordinates, residuals: &residuals, constraint };
    solve(&problem, start, data.len(), options)
}

/// One bin of a surface table: the table's fixed direction (its `theta_i, phi_i`) and
/// quadrature nodes over the bin's directions (surface frame, `z` the normal), with weights
/// summing to 1, so that `Σ w·f_r` over the nodes is the model's average over the bin in the
/// measure the table uses. The fixed direction is the light's (`f_r(ω_fixed, ω_k)`, a table
/// traced from the light) unless `fixed_is_viewer` (`f_r(ω_k, ω_fixed)`, a table traced from
/// the viewer, as the renderer's camera paths are): it matters for a non-reciprocal model.
#[derive(Clone, Debug)]
pub struct SurfaceBin {
    /// The table's fixed direction.
    pub fixed: DVec3,
    /// Whether `fixed` is toward the viewer (else toward the light).
    pub fixed_is_viewer: bool,
    /// `(direction, weight)` nodes.
    pub nodes: Vec<(DVec3, f64)>,
}

impl SurfaceBin {
    /// The model's average of `f_r` over the bin.
    #[must_use]
    pub fn average(&self, model: &SurfaceModel) -> Rgb {
        self.nodes.iter().fold(Rgb::ZERO, |acc, &(d, w)| {
            let f = if self.fixed_is_viewer { model.eval(d, self.fixed) } else { model.eval(self.fixed, d) };
            acc + f * w
        })
    }
}

/// One measured number of a surface bin.
#[derive(Clone, Copy, Debug)]
pub struct BinObservation {
    /// Index of its bin in [`SurfaceData::bins`].
    pub bin: usize,
    /// Measured bin-averaged `f_r` (sr⁻¹) in `channel`.
    pub value: f64,
    /// Its standard error (> 0).
    pub sigma: f64,
    /// What of `f_r` was measured.
    pub channel: Channel,
}

/// A surface table as fit data: its bins and the numbers measured on them.
#[derive(Clone, Debug, Default)]
pub struct SurfaceData {
    /// The bins.
    pub bins: Vec<SurfaceBin>,
    /// The measured numbers (any order; the channels of one bin share its evaluation).
    pub observations: Vec<BinObservation>,
}

/// The bins of one incidence of a surface table, `[θ_o][φ_o]` row-major: θ_o in [0, π/2]
/// in `nt` bins from the normal, φ_o (absolute azimuth from `x` toward `y`) in [−π, π) in
/// `np` bins; each bin integrated by the midpoint rule on `sub × sub` nodes weighted by the
/// `cosθ_o dω_o = sinθ_o cosθ_o dθ_o dφ_o` measure of a BRDF table (a bin's value is the power
/// it receives per cos-weighted solid angle).
#[must_use]
pub fn surface_bins(
    theta_i: f64,
    phi_i: f64,
    nt: usize,
    np: usize,
    sub: usize,
    fixed_is_viewer: bool,
) -> Vec<SurfaceBin> {
    let dir = |th: f64, ph: f64| DVec3::new(th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos());
    let wi = dir(theta_i, phi_i);
    let (dt, dp) = (std::f64::consts::FRAC_PI_2 / nt as f64, std::f64::consts::TAU / np as f64);
    let sub = sub.max(1);
    (0..nt * np)
        .map(|b| {
            let (i, j) = (b / np, b % np);
            let mut nodes = Vec::with_capacity(sub * sub);
            for a in 0..sub {
                let th = (i as f64 + (a as f64 + 0.5) / sub as f64) * dt;
                for c in 0..sub {
                    let ph = -std::f64::consts::PI + (j as f64 + (c as f64 + 0.5) / sub as f64) * dp;
                    nodes.push((dir(th, ph), th.sin() * th.cos()));
                }
            }
            let total: f64 = nodes.iter().map(|n| n.1).sum();
            nodes.iter_mut().for_each(|n| n.1 /= total);
            SurfaceBin { fixed: wi, fixed_is_viewer, nodes }
        })
        .collect()
}

/// A surface model's bin averages of `f_r` on `bins`.
#[must_use]
pub fn bin_averages(model: &SurfaceModel, bins: &[SurfaceBin]) -> Vec<Rgb> {
    bins.iter().map(|b| b.average(model)).collect()
}

/// Fits the `free` parameters of the surface model whose other parameters are `base`
/// (validated; a surface model's name) to the bins of a surface table: the objective is
/// `χ² = Σ ((⟨f_r⟩_bin − value)/σ)²` with the model averaged over each bin ([`surface_bins`]),
/// as the table's values are. A colour parameter is fitted per channel when any observation
/// is of a channel.
pub fn fit_surface(
    base: &ParamSet,
    free: &[FreeParam],
    data: &SurfaceData,
    options: &FitOptions,
) -> Result<FitResult, FitError> {
    let spec = find_surface(base.model())?;
    let obs = &data.observations;
    if let Some(o) = obs.iter().find(|o| o.bin >= data.bins.len()) {
        return Err(FitError::Setup(format!("observation of bin {} beyond the {} bins", o.bin, data.bins.len())));
    }
    let per_channel = obs.iter().any(|o| o.channel != Channel::Luminance);
    let (coordinates, start) = coordinates_of(&spec.info, base, free, per_channel)?;
    check_data(obs.len(), coordinates.len(), obs.iter().map(|o| (o.value, o.sigma)))?;
    let build = |p: &ParamSet| (spec.build)(p);
    let residuals = |m: &SurfaceModel| {
        let f = bin_averages(m, &data.bins);
        obs.iter().map(|o| (o.channel.of(f[o.bin]) - o.value) / o.sigma).collect()
    };
    let problem = Problem { build: &build, base, coordinates: &coordinates, residuals: &residuals, constraint: None };
    solve(&problem, start, obs.len(), options)
}

/// The free coordinates of `free` in the parameter table of `info` and their starting
/// values: a colour parameter is three coordinates when `per_channel`.
fn coordinates_of(
    info: &ModelInfo,
    base: &ParamSet,
    free: &[FreeParam],
    per_channel: bool,
) -> Result<(Vec<Coordinate>, Vec<f64>), FitError> {
    let spec = info;
    if free.is_empty() {
        return Err(FitError::Setup("no free parameters (give --init key=value)".into()));
    }
    let mut coordinates = Vec::new();
    let mut start = Vec::new();
    for (i, f) in free.iter().enumerate() {
        let key = f.key.as_str();
        if free[..i].iter().any(|g| g.key == f.key) {
            return Err(FitError::Setup(format!("`{key}` is given as free more than once")));
        }
        if base.is_given(key) {
            return Err(FitError::Setup(format!("`{key}` is both fixed and free; give it once")));
        }
        let Some(s) = spec.params.iter().find(|s| s.key == key) else {
            let known: Vec<&str> = spec.params.iter().map(|s| s.key).collect();
            return Err(FitError::Setup(format!(
                "model `{}` has no parameter `{key}`; its parameters are: {}",
                spec.name,
                known.join(", ")
            )));
        };
        match (s.kind, f.start.as_slice()) {
            (ParamKind::Number(range), [v]) => {
                coordinates.push(Coordinate { key: s.key, channel: None, range });
                start.push(*v);
            }
            (ParamKind::Color(range), [v]) if !per_channel => {
                coordinates.push(Coordinate { key: s.key, channel: None, range });
                start.push(*v);
            }
            (ParamKind::Color(range), [v] | [v, _, _]) if per_channel => {
                let rgb = if f.start.len() == 3 { f.start.clone() } else { vec![*v; 3] };
                for (c, x) in rgb.into_iter().enumerate() {
                    coordinates.push(Coordinate { key: s.key, channel: Some(c), range });
                    start.push(x);
                }
            }
            (ParamKind::Color(_), [_, _, _]) => {
                return Err(FitError::Setup(format!(
                    "`{key}`: luminance-only data cannot tell the channels of a colour apart; give one starting \
                     value (fitted as a grey value) or data with channels (f_r,f_g,f_b)"
                )));
            }
            (ParamKind::Number(_) | ParamKind::Color(_), _) => {
                return Err(FitError::Setup(format!(
                    "`{key}`: give one starting value{}",
                    if matches!(s.kind, ParamKind::Color(_)) { " or three (r,g,b)" } else { "" }
                )));
            }
            _ => {
                return Err(FitError::Setup(format!("`{key}` is not a real-valued parameter of `{}`", spec.name)));
            }
        }
    }
    Ok((coordinates, start))
}

/// Enough observations for the free numbers, each with a finite value and σ > 0, not all
/// values zero (there is nothing to fit to zero data: every model with f_s > 0 is as far
/// from it, by its scale alone).
fn check_data(observations: usize, free: usize, values: impl Iterator<Item = (f64, f64)>) -> Result<(), FitError> {
    if observations <= free {
        return Err(FitError::Setup(format!(
            "{observations} observations for {free} free numbers: too few to fit and estimate uncertainties"
        )));
    }
    let mut all_zero = true;
    for (v, s) in values {
        if s.is_nan() || s <= 0.0 || !v.is_finite() {
            return Err(FitError::Setup("every observation needs a finite value and σ > 0".into()));
        }
        all_zero &= v == 0.0;
    }
    if all_zero {
        return Err(FitError::Setup("every observed value is 0: there is nothing to fit".into()));
    }
    Ok(())
}

/// Nelder–Mead from `start`, polished, with the uncertainties at the optimum.
fn solve<M>(
    problem: &Problem<M>,
    start: Vec<f64>,
    observations: usize,
    options: &FitOptions,
) -> Result<FitResult, FitError> {
    let coordinates = problem.coordinates;
    let start_model = problem.model_at(&start)?;
    if !problem.admits(&start_model) {
        return Err(FitError::Setup("the starting point does not satisfy the fit's constraint".into()));
    }
    let mut simplex = vec![start.clone()];
    for k in 0..start.len() {
        let mut p = start.clone();
        p[k] += if p[k].abs() > 1e-3 { 0.15 * p[k] } else { 0.05 };
        simplex.push(p);
    }
    let solver = NelderMead::new(simplex).with_sd_tolerance(1e-9).map_err(|e| FitError::Optimizer(e.to_string()))?;
    let stoppable = Stoppable { inner: solver, stop: options.stop };
    let mut executor = Executor::new(problem.clone(), stoppable).configure(|s| s.max_iters(options.max_iters));
    if let Some(progress) = &options.progress {
        executor = executor.add_observer(IterationObserver(progress.clone()), ObserverMode::Always);
    }
    let res = executor.run().map_err(|e| FitError::Optimizer(e.to_string()))?;
    let iterations = res.state().get_iter();
    let stopped = || options.stop.is_some_and(|s| s.load(Ordering::Relaxed));
    let best = res.state().get_best_param().cloned().unwrap_or(start);
    let best = if stopped() {
        best
    } else {
        polish(problem, best, |step| {
            if let Some(progress) = &options.progress {
                progress(options.max_iters + step);
            }
        })
    };
    let m = problem.model_at(&best)?;
    let residuals = problem.residuals(&m);
    let chi2: f64 = residuals.iter().map(|r| r * r).sum();
    let dof = observations - coordinates.len();
    let at_bound: Vec<Option<AtBound>> = coordinates.iter().zip(&best).map(|(c, &v)| on_bound(v, c.range)).collect();
    if !chi2.is_finite() {
        return Err(FitError::Setup(format!(
            "χ² = {chi2} at the best point: the values and standard errors overflow double precision \
             (value / σ beyond 1e154); check the data's units"
        )));
    }
    let uncertainties = uncertainties(problem, &best, &residuals, &at_bound, chi2 / dof as f64);
    if uncertainties.iter().all(|u| matches!(u, Uncertainty::Undefined(Undefined::NoEffect))) {
        return Err(FitError::Setup(
            "no free parameter changes χ² at all: at the data's scale the model's values make no difference \
             (e.g. values of 1e300 against an f_s of order 1, or σ far larger than the values); check the \
             data's units and standard errors"
                .into(),
        ));
    }
    let mut values: Vec<(String, Vec<f64>)> = Vec::new();
    for (c, &v) in coordinates.iter().zip(&best) {
        match values.last_mut() {
            Some((k, vs)) if c.channel.is_some_and(|ch| ch > 0) && k == c.key => vs.push(v),
            _ => values.push((c.key.to_string(), vec![v])),
        }
    }
    Ok(FitResult {
        params: coordinates.iter().map(Coordinate::name).zip(best).collect(),
        uncertainties,
        at_bound,
        values,
        chi2,
        dof,
        residuals,
        iterations,
        interrupted: stopped(),
    })
}

/// Columns of the residuals' Jacobian by central differences (one-sided at the edge of a
/// parameter's valid range); `None` for a coordinate the model cannot be built on either side of.
fn jacobian<M>(problem: &Problem<M>, p: &[f64], r0: &[f64]) -> Vec<Option<Vec<f64>>> {
    (0..p.len())
        .map(|k| {
            let step = 1e-4 * p[k].abs().max(1.0);
            let (mut lo, mut hi) = (p.to_vec(), p.to_vec());
            lo[k] -= step;
            hi[k] += step;
            let (ra, rb, width) = match (problem.model_at(&lo), problem.model_at(&hi)) {
                (Ok(a), Ok(b)) => (problem.residuals(&a), problem.residuals(&b), 2.0 * step),
                (Err(_), Ok(b)) => (r0.to_vec(), problem.residuals(&b), step),
                (Ok(a), Err(_)) => (problem.residuals(&a), r0.to_vec(), step),
                _ => return None,
            };
            Some(ra.iter().zip(&rb).map(|(a, b)| (b - a) / width).collect())
        })
        .collect()
}

/// Largest number of Levenberg–Marquardt steps after the simplex (reported to the progress
/// callback as iterations after the optimizer's).
pub const POLISH_ITERATIONS: u64 = 20;

/// Levenberg–Marquardt steps from the simplex's best point (Nelder–Mead crawls in many
/// dimensions, e.g. three channels of two colours): each solves
/// `(JᵀJ + λ·diag JᵀJ) δ = −Jᵀr` and is kept only when it lowers χ² inside the valid ranges.
fn polish<M>(problem: &Problem<M>, mut p: Vec<f64>, progress: impl Fn(u64)) -> Vec<f64> {
    let chi2 = |r: &[f64]| r.iter().map(|x| x * x).sum::<f64>();
    let Ok(m) = problem.model_at(&p) else { return p };
    let mut r = problem.residuals(&m);
    let mut cost = chi2(&r);
    let mut lambda = 1e-3;
    for step in 0..POLISH_ITERATIONS {
        progress(step);
        let Some(jac) = jacobian(problem, &p, &r).into_iter().collect::<Option<Vec<_>>>() else { break };
        let n = p.len();
        let jtj: Vec<Vec<f64>> =
            (0..n).map(|a| (0..n).map(|b| jac[a].iter().zip(&jac[b]).map(|(x, y)| x * y).sum()).collect()).collect();
        let jtr: Vec<f64> = (0..n).map(|a| jac[a].iter().zip(&r).map(|(x, y)| x * y).sum()).collect();
        let mut improved = false;
        while lambda < 1e12 {
            let damped: Vec<Vec<f64>> = (0..n)
                .map(|a| {
                    (0..n).map(|b| jtj[a][b] + if a == b { lambda * jtj[a][a].max(1e-300) } else { 0.0 }).collect()
                })
                .collect();
            let Some(inv) = invert(damped) else { break };
            let trial: Vec<f64> = (0..n).map(|a| p[a] - (0..n).map(|b| inv[a][b] * jtr[b]).sum::<f64>()).collect();
            if let Ok(m) = problem.model_at(&trial)
                && problem.admits(&m)
            {
                let rt = problem.residuals(&m);
                let ct = chi2(&rt);
                if ct < cost {
                    let relative = (cost - ct) / cost.max(1e-300);
                    (p, r, cost) = (trial, rt, ct);
                    lambda = (lambda * 0.3).max(1e-12);
                    improved = relative > 1e-9;
                    break;
                }
            }
            lambda *= 10.0;
        }
        if !improved {
            break;
        }
    }
    p
}

/// The end of `range` that `v` is within [`BOUND_TOLERANCE`] of, if any.
fn on_bound(v: f64, range: Range) -> Option<AtBound> {
    let width = range.max - range.min;
    let tolerance = |bound: f64| BOUND_TOLERANCE * if width.is_finite() { width } else { bound.abs().max(1.0) };
    if range.min.is_finite() && v - range.min <= tolerance(range.min) {
        Some(AtBound { bound: range.min, lower: true, range })
    } else if range.max.is_finite() && range.max - v <= tolerance(range.max) {
        Some(AtBound { bound: range.max, lower: false, range })
    } else {
        None
    }
}

/// The uncertainties from `(JᵀJ)⁻¹ · χ²/dof` (`scale`), with a central-difference Jacobian
/// of the residuals. Coordinates on which the data do not depend, or on a bound, are held
/// fixed (their uncertainty undefined, the others' conditional on them); the rest share one
/// verdict when their scaled `JᵀJ` is ill-conditioned.
fn uncertainties<M>(
    problem: &Problem<M>,
    p: &[f64],
    r0: &[f64],
    at_bound: &[Option<AtBound>],
    scale: f64,
) -> Vec<Uncertainty> {
    let n = p.len();
    let mut out: Vec<Option<Uncertainty>> = vec![None; n];
    let jac: Vec<Vec<f64>> = jacobian(problem, p, r0)
        .into_iter()
        .enumerate()
        .map(|(k, column)| {
            match &column {
                None => out[k] = Some(Uncertainty::Undefined(Undefined::NoDerivative)),
                // No effect is the deeper reason: such a parameter drifts, and may drift onto a bound.
                Some(c) if c.iter().all(|x| *x == 0.0) => out[k] = Some(Uncertainty::Undefined(Undefined::NoEffect)),
                Some(_) if at_bound[k].is_some() => out[k] = Some(Uncertainty::Undefined(Undefined::AtBound)),
                Some(_) => {}
            }
            column.unwrap_or_default()
        })
        .collect();
    let kept: Vec<usize> = (0..n).filter(|&k| out[k].is_none()).collect();
    let jtj: Vec<Vec<f64>> = kept
        .iter()
        .map(|&a| kept.iter().map(|&b| jac[a].iter().zip(&jac[b]).map(|(x, y)| x * y).sum()).collect())
        .collect();
    // Scaled to unit diagonal, so the condition number measures dependence, not units.
    let d: Vec<f64> = (0..kept.len()).map(|i| jtj[i][i].sqrt()).collect();
    let scaled: Vec<Vec<f64>> =
        (0..kept.len()).map(|i| (0..kept.len()).map(|j| jtj[i][j] / (d[i] * d[j])).collect()).collect();
    let verdict = match invert(scaled.clone()) {
        Some(inv) => {
            let norm =
                |m: &[Vec<f64>]| m.iter().map(|row| row.iter().map(|x| x.abs()).sum::<f64>()).fold(0.0, f64::max);
            let condition = norm(&scaled) * norm(&inv);
            if condition.is_finite() && condition <= MAX_CONDITION { Ok(inv) } else { Err(condition) }
        }
        None => Err(f64::INFINITY),
    };
    for (i, &k) in kept.iter().enumerate() {
        out[k] = Some(match &verdict {
            Ok(inv) => Uncertainty::Sigma((inv[i][i] / (d[i] * d[i]) * scale).max(0.0).sqrt()),
            Err(condition) => Uncertainty::Undefined(Undefined::IllConditioned(*condition)),
        });
    }
    out.into_iter().map(|u| u.unwrap_or(Uncertainty::Undefined(Undefined::NoDerivative))).collect()
}

/// Gauss–Jordan inverse of a small symmetric matrix with partial pivoting.
fn invert(mut a: Vec<Vec<f64>>) -> Option<Vec<Vec<f64>>> {
    let n = a.len();
    let mut inv: Vec<Vec<f64>> = (0..n).map(|i| (0..n).map(|j| f64::from(u8::from(i == j))).collect()).collect();
    for c in 0..n {
        let p = (c..n).max_by(|&x, &y| a[x][c].abs().total_cmp(&a[y][c].abs()))?;
        if a[p][c].abs() < 1e-300 {
            return None;
        }
        a.swap(c, p);
        inv.swap(c, p);
        let d = a[c][c];
        for j in 0..n {
            a[c][j] /= d;
            inv[c][j] /= d;
        }
        for i in 0..n {
            if i != c {
                let f = a[i][c];
                for j in 0..n {
                    a[i][j] -= f * a[c][j];
                    inv[i][j] -= f * inv[c][j];
                }
            }
        }
    }
    Some(inv)
}

#[cfg(test)]
mod tests {
    use super::*;
    use fiberlab_math::frame::direction;
    use fiberlab_scatter::build;

    fn chiang(pairs: &[(&str, &str)]) -> ParamSet {
        let spec = find("chiang").unwrap();
        ParamSet::parse(spec.name, spec.params, pairs).unwrap()
    }

    /// Synthetic data from known Chiang parameters plus 2 % Gaussian-like noise: the fit
    /// recovers them within a few standard errors.
    #[test]
    fn round_trip_recovers_known_parameters() {
        let truth =
            build("chiang", &[("beta_m", "0.35"), ("beta_n", "0.45"), ("alpha", "3"), ("sigma_a", "0.5")]).unwrap();
        let mut uniform = fiberlab_check::rng::TestRng::new(12345).into_uniforms();
        let mut data = Vec::new();
        for i in 0..12 {
            for j in 0..16 {
                let wi = direction(-1.0 + 0.17 * i as f64, 0.0);
                let wo = direction(-1.3 + 0.16 * j as f64 + 0.05 * i as f64, 0.4 * j as f64);
                let f: f64 =
                    (0..8).map(|k| truth.eval(wi, wo, -1.0 + (k as f64 + 0.5) / 4.0).luminance()).sum::<f64>() / 8.0;
                let sigma = 0.02 * f + 1e-4;
                // Sum of 4 uniforms: a bounded, nearly Gaussian deviate of unit variance.
                let z = ((0..4).map(|_| uniform()).sum::<f64>() - 2.0) * 3f64.sqrt();
                data.push(Observation { wi, wo, value: f + sigma * z, sigma, channel: Channel::Luminance });
            }
        }
        let free = vec![("beta_m".to_string(), 0.25), ("beta_n".to_string(), 0.3), ("alpha".to_string(), 0.5)];
        let r = fit(&chiang(&[("sigma_a", "0.5")]), &free, &data, 400).unwrap();
        let expect = [0.35, 0.45, 3.0];
        for (k, ((key, v), u)) in r.params.iter().zip(&r.uncertainties).enumerate() {
            let u = u.sigma().unwrap_or_else(|| panic!("{key}: {u:?}"));
            assert!((v - expect[k]).abs() < 5.0 * u + 1e-3, "{key} = {v} ± {u}, truth {}", expect[k]);
        }
        assert!(r.at_bound.iter().all(Option::is_none), "{:?}", r.at_bound);
        assert!(r.chi2 / (r.dof as f64) < 2.0, "reduced χ² {}", r.chi2 / r.dof as f64);
    }

    /// Exact Kajiya–Kay data (p = 30): the unconstrained fit recovers p, a fit constrained
    /// to p ≥ 40 ends admissible, on the boundary, and a rejected start is an error.
    #[test]
    fn a_constraint_keeps_every_trial_model_admissible() {
        let spec = find("kajiya-kay").unwrap();
        let truth = build("kajiya-kay", &[("k_d", "0.05"), ("k_s", "0.1"), ("p", "30")]).unwrap();
        let mut data = Vec::new();
        for i in 0..9 {
            for j in 0..9 {
                let (wi, wo) = (direction(-0.8 + 0.2 * i as f64, 0.0), direction(-0.8 + 0.2 * j as f64, 1.0));
                data.push(Observation {
                    wi,
                    wo,
                    value: truth.eval(wi, wo, 0.0).luminance(),
                    sigma: 0.01,
                    channel: Channel::Luminance,
                });
            }
        }
        let base = ParamSet::parse::<&str, &str>(spec.name, spec.params, &[]).unwrap();
        let free = [("k_d".to_string(), 0.04), ("k_s".to_string(), 0.12), ("p".to_string(), 45.0)];
        let p_of = |m: &Model| match m {
            Model::KajiyaKay(k) => k.p(),
            _ => unreachable!(),
        };
        let at_least_40 = |m: &Model| p_of(m) >= 40.0;
        let free_fit = fit(&base, &free, &data, 2000).unwrap();
        assert!((free_fit.params[2].1 - 30.0).abs() < 0.5, "{:?}", free_fit.params);
        let held = fit_constrained(&base, &free, &data, 2000, Some(&at_least_40)).unwrap();
        let p = held.params[2].1;
        assert!((40.0..40.5).contains(&p), "constrained p = {p}");
        assert!(held.chi2 > free_fit.chi2, "{} vs {}", held.chi2, free_fit.chi2);
        let start = [("k_d".to_string(), 0.04), ("k_s".to_string(), 0.12), ("p".to_string(), 35.0)];
        assert!(matches!(fit_constrained(&base, &start, &data, 10, Some(&at_least_40)), Err(FitError::Setup(_))));
    }

    #[test]
    fn bad_setups_are_errors() {
        let o = Observation {
            wi: direction(0.0, 0.0),
            wo: direction(0.1, 1.0),
            value: 1.0,
            sigma: 0.0,
            channel: Channel::Luminance,
        };
        let base = chiang(&[]);
        assert!(fit(&base, &[("beta_m".into(), 0.3)], &[o, o, o], 10).is_err());
        assert!(fit(&base, &[], &[o], 10).is_err());
        // A key the model does not have, and a key that is not a real number, are named.
        let ok = [o, o, o, o].map(|mut x| {
            x.sigma = 1.0;
            x
        });
        let e = fit(&base, &[("beta".into(), 0.3)], &ok, 10).unwrap_err().to_string();
        assert!(e.contains("`beta`") && e.contains("beta_m"), "{e}");
        let spec = find("marschner").unwrap();
        let marschner = ParamSet::parse::<&str, &str>(spec.name, spec.params, &[]).unwrap();
        let e = fit(&marschner, &[("glints".into(), 0.3)], &ok, 10).unwrap_err().to_string();
        assert!(e.contains("`glints`") && e.contains("real-valued"), "{e}");
        let e = fit(&base, &[("beta_m".into(), 0.3), ("beta_m".into(), 0.4)], &ok, 10).unwrap_err().to_string();
        assert!(e.contains("more than once"), "{e}");
        let e = fit(&chiang(&[("beta_m", "0.3")]), &[("beta_m".into(), 0.3)], &ok, 10).unwrap_err().to_string();
        assert!(e.contains("both fixed and free"), "{e}");
        assert!(
            fit(
                &base,
                &[("beta_m".into(), 7.0)],
                &[o, o, o].map(|mut x| {
                    x.sigma = 1.0;
                    x
                }),
                10
            )
            .is_err()
        );
    }

    /// Directions of a small test grid (ω_i, ω_o).
    fn grid() -> Vec<(DVec3, DVec3)> {
        let mut pairs = Vec::new();
        for i in 0..8 {
            for j in 0..12 {
                pairs.push((direction(-1.1 + 0.3 * i as f64, 0.0), direction(-1.2 + 0.2 * j as f64, 0.5 * j as f64)));
            }
        }
        pairs
    }

    /// The luminance of `truth` on [`grid`], with a 1 % standard error.
    fn luminance_data(truth: &Model) -> Vec<Observation> {
        grid()
            .into_iter()
            .map(|(wi, wo)| {
                let value = truth.eval(wi, wo, 0.0).luminance();
                Observation { wi, wo, value, sigma: 0.01 * value + 1e-6, channel: Channel::Luminance }
            })
            .collect()
    }

    /// The ideal diffuse fiber is `f_s = ρ/π²` (closed form). Data of ρ = 1.3, beyond its valid
    /// range [0, 1]: the fit ends on the upper bound, says so, and gives no σ for it.
    #[test]
    fn a_parameter_on_its_bound_is_flagged_and_has_no_sigma() {
        let value = 1.3 / std::f64::consts::PI.powi(2);
        let data: Vec<Observation> = grid()
            .into_iter()
            .map(|(wi, wo)| Observation { wi, wo, value, sigma: 0.01 * value, channel: Channel::Luminance })
            .collect();
        let spec = find("diffuse").unwrap();
        let base = ParamSet::parse::<&str, &str>(spec.name, spec.params, &[]).unwrap();
        let r = fit(&base, &[("albedo".into(), 0.5)], &data, 400).unwrap();
        let b = r.at_bound[0].expect("on its bound");
        assert!(!b.lower && b.bound == 1.0, "{b:?}");
        assert!((r.params[0].1 - 1.0).abs() <= BOUND_TOLERANCE, "{:?}", r.params);
        assert_eq!(r.uncertainties[0], Uncertainty::Undefined(Undefined::AtBound));
        assert!(b.to_string().contains("upper bound 1.0"), "{b}");
        // Inside the range (ρ = 0.6), nothing is flagged and σ is defined.
        let inside: Vec<Observation> =
            data.iter().map(|o| Observation { value: o.value * 0.6 / 1.3, sigma: o.sigma * 0.6 / 1.3, ..*o }).collect();
        let r = fit(&base, &[("albedo".into(), 0.5)], &inside, 400).unwrap();
        assert!(r.at_bound[0].is_none() && r.uncertainties[0].sigma().is_some(), "{r:?}");
        assert!((r.params[0].1 - 0.6).abs() < 1e-4, "{:?}", r.params);
    }

    /// With `k_s = 0` Kajiya–Kay does not depend on its exponent `p`: p's uncertainty is
    /// undefined with that reason (never NaN), while `k_d`'s is still given.
    #[test]
    fn an_uncertainty_the_data_cannot_give_says_why() {
        let spec = find("kajiya-kay").unwrap();
        let base = ParamSet::parse(spec.name, spec.params, &[("k_s", "0")]).unwrap();
        let truth = build("kajiya-kay", &[("k_d", "0.3"), ("k_s", "0")]).unwrap();
        let data = luminance_data(&truth);
        let r = fit(&base, &[("k_d".into(), 0.2), ("p".into(), 10.0)], &data, 400).unwrap();
        assert!(r.uncertainties[0].sigma().is_some_and(f64::is_finite), "{:?}", r.uncertainties);
        assert_eq!(r.uncertainties[1], Uncertainty::Undefined(Undefined::NoEffect));
        assert!(Undefined::NoEffect.to_string().contains("do not depend"));
    }

    /// Data a fit cannot mean anything for is refused, not "fitted": all zeros, or values so
    /// large that no parameter changes χ² (the start values would come back as the fit).
    #[test]
    fn data_without_information_is_refused() {
        let spec = find("kajiya-kay").unwrap();
        let base = ParamSet::parse::<&str, &str>(spec.name, spec.params, &[]).unwrap();
        let data = luminance_data(&build("kajiya-kay", &[("k_d", "0.3")]).unwrap());
        let zeros: Vec<Observation> = data.iter().map(|o| Observation { value: 0.0, ..*o }).collect();
        let e = fit(&base, &[("k_d".into(), 0.2)], &zeros, 50).unwrap_err().to_string();
        assert!(e.contains("every observed value is 0"), "{e}");
        let huge: Vec<Observation> = data.iter().map(|o| Observation { value: 1e300, sigma: 5e298, ..*o }).collect();
        let e = fit(&base, &[("k_d".into(), 0.2)], &huge, 50).unwrap_err().to_string();
        assert!(e.contains("no free parameter changes χ²"), "{e}");
        let tiny_sigma: Vec<Observation> = data.iter().map(|o| Observation { sigma: 1e-300, ..*o }).collect();
        let e = fit(&base, &[("k_d".into(), 0.2)], &tiny_sigma, 50).unwrap_err().to_string();
        assert!(e.contains("overflow double precision"), "{e}");
    }

    /// A fit whose stop flag is set ends after the iteration in flight with its best point.
    #[test]
    fn a_stopped_fit_returns_its_best_point_so_far() {
        static STOP: AtomicBool = AtomicBool::new(true);
        let spec = find("kajiya-kay").unwrap();
        let base = ParamSet::parse::<&str, &str>(spec.name, spec.params, &[]).unwrap();
        let data = luminance_data(&build("kajiya-kay", &[("k_d", "0.3")]).unwrap());
        let free = [FreeParam { key: "k_d".into(), start: vec![0.2] }];
        let options = FitOptions { max_iters: 400, stop: Some(&STOP), ..FitOptions::default() };
        let r = fit_with(&base, &free, &data, &options).unwrap();
        assert!(r.interrupted && r.iterations <= 1, "{r:?}");
        let r = fit_with(&base, &free, &data, &FitOptions { max_iters: 400, ..FitOptions::default() }).unwrap();
        assert!(!r.interrupted && (r.params[0].1 - 0.3).abs() < 1e-3, "{r:?}");
    }

    /// Goldman's f_s is Kajiya–Kay's times `ρ_reflect·a + ρ_transmit·b` (Goldman 1997), so
    /// scaling (k_d, k_s) by c and (ρ_reflect, ρ_transmit) by 1/c fits equally well: the
    /// Jacobian is rank-deficient and every uncertainty is undefined for that reason, while
    /// the identifiable ratio k_d/k_s is recovered.
    #[test]
    fn parameters_that_trade_off_are_reported_as_ill_conditioned() {
        let truth =
            build("goldman", &[("k_d", "0.04"), ("k_s", "0.2"), ("rho_reflect", "0.5"), ("rho_transmit", "0.3")])
                .unwrap();
        let data = luminance_data(&truth);
        let spec = find("goldman").unwrap();
        let base = ParamSet::parse::<&str, &str>(spec.name, spec.params, &[]).unwrap();
        let free: Vec<(String, f64)> = [("k_d", 0.02), ("k_s", 0.1), ("rho_reflect", 0.6), ("rho_transmit", 0.4)]
            .map(|(k, v)| (k.into(), v))
            .into();
        let r = fit(&base, &free, &data, 400).unwrap();
        for u in &r.uncertainties {
            assert!(matches!(u, Uncertainty::Undefined(Undefined::IllConditioned(c)) if *c > MAX_CONDITION), "{u:?}");
        }
        assert!((r.params[0].1 / r.params[1].1 - 0.2).abs() < 1e-3, "{:?}", r.params);
        assert!(Undefined::IllConditioned(1e16).to_string().contains("ill-conditioned"));
    }

    /// A colour fitted per channel from per-channel data of the model itself at a known
    /// absorption: the three channels come back, and luminance-only data of the same model
    /// cannot be fitted with three starting channels.
    #[test]
    fn a_colour_is_recovered_per_channel() {
        let fixed = [("beta_m", "0.3"), ("beta_n", "0.4"), ("alpha", "2")];
        let truth = build("chiang", &[fixed.as_slice(), &[("sigma_a", "0.2,0.6,1.4")]].concat()).unwrap();
        let mut data = Vec::new();
        for (wi, wo) in grid() {
            let f =
                (0..8).map(|k| truth.eval(wi, wo, -1.0 + (k as f64 + 0.5) / 4.0)).fold(Rgb::ZERO, |a, b| a + b) * 0.125;
            for c in 0..3 {
                data.push(Observation { wi, wo, value: f[c], sigma: 0.01 * f[c] + 1e-6, channel: Channel::Rgb(c) });
            }
        }
        let free = [FreeParam { key: "sigma_a".into(), start: vec![0.5] }];
        let calls = Arc::new(std::sync::atomic::AtomicU64::new(0));
        let counter = calls.clone();
        let progress: Arc<dyn Fn(u64) + Send + Sync> = Arc::new(move |_| {
            counter.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        });
        let options = FitOptions { max_iters: 400, progress: Some(progress), stop: None };
        let r = fit_with(&chiang(&fixed), &free, &data, &options).unwrap();
        let names: Vec<&str> = r.params.iter().map(|(k, _)| k.as_str()).collect();
        assert_eq!(names, ["sigma_a[r]", "sigma_a[g]", "sigma_a[b]"]);
        for (c, want) in [0.2, 0.6, 1.4].into_iter().enumerate() {
            assert!((r.params[c].1 - want).abs() < 1e-3 * want, "{:?}", r.params);
        }
        assert_eq!(r.values, vec![("sigma_a".to_string(), r.params.iter().map(|p| p.1).collect())]);
        let calls = calls.load(std::sync::atomic::Ordering::Relaxed);
        assert!(calls > r.iterations && calls <= r.iterations + POLISH_ITERATIONS, "{calls} reports");
        let luminance: Vec<Observation> =
            data.iter().map(|o| Observation { channel: Channel::Luminance, ..*o }).collect();
        let three = [FreeParam { key: "sigma_a".into(), start: vec![0.5, 0.5, 0.5] }];
        let e = fit_with(&chiang(&fixed), &three, &luminance, &options).unwrap_err().to_string();
        assert!(e.contains("cannot tell the channels"), "{e}");
    }
}

#[cfg(test)]
mod surface_tests {
    use super::*;
    use fiberlab_scatter::build_surface;

    fn sadeghi(pairs: &[(&str, &str)]) -> ParamSet {
        let spec = find_surface("sadeghi-2013").unwrap();
        ParamSet::parse(spec.name, spec.params, pairs).unwrap()
    }

    /// A surface table synthesised from `sadeghi-2013` with known thread parameters — bin
    /// averages on a finer quadrature (6 × 6 nodes) than the fit's (3 × 3), plus 2 % noise
    /// per channel — is fitted from other starting values: the parameters come back within
    /// a few standard errors, the colour per channel.
    #[test]
    fn sadeghi_parameters_are_recovered_from_a_noisy_synthetic_table() {
        let truth_pairs = [("gamma_s_1", "9"), ("k_d_1", "0.4"), ("albedo_1", "0.2,0.45,0.7")];
        let truth = build_surface("sadeghi-2013", &truth_pairs).unwrap();
        let mut uniform = fiberlab_check::rng::TestRng::new(2013).into_uniforms();
        let (nt, np) = (12, 24);
        let mut data = SurfaceData::default();
        for (ti, pi) in [(0.5, 0.3), (1.0, 2.0)] {
            let fine = surface_bins(ti, pi, nt, np, 6, false);
            let f = bin_averages(&truth, &fine);
            let first = data.bins.len();
            data.bins.extend(surface_bins(ti, pi, nt, np, 3, false));
            for (b, v) in f.iter().enumerate() {
                for c in 0..3 {
                    let sigma = 0.02 * v[c] + 1e-4;
                    let z = ((0..4).map(|_| uniform()).sum::<f64>() - 2.0) * 3f64.sqrt();
                    data.observations.push(BinObservation {
                        bin: first + b,
                        value: v[c] + sigma * z,
                        sigma,
                        channel: Channel::Rgb(c),
                    });
                }
            }
        }
        let free = [
            FreeParam { key: "gamma_s_1".into(), start: vec![15.0] },
            FreeParam { key: "k_d_1".into(), start: vec![0.2] },
            FreeParam { key: "albedo_1".into(), start: vec![0.5] },
        ];
        let r = fit_surface(&sadeghi(&[]), &free, &data, &FitOptions { max_iters: 600, ..FitOptions::default() }).unwrap();
        let expect = [9.0, 0.4, 0.2, 0.45, 0.7];
        for (k, ((key, v), u)) in r.params.iter().zip(&r.uncertainties).enumerate() {
            let u = u.sigma().unwrap_or_else(|| panic!("{key}: {u:?}"));
            assert!((v - expect[k]).abs() < 5.0 * u + 0.01 * expect[k], "{key} = {v} ± {u}, truth {}", expect[k]);
        }
        assert!(r.chi2 / (r.dof as f64) < 2.0, "reduced χ² {}", r.chi2 / r.dof as f64);
    }

    /// The midpoint bins integrate the BRDF measure exactly for a constant: a Lambertian
    /// surface's bin averages equal k_d/π in every bin, whatever the node count.
    #[test]
    fn bin_averages_of_a_constant_brdf_are_that_constant() {
        let m = build_surface("lambertian", &[("k_d", "0.6")]).unwrap();
        for sub in [1, 4] {
            for f in bin_averages(&m, &surface_bins(0.7, -1.0, 5, 8, sub, sub == 4)) {
                assert!((f.luminance() - 0.6 / std::f64::consts::PI).abs() < 1e-12, "{f:?}");
            }
        }
    }

    /// The fixed direction of a bin is the light's unless `fixed_is_viewer`: for the
    /// non-reciprocal `sadeghi-2013` the two readings differ, and each is the model's
    /// `f_r(ω_light, ω_viewer)` with the directions in their places.
    #[test]
    fn the_fixed_direction_is_the_light_or_the_viewer() {
        let m = build_surface("sadeghi-2013", &[("preset", "silk-shot")]).unwrap();
        let (fixed, d) = (DVec3::new(0.5, 0.1, 0.86).normalize(), DVec3::new(-0.3, 0.6, 0.74).normalize());
        let bin = |fixed_is_viewer| SurfaceBin { fixed, fixed_is_viewer, nodes: vec![(d, 1.0)] };
        let (light, viewer) = (bin(false).average(&m), bin(true).average(&m));
        assert_eq!(light, m.eval(fixed, d));
        assert_eq!(viewer, m.eval(d, fixed));
        assert!((light.luminance() - viewer.luminance()).abs() > 1e-3 * light.luminance(), "{light:?} {viewer:?}");
    }

    /// A fiber model's name is refused by the surface fit, naming the surface models.
    #[test]
    fn a_fiber_model_is_refused_by_the_surface_fit() {
        let spec = find("chiang").unwrap();
        let base = ParamSet::parse::<&str, &str>(spec.name, spec.params, &[]).unwrap();
        let e = fit_surface(
            &base,
            &[FreeParam { key: "beta_m".into(), start: vec![0.3] }],
            &SurfaceData::default(),
            &FitOptions { max_iters: 1, ..FitOptions::default() },
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("fiber model") && e.contains("sadeghi-2013"), "{e}");
    }
}
