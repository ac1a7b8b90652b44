//! Image statistics for the benchmarks (`bench/dual_scattering/`), printed as one JSON object
//! ([`fiberlab_io::block_error`] defines the measures).
//!
//! * `exr_stats IMAGE.exr [REFERENCE.exr] [--mask COVERAGE.exr]`: the mean of each channel;
//!   with a reference, the relative error of the image mean (`mean_rel_diff`), the RMS of the
//!   16×16 block means' relative errors (`block_rel_rmse`, over `blocks` blocks) and, with a
//!   coverage mask, the coverage-weighted mean's error (`covered_mean_rel_diff`) and blocks
//!   counted only where the mask covers more than half of the block; per-channel mean ratios
//!   (`channel_ratio`, coverage-weighted with a mask) and the firefly measure (`diff_p9999`,
//!   `diff_median`, `firefly_ratio`).
//! * `exr_stats --fit OUT.exr REFERENCE.exr BASE.exr TERM.exr…`: fits per channel
//!   `REFERENCE ≈ BASE + Σ c_k TERM_k` by least squares over all pixels, writes the fitted
//!   image and prints the coefficients (`coefficients[k][channel]`).
//!
//! * `exr_stats --sub OUT.exr A.exr B.exr`: writes A − B.
//!
//! `cargo run --release -p fiberlab-io --example exr_stats -- …`

use fiberlab_io::LinearImage;
use fiberlab_io::block_error::{block_error, channel_means, channel_ratios, firefly_ratio, fit_terms};
use std::path::Path;

fn read(p: &str) -> LinearImage {
    LinearImage::read_exr(Path::new(p)).unwrap_or_else(|e| panic!("{p}: {e}"))
}

fn main() {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    if args.first().map(String::as_str) == Some("--fit") {
        assert!(args.len() >= 5, "usage: exr_stats --fit OUT.exr REFERENCE.exr BASE.exr TERM.exr…");
        let terms: Vec<LinearImage> = args[4..].iter().map(|p| read(p)).collect();
        let (coef, fitted) = fit_terms(&read(&args[2]), &read(&args[3]), &terms).unwrap_or_else(|e| panic!("{e}"));
        fitted.write_exr(Path::new(&args[1])).unwrap_or_else(|e| panic!("{}: {e}", args[1]));
        let rows: Vec<String> = coef.iter().map(|c| format!("[{:.6e}, {:.6e}, {:.6e}]", c[0], c[1], c[2])).collect();
        println!("{{\"coefficients\": [{}]}}", rows.join(", "));
        return;
    }
    if args.first().map(String::as_str) == Some("--sub") {
        assert!(args.len() == 4, "usage: exr_stats --sub OUT.exr A.exr B.exr");
        let (mut x, y) = (read(&args[2]), read(&args[3]));
        assert_eq!((x.width(), x.height()), (y.width(), y.height()), "sizes differ");
        for (p, q) in x.pixels_mut().iter_mut().zip(y.pixels()) {
            for c in 0..3 {
                p[c] -= q[c];
            }
        }
        x.clear_uint_channels();
        x.write_exr(Path::new(&args[1])).unwrap_or_else(|e| panic!("{}: {e}", args[1]));
        return;
    }
    let mask = args.iter().position(|a| a == "--mask").map(|i| {
        let path = args.get(i + 1).cloned().expect("--mask COVERAGE.exr");
        args.drain(i..i + 2);
        read(&path)
    });
    let img = read(&args[0]);
    let m = channel_means(&img);
    let mut out = format!("{{\"mean\": [{:.6e}, {:.6e}, {:.6e}]", m[0], m[1], m[2]);
    if let Some(r) = args.get(1) {
        let reference = read(r);
        let e = block_error(&img, &reference, mask.as_ref()).unwrap_or_else(|e| panic!("{e}"));
        let rm = channel_means(&reference);
        out += &format!(
            ", \"reference_mean\": [{:.6e}, {:.6e}, {:.6e}], \"mean_rel_diff\": {:.6}, \"block_rel_rmse\": {:.6}, \"blocks\": {}",
            rm[0], rm[1], rm[2], e.mean_rel, e.block_rmse, e.blocks
        );
        if mask.is_some() {
            out += &format!(", \"covered_mean_rel_diff\": {:.6}", e.covered_mean_rel);
        }
        let ratios = channel_ratios(&img, &reference, mask.as_ref()).unwrap_or_else(|e| panic!("{e}"));
        let (top, median, fireflies) = firefly_ratio(&img, &reference, mask.as_ref()).unwrap_or_else(|e| panic!("{e}"));
        out += &format!(
            ", \"channel_ratio\": [{:.4}, {:.4}, {:.4}], \"diff_p9999\": {top:.4e}, \"diff_median\": {median:.4e}, \"firefly_ratio\": {fireflies:.2}",
            ratios[0], ratios[1], ratios[2]
        );
    }
    println!("{out}}}");
}
