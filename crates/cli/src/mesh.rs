//! `fiberlab mesh cloth`: writes the draped-cloth mesh ([`fiberlab_render::draped_cloth`])
//! that `scenes/cloth.toml` uses: a square cloth over a sphere on the floor, as an OBJ with
//! texture coordinates (`u` along the cloth's `x` edge, `v` along its `z` edge) and normals.

use anyhow::Context;
use fiberlab_render::draped_cloth::DrapedCloth;
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
}

/// Runs `fiberlab mesh`.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let Kind::Cloth { out, resolution, half_size, folds } = &args.kind;
    let cloth = DrapedCloth { resolution: *resolution, half_size: *half_size, folds: *folds, ..DrapedCloth::default() };
    let grid = cloth.grid()?;
    let header = format!(
        "A cloth draped over a sphere (radius {r}, centre (0, {r}, 0)) on the floor y = 0, written by\n\
         `fiberlab mesh cloth --resolution {resolution} --half-size {half_size} --folds {folds}`\n\
         (crates/render/src/draped_cloth.rs): u = 1/2 + x/(2·{half_size}) along x, v = 1/2 − z/(2·{half_size}).",
        r = cloth.sphere_radius
    );
    if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    std::fs::write(out, grid.to_obj(&header)).with_context(|| format!("writing {}", out.display()))?;
    println!("{} ({} triangles)", out.display(), grid.triangles.len());
    Ok(())
}
