//! A registered model against a measured table of either kind — the one call behind
//! `fiberlab compare-model` and Python's `compare_model`: a fiber table lobe by lobe
//! ([`crate::fiber_table`]), a surface table by its highlight or its residual
//! ([`crate::surface_table`]). [`ModelComparison`] serializes to the JSON both print.

use crate::CompareError;
use crate::fiber_table::{LobeComparison, compare_fiber_table};
use crate::surface_table::{HighlightJson, ResidualJson, SurfaceComparison, compare_surface_table};
use fiberlab_io::table::{LobeSlices, TableKind};
use fiberlab_render::model_loader::ModelRequest;
use serde::ser::{Serialize, SerializeMap, Serializer};
use std::collections::BTreeMap;

/// How a model is compared with a table.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CompareOptions {
    /// Midpoint sub-samples per bin along θ (≥ 1) for the model's bin average.
    pub subsamples: usize,
    /// Surface tables: the table's θ_i, φ_i is the viewer's direction (a table traced from
    /// the camera); it matters for a non-reciprocal model.
    pub viewer_first: bool,
}

impl Default for CompareOptions {
    /// `fiberlab compare-model`'s defaults: 3 sub-samples, θ_i the light's.
    fn default() -> Self {
        Self { subsamples: 3, viewer_first: false }
    }
}

/// The comparison of a model with a table.
#[derive(Clone, Debug)]
pub enum ModelComparison {
    /// A fiber table, one entry per lobe both have.
    Fiber(Vec<LobeComparison>),
    /// A surface table.
    Surface(SurfaceComparison),
}

/// Compares the model of `request` with `table` (of `kind`, as `fiberlab_io::table` reads
/// it).
pub fn compare_model(
    table: &BTreeMap<String, LobeSlices>,
    kind: TableKind,
    request: &ModelRequest,
    options: CompareOptions,
) -> Result<ModelComparison, CompareError> {
    if options.subsamples == 0 {
        return Err(CompareError::Request("subsamples must be at least 1".into()));
    }
    Ok(match kind {
        TableKind::Fiber => ModelComparison::Fiber(compare_fiber_table(table, request, options.subsamples)?),
        TableKind::Surface => {
            ModelComparison::Surface(compare_surface_table(table, request, options.subsamples, options.viewer_first)?)
        }
    })
}

/// One object: a fiber comparison keyed by lobe (`r`, `tt`, `trt`, `medulla`, `all`), a
/// highlight under `fiber`, a residual under `all`, each a list per incidence (`compare-model
/// --json`).
impl Serialize for ModelComparison {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let mut map = serializer.serialize_map(None)?;
        match self {
            ModelComparison::Fiber(lobes) => {
                for l in lobes {
                    map.serialize_entry(&l.lobe, l)?;
                }
            }
            ModelComparison::Surface(SurfaceComparison::Highlight(rows)) => {
                map.serialize_entry("fiber", &rows.iter().map(HighlightJson::from).collect::<Vec<_>>())?;
            }
            ModelComparison::Surface(SurfaceComparison::Residual(rows)) => {
                map.serialize_entry("all", &rows.iter().map(ResidualJson::from).collect::<Vec<_>>())?;
            }
        }
        map.end()
    }
}
