//! `POST /api/map` and `POST /api/slices`: what the scattering views draw.
//!
//! **Map.** Fiber: `f_s(ω_i, ω_r)` over θ_r ∈ [−90°, 90°] (rows, from −90° up) and
//! φ = φ_r − φ_i ∈ [−180°, 180°] (columns) for light at (θ_i, φ_i); near-field models at the
//! requested `h`, or averaged over the width when `h` is absent ([`crate::request::offsets`]).
//! `lobes` (optional) sums only those lobes ([`crate::request::Parts`]). Surface: `f_r` over
//! the hemisphere, θ_o ∈ [0°, 90°] from the normal (rows) and φ_o (columns), light at
//! (θ_i, φ_i). The answer: `{rows, cols, theta: [lo, hi], values: [row-major], max,
//! min_positive, delta, cone}`; for a delta model (the ideal specular fiber) the map is zero
//! and `cone` is its distribution over φ on the cone θ_r = −θ_i.
//!
//! **Slices.** Fiber, per lobe: the longitudinal marginal `M_p(θ_r) = ∫ f_p dφ` and the
//! azimuthal distribution `N_p(φ) = ∫ f_p cos²θ_r dθ_r` (power per unit φ, as `fiberlab plot`
//! draws it), and `f_p` on the specular cone θ_r = −θ_i. Surface: `f_r` along the plane of
//! incidence and the plane across it (signed θ_o), and `∫ f_r cosθ_o sinθ_o dθ_o` over φ_o.

use super::{alive, blocking, number, parse};
use crate::cancel::Token;
use crate::error::{ApiError, ApiResult};
use crate::limits::{self, Limits};
use crate::request::{Built, Channel, ModelChoice, Parts, degrees, fiber_direction, offset, offsets};
use crate::state::AppState;
use axum::Json;
use axum::body::Bytes;
use axum::extract::State;
use axum::http::HeaderMap;
use fiberlab_check::surface::surface_direction;
use fiberlab_math::Rgb;
use fiberlab_scatter::{Lobes, Model, ScatteringFunction, SurfaceModel, SurfaceScattering};
use rayon::prelude::*;
use serde::Deserialize;
use serde_json::{Value, json};
use std::f64::consts::{FRAC_PI_2, PI, TAU};

fn default_rows() -> usize {
    90
}
fn default_cols() -> usize {
    180
}
fn default_points() -> usize {
    181
}

/// Where the light is and what to draw.
#[derive(Clone, Debug, Deserialize)]
pub struct View {
    /// The model.
    #[serde(flatten)]
    pub choice: ModelChoice,
    /// Light inclination, degrees: from the normal plane (fibers, [−90, 90]) or from the
    /// normal (surfaces, [0, 90)).
    pub theta_i: f64,
    /// Light azimuth, degrees (fibers: about the axis, from the frame's y; surfaces: from the
    /// tangent x).
    #[serde(default)]
    pub phi_i: f64,
    /// Offset across a near-field fiber; absent: averaged over the width.
    pub h: Option<f64>,
    /// Rows (θ) of a map.
    #[serde(default = "default_rows")]
    pub rows: usize,
    /// Columns (φ) of a map.
    #[serde(default = "default_cols")]
    pub cols: usize,
    /// Points along each slice.
    #[serde(default = "default_points")]
    pub points: usize,
    /// Channel of the values.
    #[serde(default)]
    pub channel: Channel,
    /// Only these lobes (fibers; names of [`Parts`]).
    pub lobes: Option<Vec<String>>,
}

/// The checked light direction: fiber (θ from the normal plane) or surface (θ from the normal).
pub(crate) fn light(view: &View, surface: bool) -> ApiResult<(f64, f64)> {
    let theta = if surface {
        degrees("theta_i", view.theta_i, 0.0, 89.99)?
    } else {
        degrees("theta_i", view.theta_i, -90.0, 90.0)?
    };
    Ok((theta, degrees("phi_i", view.phi_i, -360.0, 360.0)?))
}

/// A fiber's value at one pair: the whole model, or the sum of the chosen lobes, at the
/// offsets.
struct FiberValue {
    model: Model,
    parts: Option<(Parts, Vec<bool>)>,
    offsets: Vec<(f64, f64)>,
    channel: Channel,
}

