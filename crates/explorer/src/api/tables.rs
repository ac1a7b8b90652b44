//! `POST /api/tables?name=FILE.csv` with a goniophotometer table as the body (the CSV that
//! `fiberlab measure` writes, fiber or surface) → its summary `{id, name, kind, lobes,
//! incidences: [{theta_i, phi_i}], bins_theta, bins_phi}`; errors name the file and line
//! ([`fiberlab_io::table::parse`]). `GET /api/tables/{id}` → the same summary.

use crate::error::{ApiError, ApiResult};
use crate::limits;
use crate::state::{AppState, Table};
use axum::Json;
use axum::body::Bytes;
use axum::extract::{Path, Query, State};
use fiberlab_io::table::{TableKind, kind_of, parse};
use serde::Deserialize;
use serde_json::{Value, json};

/// The query of an upload.
#[derive(Debug, Deserialize)]
pub struct Upload {
    /// The file's name (for messages).
    pub name: Option<String>,
}

/// A table's summary.
#[must_use]
pub fn summary_json(id: u64, table: &Table) -> Value {
    let first = table.lobes.values().next();
    json!({
        "id": id,
        "name": table.name,
        "kind": match table.kind { TableKind::Fiber => "fiber", TableKind::Surface => "surface" },
        "lobes": table.lobes.keys().collect::<Vec<_>>(),
        "incidences": first.map_or(Vec::new(), |l| l.theta_in.iter().zip(&l.phi_in)
            .map(|(t, p)| json!({ "theta_i": t.to_degrees(), "phi_i": p.to_degrees() })).collect()),
        "bins_theta": first.map_or(0, |l| l.bins_theta),
        "bins_phi": first.map_or(0, |l| l.bins_phi),
    })
}

/// Parses and keeps a table.
pub fn load(state: &AppState, name: &str, text: &str) -> ApiResult<(u64, Value)> {
    limits::at_most("table bytes", text.len() as u64, state.limits().max_table_bytes as u64)?;
    let lobes = parse(text, name).map_err(|e| ApiError::bad(e.to_string()))?;
    if let Some(l) = lobes.values().next() {
        limits::at_most("table bins (θ × φ)", (l.bins_theta * l.bins_phi) as u64, state.limits().max_bins as u64)?;
    }
    let table = Table { name: name.to_string(), kind: kind_of(text), lobes };
    let id = state.add_table(table.clone());
    Ok((id, summary_json(id, &table)))
}

/// `POST /api/tables`.
pub async fn upload(State(state): State<AppState>, Query(q): Query<Upload>, body: Bytes) -> ApiResult<Json<Value>> {
    let name = q.name.unwrap_or_else(|| "table.csv".into());
    let text = std::str::from_utf8(&body).map_err(|e| ApiError::bad(format!("{name}: not UTF-8 text: {e}")))?;
    let state2 = state.clone();
    let text = text.to_string();
    super::blocking(move || load(&state2, &name, &text).map(|(_, s)| s)).await.map(Json)
}

/// `GET /api/tables/{id}`.
pub async fn summary(State(state): State<AppState>, Path(id): Path<u64>) -> ApiResult<Json<Value>> {
    let table = state.table(id).ok_or_else(|| {
        ApiError::not_found(format!(
            "no table {id} (loaded tables are kept until {} newer ones replace them)",
            state.limits().max_tables
        ))
    })?;
    Ok(Json(summary_json(id, &table)))
}
