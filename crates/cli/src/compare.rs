//! `fiberlab compare A B`: image metrics between a reference A (a photograph or render) and B:
//! RMSE and relative MSE (linear values), SSIM (luminance of the sRGB-encoded images, 11×11
//! Gaussian window, σ = 1.5) and FLIP (NVIDIA's ꟻLIP through the `nv-flip` crate), with
//! optional per-channel least-squares exposure/white-balance alignment of B to A, a mask,
//! per-channel histograms, and a side-by-side + false-colour difference figure.

use anyhow::{Context, bail};
use fiberlab_io::LinearImage;
use fiberlab_io::image_file::{decode_srgb8 as srgb_to_linear, encode_srgb8};
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

/// A linear RGB image in memory.
#[derive(Clone)]
pub(crate) struct Image {
    pub width: usize,
    pub height: usize,
    pub pixels: Vec<[f64; 3]>,
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
        let d = image::open(path).with_context(|| format!("reading {}", path.display()))?.to_rgb8();
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

/// The metrics of one comparison.
#[derive(Clone, Debug, serde::Serialize)]
pub(crate) struct Metrics {
    pub rmse: f64,
    pub relmse: f64,
    pub ssim: f64,
    pub flip: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub scale: Option<[f64; 3]>,
}

/// Least-squares per-channel factors `s_c` minimizing `Σ (a − s_c b)²` over masked pixels.
fn alignment(a: &Image, b: &Image, mask: &[bool]) -> [f64; 3] {
    let mut s = [0.0; 3];
    for c in 0..3 {
        let (mut ab, mut bb) = (0.0, 0.0);
        for ((pa, pb), &m) in a.pixels.iter().zip(&b.pixels).zip(mask) {
            if m {
                ab += pa[c] * pb[c];
                bb += pb[c] * pb[c];
            }
        }
        s[c] = if bb > 0.0 { ab / bb } else { 1.0 };
    }
    s
}

fn luminance_srgb(p: &[f64; 3]) -> f64 {
    let l = 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2];
    f64::from(encode_srgb8(l)) / 255.0
}

/// Mean SSIM of the sRGB-encoded luminance over masked pixels (Wang et al. 2004 constants).
fn ssim(a: &Image, b: &Image, mask: &[bool]) -> f64 {
    let (w, h) = (a.width, a.height);
    let la: Vec<f64> = a.pixels.iter().map(luminance_srgb).collect();
    let lb: Vec<f64> = b.pixels.iter().map(luminance_srgb).collect();
    let radius = 5i64;
    let weights: Vec<f64> = (-radius..=radius).map(|k| (-(k * k) as f64 / (2.0 * 1.5 * 1.5)).exp()).collect();
    let (c1, c2) = (0.01f64.powi(2), 0.03f64.powi(2));
    let (mut sum, mut n) = (0.0, 0usize);
    for y in 0..h {
        for x in 0..w {
            if !mask[y * w + x] {
                continue;
            }
            let (mut wsum, mut ma, mut mb, mut aa, mut bb, mut ab) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
            for dy in -radius..=radius {
                for dx in -radius..=radius {
                    let (xx, yy) = (x as i64 + dx, y as i64 + dy);
                    if xx < 0 || yy < 0 || xx >= w as i64 || yy >= h as i64 {
                        continue;
                    }
                    let k = yy as usize * w + xx as usize;
                    let g = weights[(dx + radius) as usize] * weights[(dy + radius) as usize];
                    wsum += g;
                    ma += g * la[k];
                    mb += g * lb[k];
                    aa += g * la[k] * la[k];
                    bb += g * lb[k] * lb[k];
                    ab += g * la[k] * lb[k];
                }
            }
            let (ma, mb) = (ma / wsum, mb / wsum);
            let (va, vb, cov) = (aa / wsum - ma * ma, bb / wsum - mb * mb, ab / wsum - ma * mb);
            sum += ((2.0 * ma * mb + c1) * (2.0 * cov + c2)) / ((ma * ma + mb * mb + c1) * (va + vb + c2));
            n += 1;
        }
    }
    if n == 0 { f64::NAN } else { sum / n as f64 }
}

fn srgb8(img: &Image) -> Vec<u8> {
    img.pixels.iter().flat_map(|p| p.map(encode_srgb8)).collect()
}

