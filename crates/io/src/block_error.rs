//! Errors of a rendered image against a reference, as the dual-scattering benchmarks
//! (`bench/dual_scattering/`) report them, and the per-channel least-squares fit of the fitted
//! baselines there. Luminance is `0.2126 R + 0.7152 G + 0.0722 B` of linear values.
//!
//! * image mean: `lum(mean(image)) / lum(mean(reference)) − 1`;
//! * covered mean: the same with every pixel weighted by a coverage mask (the hair's share of
//!   the pixel), so that only what the hair shows counts;
//! * block RMSE: the image cut into 16 × 16 blocks; for each counted block the relative error
//!   of its mean luminance; the root mean square of those. Without a mask a block counts when
//!   its reference mean is above 1 % of the image's; with a mask when the mask's mean over the
//!   block is above ½ (the hair covers most of it).
//! * channel ratios: per channel, the (coverage-weighted) mean of the image over that of the
//!   reference ([`channel_ratios`]);
//! * firefly ratio: over the counted pixels (mask above ½, or all), the 99.99th percentile of
//!   the per-pixel `|lum(image − reference)|` over its median ([`firefly_ratio`]): about 4–6
//!   for noise with light tails at a few thousand pixels, 10² and more when a few pixels carry
//!   rare, huge samples.

use crate::LinearImage;
use thiserror::Error;

/// Side of the blocks, pixels.
pub const BLOCK: usize = 16;

/// Why images cannot be compared or fitted.
#[derive(Debug, Error, PartialEq, Eq)]
#[non_exhaustive]
pub enum BlockErrorError {
    /// Two images of different sizes.
    #[error("{what} is {found_w}×{found_h}, the reference is {width}×{height}")]
    Size {
        /// Which image.
        what: String,
        /// Reference width.
        width: usize,
        /// Reference height.
        height: usize,
        /// Its width.
        found_w: usize,
        /// Its height.
        found_h: usize,
    },
    /// The least-squares system is singular (a term is zero or two are proportional).
    #[error("the fit's terms are linearly dependent in channel {0} (a term is black or two are proportional)")]
    Singular(usize),
}

/// The errors of an image against its reference.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BlockError {
    /// Relative error of the image mean's luminance.
    pub mean_rel: f64,
    /// Relative error of the coverage-weighted mean (NaN without a mask).
    pub covered_mean_rel: f64,
    /// RMS over the counted blocks of the block means' relative errors (NaN with none).
    pub block_rmse: f64,
    /// Blocks counted.
    pub blocks: usize,
}

fn lum(v: [f64; 3]) -> f64 {
    fiberlab_math::Rgb(v).luminance()
}

fn check(what: &str, a: &LinearImage, reference: &LinearImage) -> Result<(), BlockErrorError> {
    let (width, height) = (reference.width(), reference.height());
    if (a.width(), a.height()) == (width, height) {
        Ok(())
    } else {
        Err(BlockErrorError::Size { what: what.into(), width, height, found_w: a.width(), found_h: a.height() })
    }
}

/// Weighted mean of the pixels in `[x0, x1) × [y0, y1)` (weight 1 without `w`).
fn mean(img: &LinearImage, w: Option<&LinearImage>, x0: usize, y0: usize, x1: usize, y1: usize) -> [f64; 3] {
    let (mut s, mut n) = ([0.0; 3], 0.0);
    for y in y0..y1 {
        for x in x0..x1 {
            let k = w.map_or(1.0, |w| f64::from(w.get(x, y)[0]));
            let p = img.get(x, y);
            for c in 0..3 {
                s[c] += k * f64::from(p[c]);
            }
            n += k;
        }
    }
    s.map(|v| v / n)
}

/// Mean of each channel of `img`.
#[must_use]
pub fn channel_means(img: &LinearImage) -> [f64; 3] {
    mean(img, None, 0, 0, img.width(), img.height())
}

