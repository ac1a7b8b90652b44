//! `fiberlab mesh cloth`: writes the draped-cloth mesh ([`fiberlab_procedural::draped_cloth`])
//! that `scenes/cloth.toml` uses: a square cloth over a sphere on the floor, as an OBJ with
//! texture coordinates (`u` along the cloth's `x` edge, `v` along its `z` edge) and normals.
//!
//! `fiberlab mesh cloth-patch`: writes the fibers of an explicit woven patch
//! ([`fiberlab_procedural::woven_patch`]) as a strand file (`.usda`, `.hair`, `.pbrt`), which a
//! scene renders with `[[hair]] file = …`.

use anyhow::Context;
use fiberlab_procedural::draped_cloth::DrapedCloth;
use fiberlab_procedural::woven_patch::{Weave, WovenPatch};
use std::path::PathBuf;

/// Flags of `fiberlab mesh`.
#[derive(clap::Args)]
pub struct Args {
    #[command(subcommand)]
    kind: Kind,
}

#[derive(clap::Subcommand)]
enum Kind {
    /// A square cloth draped over a sphere (radius 0.5, centre (0, 0.5, 0)) on the floor y = 0.
    Cloth {
        /// Output OBJ file (its directory is created if missing).
        #[arg(long, default_value = "scenes/cloth.obj")]
        out: PathBuf,
        /// Grid cells per side (≥ 32; two triangles per cell).
        #[arg(long, default_value_t = 64)]
        resolution: usize,
        /// Half the cloth's side (scene units; larger than the sphere radius 0.5).
        #[arg(long, default_value_t = 1.5)]
        half_size: f64,
        /// Number of folds around the sphere.
        #[arg(long, default_value_t = 7)]
        folds: u32,
    },
    /// The fibers of a woven patch (warp along y, weft along x, z up), as polylines.
    ClothPatch {
        #[command(flatten)]
        patch: PatchArgs,
        /// Pattern repeats along x and y (the patch covers periods × period).
        #[arg(long, default_value_t = 4)]
        periods: usize,
        /// Output strand file: .usda, .hair or .pbrt (by extension).
        #[arg(long)]
        out: PathBuf,
    },
}

/// The woven patch's flags (shared with `measure --surface --cloth`); lengths in mm.
#[derive(clap::Args, Clone, Debug)]
pub struct PatchArgs {
    /// Weave: plain, twill (= twill-2/1) or twill-2/2.
    #[arg(long, default_value = "plain")]
    pub weave: String,
    /// Distance between neighbouring yarn centres (mm).
    #[arg(long, default_value_t = 0.32)]
    pub spacing: f64,
    /// Yarn radius (mm, ≤ spacing/2).
    #[arg(long, default_value_t = 0.1)]
    pub yarn_radius: f64,
    /// Height of a yarn centre at a crossing (mm, ≥ yarn radius; checked for clearance).
    #[arg(long, default_value_t = 0.11)]
    pub crimp: f64,
    /// Plies per yarn (1 … 8).
    #[arg(long, default_value_t = 2)]
    pub plies: usize,
    /// Ply twist angle, degrees [0, 80].
    #[arg(long, default_value_t = 20.0)]
    pub ply_twist: f64,
    /// Fibers per ply (1 … 2000).
    #[arg(long, default_value_t = 24)]
    pub fibers_per_ply: usize,
    /// Fiber radius (mm).
    #[arg(long, default_value_t = 0.008)]
    pub fiber_radius: f64,
    /// Fiber twist angle ψ at the ply surface, degrees [0, 80].
    #[arg(long, default_value_t = 30.0)]
    pub psi: f64,
    /// Polyline vertices per yarn spacing (≥ 4; more where the twist needs them).
    #[arg(long, default_value_t = 24)]
    pub samples_per_spacing: usize,
    /// Seed of the per-yarn phases.
    #[arg(long, default_value_t = 1)]
    pub patch_seed: u64,
}

impl PatchArgs {
    /// The typed, validated patch.
    pub fn patch(&self) -> anyhow::Result<WovenPatch> {
        let p = WovenPatch {
            weave: Weave::parse(&self.weave)?,
            spacing: self.spacing,
            yarn_radius: self.yarn_radius,
            crimp: self.crimp,
            plies: self.plies,
            ply_twist: self.ply_twist.to_radians(),
            fibers_per_ply: self.fibers_per_ply,
            fiber_radius: self.fiber_radius,
            psi: self.psi.to_radians(),
            samples_per_spacing: self.samples_per_spacing,
            seed: self.patch_seed,
        };
        p.validate()?;
        Ok(p)
    }
}

/// Runs `fiberlab mesh`.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let (out, resolution, half_size, folds) = match &args.kind {
        Kind::Cloth { out, resolution, half_size, folds } => (out, resolution, half_size, folds),
        Kind::ClothPatch { patch, periods, out } => return cloth_patch(patch, *periods, out),
    };
    let cloth = DrapedCloth { resolution: *resolution, half_size: *half_size, folds: *folds, ..DrapedCloth::default() };
    // (n + 1)² vertices (position, normal, uv: 64 bytes; ~90 bytes of OBJ text) and 2n²
    // triangles (24 bytes; ~40 of text), counted before the grid is made.
    let n = (*resolution as u64).saturating_add(1);
    let vertices = n.saturating_mul(n);
    crate::memory_budget::check(&[crate::memory_budget::Need::items(
        format!("cloth mesh of {vertices} vertices (--resolution {resolution})"),
        vertices,
        64 + 90 + 2 * (24 + 40),
    )])?;
    let grid = cloth.grid()?;
    let header = format!(
        "A cloth draped over a sphere (radius {r}, centre (0, {r}, 0)) on the floor y = 0, written by\n\
         `fiberlab mesh cloth --resolution {resolution} --half-size {half_size} --folds {folds}`\n\
         (crates/procedural/src/draped_cloth.rs): u = 1/2 + x/(2·{half_size}) along x, v = 1/2 − z/(2·{half_size}).",
        r = cloth.sphere_radius
    );
    if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    crate::files::write_atomically(out, grid.to_obj(&header).as_bytes())?;
    println!("{} ({} triangles)", out.display(), grid.triangles.len());
    Ok(())
}

/// `fiberlab mesh cloth-patch`: the patch's fibers as a strand file (f32 points, diameters).
fn cloth_patch(args: &PatchArgs, periods: usize, out: &std::path::Path) -> anyhow::Result<()> {
    let patch = args.patch()?;
    let (segments, _, _) = patch.estimated_segments(periods, periods);
    crate::memory_budget::check(&[crate::memory_budget::Need::new(
        format!("{periods} × {periods} periods of the woven patch ({segments} segments)"),
        fiberlab_geometry::curves::CurveSet::estimated_bytes(segments),
    )])?;
    let fibers = patch.fibers(periods, periods)?;
    let strands = fibers.strands();
    if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    fiberlab_io::strand_files::write(out, &strands, 1)?;
    let (alpha, psi) = patch.effective_twists();
    println!(
        "{} ({} fibers, {} segments; patch {:.4} × {:.4} mm, period {:.4} mm; effective ply twist {:.2}°, ψ {:.2}°)",
        out.display(),
        fibers.counts.len(),
        fibers.segment_count(),
        patch.period() * periods as f64,
        patch.period() * periods as f64,
        patch.period(),
        alpha.to_degrees(),
        psi.to_degrees()
    );
    Ok(())
}
