//! Image statistics for the benchmarks (`bench/dual_scattering/`): prints, as one JSON object,
//! the mean of each channel of an EXR and, given a reference EXR, the relative difference of
//! the means and the RMS over 16×16 blocks of the per-block relative error of the block means
//! (blocks whose reference mean is below 1 % of the image mean are skipped).
//!
//! `cargo run --release -p fiberlab-io --example exr_stats -- IMAGE.exr [REFERENCE.exr]`

use fiberlab_io::LinearImage;
use std::path::Path;

fn mean(img: &LinearImage, x0: usize, y0: usize, x1: usize, y1: usize) -> [f64; 3] {
    let mut s = [0.0; 3];
    for y in y0..y1 {
        for x in x0..x1 {
            let p = img.get(x, y);
            for c in 0..3 {
                s[c] += f64::from(p[c]);
            }
        }
    }
    let n = ((x1 - x0) * (y1 - y0)) as f64;
    s.map(|v| v / n)
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let read = |p: &str| LinearImage::read_exr(Path::new(p)).unwrap_or_else(|e| panic!("{p}: {e}"));
    let img = read(&args[0]);
    let (w, h) = (img.width(), img.height());
    let m = mean(&img, 0, 0, w, h);
    let mut out = format!("{{\"mean\": [{:.6e}, {:.6e}, {:.6e}]", m[0], m[1], m[2]);
    if let Some(r) = args.get(1) {
        let reference = read(r);
        assert_eq!((reference.width(), reference.height()), (w, h), "sizes differ");
        let rm = mean(&reference, 0, 0, w, h);
        let lum = |v: [f64; 3]| 0.2126 * v[0] + 0.7152 * v[1] + 0.0722 * v[2];
        let (mut sum2, mut blocks) = (0.0, 0usize);
        for by in (0..h).step_by(16) {
            for bx in (0..w).step_by(16) {
                let (x1, y1) = ((bx + 16).min(w), (by + 16).min(h));
                let (a, b) = (lum(mean(&img, bx, by, x1, y1)), lum(mean(&reference, bx, by, x1, y1)));
                if b > 0.01 * lum(rm) {
                    sum2 += ((a - b) / b).powi(2);
                    blocks += 1;
                }
            }
        }
        let block_rmse = if blocks > 0 { (sum2 / blocks as f64).sqrt() } else { f64::NAN };
        out += &format!(
            ", \"reference_mean\": [{:.6e}, {:.6e}, {:.6e}], \"mean_rel_diff\": {:.6}, \"block_rel_rmse\": {:.6}, \"blocks\": {blocks}",
            rm[0],
            rm[1],
            rm[2],
            lum(m) / lum(rm) - 1.0,
            block_rmse
        );
    }
    println!("{out}}}");
}