/// Computes every metric of B against reference A.
pub(crate) fn compare(a: &Image, b: &Image, mask: Option<&Image>, align: bool) -> anyhow::Result<(Metrics, Vec<f64>)> {
    if (a.width, a.height) != (b.width, b.height) {
        bail!("size mismatch: A is {}×{}, B is {}×{}", a.width, a.height, b.width, b.height);
    }
    let mask: Vec<bool> = match mask {
        Some(m) if (m.width, m.height) != (a.width, a.height) => {
            bail!("size mismatch: the mask is {}×{}, the images {}×{}", m.width, m.height, a.width, a.height)
        }
        Some(m) => m.pixels.iter().map(|p| (p[0] + p[1] + p[2]) / 3.0 > 0.5).collect(),
        None => vec![true; a.pixels.len()],
    };
    let scale = align.then(|| alignment(a, b, &mask));
    let b = Image {
        width: b.width,
        height: b.height,
        pixels: b.pixels.iter().map(|p| scale.map_or(*p, |s| [p[0] * s[0], p[1] * s[1], p[2] * s[2]])).collect(),
    };
    let (mut se, mut rel, mut n) = (0.0, 0.0, 0usize);
    let mut diff = Vec::with_capacity(a.pixels.len());
    for ((pa, pb), &m) in a.pixels.iter().zip(&b.pixels).zip(&mask) {
        let d: f64 = (0..3).map(|c| (pa[c] - pb[c]).powi(2)).sum::<f64>() / 3.0;
        diff.push(if m { d.sqrt() } else { 0.0 });
        if m {
            se += d;
            rel += (0..3).map(|c| (pa[c] - pb[c]).powi(2) / (pa[c] * pa[c] + 1e-2)).sum::<f64>() / 3.0;
            n += 1;
        }
    }
    if n == 0 {
        bail!("the mask selects no pixel");
    }
    let fa = nv_flip::FlipImageRgb8::with_data(a.width as u32, a.height as u32, &srgb8(a));
    let fb = nv_flip::FlipImageRgb8::with_data(b.width as u32, b.height as u32, &srgb8(&b));
    let error = nv_flip::flip(fa, fb, nv_flip::DEFAULT_PIXELS_PER_DEGREE).to_vec();
    let flip_mean = error.iter().zip(&mask).filter(|(_, m)| **m).map(|(e, _)| f64::from(*e)).sum::<f64>() / n as f64;
    let metrics = Metrics {
        rmse: (se / n as f64).sqrt(),
        relmse: rel / n as f64,
        ssim: ssim(a, &b, &mask),
        flip: flip_mean,
        scale,
    };
    Ok((metrics, diff))
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

#[cfg(test)]
mod tests {
    use super::*;

    fn flat(w: usize, h: usize, f: impl Fn(usize, usize) -> [f64; 3]) -> Image {
        Image { width: w, height: h, pixels: (0..w * h).map(|k| f(k % w, k / w)).collect() }
    }

    #[test]
    fn identical_images_have_zero_error() {
        let a = flat(32, 24, |x, y| [x as f64 / 32.0, y as f64 / 24.0, 0.3]);
        let (m, _) = compare(&a, &flat(32, 24, |x, y| [x as f64 / 32.0, y as f64 / 24.0, 0.3]), None, false).unwrap();
        assert_eq!(m.rmse, 0.0);
        assert_eq!(m.relmse, 0.0);
        assert!((m.ssim - 1.0).abs() < 1e-12);
        assert!(m.flip.abs() < 1e-6);
    }

    #[test]
    fn known_offsets_and_scales_give_known_values() {
        let a = flat(16, 16, |_, _| [0.5, 0.5, 0.5]);
        let b = flat(16, 16, |_, _| [0.3, 0.3, 0.3]);
        let (m, _) = compare(&a, &b, None, false).unwrap();
        assert!((m.rmse - 0.2).abs() < 1e-12);
        assert!((m.relmse - 0.04 / 0.26).abs() < 1e-12);
        // B = A/2 per channel with different factors: alignment recovers them exactly.
        let a = flat(20, 10, |x, y| [0.1 + x as f64 / 40.0, 0.2 + y as f64 / 30.0, 0.4]);
        let b = flat(20, 10, |x, y| [(0.1 + x as f64 / 40.0) / 2.0, (0.2 + y as f64 / 30.0) / 4.0, 0.4 * 1.25]);
        let (m, _) = compare(&a, &b, None, true).unwrap();
        let s = m.scale.unwrap();
        assert!((s[0] - 2.0).abs() < 1e-12 && (s[1] - 4.0).abs() < 1e-12 && (s[2] - 0.8).abs() < 1e-12);
        assert!(m.rmse < 1e-12);
        let big = flat(21, 10, |_, _| [0.0; 3]);
        assert!(compare(&a, &big, None, false).unwrap_err().to_string().contains("size mismatch"));
    }
}
