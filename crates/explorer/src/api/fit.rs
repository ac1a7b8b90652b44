//! `POST /api/fit`: fit a model's free parameters to a loaded or measured table with
//! [`fiberlab_fit`] (Nelder–Mead, polished by Levenberg–Marquardt, uncertainties from the
//! covariance), streamed as server-sent events so that the page watches the parameters and χ²
//! converge.
//!
//! Request: `{"model", "params" (held fixed), "free": [{"key", "start": x | [r, g, b]}],
//! "table": id, "lobe": "all", "incidence"?: k (default every incidence), "luminance": false,
//! "iterations": 200}`. A fiber table's bins are observations at their centres with the
//! table's standard errors, floored at 1 % of the lobe's peak (as `fiberlab fit --table`
//! builds them); a surface table's bins are fitted with the model's bin averages
//! ([`fiberlab_fit::surface_bins`], [`fiberlab_fit::fit_surface`]), errors floored at the
//! median positive one. Events: `{"type": "step", "iteration", "chi2", "params": [[name,
//! value], …]}` (at most every 50 ms), then `{"type": "done", "params", "uncertainties",
//! "at_bound", "values", "chi2", "dof", "reduced_chi2", "iterations"}`. The work is bounded by
//! the iteration count and the observation limit.

use super::{Events, number, parse, stream};
use crate::error::{ApiError, ApiResult};
use crate::limits;
use crate::request::{ModelChoice, fiber_direction};
use crate::state::{AppState, Table};
use axum::body::Bytes;
use axum::extract::State;
use axum::http::HeaderMap;
use axum::response::IntoResponse;
use fiberlab_fit::{BinObservation, Channel, FitOptions, FitResult, FreeParam, Observation, Step, SurfaceData};
use fiberlab_io::table::{LobeSlices, TableKind};
use fiberlab_scatter::params::ParamSet;
use serde::Deserialize;
use serde_json::{Value, json};
use std::f64::consts::{FRAC_PI_2, PI, TAU};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// A free parameter and its start.
#[derive(Clone, Debug, Deserialize)]
pub struct Free {
    /// The key.
    pub key: String,
    /// One value, or r, g, b for a colour.
    pub start: Start,
}

/// A starting value.
#[derive(Clone, Debug, Deserialize)]
#[serde(untagged)]
pub enum Start {
    /// One number.
    One(f64),
    /// Several (a colour's channels).
    Many(Vec<f64>),
}

fn default_lobe() -> String {
    "all".into()
}
fn default_iterations() -> u64 {
    200
}

/// The request.
#[derive(Debug, Deserialize)]
pub struct FitRequest {
    /// The model and its fixed parameters.
    #[serde(flatten)]
    pub choice: ModelChoice,
    /// The free parameters.
    pub free: Vec<Free>,
    /// The table's id.
    pub table: u64,
    /// The table's lobe (path class).
    #[serde(default = "default_lobe")]
    pub lobe: String,
    /// One incidence (default: all).
    pub incidence: Option<usize>,
    /// Fit luminance only (colours as grey).
    #[serde(default)]
    pub luminance: bool,
    /// Largest number of Nelder–Mead iterations.
    #[serde(default = "default_iterations")]
    pub iterations: u64,
}

fn channels(luminance: bool) -> Vec<Channel> {
    if luminance { vec![Channel::Luminance] } else { (0..3).map(Channel::Rgb).collect() }
}

fn incidences(req: &FitRequest, t: &LobeSlices) -> ApiResult<Vec<usize>> {
    match req.incidence {
        None => Ok((0..t.theta_in.len()).collect()),
        Some(k) if k < t.theta_in.len() => Ok(vec![k]),
        Some(k) => Err(ApiError::bad(format!("incidence {k}: the table has {}", t.theta_in.len()))),
    }
}

/// A fiber table lobe's bins as observations (see the module documentation).
fn fiber_observations(req: &FitRequest, t: &LobeSlices) -> ApiResult<Vec<Observation>> {
    let (nt, np) = (t.bins_theta, t.bins_phi);
    let peak = t.f.iter().flatten().map(|v| v.luminance()).fold(0.0, f64::max);
    let mut obs = Vec::new();
    for s in incidences(req, t)? {
        let wi = fiber_direction(t.theta_in[s], t.phi_in[s]);
        for b in 0..nt * np {
            let tr = -FRAC_PI_2 + ((b / np) as f64 + 0.5) * PI / nt as f64;
            let p = -PI + ((b % np) as f64 + 0.5) * TAU / np as f64;
            for channel in channels(req.luminance) {
                obs.push(Observation {
                    wi,
                    wo: fiber_direction(tr, t.phi_in[s] + p),
                    value: channel.of(t.f[s][b]),
                    sigma: channel.of(t.std[s][b]).max(0.01 * peak),
                    channel,
                });
            }
        }
    }
    Ok(obs)
}

/// A surface table lobe's bins as fit data (see the module documentation).
fn surface_data(req: &FitRequest, t: &LobeSlices) -> ApiResult<SurfaceData> {
    let (nt, np) = (t.bins_theta, t.bins_phi);
    let mut spread: Vec<f64> = t.std.iter().flatten().flat_map(|v| [v[0], v[1], v[2]]).filter(|&v| v > 0.0).collect();
    spread.sort_by(f64::total_cmp);
    let peak = t.f.iter().flatten().map(|v| v.luminance()).fold(0.0, f64::max);
    let floor = spread.get(spread.len() / 2).copied().unwrap_or(0.01 * peak);
    let mut data = SurfaceData::default();
    for s in incidences(req, t)? {
        let first = data.bins.len();
        data.bins.extend(fiberlab_fit::surface_bins(t.theta_in[s], t.phi_in[s], nt, np, 3, false));
        for b in 0..nt * np {
            for channel in channels(req.luminance) {
                data.observations.push(BinObservation {
                    bin: first + b,
                    value: channel.of(t.f[s][b]),
                    sigma: channel.of(t.std[s][b]).max(floor),
                    channel,
                });
            }
        }
    }
    Ok(data)
}

