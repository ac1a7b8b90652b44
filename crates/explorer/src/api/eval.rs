//! `POST /api/eval`: `{"model", "params", "wi": [x, y, z], "wo": [x, y, z], "h"?}` →
//! `{"f": [r, g, b], "pdf": p}`, exactly what `fiberlab eval` prints for the same row (fiber
//! directions in the fiber frame, `h` the offset across the fiber, default 0; surface
//! directions in the local frame, z = normal, and no `h`). Errors are the command line's.

use super::{parse, rgb};
use crate::error::{ApiError, ApiResult};
use crate::request::{Built, ModelChoice, offset, unit};
use axum::Json;
use axum::body::Bytes;
use fiberlab_scatter::{ScatteringFunction, SurfaceScattering};
use serde::Deserialize;
use serde_json::{Value, json};

/// The request.
#[derive(Debug, Deserialize)]
pub struct EvalRequest {
    /// The model.
    #[serde(flatten)]
    pub choice: ModelChoice,
    /// Toward the light.
    pub wi: [f64; 3],
    /// Toward the viewer.
    pub wo: [f64; 3],
    /// Offset across a fiber.
    pub h: Option<f64>,
}

/// Evaluates one pair of directions.
pub fn evaluate(request: &EvalRequest) -> ApiResult<Value> {
    let model = request.choice.build()?;
    let wi = unit(request.wi, "wi")?;
    let wo = unit(request.wo, "wo")?;
    let (f, pdf) = match &model {
        Built::Fiber(m) => {
            let h = offset(request.h.unwrap_or(0.0))?;
            (m.eval(wi, wo, h), m.pdf(wi, wo, h))
        }
        Built::Surface(m) => {
            if request.h.is_some() {
                return Err(ApiError::bad(format!(
                    "h is the offset across a fiber; `{}` is a surface model",
                    request.choice.model
                )));
            }
            m.eval_and_pdf(wi, wo)
        }
    };
    Ok(json!({ "f": rgb(f), "pdf": super::number(pdf) }))
}

/// `POST /api/eval`.
pub async fn eval(body: Bytes) -> ApiResult<Json<Value>> {
    let request: EvalRequest = parse(&body)?;
    Ok(Json(evaluate(&request)?))
}
