//! `POST /api/numbers`: the read-outs of the validation harness for the model as configured,
//! at the dragged direction — the same library calls `fiberlab check` makes, at a coarser
//! quadrature so that they follow the knobs:
//!
//! - fibers: light-side albedo `ρ(ω_i)` per channel ([`radiometry::albedo`]), camera-side
//!   furnace at `ω_o = ω_i` ([`radiometry::furnace`]), each lobe's share
//!   ([`radiometry::lobe_albedos`], or per-lobe models for a `lobes` parameter), the largest
//!   relative reciprocity defect over random pairs ([`fiberlab_check::reciprocity`]) and
//!   `∫ pdf dω` at `ω_o` ([`fiberlab_check::pdf_integral`]);
//! - surfaces: [`surface::smooth_albedo`], [`surface::smooth_furnace`],
//!   [`surface::reciprocity`] and [`surface::pdf_integral`] (delta lobes left out, as the
//!   harness leaves them out of these integrals).
//!
//! The answer also says what the model claims (`reciprocal`, `energy_conserving`) and the
//! quadrature used.

use super::{alive, blocking, number, parse, rgb};
use crate::api::plots::View;
use crate::cancel::Token;
use crate::error::ApiResult;
use crate::request::{Built, Parts, degrees, fiber_direction, offset};
use crate::state::AppState;
use axum::Json;
use axum::body::Bytes;
use axum::extract::State;
use axum::http::HeaderMap;
use fiberlab_check::rng::TestRng;
use fiberlab_check::surface;
use fiberlab_math::Rgb;
use fiberlab_scatter::radiometry::{self, Quadrature};
use fiberlab_scatter::{ScatteringFunction, SurfaceModel, SurfaceScattering};
use serde_json::{Value, json};

/// The read-outs' quadrature over ω (θ × φ cells, h cells for near-field models): a quarter
/// of the harness's in each angle, within 1e−3 of it for the registry's default lobes.
pub const LIVE_QUADRATURE: Quadrature = Quadrature { theta: 128, phi: 256, h: 8 };

/// Random pairs of the reciprocity read-out (the harness's count).
pub const RECIPROCITY_PAIRS: usize = 5000;

/// Cells of the surface albedo quadratures (θ per hemisphere × φ).
const SURFACE_CELLS: (usize, usize) = (128, 512);

fn fiber_numbers(view: &View, token: &Token) -> ApiResult<Value> {
    let model = view.choice.build_fiber()?;
    let theta_i = degrees("theta_i", view.theta_i, -90.0, 90.0)?;
    let phi_i = degrees("phi_i", view.phi_i, -360.0, 360.0)?;
    let h = offset(view.h.unwrap_or(0.0))?;
    let w = fiber_direction(theta_i, phi_i);
    let q = LIVE_QUADRATURE;
    let ((light, camera), (lobes, (recip, pdf))) = rayon::join(
        || rayon::join(|| radiometry::albedo(&model, w, &q), || radiometry::furnace(&model, w, &q)),
        || {
            rayon::join(
                || -> ApiResult<Vec<(String, Rgb)>> {
                    let parts = Parts::of(&view.choice)?;
                    alive(token)?;
                    Ok(match radiometry::lobe_albedos(&model, w, &q) {
                        Some(a) => parts.names.iter().cloned().zip(a).collect(),
                        None if parts.names.len() > 1 => {
                            // One model per enabled lobe (a `lobes` parameter).
                            let mut out = Vec::new();
                            for (name, lobe) in parts.names.iter().zip(lobe_models(view, &parts.names)?) {
                                alive(token)?;
                                out.push((name.clone(), radiometry::albedo(&lobe, w, &q)));
                            }
                            out
                        }
                        None => Vec::new(),
                    })
                },
                || {
                    let (worst, _) = fiberlab_check::reciprocity(&model, RECIPROCITY_PAIRS, &mut TestRng::new(0x5eed));
                    (worst, fiberlab_check::pdf_integral(&model, w, h))
                },
            )
        },
    );
    alive(token)?;
    let lobes = lobes?;
    let props = model.properties();
    Ok(json!({
        "kind": "fiber",
        "albedo_light": rgb(light),
        "albedo_camera": rgb(camera),
        "lobes": lobes.iter().map(|(n, a)| json!({ "name": n, "albedo": rgb(*a) })).collect::<Vec<_>>(),
        "reciprocity": number(recip),
        "pdf_integral": number(pdf),
        "reciprocal": props.reciprocal,
        "energy_conserving": props.energy_conserving,
        "quadrature": format!("{} × {} cells in (θ, φ){}", q.theta, q.phi,
            if props.field == fiberlab_scatter::Field::Near { format!(", {} offsets h", q.h) } else { String::new() }),
    }))
}

/// The fiber models of each lobe of a model with a `lobes` parameter.
fn lobe_models(view: &View, names: &[String]) -> ApiResult<Vec<fiberlab_scatter::Model>> {
    names
        .iter()
        .map(|n| match view.choice.build_with(&[("lobes", fiberlab_scatter::params::RawValue::Text(n.clone()))])? {
            Built::Fiber(m) => Ok(m),
            Built::Surface(_) => Err(crate::error::ApiError::internal("a fiber lobe built a surface model")),
        })
        .collect()
}

fn surface_numbers(view: &View, model: &SurfaceModel, token: &Token) -> ApiResult<Value> {
    let theta_i = degrees("theta_i", view.theta_i, 0.0, 89.99)?;
    let phi_i = degrees("phi_i", view.phi_i, -360.0, 360.0)?;
    let w = surface::surface_direction(theta_i, phi_i);
    let (nt, np) = SURFACE_CELLS;
    let ((light, camera), (recip, pdf)) = rayon::join(
        || rayon::join(|| surface::smooth_albedo(model, w, nt, np), || surface::smooth_furnace(model, w, nt, np)),
        || {
            rayon::join(
                || surface::reciprocity(model, RECIPROCITY_PAIRS, &mut TestRng::new(0x5eed)),
                || surface::pdf_integral(model, w),
            )
        },
    );
    alive(token)?;
    let props = model.properties();
    Ok(json!({
        "kind": "surface",
        "albedo_light": rgb(light),
        "albedo_camera": rgb(camera),
        "lobes": [],
        "reciprocity": number(recip),
        "pdf_integral": number(pdf),
        "reciprocal": props.reciprocal,
        "energy_conserving": props.energy_conserving,
        "has_delta": props.has_delta,
        "quadrature": format!("{nt} × {np} cells in (θ, φ) per hemisphere (smooth lobes)"),
    }))
}

/// The read-outs for `view`.
pub fn compute(view: &View, token: &Token) -> ApiResult<Value> {
    match view.choice.build()? {
        Built::Fiber(_) => fiber_numbers(view, token),
        Built::Surface(m) => surface_numbers(view, &m, token),
    }
}

/// `POST /api/numbers`.
pub async fn numbers(State(state): State<AppState>, headers: HeaderMap, body: Bytes) -> ApiResult<Json<Value>> {
    let view: View = parse(&body)?;
    let (token, _guard) = state.supersede(&headers, "numbers");
    blocking(move || state.in_background(|| compute(&view, &token))).await.map(Json)
}
