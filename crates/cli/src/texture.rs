//! `fiberlab texture wood`: writes the procedural figured-maple fiber map
//! ([`fiberlab_procedural::figured_maple`]) that `scenes/wood.toml` uses, in the output directory:
//! `fiber_angle.png` and `fiber_dip.png` (16-bit grey, linear: code `c` means
//! `−90° + 180°·c/65535`, read with `remap = [-90, 90]`) and `k_d.png` (8-bit sRGB colour).

use anyhow::Context;
use fiberlab_io::ToneMap;
use fiberlab_procedural::figured_maple::MapleFigure;
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
    // Three linear images (12 bytes a texel) and the encoders' copies (8), before any work.
    crate::memory_budget::check(&[crate::memory_budget::Need::items(
        format!("texture {width}×{height} (three maps)"),
        (width as u64).saturating_mul(height as u64),
        3 * 20,
    )])?;
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let maps = figure.maps();
    for (name, image) in [("fiber_angle.png", &maps.fiber_angle), ("fiber_dip.png", &maps.fiber_dip)] {
        let path = out.join(name);
        write_degrees_png(image, &path).with_context(|| format!("writing {}", path.display()))?;
        println!("{}", path.display());
    }
    let path = out.join("k_d.png");
    maps.k_d.write_png(&path, 0.0, ToneMap::Clamp).with_context(|| format!("writing {}", path.display()))?;
    println!("{}", path.display());
    Ok(())
}

/// Angles in degrees (the red channel, within ±90°) as a 16-bit grey PNG, code
/// `round((a + 90)/180 · 65535)`.
fn write_degrees_png(image: &fiberlab_io::LinearImage, path: &std::path::Path) -> anyhow::Result<()> {
    let codes: Vec<u16> = image
        .pixels()
        .iter()
        .map(|p| ((f64::from(p[0]).clamp(-90.0, 90.0) + 90.0) / 180.0 * 65535.0).round() as u16)
        .collect();
    let (w, h) = (u32::try_from(image.width())?, u32::try_from(image.height())?);
    let buffer = image::ImageBuffer::<image::Luma<u16>, _>::from_raw(w, h, codes).context("image size")?;
    let mut bytes = std::io::Cursor::new(Vec::new());
    buffer.write_to(&mut bytes, image::ImageFormat::Png)?;
    crate::files::write_atomically(path, bytes.get_ref())
}
