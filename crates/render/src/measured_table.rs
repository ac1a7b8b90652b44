//! Loading a goniophotometer table (`fiberlab measure` CSV, lobe `all`) as the `measured`
//! scattering model, for scenes and the command line.

use fiberlab_scatter::measured::{Measured, MeasuredTable};
use std::path::Path;

/// Reads `path` and builds the tabulated model; the error names the file and what is wrong.
pub fn load_measured(path: &Path) -> Result<Measured, String> {
    let lobes = fiberlab_io::table::read(path).map_err(|e| e.to_string())?;
    let all = lobes.get("all").ok_or_else(|| format!("{}: no rows with lobe `all`", path.display()))?;
    Measured::new(MeasuredTable {
        theta_in: all.theta_in.clone(),
        bins_theta: all.bins_theta,
        bins_phi: all.bins_phi,
        f: all.f.clone(),
    })
    .map_err(|e| format!("{}: {e}", path.display()))
}
