//! From spectra to fiberlab's RGB: a reflectance (or transmittance) spectrum seen under the CIE
//! standard illuminant D65 by the CIE 1931 2° standard observer, converted to linear Rec. 709
//! RGB ([`crate::spectrum`]'s convention; D65 is its white point) and normalized per channel so
//! that a spectrum equal to c at every wavelength is exactly `(c, c, c)`.
//!
//! # Formula
//! With the tables of [`cie_tables`] at λ_k = 380, 385, …, 780 nm:
//! `XYZ = Σ_k R(λ_k)·S(λ_k)·(x̄, ȳ, z̄)(λ_k)`, `rgb = M·XYZ`, `M` the XYZ → linear Rec. 709 matrix
//! of IEC 61966-2-1 (sRGB), and each channel divided by the same sum for `R ≡ 1` (the white's
//! rgb, within 0.2 % of 1 already: the per-channel normalization only removes the rounding of
//! the published matrix and the 5 nm summation). Summation at 5 nm is the CIE's own practice for
//! tristimulus values. `R` is interpolated linearly in λ from the samples given and held at its
//! end values outside them (e.g. PROSPECT's spectra start at 400 nm; the observer sees 0.05 %
//! of D65's luminance below 400 nm).

pub mod cie_tables;

use crate::Rgb;
use cie_tables::{CMF_1931_2DEG, D65, START_NM, STEP_NM};

/// XYZ → linear Rec. 709 RGB (IEC 61966-2-1).
pub const XYZ_TO_REC709: [[f64; 3]; 3] =
    [[3.2406, -1.5372, -0.4986], [-0.9689, 1.8758, 0.0415], [0.0557, -0.2040, 1.0570]];

/// `Σ_k R(λ_k) S(λ_k) (x̄, ȳ, z̄)(λ_k)` for `R` given by `sample(λ)`.
fn tristimulus(sample: impl Fn(f64) -> f64) -> [f64; 3] {
    let mut xyz = [0.0; 3];
    for (k, (cmf, s)) in CMF_1931_2DEG.iter().zip(D65).enumerate() {
        let w = sample(START_NM + STEP_NM * k as f64) * s;
        for c in 0..3 {
            xyz[c] += w * cmf[c];
        }
    }
    xyz
}

fn to_rec709(xyz: [f64; 3]) -> [f64; 3] {
    XYZ_TO_REC709.map(|row| row[0] * xyz[0] + row[1] * xyz[1] + row[2] * xyz[2])
}

/// The linear Rec. 709 RGB of a perfect white reflector before normalization (≈ 1 per
/// channel, × the same factor in every channel: the tristimulus sums are not divided by ȳ's).
fn white() -> [f64; 3] {
    to_rec709(tristimulus(|_| 1.0))
}

/// CIE 1931 chromaticity `(x, y)` of D65 as the tables give it (0.3127, 0.3290 published).
#[must_use]
pub fn d65_chromaticity() -> (f64, f64) {
    let [x, y, z] = tristimulus(|_| 1.0);
    (x / (x + y + z), y / (x + y + z))
}

/// The linear Rec. 709 RGB of a reflectance spectrum sampled at `start_nm + k·step_nm`
/// (`values[k]`, k = 0 …), under D65, white-normalized (see the module docs). `step_nm` must be
/// positive and `values` non-empty; no allocation.
#[must_use]
pub fn reflectance_to_rgb(start_nm: f64, step_nm: f64, values: &[f64]) -> Rgb {
    assert!(step_nm > 0.0 && !values.is_empty(), "reflectance_to_rgb: empty spectrum or step ≤ 0");
    let last = values.len() - 1;
    let sample = |lambda: f64| {
        let x = ((lambda - start_nm) / step_nm).clamp(0.0, last as f64);
        let k = (x.floor() as usize).min(last.saturating_sub(1));
        if last == 0 {
            return values[0];
        }
        let t = x - k as f64;
        values[k] * (1.0 - t) + values[k + 1] * t
    };
    let (rgb, w) = (to_rec709(tristimulus(sample)), white());
    Rgb::new(rgb[0] / w[0], rgb[1] / w[1], rgb[2] / w[2])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_flat_spectrum_is_grey_and_d65_is_the_white_point() {
        for c in [0.0, 0.3, 1.0] {
            let rgb = reflectance_to_rgb(400.0, 10.0, &[c; 41]);
            for k in 0..3 {
                assert!((rgb[k] - c).abs() < 1e-14, "{rgb:?}");
            }
        }
        let (x, y) = d65_chromaticity();
        assert!((x - 0.3127).abs() < 2e-4 && (y - 0.3290).abs() < 2e-4, "{x} {y}");
        // The published matrix maps D65 nearly to equal channels already.
        let w = white();
        let mean = (w[0] + w[1] + w[2]) / 3.0;
        assert!(w.iter().all(|c| (c / mean - 1.0).abs() < 2e-3), "{w:?}");
    }

    /// A spectrum that reflects only long wavelengths is red, only short ones blue, only the
    /// middle green; a sample grid coarser than the tables is interpolated linearly.
    #[test]
    fn colours_land_in_their_channels() {
        let band = |lo: f64, hi: f64| -> Vec<f64> {
            (0..=400).map(|k| f64::from(u8::from((lo..hi).contains(&(400.0 + k as f64))))).collect()
        };
        let red = reflectance_to_rgb(400.0, 1.0, &band(600.0, 700.0));
        let green = reflectance_to_rgb(400.0, 1.0, &band(500.0, 570.0));
        let blue = reflectance_to_rgb(400.0, 1.0, &band(420.0, 480.0));
        assert!(red[0] > 3.0 * red[1].abs() && red[0] > 3.0 * red[2].abs(), "{red:?}");
        assert!(green[1] > 2.0 * green[0].abs() && green[1] > 2.0 * green[2].abs(), "{green:?}");
        assert!(blue[2] > 3.0 * blue[0].abs() && blue[2] > 3.0 * blue[1].abs(), "{blue:?}");
        let ramp: Vec<f64> = (0..=4).map(|k| 0.2 * k as f64).collect();
        let fine: Vec<f64> = (0..=400).map(|k| 0.2 * k as f64 / 100.0).collect();
        let (a, b) = (reflectance_to_rgb(380.0, 100.0, &ramp), reflectance_to_rgb(380.0, 1.0, &fine));
        assert!((a - b).max_component().abs() < 1e-12);
    }
}
