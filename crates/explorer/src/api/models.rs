//! `GET /api/models`: both registries, what the page generates its controls from.
//!
//! Each entry: `name`, `kind` (`fiber` | `surface`), `summary`, `citation`, `needs_data`
//! (built from a measured table: not buildable from parameters), `properties` (what the model
//! claims: reciprocity, energy, near/far field, delta lobes), `lobes` (`[{name, delta}]` of the
//! default model), `lobe_parameter` (the key of a `lobes` subset parameter, if any) and
//! `params`: `[{key, kind, unit, default, min, max, min_inclusive, max_inclusive, choices,
//! doc}]` with `kind` one of `number`, `integer`, `color`, `choice`, `subset`, `text` (an
//! unbounded end is `null`).

use super::number;
use crate::request::{Built, ModelChoice};
use axum::Json;
use fiberlab_scatter::params::{ParamKind, ParamSpec};
use fiberlab_scatter::{Field, Lobes, ScatteringFunction, SurfaceScattering, registry};
use serde_json::{Value, json};

/// One parameter's description.
#[must_use]
pub fn param_json(p: &ParamSpec) -> Value {
    let (kind, range, choices): (&str, Option<fiberlab_scatter::params::Range>, Option<&[&str]>) = match p.kind {
        ParamKind::Number(r) => ("number", Some(r), None),
        ParamKind::Integer(r) => ("integer", Some(r), None),
        ParamKind::Color(r) => ("color", Some(r), None),
        ParamKind::Choice(c) => ("choice", None, Some(c)),
        ParamKind::Subset(c) => ("subset", None, Some(c)),
        ParamKind::Text => ("text", None, None),
    };
    json!({
        "key": p.key,
        "kind": kind,
        "unit": p.unit,
        "default": p.default,
        "min": range.map_or(Value::Null, |r| number(r.min)),
        "max": range.map_or(Value::Null, |r| number(r.max)),
        "min_inclusive": range.is_some_and(|r| r.min_inclusive),
        "max_inclusive": range.is_some_and(|r| r.max_inclusive),
        "choices": choices.map_or(Value::Null, |c| json!(c)),
        "valid": p.valid(),
        "doc": p.doc,
    })
}

/// The registry as JSON (see the module documentation).
#[must_use]
pub fn registry_json() -> Value {
    let entries: Vec<Value> = registry()
        .map(|entry| {
            let info = entry.info();
            let built = if info.data.is_some_and(|d| matches!(d, fiberlab_scatter::ExternalData::Table { .. })) {
                None
            } else {
                ModelChoice::new(info.name, &[]).build().ok()
            };
            let (properties, lobes) = match &built {
                Some(Built::Fiber(m)) => {
                    let p = m.properties();
                    (
                        json!({
                            "reciprocal": p.reciprocal,
                            "energy_conserving": p.energy_conserving,
                            "near_field": p.field == Field::Near,
                            "delta": p.lobes == Lobes::Delta,
                        }),
                        m.lobes(),
                    )
                }
                Some(Built::Surface(m)) => {
                    let p = m.properties();
                    (
                        json!({
                            "reciprocal": p.reciprocal,
                            "energy_conserving": p.energy_conserving,
                            "has_delta": p.has_delta,
                            "transmits": p.transmits,
                        }),
                        m.lobes(),
                    )
                }
                None => (Value::Null, Vec::new()),
            };
            let lobe_parameter =
                info.params.iter().find(|p| p.key == "lobes" && matches!(p.kind, ParamKind::Subset(_))).map(|p| p.key);
            json!({
                "name": info.name,
                "kind": entry.kind().name(),
                "summary": info.summary,
                "citation": info.citation,
                "needs_data": built.is_none(),
                "properties": properties,
                "lobes": lobes.iter().map(|l| json!({ "name": l.name, "delta": l.delta })).collect::<Vec<_>>(),
                "lobe_parameter": lobe_parameter,
                "params": info.params.iter().map(param_json).collect::<Vec<_>>(),
            })
        })
        .collect();
    Value::Array(entries)
}

/// `GET /api/models`.
pub async fn models() -> Json<Value> {
    Json(registry_json())
}
