//! `fiberlab texture wood`: writes the procedural figured-maple fiber map
//! ([`fiberlab_render::figured_maple`]) that `scenes/wood.toml` uses: `fiber_angle.exr` and
//! `fiber_dip.exr` (degrees, linear) and `k_d.png` (sRGB) in the output directory.

use anyhow::Context;
use fiberlab_io::ToneMap;
use fiberlab_render::figured_maple::MapleFigure;
use std::path::PathBuf;

/// Flags of `fiberlab texture`.
#[derive(clap::Args)]
pub struct Args {
    #[command(subcommand)]
    kind: Kind,
}

#[derive(clap::Subcommand)]
enum Kind {
    /// Figured (curly) maple: fiber angle, fiber dip and diffuse colour maps.
    Wood {
        /// Output directory (created if missing).
        #[arg(long, default_value = "scenes/textures/maple")]
        out: PathBuf,
        /// Texels along the grain (u).
        #[arg(long, default_value_t = 512)]
        width: usize,
        /// Texels across the grain (v).
        #[arg(long, default_value_t = 128)]
        height: usize,
        /// Curl stripes along the board.
        #[arg(long, default_value_t = 12.0)]
        stripes: f64,
        /// Largest fiber dip, degrees.
        #[arg(long, default_value_t = 30.0)]
        dip: f64,
        /// Noise seed.
        #[arg(long, default_value_t = 1)]
        seed: u64,
    },
}

/// Runs `fiberlab texture`.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let Kind::Wood { out, width, height, stripes, dip, seed } = &args.kind;
    let (width, height, stripes, dip, seed) = (*width, *height, *stripes, *dip, *seed);
    anyhow::ensure!(width > 0 && height > 0, "--width and --height must be > 0");
    anyhow::ensure!(stripes.is_finite() && stripes >= 0.0, "--stripes = {stripes} must be finite and ≥ 0");
    anyhow::ensure!((0.0..=90.0).contains(&dip), "--dip = {dip} must be in [0, 90] degrees");
    let figure = MapleFigure { width, height, stripes, dip_amplitude_deg: dip, seed, ..MapleFigure::default() };
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let maps = figure.maps();
    for (name, image) in [("fiber_angle.exr", &maps.fiber_angle), ("fiber_dip.exr", &maps.fiber_dip)] {
        let path = out.join(name);
        image.write_exr(&path).with_context(|| format!("writing {}", path.display()))?;
        println!("{}", path.display());
    }
    let path = out.join("k_d.png");
    maps.k_d.write_png(&path, 0.0, ToneMap::Clamp).with_context(|| format!("writing {}", path.display()))?;
    println!("{}", path.display());
    Ok(())
}
