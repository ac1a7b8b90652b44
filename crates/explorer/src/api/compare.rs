//! `POST /api/compare`: a model `a` against a reference — a second model `b` of the same kind,
//! or a loaded or measured table (`table`: its id) — on the same axes, with the difference
//! `a − reference` and, per lobe, the relative L2 error
//! `sqrt(Σ w (a − ref)² / Σ w ref²)` with the bins' measure `w` (∫cos²θ dθ dφ for fibers, as
//! `fiberlab compare-model` weighs its bins; `cosθ dω` for surfaces) and, against a table,
//! the same norm of the table's Monte Carlo errors (`mc_rel_l2`: what a perfect model gets).
//!
//! Against a fiber table this is `fiberlab compare-model`'s comparison
//! ([`fiberlab_compare::fiber_table`]) at the incidence nearest θ_i: the model's average over
//! each bin of its width-averaged `f_s` ([`fiberlab_scatter::ScatteringFunction::eval_far`]),
//! in luminance whatever the view's channel, lobe by lobe (the table's `r`, `tt`, `trt`,
//! `medulla` against the model reduced to that lobe, `all` against the whole model). Against a
//! surface table, the model's bin averages of [`fiberlab_fit::surface_bins`] are compared with
//! the table's `all` class.

use super::plots::{View, fiber_grid, light, surface_grid};
use super::{alive, blocking, number, parse};
use crate::cancel::Token;
use crate::error::{ApiError, ApiResult};
use crate::limits::Limits;
use crate::request::{Built, ModelChoice, Parts};
use crate::state::{AppState, Table};
use axum::Json;
use axum::body::Bytes;
use axum::extract::State;
use axum::http::HeaderMap;
use fiberlab_compare::fiber_table::{LOBES, bin_averages, compare_incidence};
use fiberlab_io::table::{LobeSlices, TableKind};
use fiberlab_math::Rgb;
use fiberlab_render::model_loader::ModelRequest;
use rayon::prelude::*;
use serde::Deserialize;
use serde_json::{Value, json};
use std::f64::consts::{FRAC_PI_2, PI};

/// Midpoint sub-samples per bin along θ_r (`fiberlab compare-model`'s default).
const SUBSAMPLES: usize = 3;

/// The request: a [`View`] of model `a` (flattened) and the reference.
#[derive(Debug, Deserialize)]
pub struct CompareRequest {
    /// Model `a` and where the light is.
    #[serde(flatten)]
    pub view: View,
    /// The reference model (same kind as `a`).
    pub b: Option<ModelChoice>,
    /// Or the reference table's id.
    pub table: Option<u64>,
    /// Which incidence of the table (default: the one nearest `theta_i`).
    pub incidence: Option<usize>,
}

/// Relative L2 of `a` against `reference` under the weights, and of `std` if given.
fn rel_l2(a: &[f64], reference: &[f64], std: Option<&[f64]>, weight: impl Fn(usize) -> f64) -> (f64, Option<f64>) {
    let (mut num, mut den, mut mc) = (0.0, 0.0, 0.0);
    for b in 0..a.len() {
        let w = weight(b);
        num += w * (a[b] - reference[b]).powi(2);
        den += w * reference[b].powi(2);
        if let Some(s) = std {
            mc += w * s[b].powi(2);
        }
    }
    let ratio = |x: f64| if den > 0.0 { (x / den).sqrt() } else { f64::NAN };
    (ratio(num), std.map(|_| ratio(mc)))
}

/// `∫ cos²θ dθ` over θ-row `i` of `rows` rows on [−π/2, π/2] (the fiber bins' measure, per
/// unit φ).
fn fiber_row_weight(i: usize, rows: usize) -> f64 {
    let a = -FRAC_PI_2 + i as f64 * PI / rows as f64;
    let prim = |x: f64| 0.5 * x + 0.25 * (2.0 * x).sin();
    prim(a + PI / rows as f64) - prim(a)
}

/// `∫ cosθ sinθ dθ` over θ-row `i` of `rows` rows on [0, π/2] (the surface bins' measure).
fn surface_row_weight(i: usize, rows: usize) -> f64 {
    let dt = FRAC_PI_2 / rows as f64;
    0.5 * (((i + 1) as f64 * dt).sin().powi(2) - (i as f64 * dt).sin().powi(2))
}

fn to_f64(v: &[f32]) -> Vec<f64> {
    v.iter().map(|&x| f64::from(x)).collect()
}

