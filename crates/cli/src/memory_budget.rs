//! The memory check of every verb that allocates in proportion to its input (`render`,
//! `evaluate`, `measure`, `hair generate`, `texture`, `mesh`, `dual-tables`, `fit`, …), run
//! before any work: the quantities it will hold
//! are estimated from the command line and the scene file alone — the image from the camera,
//! the strands × segments from each `[[hair]]` generator or `.hair` header, their BVH, the
//! goniophotometer's bins — and the command is refused with an error naming the largest
//! quantity and its estimate when their sum is above what the machine has available.
//! `--memory-limit SIZE` replaces that figure (a smaller budget, or a larger one at the
//! user's risk). The estimators live beside what they estimate
//! ([`fiberlab_render::scene_file::SceneFile::memory_estimate`],
//! [`fiberlab_gonio::Setup::estimated_bytes`],
//! [`fiberlab_procedural::generator::HairParams::estimated_bytes`]); this module only adds them up
//! and compares.
//!
//! The check itself, the budget and the size parser live in [`fiberlab_io::memory_budget`],
//! shared with the Python package (which raises `MemoryError` with the same message).
//! Counts are u64 and checked: an estimate that overflows 64 bits, or is more than this
//! machine's address space, is refused even with `--memory-limit`.
//!
//! `sample` and `eval` stream their CSV rows, so their memory does not grow with `--count` or
//! the input; they have nothing to estimate.

use fiberlab_gonio::Setup;
use fiberlab_io::memory_budget as budget;
pub use fiberlab_io::memory_budget::{Need, memory_size};
use fiberlab_procedural::generator::HairParams;
use fiberlab_procedural::grass::GrassParams;
use fiberlab_render::scene_file::{MemoryEstimate, SceneFile};

/// `--memory-limit SIZE`, the flag of every verb that runs the check.
#[derive(clap::Args, Clone, Debug, Default)]
pub struct MemoryLimit {
    /// Memory the command may use, e.g. 8G, 512M or a number of bytes (K, M, G, T: powers of
    /// 1024). Default: what the machine has available (MemAvailable, the cgroup's and the
    /// address-space limit's room); the command is refused before any work when its estimate
    /// is above it, and no input file larger than it is read.
    #[arg(long = "memory-limit", value_name = "SIZE", value_parser = memory_size)]
    limit: Option<u64>,
}

impl MemoryLimit {
    /// The limit given, if any (set for the whole process by `main` before the verb runs, so
    /// that it also bounds the input files).
    #[must_use]
    pub fn bytes(&self) -> Option<u64> {
        self.limit
    }

    /// Refuses `needs` when their sum is above the limit (see the module documentation).
    pub fn check(&self, needs: &[Need]) -> anyhow::Result<()> {
        let b = match self.limit {
            Some(bytes) => budget::Budget::Flag(bytes),
            None => budget::budget(),
        };
        budget::check(needs, b, usize::MAX as u64).map_err(anyhow::Error::msg)
    }

    /// Checks what building and rendering `file` takes ([`scene_needs`]).
    pub fn check_scene(&self, file: &SceneFile) -> anyhow::Result<()> {
        self.check(&scene_needs(&file.memory_estimate()?))
    }

    /// Checks what `evaluate` of `file` with the comma-separated `models` takes
    /// ([`evaluate_needs`]: a reference and one render per model).
    pub fn check_evaluate(&self, file: &SceneFile, models: &str) -> anyhow::Result<()> {
        let renders = 1 + models.split(',').filter(|n| !n.trim().is_empty()).count() as u64;
        self.check(&evaluate_needs(&file.memory_estimate()?, renders))
    }
}

/// Checks `needs` against the process's budget (`--memory-limit` where the verb has it, set
/// by `main`; else the available memory): the check of the verbs without the flag.
pub fn check(needs: &[Need]) -> anyhow::Result<()> {
    budget::check_needs(needs).map_err(anyhow::Error::from)
}

