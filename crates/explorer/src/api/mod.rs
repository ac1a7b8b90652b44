//! The HTTP API (documented in the book's explorer chapter, `docs/book/src/explorer.md`).
//! Every endpoint takes and returns JSON; angles are in degrees, `f_s` and `f_r` in sr⁻¹;
//! errors are `{"error": "…"}` with status 400 (bad input, the command line's message), 404
//! (unknown table), 409 (replaced by a newer request of the same page), 413 (above the limits).
//! Long work (measure, fit, render) answers with a stream of server-sent events.
//!
//! | method | path | what |
//! |---|---|---|
//! | GET | `/api/models` | the registry ([`models`]) |
//! | POST | `/api/eval` | `f` and `pdf` at one pair of directions ([`eval`]) |
//! | POST | `/api/map` | `f_s` over (θ_r, φ), or `f_r` over the hemisphere ([`plots`]) |
//! | POST | `/api/slices` | M(θ) and N(φ) per lobe; a surface's planes ([`plots`]) |
//! | POST | `/api/numbers` | albedos, reciprocity, ∫pdf, energy per lobe ([`numbers`]) |
//! | POST | `/api/tables` | load a goniophotometer table (CSV body) ([`tables`]) |
//! | GET | `/api/tables/{id}` | a loaded table's summary ([`tables`]) |
//! | POST | `/api/compare` | two models, or a model and a table ([`compare`]) |
//! | POST | `/api/measure` | measure an explicit fiber (event stream) ([`measure`]) |
//! | POST | `/api/fit` | fit a model to a table (event stream) ([`fit`]) |
//! | POST | `/api/render` | progressive preview (event stream) ([`render`]) |

pub mod compare;
pub mod eval;
pub mod fit;
pub mod measure;
pub mod models;
pub mod numbers;
pub mod plots;
pub mod render;
pub mod tables;

use crate::cancel::Token;
use crate::error::{ApiError, ApiResult};
use crate::state::AppState;
use axum::Router;
use axum::body::Bytes;
use axum::response::sse::{Event, KeepAlive, Sse};
use axum::routing::{get, post};
use futures_util::Stream;
use serde::de::DeserializeOwned;
use std::convert::Infallible;

/// The application: the API under `/api`, the embedded page everywhere else.
pub fn router(state: AppState) -> Router {
    Router::new()
        .route("/api/models", get(models::models))
        .route("/api/eval", post(eval::eval))
        .route("/api/map", post(plots::map))
        .route("/api/slices", post(plots::slices))
        .route("/api/numbers", post(numbers::numbers))
        .route("/api/tables", post(tables::upload))
        .route("/api/tables/{id}", get(tables::summary))
        .route("/api/compare", post(compare::compare))
        .route("/api/measure", post(measure::measure))
        .route("/api/fit", post(fit::fit))
        .route("/api/render", post(render::render))
        .route("/api/{*rest}", get(unknown).post(unknown))
        .fallback(get(crate::bundle::asset))
        .layer(axum::extract::DefaultBodyLimit::max(80 << 20))
        .with_state(state)
}

async fn unknown() -> ApiError {
    ApiError::not_found("no such API endpoint; see the book's explorer chapter for the list")
}

/// Parses a JSON request body; a malformed one is 400 naming what serde found.
pub(crate) fn parse<T: DeserializeOwned>(body: &Bytes) -> ApiResult<T> {
    serde_json::from_slice(body).map_err(|e| ApiError::bad(format!("request body: {e}")))
}

/// Runs `work` on the blocking pool (it uses rayon inside); a panic is a 500.
pub(crate) async fn blocking<T: Send + 'static>(work: impl FnOnce() -> ApiResult<T> + Send + 'static) -> ApiResult<T> {
    tokio::task::spawn_blocking(work).await.map_err(|e| ApiError::internal(format!("the computation failed: {e}")))?
}

/// `Err(cancelled)` once `token` is cancelled.
pub(crate) fn alive(token: &Token) -> ApiResult<()> {
    if token.is_cancelled() { Err(ApiError::cancelled()) } else { Ok(()) }
}

/// A JSON number, or null for NaN and ±∞.
pub(crate) fn number(x: f64) -> serde_json::Value {
    serde_json::Number::from_f64(x).map_or(serde_json::Value::Null, serde_json::Value::Number)
}

/// An RGB triple as JSON numbers.
pub(crate) fn rgb(c: fiberlab_math::Rgb) -> serde_json::Value {
    serde_json::Value::Array(vec![number(c[0]), number(c[1]), number(c[2])])
}

/// Sends events from blocking work to a page: `send` returns false once the page went away.
#[derive(Clone)]
pub(crate) struct Events(tokio::sync::mpsc::Sender<Event>);

impl Events {
    /// Another handle on the same stream (for callbacks that must own one).
    pub(crate) fn clone_sender(&self) -> Self {
        self.clone()
    }

    /// Sends `value` as the data of a `message` event.
    pub(crate) fn send(&self, value: &serde_json::Value) -> bool {
        self.0.blocking_send(Event::default().data(value.to_string())).is_ok()
    }
}

/// An event stream fed by `work` on the blocking pool. The stream holds `guard`: when the page
/// closes the connection, the stream is dropped and the work's token is cancelled. An error of
/// the work is sent as `{"type": "error", "error": …}`.
pub(crate) fn stream(
    guard: crate::cancel::Guard,
    work: impl FnOnce(&Events) -> ApiResult<()> + Send + 'static,
) -> Sse<impl Stream<Item = Result<Event, Infallible>>> {
    let (tx, rx) = tokio::sync::mpsc::channel(16);
    tokio::task::spawn_blocking(move || {
        let events = Events(tx);
        if let Err(e) = work(&events) {
            events.send(&serde_json::json!({ "type": "error", "status": e.status.as_u16(), "error": e.message }));
        }
    });
    let events = futures_util::StreamExt::map(tokio_stream::wrappers::ReceiverStream::new(rx), move |e| {
        let _held = &guard;
        Ok::<_, Infallible>(e)
    });
    Sse::new(events).keep_alive(KeepAlive::default())
}
