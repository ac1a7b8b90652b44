//! `POST /api/measure`: measure an explicit fiber with the virtual goniophotometer
//! ([`fiberlab_gonio::measure`]) on the server, streamed as server-sent events.
//!
//! Request: `{"fiber": {key: value} (the keys of `fiberlab measure --param`,
//! [`fiberlab_gonio::FIBER_PARAMS`]), "theta_i": [degrees…], "phi_i": 0, "rays": 1000000,
//! "bins_theta": 90, "bins_phi": 180, "seed": 1}`. Events: `{"type": "progress", "done",
//! "total"}` (rays), then `{"type": "done", "table": summary}` — the table is kept like an
//! uploaded one ([`crate::api::tables`]) for Compare and Fit. Rays, bins and the measurement's
//! memory ([`fiberlab_gonio::Setup::estimated_bytes`]) are checked first; the page going
//! away stops the measurement.

use super::{Events, parse, stream};
use crate::error::{ApiError, ApiResult};
use crate::limits;
use crate::request::{degrees, raw};
use crate::state::{AppState, Table};
use axum::body::Bytes;
use axum::extract::State;
use axum::http::HeaderMap;
use axum::response::IntoResponse;
use fiberlab_gonio::{Fiber, Measurement, Setup};
use fiberlab_io::table::{LobeSlices, TableKind};
use serde::Deserialize;
use serde_json::{Map, Value, json};
use std::collections::BTreeMap;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{Duration, Instant};

fn default_rays() -> usize {
    1_000_000
}
fn default_bins_theta() -> usize {
    90
}
fn default_bins_phi() -> usize {
    180
}
fn default_seed() -> u64 {
    1
}

/// The request.
#[derive(Debug, Deserialize)]
pub struct MeasureRequest {
    /// The explicit fiber's parameters.
    #[serde(default)]
    pub fiber: Map<String, Value>,
    /// Light inclinations, degrees in (−89.9, 89.9).
    pub theta_i: Vec<f64>,
    /// Light azimuth, degrees.
    #[serde(default)]
    pub phi_i: f64,
    /// Rays per incidence.
    #[serde(default = "default_rays")]
    pub rays: usize,
    /// Bins in θ_r.
    #[serde(default = "default_bins_theta")]
    pub bins_theta: usize,
    /// Bins in φ.
    #[serde(default = "default_bins_phi")]
    pub bins_phi: usize,
    /// Seed of the ray streams.
    #[serde(default = "default_seed")]
    pub seed: u64,
}

/// The checked fiber and setups.
pub fn prepare(req: &MeasureRequest, state: &AppState) -> ApiResult<(Fiber, Vec<Setup>)> {
    let l = state.limits();
    let pairs: Vec<(String, fiberlab_scatter::params::RawValue)> = req
        .fiber
        .iter()
        .filter_map(|(k, v)| raw(k, v).transpose().map(|r| r.map(|r| (k.clone(), r))))
        .collect::<ApiResult<_>>()?;
    let fiber = Fiber::from_raw(&pairs).map_err(|e| ApiError::bad(e.to_string()))?;
    limits::count("theta_i (incidences)", req.theta_i.len(), 16)?;
    limits::count("rays", req.rays, l.max_rays)?;
    limits::at_most("rays × incidences", (req.rays * req.theta_i.len()) as u64, l.max_rays as u64)?;
    limits::count("bins_theta", req.bins_theta, l.max_bins)?;
    limits::count("bins_phi", req.bins_phi, l.max_bins)?;
    limits::at_most("bins (θ × φ)", (req.bins_theta * req.bins_phi) as u64, l.max_bins as u64)?;
    let phi_i = degrees("phi_i", req.phi_i, -360.0, 360.0)?;
    let setups = req
        .theta_i
        .iter()
        .map(|&t| {
            let theta_i = degrees("theta_i", t, -89.9, 89.9)?;
            let setup = Setup {
                theta_i,
                phi_i,
                rays: req.rays,
                bins_theta: req.bins_theta,
                bins_phi: req.bins_phi,
                seed: req.seed,
            };
            setup.check_bins().map_err(|e| ApiError::bad(e.to_string()))?;
            limits::memory(
                "the measurement",
                setup.estimated_bytes(rayon::current_num_threads()).and_then(|b| {
                    b.checked_add(
                        req.theta_i.len() as u64 * (setup.bin_count()? * fiberlab_gonio::RESULT_BYTES_PER_BIN),
                    )
                }),
                l,
            )?;
            Ok(setup)
        })
        .collect::<ApiResult<Vec<_>>>()?;
    Ok((fiber, setups))
}

/// The measurements as one table (lobes by [`Measurement::LOBE_NAMES`]).
pub fn table_of(name: String, measurements: &[Measurement]) -> Table {
    let mut lobes = BTreeMap::new();
    for (k, lobe) in Measurement::LOBE_NAMES.iter().enumerate() {
        let mut slices = LobeSlices {
            theta_in: Vec::new(),
            phi_in: Vec::new(),
            bins_theta: 0,
            bins_phi: 0,
            f: Vec::new(),
            std: Vec::new(),
        };
        for m in measurements {
            slices.theta_in.push(m.setup.theta_i);
            slices.phi_in.push(m.setup.phi_i);
            slices.bins_theta = m.setup.bins_theta;
            slices.bins_phi = m.setup.bins_phi;
            slices.f.push(m.lobes[k].f.clone());
            slices.std.push(m.lobes[k].std.clone());
        }
        lobes.insert((*lobe).to_string(), slices);
    }
    Table { name, kind: TableKind::Fiber, lobes }
}

fn run(req: &MeasureRequest, state: &AppState, token: &crate::cancel::Token, events: &Events) -> ApiResult<()> {
    let (fiber, setups) = prepare(req, state)?;
    let total = req.rays * setups.len();
    let mut measurements = Vec::with_capacity(setups.len());
    for (k, setup) in setups.iter().enumerate() {
        let before = k * req.rays;
        let last = std::sync::Mutex::new(Instant::now());
        let done = AtomicUsize::new(0);
        let m = fiberlab_gonio::measure(&fiber, setup, token.flag(), |rays| {
            done.store(rays, Ordering::Relaxed);
            let mut t = last.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
            if t.elapsed() > Duration::from_millis(100) {
                *t = Instant::now();
                if !events.send(&json!({ "type": "progress", "done": before + rays, "total": total })) {
                    token.cancel();
                }
            }
        })
        .map_err(|e| ApiError::bad(e.to_string()))?;
        // A cancelled stream ends with a 409 event (the page ignores it; a client that
        // stays to the end, as at a server shutdown, learns why it ended).
        super::alive(token)?;
        events.send(&json!({ "type": "progress", "done": before + m.traced, "total": total }));
        measurements.push(m);
    }
    let degrees: Vec<String> = req.theta_i.iter().map(|t| format!("{t}")).collect();
    let name = format!("measured θ_i = {}°, {} rays", degrees.join(", "), req.rays);
    let table = table_of(name, &measurements);
    let id = state.add_table(table.clone());
    events.send(&json!({ "type": "done", "table": super::tables::summary_json(id, &table) }));
    Ok(())
}

/// `POST /api/measure`.
pub async fn measure(State(state): State<AppState>, headers: HeaderMap, body: Bytes) -> ApiResult<impl IntoResponse> {
    let req: MeasureRequest = parse(&body)?;
    // Refuse bad input at once (400), before the event stream starts.
    prepare(&req, &state)?;
    let (token, guard) = state.supersede(&headers, "measure");
    Ok(stream(guard, move |events| run(&req, &state, &token, events)))
}