impl FiberValue {
    fn new(view: &View) -> ApiResult<Self> {
        let model = view.choice.build_fiber()?;
        let h = view.h.map(offset).transpose()?;
        let parts = match &view.lobes {
            None => None,
            Some(chosen) => {
                let parts = Parts::of(&view.choice)?;
                if let Some(bad) = chosen.iter().find(|c| !parts.names.contains(c)) {
                    return Err(ApiError::bad(format!(
                        "lobes: `{bad}` is not a lobe of `{}` (its lobes: {})",
                        view.choice.model,
                        parts.names.join(", ")
                    )));
                }
                let on = parts.names.iter().map(|n| chosen.contains(n)).collect();
                Some((parts, on))
            }
        };
        Ok(Self { offsets: offsets(&model, h), model, parts, channel: view.channel })
    }

    fn at(&self, wi: fiberlab_math::DVec3, wo: fiberlab_math::DVec3, scratch: &mut Vec<Rgb>) -> f64 {
        let mut sum = Rgb::ZERO;
        match &self.parts {
            None => {
                for &(h, w) in &self.offsets {
                    sum += self.model.eval(wi, wo, h) * w;
                }
            }
            Some((parts, on)) => {
                scratch.resize(parts.names.len(), Rgb::ZERO);
                for &(h, w) in &self.offsets {
                    parts.eval(wi, wo, h, scratch);
                    for (v, &o) in scratch.iter().zip(on) {
                        if o {
                            sum += *v * w;
                        }
                    }
                }
            }
        }
        self.channel.of(sum)
    }
}

/// Maximum and smallest positive value.
pub(crate) fn range_of(values: &[f32]) -> (f64, f64) {
    let max = values.iter().copied().fold(0.0f32, f32::max);
    let min = values.iter().copied().filter(|&v| v > 0.0).fold(f32::INFINITY, f32::min);
    (f64::from(max), if min.is_finite() { f64::from(min) } else { 0.0 })
}

fn check_grid(view: &View, limits: &Limits) -> ApiResult<()> {
    limits::count("rows", view.rows, limits.max_cells)?;
    limits::count("cols", view.cols, limits.max_cells)?;
    limits::at_most("rows × cols", (view.rows * view.cols) as u64, limits.max_cells as u64)
}

/// The fiber map's values, row-major (see the module documentation), and the model's cone
/// over the columns when it is a delta model.
pub fn fiber_grid(view: &View, limits: &Limits, token: &Token) -> ApiResult<(Vec<f32>, Option<Vec<f64>>)> {
    check_grid(view, limits)?;
    let (theta_i, phi_i) = light(view, false)?;
    let value = FiberValue::new(view)?;
    let (rows, cols) = (view.rows, view.cols);
    let delta = value.model.properties().lobes == Lobes::Delta;
    let wi = fiber_direction(theta_i, phi_i);
    let values: Vec<f32> = if delta {
        vec![0.0; rows * cols]
    } else {
        let per_row: Vec<Vec<f32>> = (0..rows)
            .into_par_iter()
            .map(|r| {
                alive(token)?;
                let tr = -FRAC_PI_2 + (r as f64 + 0.5) * PI / rows as f64;
                let mut scratch = Vec::new();
                Ok((0..cols)
                    .map(|c| {
                        let p = -PI + (c as f64 + 0.5) * TAU / cols as f64;
                        value.at(wi, fiber_direction(tr, phi_i + p), &mut scratch) as f32
                    })
                    .collect())
            })
            .collect::<ApiResult<_>>()?;
        per_row.concat()
    };
    let cone = delta.then(|| {
        (0..cols)
            .map(|c| value.channel.of(value.model.cone(theta_i, -PI + (c as f64 + 0.5) * TAU / cols as f64).value))
            .collect()
    });
    Ok((values, cone))
}

/// The fiber map (see the module documentation).
pub fn fiber_map(view: &View, limits: &Limits, token: &Token) -> ApiResult<Value> {
    let (values, cone) = fiber_grid(view, limits, token)?;
    let (rows, cols) = (view.rows, view.cols);
    let delta = cone.is_some();
    let cone = cone.unwrap_or_default();
    let (max, min_positive) = range_of(&values);
    Ok(json!({
        "kind": "fiber",
        "rows": rows, "cols": cols,
        "theta": [-90.0, 90.0], "phi": [-180.0, 180.0],
        "values": values,
        "max": number(max), "min_positive": number(min_positive),
        "delta": delta, "cone": cone,
    }))
}