fn answer(
    rows: usize,
    cols: usize,
    theta: [f64; 2],
    a: &[f64],
    b: &[f64],
    lobes: Vec<Value>,
    incidence: Value,
) -> Value {
    let difference: Vec<f32> = a.iter().zip(b).map(|(x, y)| (x - y) as f32).collect();
    let af: Vec<f32> = a.iter().map(|&x| x as f32).collect();
    let bf: Vec<f32> = b.iter().map(|&x| x as f32).collect();
    let (amax, amin) = super::plots::range_of(&af);
    let (bmax, bmin) = super::plots::range_of(&bf);
    let dmax = difference.iter().fold(0.0f32, |m, d| m.max(d.abs()));
    json!({
        "rows": rows, "cols": cols, "theta": theta, "phi": [-180.0, 180.0],
        "a": af, "b": bf, "difference": difference,
        "max": number(amax.max(bmax)), "min_positive": number(if amin > 0.0 && bmin > 0.0 { amin.min(bmin) } else { amin.max(bmin) }),
        "difference_max": number(f64::from(dmax)),
        "lobes": lobes, "incidence": incidence,
    })
}

/// Model against model.
fn two_models(req: &CompareRequest, b: &ModelChoice, limits: &Limits, token: &Token) -> ApiResult<Value> {
    let view = &req.view;
    let (ka, kb) = (view.choice.kind()?, b.kind()?);
    if ka != kb {
        return Err(ApiError::bad(format!(
            "`{}` is a {ka} model and `{}` a {kb} model: compare models of one kind",
            view.choice.model, b.model
        )));
    }
    let view_b = View { choice: b.clone(), ..view.clone() };
    let (rows, cols) = (view.rows, view.cols);
    match view.choice.build()? {
        Built::Surface(ma) => {
            let Built::Surface(mb) = b.build()? else { unreachable!("kinds checked") };
            let a = to_f64(&surface_grid(view, &ma, limits, token)?);
            let r = to_f64(&surface_grid(&view_b, &mb, limits, token)?);
            let (l2, _) = rel_l2(&a, &r, None, |k| surface_row_weight(k / cols, rows));
            Ok(answer(
                rows,
                cols,
                [0.0, 90.0],
                &a,
                &r,
                vec![json!({ "name": "all", "rel_l2": number(l2) })],
                Value::Null,
            ))
        }
        Built::Fiber(_) => {
            let whole = |v: &View| -> ApiResult<Vec<f64>> {
                Ok(to_f64(&fiber_grid(&View { lobes: None, ..v.clone() }, limits, token)?.0))
            };
            let a = whole(view)?;
            let r = whole(&view_b)?;
            let weight = |k: usize| fiber_row_weight(k / cols, rows);
            let mut lobes = vec![json!({ "name": "all", "rel_l2": number(rel_l2(&a, &r, None, weight).0) })];
            let (pa, pb) = (Parts::of(&view.choice)?, Parts::of(b)?);
            for name in pa.names.iter().filter(|n| pb.names.contains(n) && *n != "all") {
                alive(token)?;
                let one = Some(vec![name.clone()]);
                let la = to_f64(&fiber_grid(&View { lobes: one.clone(), ..view.clone() }, limits, token)?.0);
                let lb = to_f64(&fiber_grid(&View { lobes: one, ..view_b.clone() }, limits, token)?.0);
                lobes.push(json!({ "name": name, "rel_l2": number(rel_l2(&la, &lb, None, weight).0) }));
            }
            Ok(answer(rows, cols, [-90.0, 90.0], &a, &r, lobes, Value::Null))
        }
    }
}

/// The incidence of `slices` to compare at.
fn incidence_of(req: &CompareRequest, slices: &LobeSlices) -> ApiResult<usize> {
    let n = slices.theta_in.len();
    match req.incidence {
        Some(k) if k < n => Ok(k),
        Some(k) => Err(ApiError::bad(format!("incidence {k}: the table has {n} (0 to {})", n - 1))),
        None => {
            let t = req.view.theta_i.to_radians();
            Ok((0..n)
                .min_by(|&a, &b| (slices.theta_in[a] - t).abs().total_cmp(&(slices.theta_in[b] - t).abs()))
                .unwrap_or(0))
        }
    }
}

