//! `POST /api/render`: a progressive render preview, streamed as server-sent events.
//!
//! Request: `{"model", "params", "scene": "fiber"|"tress"|"fur"|"sphere"|"sample",
//! "light": [azimuth°, elevation°], "size": 256, "spp": 64, "exposure": 0}`. The renderer
//! ([`fiberlab_render::integrator::render_continuing`]) brings every pixel to 1, 2, 4, … `spp`
//! samples, continuing its accumulation, and after each pass the page gets
//! `{"type": "frame", "spp", "target", "width", "height", "seconds", "png": "data:image/png;base64,…"}`
//! (filmic tone map, sRGB), then `{"type": "done", "spp"}`. One render per page: the page's
//! next render, or the page going away, stops it within one pixel's samples.

use super::{Events, parse, stream};
use crate::error::{ApiError, ApiResult};
use crate::limits;
use crate::preview::{self, Kind};
use crate::request::{ModelChoice, degrees};
use crate::state::AppState;
use axum::body::Bytes;
use axum::extract::State;
use axum::http::HeaderMap;
use axum::response::IntoResponse;
use base64::Engine;
use fiberlab_io::image_file::ToneMap;
use fiberlab_render::accumulation::Accumulation;
use fiberlab_render::integrator::{RenderSettings, render_continuing};
use fiberlab_render::scene::Scene;
use serde::Deserialize;
use serde_json::json;

fn default_size() -> u32 {
    256
}
fn default_spp() -> u32 {
    64
}
fn default_light() -> [f64; 2] {
    [35.0, 40.0]
}

/// The request.
#[derive(Debug, Deserialize)]
pub struct RenderRequest {
    /// The model.
    #[serde(flatten)]
    pub choice: ModelChoice,
    /// The scene.
    pub scene: Kind,
    /// Light azimuth and elevation, degrees.
    #[serde(default = "default_light")]
    pub light: [f64; 2],
    /// Image edge, pixels.
    #[serde(default = "default_size")]
    pub size: u32,
    /// Samples per pixel to reach.
    #[serde(default = "default_spp")]
    pub spp: u32,
    /// Exposure, stops.
    #[serde(default)]
    pub exposure: f64,
}

/// PNG bytes of an sRGB image.
fn png(rgb: &[u8], width: u32, height: u32) -> ApiResult<Vec<u8>> {
    let mut bytes = Vec::new();
    let mut enc = png::Encoder::new(&mut bytes, width, height);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    enc.write_header()
        .and_then(|mut w| w.write_image_data(rgb))
        .map_err(|e| ApiError::internal(format!("encoding the preview: {e}")))?;
    Ok(bytes)
}

/// Checks the request and builds its scene (errors before any event is sent).
pub fn prepare(req: &RenderRequest, state: &AppState) -> ApiResult<(Scene, u32)> {
    let l = state.limits();
    limits::count("size", req.size as usize, 4096)?;
    limits::count("spp", req.spp as usize, l.max_spp as usize)?;
    if !req.exposure.is_finite() || req.exposure.abs() > 20.0 {
        return Err(ApiError::bad(format!("exposure: expected stops in [-20, 20], got {}", req.exposure)));
    }
    let azimuth = degrees("light azimuth", req.light[0], -360.0, 360.0)?.to_degrees();
    let elevation = degrees("light elevation", req.light[1], -90.0, 90.0)?.to_degrees();
    preview::check(req.scene, req.size, l)?;
    preview::build(req.scene, &req.choice, preview::light_direction(azimuth, elevation), req.size)
}

/// Renders the prepared scene, sending frames (see the module documentation).
fn run(req: &RenderRequest, prepared: (Scene, u32), token: &crate::cancel::Token, events: &Events) -> ApiResult<()> {
    let (scene, max_depth) = prepared;
    let settings = RenderSettings { max_depth, ..RenderSettings::default() };
    let mut accumulation = Accumulation::new(req.size, req.size);
    let mut target = 1;
    let start = std::time::Instant::now();
    loop {
        let pass = RenderSettings { spp: target, ..settings.clone() };
        let out = render_continuing(&scene, &pass, accumulation, &|_| {}, token.flag())
            .map_err(|e| ApiError::internal(e.to_string()))?;
        // A cancelled stream ends with a 409 event (the page ignores it; a client that
        // stays to the end, as at a server shutdown, learns why it ended).
        super::alive(token)?;
        let rgb = out.image.to_srgb8(req.exposure, ToneMap::Filmic);
        let data = base64::engine::general_purpose::STANDARD.encode(png(&rgb, req.size, req.size)?);
        let frame = json!({
            "type": "frame", "spp": out.stats.spp_min, "target": req.spp,
            "width": req.size, "height": req.size,
            "seconds": start.elapsed().as_secs_f64(),
            "png": format!("data:image/png;base64,{data}"),
        });
        if !events.send(&frame) {
            return Ok(());
        }
        accumulation = out.accumulation;
        if target >= req.spp {
            break;
        }
        target = (target * 2).min(req.spp);
    }
    events.send(&json!({ "type": "done", "spp": target, "seconds": start.elapsed().as_secs_f64() }));
    Ok(())
}

/// `POST /api/render`.
pub async fn render(State(state): State<AppState>, headers: HeaderMap, body: Bytes) -> ApiResult<impl IntoResponse> {
    let req: RenderRequest = parse(&body)?;
    let (token, guard) = state.supersede(&headers, "render");
    let req = std::sync::Arc::new(req);
    let (r, s) = (req.clone(), state.clone());
    let prepared = super::blocking(move || prepare(&r, &s)).await?;
    Ok(stream(guard, move |events| run(&req, prepared, &token, events)))
}