/// The surface map's values, row-major (see the module documentation).
pub fn surface_grid(view: &View, model: &SurfaceModel, limits: &Limits, token: &Token) -> ApiResult<Vec<f32>> {
    check_grid(view, limits)?;
    let (theta_i, phi_i) = light(view, true)?;
    let wi = surface_direction(theta_i, phi_i);
    let (rows, cols) = (view.rows, view.cols);
    let per_row: Vec<Vec<f32>> = (0..rows)
        .into_par_iter()
        .map(|r| {
            alive(token)?;
            let t = (r as f64 + 0.5) * FRAC_PI_2 / rows as f64;
            Ok((0..cols)
                .map(|c| {
                    let p = -PI + (c as f64 + 0.5) * TAU / cols as f64;
                    view.channel.of(model.eval(wi, surface_direction(t, p))) as f32
                })
                .collect())
        })
        .collect::<ApiResult<_>>()?;
    Ok(per_row.concat())
}

/// The surface map (see the module documentation).
pub fn surface_map(view: &View, model: &SurfaceModel, limits: &Limits, token: &Token) -> ApiResult<Value> {
    let values = surface_grid(view, model, limits, token)?;
    let (rows, cols) = (view.rows, view.cols);
    let (max, min_positive) = range_of(&values);
    Ok(json!({
        "kind": "surface",
        "rows": rows, "cols": cols,
        "theta": [0.0, 90.0], "phi": [-180.0, 180.0],
        "values": values,
        "max": number(max), "min_positive": number(min_positive),
        "delta": false, "cone": [],
    }))
}

/// `POST /api/map`.
pub async fn map(State(state): State<AppState>, headers: HeaderMap, body: Bytes) -> ApiResult<Json<Value>> {
    let view: View = parse(&body)?;
    let (token, _guard) = state.supersede(&headers, "map");
    let limits = state.limits().clone();
    blocking(move || match view.choice.build()? {
        Built::Fiber(_) => fiber_map(&view, &limits, &token),
        Built::Surface(m) => surface_map(&view, &m, &limits, &token),
    })
    .await
    .map(Json)
}

/// Nodes of the integrals along the other angle of a slice.
const SLICE_NODES: usize = 90;

/// The fiber slices (see the module documentation).
pub fn fiber_slices(view: &View, limits: &Limits, token: &Token) -> ApiResult<Value> {
    let n = limits::count("points", view.points, limits.max_slice_points)?;
    let (theta_i, phi_i) = light(view, false)?;
    let parts = Parts::of(&view.choice)?;
    let h = view.h.map(offset).transpose()?;
    let offs = offsets(parts.model(), h);
    let k = parts.names.len();
    let wi = fiber_direction(theta_i, phi_i);
    let delta = parts.model().properties().lobes == Lobes::Delta;
    let channel = view.channel;
    // Per-lobe value at (θ_r, φ), averaged over the offsets.
    let lobes_at = |tr: f64, p: f64, scratch: &mut Vec<Rgb>, out: &mut [f64]| {
        scratch.resize(k, Rgb::ZERO);
        out.iter_mut().for_each(|o| *o = 0.0);
        for &(h, w) in &offs {
            parts.eval(wi, fiber_direction(tr, phi_i + p), h, scratch);
            for (o, v) in out.iter_mut().zip(scratch.iter()) {
                *o += channel.of(*v) * w;
            }
        }
    };
    let theta_at = |j: usize, m: usize| -FRAC_PI_2 + (j as f64 + 0.5) * PI / m as f64;
    let phi_at = |j: usize, m: usize| -PI + (j as f64 + 0.5) * TAU / m as f64;
    let longitudinal: Vec<Vec<f64>> = (0..n)
        .into_par_iter()
        .map(|j| {
            alive(token)?;
            let (mut scratch, mut v, mut sum) = (Vec::new(), vec![0.0; k], vec![0.0; k]);
            for q in 0..2 * SLICE_NODES {
                lobes_at(theta_at(j, n), phi_at(q, 2 * SLICE_NODES), &mut scratch, &mut v);
                sum.iter_mut().zip(&v).for_each(|(s, x)| *s += x * TAU / (2 * SLICE_NODES) as f64);
            }
            Ok(sum)
        })
        .collect::<ApiResult<_>>()?;
    let azimuthal: Vec<Vec<f64>> = (0..n)
        .into_par_iter()
        .map(|j| {
            alive(token)?;
            let (mut scratch, mut v, mut sum) = (Vec::new(), vec![0.0; k], vec![0.0; k]);
            for q in 0..SLICE_NODES {
                let tr = theta_at(q, SLICE_NODES);
                lobes_at(tr, phi_at(j, n), &mut scratch, &mut v);
                let w = tr.cos().powi(2) * PI / SLICE_NODES as f64;
                sum.iter_mut().zip(&v).for_each(|(s, x)| *s += x * w);
            }
            Ok(sum)
        })
        .collect::<ApiResult<_>>()?;
    let cone: Vec<Vec<f64>> = (0..n)
        .map(|j| {
            let mut v = vec![0.0; k];
            if delta {
                v[0] = channel.of(parts.model().cone(theta_i, phi_at(j, n)).value);
            } else {
                lobes_at(-theta_i, phi_at(j, n), &mut Vec::new(), &mut v);
            }
            v
        })
        .collect();
    let per_lobe = |rows: &[Vec<f64>]| -> Value {
        parts
            .names
            .iter()
            .enumerate()
            .map(|(l, name)| (name.clone(), json!(rows.iter().map(|r| r[l]).collect::<Vec<_>>())))
            .collect::<serde_json::Map<_, _>>()
            .into()
    };
    Ok(json!({
        "kind": "fiber",
        "lobes": parts.names,
        "delta": delta,
        "theta": (0..n).map(|j| theta_at(j, n).to_degrees()).collect::<Vec<_>>(),
        "phi": (0..n).map(|j| phi_at(j, n).to_degrees()).collect::<Vec<_>>(),
        "longitudinal": per_lobe(&longitudinal),
        "azimuthal": per_lobe(&azimuthal),
        "cone": per_lobe(&cone),
    }))
}