/// Model against a table.
fn model_and_table(req: &CompareRequest, table: &Table, token: &Token) -> ApiResult<Value> {
    let view = &req.view;
    let channel = view.channel;
    let lum = |v: &[Rgb]| -> Vec<f64> { v.iter().map(|&c| channel.of(c)).collect() };
    match (view.choice.build()?, table.kind) {
        (Built::Fiber(model), TableKind::Fiber) => {
            // `fiberlab compare-model`'s comparison (fiberlab-compare), lobe by lobe, at one
            // incidence: bin averages of the width-averaged model, in luminance.
            let request = ModelRequest::new(view.choice.model.clone(), view.choice.pairs()?);
            let first = table
                .lobes
                .get("all")
                .or_else(|| table.lobes.values().next())
                .ok_or_else(|| ApiError::bad("the table is empty"))?;
            let s = incidence_of(req, first)?;
            let (nt, np) = (first.bins_theta, first.bins_phi);
            let (ti, pi) = (first.theta_in[s], first.phi_in[s]);
            let mut lobes = Vec::new();
            let mut shown = None;
            for (name, model_lobes) in LOBES {
                alive(token)?;
                let Some(slices) = table.lobes.get(name) else { continue };
                if slices.bins_theta != nt || slices.bins_phi != np || s >= slices.f.len() {
                    continue;
                }
                let lobe_model = match model_lobes {
                    None => model.clone(),
                    Some(names) => match request
                        .build_lobes(names)
                        .map_err(|e| ApiError::bad(format!("model `{}`: {e}", view.choice.model)))?
                    {
                        Some(m) => m,
                        None => continue,
                    },
                };
                let c = compare_incidence(&lobe_model, slices, s, SUBSAMPLES);
                lobes.push(json!({ "name": name, "rel_l2": number(c.rel_l2), "mc_rel_l2": number(c.mc_rel_l2) }));
                if name == "all" {
                    let measured: Vec<f64> = slices.f[s].iter().map(|v| v.luminance()).collect();
                    shown = Some((bin_averages(&lobe_model, ti, pi, nt, np, SUBSAMPLES), measured));
                }
            }
            let (a, r) = match shown {
                Some(x) => x,
                None => (bin_averages(&model, ti, pi, nt, np, SUBSAMPLES), vec![0.0; nt * np]),
            };
            let incidence = json!({ "index": s, "theta_i": ti.to_degrees(), "phi_i": pi.to_degrees() });
            Ok(answer(nt, np, [-90.0, 90.0], &a, &r, lobes, incidence))
        }
        (Built::Surface(model), TableKind::Surface) => {
            let all = table.lobes.get("all").ok_or_else(|| {
                ApiError::bad(format!("{}: a surface table needs its `all` class (every path)", table.name))
            })?;
            let s = incidence_of(req, all)?;
            let (nt, np) = (all.bins_theta, all.bins_phi);
            let (ti, pi) = (all.theta_in[s], all.phi_in[s]);
            let bins = fiberlab_fit::surface_bins(ti, pi, nt, np, 3, false);
            let a: Vec<f64> = bins.par_iter().map(|b| channel.of(b.average(&model))).collect();
            alive(token)?;
            let (measured, std) = (lum(&all.f[s]), lum(&all.std[s]));
            let (l2, mc) = rel_l2(&a, &measured, Some(&std), |b| surface_row_weight(b / np, nt));
            let lobes =
                vec![json!({ "name": "all", "rel_l2": number(l2), "mc_rel_l2": mc.map_or(Value::Null, number) })];
            let incidence = json!({ "index": s, "theta_i": ti.to_degrees(), "phi_i": pi.to_degrees() });
            Ok(answer(nt, np, [0.0, 90.0], &a, &measured, lobes, incidence))
        }
        (Built::Fiber(_), TableKind::Surface) => Err(ApiError::bad(format!(
            "{} is a surface table; `{}` is a fiber model — compare a surface model with it",
            table.name, view.choice.model
        ))),
        (Built::Surface(_), TableKind::Fiber) => Err(ApiError::bad(format!(
            "{} is a fiber table; `{}` is a surface model — compare a fiber model with it",
            table.name, view.choice.model
        ))),
    }
}

/// The comparison (see the module documentation).
pub fn compute(req: &CompareRequest, state: &AppState, token: &Token) -> ApiResult<Value> {
    match (&req.b, req.table) {
        (Some(b), None) => two_models(req, b, state.limits(), token),
        (None, Some(id)) => {
            let table = state.table(id).ok_or_else(|| ApiError::not_found(format!("no table {id}")))?;
            if table.kind == TableKind::Fiber {
                light(&req.view, false)?;
            }
            model_and_table(req, &table, token)
        }
        _ => Err(ApiError::bad("give one reference: `b` (a model) or `table` (a table id)")),
    }
}

/// `POST /api/compare`.
pub async fn compare(State(state): State<AppState>, headers: HeaderMap, body: Bytes) -> ApiResult<Json<Value>> {
    let req: CompareRequest = parse(&body)?;
    let (token, _guard) = state.supersede(&headers, "compare");
    blocking(move || state.in_background(|| compute(&req, &state, &token))).await.map(Json)
}
