//! `fiberlab compare A B`: image metrics between a reference A (a photograph or render) and B
//! (computed by `fiberlab_io::image_metrics`: RMSE, relative MSE, SSIM, FLIP, optional
//! alignment and mask), per-channel histograms, and a side-by-side + false-colour difference
//! figure.

use anyhow::{Context, bail};
use fiberlab_io::LinearImage;
use fiberlab_io::image_file::decode_srgb8 as srgb_to_linear;
pub(crate) use fiberlab_io::image_metrics::{Image, compare};
use plotters::style::colors::colormaps::ViridisRGB;
use std::path::{Path, PathBuf};

/// Flags of `fiberlab compare`.
#[derive(clap::Args)]
pub struct Args {
    /// Reference image (EXR, PNG or JPEG).
    a: PathBuf,
    /// Test image (EXR, PNG or JPEG), same size.
    b: PathBuf,
    /// Mask image: pixels whose value is above one half are compared.
    #[arg(long)]
    mask: Option<PathBuf>,
    /// Scale each channel of B by the least-squares factor that best matches A (reported).
    #[arg(long)]
    align: bool,
    /// Output prefix of the figure PREFIX.png (A | B | false-colour |A − B|).
    #[arg(long, value_name = "PREFIX", value_parser = crate::arg_values::out_prefix)]
    out: Option<crate::arg_values::OutPrefix>,
    /// Print one JSON object instead of text.
    #[arg(long)]
    json: bool,
}

/// Reads EXR (linear) or PNG/JPEG (sRGB, decoded to linear); counts NaN/Inf pixels as errors.
pub(crate) fn load(path: &Path) -> anyhow::Result<Image> {
    let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    let img = if ext.as_deref() == Some("exr") {
        let l = LinearImage::read_exr(path).with_context(|| format!("reading {}", path.display()))?;
        Image {
            width: l.width(),
            height: l.height(),
            pixels: l.pixels().iter().map(|p| [f64::from(p[0]), f64::from(p[1]), f64::from(p[2])]).collect(),
        }
    } else {
        let d = fiberlab_io::image_file::decode_image(path)?.to_rgb8();
        Image {
            width: d.width() as usize,
            height: d.height() as usize,
            pixels: d.pixels().map(|p| [srgb_to_linear(p[0]), srgb_to_linear(p[1]), srgb_to_linear(p[2])]).collect(),
        }
    };
    let bad = img.pixels.iter().filter(|p| p.iter().any(|c| !c.is_finite())).count();
    if bad > 0 {
        bail!("{}: {bad} pixels are NaN or infinite", path.display());
    }
    Ok(img)
}

/// Runs the comparison.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let (a, b) = (load(&args.a)?, load(&args.b)?);
    let mask = args.mask.as_deref().map(load).transpose()?;
    let (m, diff) = compare(&a, &b, mask.as_ref(), args.align)?;
    if args.json {
        println!("{}", serde_json::to_string(&m)?);
    } else {
        println!("rmse {:.6}  relmse {:.6}  ssim {:.6}  flip {:.6}", m.rmse, m.relmse, m.ssim, m.flip);
        if let Some(s) = m.scale {
            println!("alignment scale of B per channel: {:.6} {:.6} {:.6}", s[0], s[1], s[2]);
        }
        for (name, img) in [("A", &a), ("B", &b)] {
            println!("{name} histogram (linear, 8 bins of [0, 1] + above):");
            for c in 0..3 {
                let mut bins = [0usize; 9];
                for p in &img.pixels {
                    bins[((p[c].max(0.0) * 8.0) as usize).min(8)] += 1;
                }
                println!("  {}: {:?}", ["r", "g", "b"][c], bins);
            }
        }
    }
    if let Some(prefix) = &args.out {
        figure(&a, &b, &diff, &prefix.with(".png"))?;
    }
    Ok(())
}

/// A | B | false-colour |A − B| (viridis, scaled to the largest difference).
fn figure(a: &Image, b: &Image, diff: &[f64], path: &Path) -> anyhow::Result<()> {
    let (w, h) = (a.width, a.height);
    let mut out = LinearImage::new(3 * w, h);
    let max = diff.iter().copied().fold(0.0, f64::max).max(1e-12);
    for y in 0..h {
        for x in 0..w {
            let k = y * w + x;
            let f = |p: [f64; 3]| [p[0] as f32, p[1] as f32, p[2] as f32];
            out.set(x, y, f(a.pixels[k]));
            out.set(w + x, y, f(b.pixels[k]));
            let c = ViridisRGB::get_color_normalized(diff[k], 0.0, max);
            out.set(2 * w + x, y, [c.0, c.1, c.2].map(|v| srgb_to_linear(v) as f32));
        }
    }
    out.write_png(path, 0.0, fiberlab_io::ToneMap::Clamp).with_context(|| format!("writing {}", path.display()))
}
