//! The least-squares problem: free coordinates (a parameter, or one channel of a colour) set as
//! numbers on a model's validated parameters, the normalized residuals of the trial model, and
//! χ² as the optimizer's cost (parameters outside their valid range, or models a constraint
//! rejects, cost "infinitely" much).

use crate::observation::Observation;
use crate::outcome::{FitError, FreeParam, Step, Trace};
use argmin::core::observers::Observe;
use argmin::core::{CostFunction, Error, KV, State};
use fiberlab_math::{DVec3, Rgb};
use fiberlab_scatter::params::{ParamKind, ParamSet, Range, RawValue};
use fiberlab_scatter::{Model, ModelError, ModelInfo, ScatteringFunction};
use std::sync::Arc;

/// One free number: a parameter, or one channel of a colour parameter.
#[derive(Clone, Debug)]
pub(crate) struct Coordinate {
    pub(crate) key: &'static str,
    /// `None`: the whole parameter (a number, or a colour as grey); `Some(c)`: channel c.
    pub(crate) channel: Option<usize>,
    pub(crate) range: Range,
}

impl Coordinate {
    pub(crate) fn name(&self) -> String {
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
pub(crate) struct Problem<'a, M> {
    pub(crate) build: &'a dyn Fn(&ParamSet) -> Result<M, ModelError>,
    pub(crate) base: &'a ParamSet,
    pub(crate) coordinates: &'a [Coordinate],
    pub(crate) residuals: &'a dyn Fn(&M) -> Vec<f64>,
    pub(crate) constraint: Option<&'a (dyn Fn(&M) -> bool + Sync)>,
}

impl<M> Clone for Problem<'_, M> {
    fn clone(&self) -> Self {
        Self { ..*self }
    }
}

impl<M> Problem<'_, M> {
    pub(crate) fn model_at(&self, p: &[f64]) -> Result<M, ModelError> {
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
    pub(crate) fn admits(&self, m: &M) -> bool {
        self.constraint.is_none_or(|admissible| admissible(m))
    }

    pub(crate) fn residuals(&self, m: &M) -> Vec<f64> {
        (self.residuals)(m)
    }
}

/// Normalized residuals of a fiber model on point observations.
pub(crate) fn fiber_residuals(data: &[Observation], m: &Model) -> Vec<f64> {
    // The channels of one direction pair follow each other: evaluate the model once for them.
    let mut last: Option<(DVec3, DVec3, Rgb)> = None;
    data.iter()
        .map(|o| {
            let f = match last {
                Some((wi, wo, f)) if wi == o.wi && wo == o.wo => f,
                _ => {
                    let f = m.eval_far(o.wi, o.wo);
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

/// Reports each optimizer iteration to the callbacks of [`crate::FitOptions`].
pub(crate) struct IterationObserver {
    pub(crate) progress: Option<Arc<dyn Fn(u64) + Send + Sync>>,
    pub(crate) trace: Option<Trace>,
    pub(crate) names: Vec<String>,
}

impl<I: State<Param = Vec<f64>, Float = f64>> Observe<I> for IterationObserver {
    fn observe_iter(&mut self, state: &I, _kv: &KV) -> Result<(), Error> {
        if let Some(progress) = &self.progress {
            progress(state.get_iter());
        }
        if let (Some(trace), Some(best)) = (&self.trace, state.get_best_param()) {
            let params = self.names.iter().cloned().zip(best.iter().copied()).collect();
            trace(&Step { iteration: state.get_iter(), params, chi2: state.get_best_cost() });
        }
        Ok(())
    }
}

/// The free coordinates of `free` in the parameter table of `info` and their starting
/// values: a colour parameter is three coordinates when `per_channel`.
pub(crate) fn coordinates_of(
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
/// Largest |value| a fit accepts (sr⁻¹): many orders above the peak of any lobe a model
/// builds (even the narrowest longitudinal lobe at a grazing angle), and far below the scale
/// (1e154) where χ² overflows; larger values are data in the wrong units.
pub(crate) const MAX_VALUE: f64 = 1e30;

pub(crate) fn check_data(
    observations: usize,
    free: usize,
    values: impl Iterator<Item = (f64, f64)>,
) -> Result<(), FitError> {
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
        if v.abs() > MAX_VALUE {
            return Err(FitError::Setup(format!(
                "an observed value of {v:e} sr⁻¹ is beyond any scattering function (at most {MAX_VALUE:e} here): \
                 no free parameter changes χ² at the data's scale; check the data's units"
            )));
        }
        all_zero &= v == 0.0;
    }
    if all_zero {
        return Err(FitError::Setup("every observed value is 0: there is nothing to fit".into()));
    }
    Ok(())
}

/// Columns of the residuals' Jacobian by central differences (one-sided at the edge of a
/// parameter's valid range); `None` for a coordinate the model cannot be built on either side of.
pub(crate) fn jacobian<M>(problem: &Problem<M>, p: &[f64], r0: &[f64]) -> Vec<Option<Vec<f64>>> {
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