/// The errors of `img` against `reference`, with blocks and the covered mean taken from the
/// coverage `mask` (its first channel, values in [0, 1]) when given.
pub fn block_error(
    img: &LinearImage,
    reference: &LinearImage,
    mask: Option<&LinearImage>,
) -> Result<BlockError, BlockErrorError> {
    check("the image", img, reference)?;
    if let Some(m) = mask {
        check("the mask", m, reference)?;
    }
    let (w, h) = (reference.width(), reference.height());
    let ref_lum = lum(mean(reference, None, 0, 0, w, h));
    let mean_rel = lum(mean(img, None, 0, 0, w, h)) / ref_lum - 1.0;
    let covered_mean_rel = mask
        .map_or(f64::NAN, |m| lum(mean(img, Some(m), 0, 0, w, h)) / lum(mean(reference, Some(m), 0, 0, w, h)) - 1.0);
    let (mut sum2, mut blocks) = (0.0, 0usize);
    for by in (0..h).step_by(BLOCK) {
        for bx in (0..w).step_by(BLOCK) {
            let (x1, y1) = ((bx + BLOCK).min(w), (by + BLOCK).min(h));
            let b = lum(mean(reference, None, bx, by, x1, y1));
            let counted = match mask {
                Some(m) => mean(m, None, bx, by, x1, y1)[0] > 0.5,
                None => b > 0.01 * ref_lum,
            };
            if counted && b > 0.0 {
                let a = lum(mean(img, None, bx, by, x1, y1));
                sum2 += ((a - b) / b).powi(2);
                blocks += 1;
            }
        }
    }
    let block_rmse = if blocks > 0 { (sum2 / blocks as f64).sqrt() } else { f64::NAN };
    Ok(BlockError { mean_rel, covered_mean_rel, block_rmse, blocks })
}

/// Per channel, the mean of `img` over that of `reference`, both weighted by the coverage
/// `mask` (its first channel) when given; NaN for a channel whose reference mean is 0.
pub fn channel_ratios(
    img: &LinearImage,
    reference: &LinearImage,
    mask: Option<&LinearImage>,
) -> Result<[f64; 3], BlockErrorError> {
    check("the image", img, reference)?;
    if let Some(m) = mask {
        check("the mask", m, reference)?;
    }
    let (w, h) = (reference.width(), reference.height());
    let (a, b) = (mean(img, mask, 0, 0, w, h), mean(reference, mask, 0, 0, w, h));
    Ok([0, 1, 2].map(|c| if b[c] > 0.0 { a[c] / b[c] } else { f64::NAN }))
}

/// Quantile `q` ∈ [0, 1] of `values` (sorted in place; nearest rank), NaN when empty.
fn quantile(values: &mut [f64], q: f64) -> f64 {
    if values.is_empty() {
        return f64::NAN;
    }
    values.sort_by(f64::total_cmp);
    let k = ((q * (values.len() - 1) as f64).round() as usize).min(values.len() - 1);
    values[k]
}

/// The firefly measure (module docs): `(p99.99, median, p99.99/median)` of the per-pixel
/// `|lum(img − reference)|` over the pixels whose `mask` is above ½ (all without a mask).
pub fn firefly_ratio(
    img: &LinearImage,
    reference: &LinearImage,
    mask: Option<&LinearImage>,
) -> Result<(f64, f64, f64), BlockErrorError> {
    check("the image", img, reference)?;
    if let Some(m) = mask {
        check("the mask", m, reference)?;
    }
    let mut d = Vec::with_capacity(img.pixels().len());
    for (i, (a, b)) in img.pixels().iter().zip(reference.pixels()).enumerate() {
        if mask.is_none_or(|m| m.pixels()[i][0] > 0.5) {
            d.push(lum([0, 1, 2].map(|c| f64::from(a[c]) - f64::from(b[c]))).abs());
        }
    }
    let top = quantile(&mut d, 0.9999);
    let median = quantile(&mut d, 0.5);
    Ok((top, median, if median > 0.0 { top / median } else { f64::INFINITY }))
}

