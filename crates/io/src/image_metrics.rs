//! Image metrics between a reference A (a photograph or render) and a test image B, what
//! `fiberlab compare` prints and the Python package's `fiberlab.compare` returns: RMSE and
//! relative MSE (linear values), SSIM (luminance of the sRGB-encoded images, 11×11 Gaussian
//! window, σ = 1.5; Wang et al. 2004) and FLIP (NVIDIA's ꟻLIP, Andersson et al. 2020, through
//! the `nv-flip` crate), with an optional mask and per-channel least-squares exposure /
//! white-balance alignment of B to A.

use crate::image_file::encode_srgb8;

/// A linear RGB image in memory, row-major from the top-left pixel.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    /// Pixels per row.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// `width × height` linear RGB values.
    pub pixels: Vec<[f64; 3]>,
}

/// The metrics of one comparison.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Metrics {
    /// Root mean square of A − B over the channels of the compared pixels.
    pub rmse: f64,
    /// Mean of (A − B)² / (A² + 0.01) over the channels of the compared pixels.
    pub relmse: f64,
    /// Mean SSIM of the sRGB-encoded luminance.
    pub ssim: f64,
    /// Mean ꟻLIP error of the sRGB-encoded images.
    pub flip: f64,
    /// The per-channel factors B was scaled by (only with alignment).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub scale: Option<[f64; 3]>,
}

/// Why two images cannot be compared.
#[derive(Debug, thiserror::Error)]
pub enum MetricsError {
    /// A and B differ in size.
    #[error("size mismatch: A is {0}×{1}, B is {2}×{3}")]
    SizeMismatch(usize, usize, usize, usize),
    /// The mask differs in size from the images.
    #[error("size mismatch: the mask is {0}×{1}, the images {2}×{3}")]
    MaskSize(usize, usize, usize, usize),
    /// The mask selects nothing.
    #[error("the mask selects no pixel")]
    EmptyMask,
    /// An image has a NaN or infinite pixel.
    #[error("{0}: {1} pixels are NaN or infinite")]
    NotFinite(&'static str, usize),
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
    let l = fiberlab_math::Rgb(*p).luminance();
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

/// Computes every metric of B against reference A, over the pixels whose `mask` value (mean
/// of its channels) is above one half; B is first scaled per channel by the least-squares
/// factors when `align` is set. Also returns the per-pixel RMS difference (0 outside the mask).
pub fn compare(a: &Image, b: &Image, mask: Option<&Image>, align: bool) -> Result<(Metrics, Vec<f64>), MetricsError> {
    if (a.width, a.height) != (b.width, b.height) {
        return Err(MetricsError::SizeMismatch(a.width, a.height, b.width, b.height));
    }
    for (name, img) in [("A", a), ("B", b)] {
        let bad = img.pixels.iter().filter(|p| p.iter().any(|c| !c.is_finite())).count();
        if bad > 0 {
            return Err(MetricsError::NotFinite(name, bad));
        }
    }
    let mask: Vec<bool> = match mask {
        Some(m) if (m.width, m.height) != (a.width, a.height) => {
            return Err(MetricsError::MaskSize(m.width, m.height, a.width, a.height));
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
        return Err(MetricsError::EmptyMask);
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

    #[test]
    fn a_mask_that_selects_nothing_and_nan_pixels_are_refused() {
        let a = flat(8, 8, |_, _| [0.5; 3]);
        let none = flat(8, 8, |_, _| [0.0; 3]);
        assert!(matches!(compare(&a, &a, Some(&none), false), Err(MetricsError::EmptyMask)));
        let nan = flat(8, 8, |x, _| if x == 3 { [f64::NAN; 3] } else { [0.5; 3] });
        assert!(matches!(compare(&a, &nan, None, false), Err(MetricsError::NotFinite("B", 8))));
    }
}