/// The needs of building and rendering a scene: the image, then each `[[hair]]` entry's
/// strands and BVH ([`MemoryEstimate::needs`]).
#[must_use]
pub fn scene_needs(e: &MemoryEstimate) -> Vec<Need> {
    e.needs()
}

/// `evaluate`: the scene, and the `renders` images (the reference and one per model) kept as
/// f64 RGB (24 bytes per pixel) and laid side by side in the 8-bit grid (3 per pixel).
#[must_use]
pub fn evaluate_needs(e: &MemoryEstimate, renders: u64) -> Vec<Need> {
    let mut needs = scene_needs(e);
    let pixels = u64::from(e.width) * u64::from(e.height);
    let kept = pixels.checked_mul(24 + 3).and_then(|b| b.checked_mul(renders));
    needs.push(Need::new(format!("{renders} images {}×{} compared and in the grid", e.width, e.height), kept));
    needs
}

/// `measure`: one measurement at a time ([`Setup::estimated_bytes`]), the finished tables of
/// every incidence ([`fiberlab_gonio::RESULT_BYTES_PER_BIN`] per bin), and the figure and EXR
/// of the first (a f64 and 3 f32 per bin).
#[must_use]
pub fn measure_needs(setup: &Setup, incidences: usize, threads: usize) -> Vec<Need> {
    let bins = setup.bin_count();
    let kept = bins
        .and_then(|b| b.checked_mul(fiberlab_gonio::RESULT_BYTES_PER_BIN))
        .and_then(|b| b.checked_mul(incidences.saturating_sub(1) as u64));
    let figure = bins.and_then(|b| b.checked_mul(8 + 12));
    let what = format!("goniophotometer bins {}×{}", setup.bins_theta, setup.bins_phi);
    vec![
        Need::new(what.clone(), setup.estimated_bytes(threads)),
        Need::new(format!("{what} of {} more incidences", incidences.saturating_sub(1)), kept),
        Need::new(format!("figure and EXR of {what}"), figure),
    ]
}

/// `hair generate`: the generator's peak ([`HairParams::estimated_bytes`]; the file written
/// from it afterwards is smaller).
#[must_use]
pub fn hair_generate_needs(p: &HairParams) -> Vec<Need> {
    vec![Need::new(format!("hair {} strands × {} segments", p.strands, p.segments), p.estimated_bytes())]
}

/// `hair generate --style grass`: the blades as ribbon curves and their `.usda` text
/// ([`GrassParams::estimated_strand_bytes`]).
#[must_use]
pub fn grass_generate_needs(p: &GrassParams) -> Vec<Need> {
    vec![Need::new(format!("grass {} blades × {} segments", p.blades, p.segments), Some(p.estimated_strand_bytes()))]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scene_and_measure_needs_add_their_parts() {
        let e = SceneFile::default_scene().memory_estimate().unwrap();
        let needs = scene_needs(&e);
        let what: Vec<&str> = needs.iter().map(|n| n.what.as_str()).collect();
        assert_eq!(
            what,
            ["image 512×512", "hair 20000 strands × 480000 segments (generated)", "BVH of 480000 segments"]
        );
        // 512² · 139 + 20000 · (25 · 40 + 50) + 480000 · 1200 bytes.
        let sum: u64 = needs.iter().map(|n| n.bytes.unwrap()).sum();
        assert_eq!(sum, 512 * 512 * 139 + 20_000 * 1050 + 480_000 * 1200);
        let eval = evaluate_needs(&e, 4);
        assert_eq!(eval.last().unwrap().bytes, Some(4 * 512 * 512 * 27));
        let setup = Setup { theta_i: 0.0, phi_i: 0.0, rays: 1, bins_theta: 10, bins_phi: 20, seed: 1 };
        let m = measure_needs(&setup, 3, 1);
        // One measurement in flight (576 per bin, 2 chunks of records), two more kept (288 per
        // bin each), the figure and EXR (20 per bin).
        assert_eq!(m[0].bytes, Some(200 * 576 + 2 * 65_536 * 32));
        assert_eq!(m[1].bytes, Some(2 * 200 * 288));
        assert_eq!(m[2].bytes, Some(200 * 20));
    }
}
