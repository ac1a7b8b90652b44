//! `fiberlab merge`: combine parts rendered with `--tile I/N` or disjoint `--crop`s (same scene
//! and seed) into the image a single machine would have rendered, bit for bit.

use fiberlab_io::{LinearImage, ToneMap};
use fiberlab_render::integrator::merge;
use std::path::PathBuf;

/// Flags of `fiberlab merge`.
#[derive(clap::Args)]
pub struct Args {
    /// Part images (EXR) written by `fiberlab render --tile I/N`.
    #[arg(required = true)]
    parts: Vec<PathBuf>,
    /// Output prefix: writes PREFIX.exr and PREFIX.png.
    #[arg(long, default_value = "render")]
    out: String,
    /// Exposure for the PNG in stops.
    #[arg(long, default_value_t = 0.0)]
    exposure: f64,
}

/// Runs `fiberlab merge`.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let parts: Vec<LinearImage> = args.parts.iter().map(|p| LinearImage::read_exr(p)).collect::<Result<_, _>>()?;
    let image = merge(&parts)?;
    image.write_exr(&PathBuf::from(format!("{}.exr", args.out)))?;
    image.write_png(&PathBuf::from(format!("{}.png", args.out)), args.exposure, ToneMap::Filmic)?;
    eprintln!("merged {} parts → {}.exr, {}.png", parts.len(), args.out, args.out);
    Ok(())
}