fn result_json(r: &FitResult) -> Value {
    json!({
        "type": "done",
        "params": r.params.iter().map(|(k, v)| json!([k, number(*v)])).collect::<Vec<_>>(),
        "uncertainties": r.uncertainties.iter().map(|u| match u {
            fiberlab_fit::Uncertainty::Sigma(s) => json!({ "sigma": number(*s) }),
            fiberlab_fit::Uncertainty::Undefined(why) => json!({ "undefined": why.to_string() }),
        }).collect::<Vec<_>>(),
        "at_bound": r.at_bound.iter().map(|b| b.map_or(Value::Null, |b| json!(b.to_string()))).collect::<Vec<_>>(),
        "values": r.values.iter().map(|(k, v)| (k.clone(), json!(v))).collect::<serde_json::Map<_, _>>(),
        "chi2": number(r.chi2),
        "dof": r.dof,
        "reduced_chi2": number(r.chi2 / r.dof.max(1) as f64),
        "iterations": r.iterations,
    })
}

/// What a fit needs, checked: the base parameters, the free ones, the table's lobe.
fn prepare(req: &FitRequest, state: &AppState) -> ApiResult<(ParamSet, Vec<FreeParam>, Arc<Table>)> {
    limits::count("iterations", req.iterations as usize, 5000)?;
    let table = state.table(req.table).ok_or_else(|| ApiError::not_found(format!("no table {}", req.table)))?;
    let kind = req.choice.kind()?;
    let spec_params = fiberlab_scatter::lookup(&req.choice.model).map_err(|e| ApiError::bad(e.to_string()))?.info();
    let free_keys: Vec<&str> = req.free.iter().map(|f| f.key.as_str()).collect();
    let pairs: Vec<_> = req.choice.pairs()?.into_iter().filter(|(k, _)| !free_keys.contains(&k.as_str())).collect();
    let base = ParamSet::from_raw(spec_params.name, spec_params.params, &pairs)
        .map_err(|e| ApiError::bad(format!("model `{}`: {e}", req.choice.model)))?;
    let free = req
        .free
        .iter()
        .map(|f| FreeParam {
            key: f.key.clone(),
            start: match &f.start {
                Start::One(x) => vec![*x],
                Start::Many(v) => v.clone(),
            },
        })
        .collect();
    let table_kind = if kind == fiberlab_scatter::ModelKind::Fiber { TableKind::Fiber } else { TableKind::Surface };
    if table.kind != table_kind {
        return Err(ApiError::bad(format!(
            "{} is a {} table; `{}` is a {kind} model",
            table.name,
            if table.kind == TableKind::Fiber { "fiber" } else { "surface" },
            req.choice.model
        )));
    }
    if !table.lobes.contains_key(&req.lobe) {
        return Err(ApiError::bad(format!(
            "{}: no lobe `{}` (it has: {})",
            table.name,
            req.lobe,
            table.lobes.keys().cloned().collect::<Vec<_>>().join(", ")
        )));
    }
    Ok((base, free, table))
}

fn run(req: &FitRequest, state: &AppState, token: &crate::cancel::Token, events: &Events) -> ApiResult<()> {
    let (base, free, table) = prepare(req, state)?;
    let lobe = &table.lobes[&req.lobe];
    let last = Arc::new(Mutex::new(Instant::now() - Duration::from_secs(1)));
    let sink = events.clone_sender();
    let stop = token.clone();
    let options = FitOptions {
        max_iters: req.iterations,
        trace: Some(Arc::new(move |s: &Step| {
            let mut t = last.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
            if t.elapsed() >= Duration::from_millis(50) && !stop.is_cancelled() {
                *t = Instant::now();
                let params: Vec<Value> = s.params.iter().map(|(k, v)| json!([k, number(*v)])).collect();
                if !sink.send(
                    &json!({ "type": "step", "iteration": s.iteration, "chi2": number(s.chi2), "params": params }),
                ) {
                    stop.cancel();
                }
            }
        })),
        stop: Some({
            let token = token.clone();
            Arc::new(move || token.is_cancelled())
        }),
        ..FitOptions::default()
    };
    let max = state.limits().max_observations;
    let result = if table.kind == TableKind::Fiber {
        let obs = fiber_observations(req, lobe)?;
        limits::at_most("observations", obs.len() as u64, max as u64)?;
        fiberlab_fit::fit_with(&base, &free, &obs, &options)
    } else {
        let data = surface_data(req, lobe)?;
        limits::at_most("observations", data.observations.len() as u64, max as u64)?;
        fiberlab_fit::fit_surface(&base, &free, &data, &options)
    };
    let r = result.map_err(|e| ApiError::bad(format!("fit: {e}")))?;
    // A cancelled fit ends with a 409 event, not with its unfinished point as a result.
    super::alive(token)?;
    events.send(&result_json(&r));
    Ok(())
}

/// `POST /api/fit`.
pub async fn fit(State(state): State<AppState>, headers: HeaderMap, body: Bytes) -> ApiResult<impl IntoResponse> {
    let req: FitRequest = parse(&body)?;
    prepare(&req, &state)?;
    let (token, guard) = state.supersede(&headers, "fit");
    Ok(stream(guard, move |events| run(&req, &state, &token, events)))
}