/// Fits, per channel and by least squares over all pixels, `reference ≈ base + Σ_k c_k·term_k`
/// and returns the coefficients (`[channel][k]`) and the fitted image. Coefficients are not
/// constrained in sign.
pub fn fit_terms(
    reference: &LinearImage,
    base: &LinearImage,
    terms: &[LinearImage],
) -> Result<(Vec<[f64; 3]>, LinearImage), BlockErrorError> {
    check("the base", base, reference)?;
    for (k, t) in terms.iter().enumerate() {
        check(&format!("term {}", k + 1), t, reference)?;
    }
    let m = terms.len();
    let mut coef = vec![[0.0; 3]; m];
    for c in 0..3 {
        // Normal equations A x = b, A_jk = Σ t_j t_k, b_j = Σ t_j (ref − base).
        let mut a = vec![vec![0.0; m + 1]; m];
        for (i, (r, b0)) in reference.pixels().iter().zip(base.pixels()).enumerate() {
            let y = f64::from(r[c]) - f64::from(b0[c]);
            for j in 0..m {
                let tj = f64::from(terms[j].pixels()[i][c]);
                for k in 0..m {
                    a[j][k] += tj * f64::from(terms[k].pixels()[i][c]);
                }
                a[j][m] += tj * y;
            }
        }
        // Gauss–Jordan with partial pivoting.
        let scale = (0..m).map(|j| a[j][j]).fold(0.0, f64::max);
        for col in 0..m {
            let piv = (col..m).max_by(|&p, &q| a[p][col].abs().total_cmp(&a[q][col].abs())).unwrap_or(col);
            a.swap(col, piv);
            if a[col][col].abs() <= 1e-12 * scale || scale == 0.0 {
                return Err(BlockErrorError::Singular(c));
            }
            let pivot = a[col].clone();
            for (r, row) in a.iter_mut().enumerate() {
                if r != col {
                    let f = row[col] / pivot[col];
                    for (x, p) in row.iter_mut().zip(&pivot).skip(col) {
                        *x -= f * p;
                    }
                }
            }
        }
        for j in 0..m {
            coef[j][c] = a[j][m] / a[j][j];
        }
    }
    let mut out = base.clone();
    out.clear_uint_channels();
    for (i, p) in out.pixels_mut().iter_mut().enumerate() {
        for c in 0..3 {
            let add: f64 = (0..m).map(|k| coef[k][c] * f64::from(terms[k].pixels()[i][c])).sum();
            p[c] = (f64::from(p[c]) + add) as f32;
        }
    }
    Ok((coef, out))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn image(w: usize, h: usize, f: impl Fn(usize, usize) -> [f32; 3]) -> LinearImage {
        LinearImage::from_pixels(w, h, (0..w * h).map(|i| f(i % w, i / w)).collect()).unwrap()
    }

    #[test]
    fn masked_blocks_count_only_where_the_mask_covers_most_of_the_block() {
        // 64 × 32: 8 blocks. The mask covers the left half (x < 32) fully and, in the right
        // half, the first 7 of every 16 rows (44 % of a block: not counted).
        let reference = image(64, 32, |x, y| [1.0 + (x + y) as f32 * 0.01; 3]);
        let mask = image(64, 32, |x, y| if x < 32 || y % 16 < 7 { [1.0; 3] } else { [0.0; 3] });
        // 10 % too bright on the left, 3 × too bright on the right.
        let img = image(64, 32, |x, y| {
            let r = reference.get(x, y)[0];
            [if x < 32 { 1.1 * r } else { 3.0 * r }; 3]
        });
        let e = block_error(&img, &reference, Some(&mask)).unwrap();
        assert_eq!(e.blocks, 4);
        assert!((e.block_rmse - 0.1).abs() < 1e-5, "{e:?}");
        // Without the mask every block counts: sqrt((4·0.01 + 4·4)/8).
        let all = block_error(&img, &reference, None).unwrap();
        assert_eq!(all.blocks, 8);
        assert!((all.block_rmse - ((4.0 * 0.01 + 4.0 * 4.0) / 8.0_f64).sqrt()).abs() < 1e-5, "{all:?}");
        // The covered mean weights by the mask: the right half's 7 rows of 16 at 3×.
        let (wl, wr) = (32.0 * 32.0, 32.0 * 14.0);
        let sum = |x0: usize, rows: &dyn Fn(usize) -> bool| -> (f64, f64) {
            let (mut s, mut t) = (0.0, 0.0);
            for y in 0..32 {
                for x in x0..x0 + 32 {
                    if rows(y) {
                        s += f64::from(img.get(x, y)[0]);
                        t += f64::from(reference.get(x, y)[0]);
                    }
                }
            }
            (s, t)
        };
        let (sl, tl) = sum(0, &|_| true);
        let (sr, tr) = sum(32, &|y| y % 16 < 7);
        let expected = ((sl + sr) / (wl + wr)) / ((tl + tr) / (wl + wr)) - 1.0;
        assert!((e.covered_mean_rel - expected).abs() < 1e-5, "{} vs {expected}", e.covered_mean_rel);
        assert!(block_error(&img, &image(8, 8, |_, _| [1.0; 3]), None).is_err());
    }

    #[test]
    fn channel_ratios_and_the_firefly_ratio() {
        let reference = image(100, 100, |x, _| [1.0, 2.0, 0.5 + 0.001 * x as f32]);
        let mask = image(100, 100, |x, _| if x < 50 { [1.0; 3] } else { [0.0; 3] });
        // 10 % brighter in red on the left, 3 × on the right; noise ±0.01·(1 + y mod 3) in
        // green; one pixel on the left 50 above.
        let img = image(100, 100, |x, y| {
            let r = reference.get(x, y);
            let noise = 0.01 * (1.0 + (y % 3) as f32) * if (x + y) % 2 == 0 { 1.0 } else { -1.0 };
            let spike = if (x, y) == (10, 10) { 50.0 } else { 0.0 };
            [r[0] * if x < 50 { 1.1 } else { 3.0 } + spike, r[1] + noise, r[2]]
        });
        let ratios = channel_ratios(&img, &reference, Some(&mask)).unwrap();
        // Red: 1.1 plus the spike's 50/5000 = 0.01.
        assert!((ratios[0] - 1.11).abs() < 1e-5 && (ratios[1] - 1.0).abs() < 1e-4 && (ratios[2] - 1.0).abs() < 1e-6);
        let (top, median, ratio) = firefly_ratio(&img, &reference, Some(&mask)).unwrap();
        // The 5000 masked pixels: the 99.99th percentile (rank 4999) is the spike. The per-pixel
        // differences 0.2126·0.1 + 0.7152·g with g = ±0.01, ±0.02, ±0.03 in equal shares sort
        // as 0.0002, 0.0070, 0.0141, 0.0284, 0.0356, 0.0427: the median is the third or fourth,
        // |0.2126·0.1 ± 0.7152·0.01|.
        let spike = 0.2126 * (50.0 + 0.1) + 0.7152 * 0.02;
        assert!((top - spike).abs() < 0.05, "{top} vs {spike}");
        assert!(
            (median - (0.02126 + 0.7152 * 0.01)).abs() < 1e-4 || (median - (0.02126 - 0.7152 * 0.01)).abs() < 1e-4,
            "{median}"
        );
        assert!(ratio > 100.0);
        assert!(channel_ratios(&img, &image(8, 8, |_, _| [1.0; 3]), None).is_err());
    }

    #[test]
    fn the_fit_recovers_known_coefficients_per_channel() {
        let base = image(32, 16, |x, _| [0.1 * x as f32, 0.2, 0.3]);
        let t1 = image(32, 16, |x, y| [((x * y) % 7) as f32, (x % 3) as f32, 1.0 + y as f32]);
        let t2 = image(32, 16, |x, y| [(y % 5) as f32, ((x + y) % 4) as f32, (x % 2) as f32]);
        let (c1, c2) = ([0.5, 2.0, -0.25], [1.5, 0.0, 3.0]);
        let reference = image(32, 16, |x, y| {
            let (b, p, q) = (base.get(x, y), t1.get(x, y), t2.get(x, y));
            [0, 1, 2].map(|c| (f64::from(b[c]) + c1[c] * f64::from(p[c]) + c2[c] * f64::from(q[c])) as f32)
        });
        let (coef, fitted) = fit_terms(&reference, &base, &[t1.clone(), t2.clone()]).unwrap();
        for c in 0..3 {
            assert!((coef[0][c] - c1[c]).abs() < 1e-4 && (coef[1][c] - c2[c]).abs() < 1e-4, "{coef:?}");
        }
        let e = block_error(&fitted, &reference, None).unwrap();
        assert!(e.mean_rel.abs() < 1e-5 && e.block_rmse < 1e-4, "{e:?}");
        // A black term makes the system singular.
        let black = image(32, 16, |_, _| [0.0; 3]);
        assert_eq!(fit_terms(&reference, &base, &[t1, black]).unwrap_err(), BlockErrorError::Singular(0));
    }
}
