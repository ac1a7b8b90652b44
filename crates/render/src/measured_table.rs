//! Loading a goniophotometer table (`fiberlab measure` CSV, lobe `all`) as the `measured`
//! scattering model, for scenes and the command line.

use fiberlab_scatter::measured::{Measured, MeasuredTable};
use std::path::{Path, PathBuf};
use thiserror::Error;

/// A table that could not be read or used; the message names the file.
#[non_exhaustive]
#[derive(Debug, Error)]
pub enum TableError {
    /// Unreadable or malformed CSV (the message names the file and line).
    #[error(transparent)]
    Read(#[from] fiberlab_io::table::TableError),
    /// Read, but not a usable table.
    #[error("{}: {message}", path.display())]
    Invalid {
        /// The table file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
}

/// Reads `path` and builds the tabulated model; the error names the file and what is wrong.
pub fn load_measured(path: &Path) -> Result<Measured, TableError> {
    let invalid = |message: String| TableError::Invalid { path: path.into(), message };
    let lobes = fiberlab_io::table::read(path)?;
    let all = lobes.get("all").ok_or_else(|| invalid("no rows with lobe `all`".into()))?;
    Measured::new(MeasuredTable {
        theta_in: all.theta_in.clone(),
        bins_theta: all.bins_theta,
        bins_phi: all.bins_phi,
        f: all.f.clone(),
    })
    .map_err(|e| invalid(e.to_string()))
}
