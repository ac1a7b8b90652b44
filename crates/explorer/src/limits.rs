//! The bounds on one request's work and memory, checked before the work starts: grid cells of
//! a map, points of a slice, rays and bins of a measurement (with the goniophotometer's own
//! memory estimate, [`fiberlab_gonio::Setup::estimated_bytes`]), pixels and samples of a
//! render preview (with the generator's and the BVH's estimates), observations of a fit, the
//! size of an uploaded table. A request above a bound is refused with 413 and a message that
//! names the quantity, its value and the bound.

use crate::error::ApiError;

/// Bounds on each request (the defaults suit a 2-core laptop; see the book's explorer chapter).
#[derive(Clone, Debug, PartialEq)]
pub struct Limits {
    /// Cells of a map (rows × columns).
    pub max_cells: usize,
    /// Points along a slice.
    pub max_slice_points: usize,
    /// Rays of one goniophotometer measurement.
    pub max_rays: usize,
    /// Bins of one measurement table (θ × φ).
    pub max_bins: usize,
    /// Pixels of a render preview.
    pub max_pixels: u32,
    /// Samples per pixel of a render preview.
    pub max_spp: u32,
    /// Bytes of an uploaded table (CSV text).
    pub max_table_bytes: usize,
    /// Tables kept in memory (uploaded or measured); the oldest is dropped beyond it.
    pub max_tables: usize,
    /// Observations of one fit.
    pub max_observations: usize,
    /// Bytes one request may hold (maps, measurements, renders, fits), from the estimates.
    pub memory_bytes: u64,
}

impl Default for Limits {
    fn default() -> Self {
        Self {
            max_cells: 360 * 720,
            max_slice_points: 2048,
            max_rays: 20_000_000,
            max_bins: 180 * 360,
            max_pixels: 640 * 640,
            max_spp: 4096,
            max_table_bytes: 64 << 20,
            max_tables: 16,
            max_observations: 400_000,
            memory_bytes: 1 << 30,
        }
    }
}

/// Refuses `value` above `max` with a message naming `what`.
pub fn at_most(what: &str, value: u64, max: u64) -> Result<(), ApiError> {
    if value > max {
        return Err(ApiError::too_large(format!("{what} = {value} is above this server's limit of {max}")));
    }
    Ok(())
}

/// Refuses an estimate of `bytes` (None: more than u64 counts) above the memory bound.
pub fn memory(what: &str, bytes: Option<u64>, limits: &Limits) -> Result<(), ApiError> {
    match bytes {
        Some(b) if b <= limits.memory_bytes => Ok(()),
        Some(b) => Err(ApiError::too_large(format!(
            "{what} needs about {} MiB; this server allows {} MiB per request",
            b.div_ceil(1 << 20),
            limits.memory_bytes >> 20
        ))),
        None => Err(ApiError::too_large(format!("{what}: the memory needed overflows 64 bits"))),
    }
}

/// Refuses zero or a count above `max`.
pub fn count(what: &str, value: usize, max: usize) -> Result<usize, ApiError> {
    if value == 0 {
        return Err(ApiError::bad(format!("{what} = 0: expected at least 1")));
    }
    at_most(what, value as u64, max as u64)?;
    Ok(value)
}