/// The surface slices (see the module documentation).
pub fn surface_slices(view: &View, model: &SurfaceModel, limits: &Limits, token: &Token) -> ApiResult<Value> {
    let n = limits::count("points", view.points, limits.max_slice_points)?;
    let (theta_i, phi_i) = light(view, true)?;
    let wi = surface_direction(theta_i, phi_i);
    let f = |t: f64, p: f64| view.channel.of(model.eval(wi, surface_direction(t, p)));
    // Signed θ_o in (−90°, 90°): positive toward azimuth `a`, negative toward `a + π`.
    let signed = |j: usize| -FRAC_PI_2 + (j as f64 + 0.5) * PI / n as f64;
    let plane = |a: f64| -> Vec<f64> {
        (0..n)
            .map(|j| {
                let s = signed(j);
                if s >= 0.0 { f(s, a) } else { f(-s, a + PI) }
            })
            .collect()
    };
    alive(token)?;
    let incidence = plane(phi_i + PI);
    let across = plane(phi_i + FRAC_PI_2);
    let phi_at = |j: usize| -PI + (j as f64 + 0.5) * TAU / n as f64;
    let azimuthal: Vec<f64> = (0..n)
        .into_par_iter()
        .map(|j| {
            (0..SLICE_NODES)
                .map(|q| {
                    let t = (q as f64 + 0.5) * FRAC_PI_2 / SLICE_NODES as f64;
                    f(t, phi_at(j)) * t.cos() * t.sin() * FRAC_PI_2 / SLICE_NODES as f64
                })
                .sum()
        })
        .collect();
    alive(token)?;
    Ok(json!({
        "kind": "surface",
        "lobes": ["all"],
        "delta": false,
        "theta": (0..n).map(|j| signed(j).to_degrees()).collect::<Vec<_>>(),
        "phi": (0..n).map(|j| phi_at(j).to_degrees()).collect::<Vec<_>>(),
        "incidence_plane": incidence,
        "across_plane": across,
        "azimuthal": { "all": azimuthal },
    }))
}

/// `POST /api/slices`.
pub async fn slices(State(state): State<AppState>, headers: HeaderMap, body: Bytes) -> ApiResult<Json<Value>> {
    let view: View = parse(&body)?;
    let (token, _guard) = state.supersede(&headers, "slices");
    let limits = state.limits().clone();
    blocking(move || {
        state.in_background(|| match view.choice.build()? {
            Built::Fiber(_) => fiber_slices(&view, &limits, &token),
            Built::Surface(m) => surface_slices(&view, &m, &limits, &token),
        })
    })
    .await
    .map(Json)
}
