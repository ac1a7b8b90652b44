//! fiberlab's comparisons — the science behind `fiberlab plot`, `compare-model`, `evaluate`,
//! the explorer's plots and their Python equivalents, written once:
//!
//! * [`maps`]: a scattering function as numbers one can draw (`f_s` over outgoing directions at
//!   one incidence, its azimuthal distribution, its values on the specular cone);
//! * [`fiber_table`]: a fiber model against a measured fiber table, lobe by lobe (bin-averaged,
//!   width-averaged through the one width average of the scattering crate);
//! * [`surface_table`]: a surface model against a measured surface table (a fiber highlight
//!   against the single-fiber class, or a residual against every path);
//! * [`evaluation`]: the colour-matched evaluation of hair models in renders against a
//!   reference, with noise floors and the constrained Kajiya–Kay fit.
//!
//! It reads no files and prints nothing: tables and images come in as values, results go out
//! as values; the front ends read, write and print.
#![forbid(unsafe_code)]

pub mod evaluation;
pub mod fiber_table;
pub mod maps;
pub mod surface_table;

use thiserror::Error;

/// Why a comparison could not be made.
#[non_exhaustive]
#[derive(Debug, Error)]
pub enum CompareError {
    /// A model could not be built (unknown name or key, bad value, unreadable data).
    #[error(transparent)]
    Load(#[from] fiberlab_render::model_loader::LoadError),
    /// A model's parameters are invalid.
    #[error(transparent)]
    Model(#[from] fiberlab_scatter::ModelError),
    /// A fit inside the comparison failed.
    #[error("fitting: {0}")]
    Fit(#[from] fiberlab_fit::FitError),
    /// The images could not be compared.
    #[error(transparent)]
    Metrics(#[from] fiberlab_io::image_metrics::MetricsError),
    /// The table lacks what the comparison needs.
    #[error("{0}")]
    Table(String),
    /// The request is incomplete or inconsistent.
    #[error("{0}")]
    Request(String),
}
