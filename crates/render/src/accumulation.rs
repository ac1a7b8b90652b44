//! The state of a progressive render: for every pixel, the exact sum of its radiance samples
//! (f64, in sample order) and how many samples it has.
//!
//! A pixel's value is `sum / count`, rounded once to f32. Because a sum is extended one sample
//! at a time in sample-index order, a render continued from a saved state (`fiberlab render
//! --resume`) reaches the same bits as one uninterrupted render of the same total sample
//! count, however the work was split into passes, tiles or sessions.
//!
//! # In an EXR file
//! The state travels in the image file beside the f32 R, G, B means (which any viewer shows),
//! as lossless 32-bit unsigned integer channels: `fiberlab.sum_hi.{R,G,B}` and
//! `fiberlab.sum_lo.{R,G,B}` (the high and low 32 bits of each f64 sum) and `fiberlab.spp`
//! (samples per pixel). The header attribute `fiberlab.spp` is the smallest sample count over
//! the rendered pixels; `fiberlab.spp_max` is added only when the counts differ (a render
//! interrupted within a pass).

use crate::region::Region;
use fiberlab_io::LinearImage;
use fiberlab_math::Rgb;

/// Bytes per pixel a progressive render holds besides the RGB image: the accumulation's sum
/// (3 × f64) and count (u32), 28, twice (the whole-image state and the per-tile copies the
/// passes work on), and the seven state channels of the written image (7 × u32, 28) with the
/// EXR encoder's copy of them (28).
pub const BYTES_PER_PIXEL: u64 = 4 * 28;

/// Names of the unsigned integer channels holding the state (without the file prefix).
const SUM_HI: [&str; 3] = ["sum_hi.R", "sum_hi.G", "sum_hi.B"];
const SUM_LO: [&str; 3] = ["sum_lo.R", "sum_lo.G", "sum_lo.B"];
const COUNT: &str = "spp";

/// Why an image cannot be continued.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ResumeError {
    /// The image has no saved state (not written by a progressive render, or merged from
    /// parts that had none).
    #[error(
        "it has no sample sums (channel fiberlab.{0} is missing): only images written by `fiberlab render` can be continued"
    )]
    NoState(String),
    /// Its size is not the camera's.
    #[error("it is {found_w}×{found_h}, the scene's camera renders {w}×{h}")]
    Size {
        /// Image width.
        found_w: usize,
        /// Image height.
        found_h: usize,
        /// Camera width.
        w: u32,
        /// Camera height.
        h: u32,
    },
    /// A saved sum is NaN, infinite or negative.
    #[error("its saved sum at x = {x}, y = {y} is {value} (sums of radiance are finite and ≥ 0)")]
    BadSum {
        /// Column.
        x: usize,
        /// Row.
        y: usize,
        /// The value.
        value: f64,
    },
}

/// Per-pixel sample sums and counts of a whole image (pixels outside the rendered region
/// have count 0).
#[derive(Clone, Debug, PartialEq)]
pub struct Accumulation {
    width: u32,
    height: u32,
    sums: Vec<Rgb>,
    counts: Vec<u32>,
}

impl Accumulation {
    /// No samples anywhere.
    #[must_use]
    pub fn new(width: u32, height: u32) -> Self {
        let n = width as usize * height as usize;
        Self { width, height, sums: vec![Rgb::ZERO; n], counts: vec![0; n] }
    }

    /// Width in pixels.
    #[must_use]
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height in pixels.
    #[must_use]
    pub fn height(&self) -> u32 {
        self.height
    }

    fn index(&self, x: u32, y: u32) -> usize {
        y as usize * self.width as usize + x as usize
    }

    /// The sum and count of pixel `(x, y)`.
    #[must_use]
    pub fn pixel(&self, x: u32, y: u32) -> (Rgb, u32) {
        let i = self.index(x, y);
        (self.sums[i], self.counts[i])
    }

    /// Replaces the sum and count of pixel `(x, y)`.
    pub fn set_pixel(&mut self, x: u32, y: u32, sum: Rgb, count: u32) {
        let i = self.index(x, y);
        self.sums[i] = sum;
        self.counts[i] = count;
    }

    /// Smallest and largest sample count over `region` (`(0, 0)` for an empty region).
    #[must_use]
    pub fn count_range(&self, region: Region) -> (u32, u32) {
        let mut range: Option<(u32, u32)> = None;
        for y in region.y0..region.y1.min(self.height) {
            for x in region.x0..region.x1.min(self.width) {
                let c = self.counts[self.index(x, y)];
                range = Some(range.map_or((c, c), |(lo, hi)| (lo.min(c), hi.max(c))));
            }
        }
        range.unwrap_or((0, 0))
    }

    /// Samples still to take to bring every pixel of `region` to `spp`.
    #[must_use]
    pub fn samples_missing(&self, region: Region, spp: u32) -> u64 {
        let mut n = 0;
        for y in region.y0..region.y1.min(self.height) {
            for x in region.x0..region.x1.min(self.width) {
                n += u64::from(spp.saturating_sub(self.counts[self.index(x, y)]));
            }
        }
        n
    }

    /// The image: each pixel's mean `sum / count` as f32 (black where count is 0), the state
    /// channels, and the `spp` attributes over `region` (see the module docs).
    #[must_use]
    pub fn image(&self, region: Region) -> LinearImage {
        let pixels = self
            .sums
            .iter()
            .zip(&self.counts)
            .map(|(s, &c)| {
                let v = if c == 0 { Rgb::ZERO } else { *s / f64::from(c) };
                [v[0] as f32, v[1] as f32, v[2] as f32]
            })
            .collect();
        let mut image =
            LinearImage::from_pixels(self.width as usize, self.height as usize, pixels).expect("one mean per pixel");
        let bits = |k: usize, hi: bool| -> Vec<u32> {
            self.sums.iter().map(|s| if hi { (s[k].to_bits() >> 32) as u32 } else { s[k].to_bits() as u32 }).collect()
        };
        for k in 0..3 {
            image.set_uint_channel(SUM_HI[k], bits(k, true)).expect("one value per pixel");
            image.set_uint_channel(SUM_LO[k], bits(k, false)).expect("one value per pixel");
        }
        image.set_uint_channel(COUNT, self.counts.clone()).expect("one value per pixel");
        let (lo, hi) = self.count_range(region);
        image.set_attribute("spp", lo.to_string());
        if hi != lo {
            image.set_attribute("spp_max", hi.to_string());
        }
        image
    }

    /// The state saved in `image` (written by [`Accumulation::image`]), for a camera of
    /// `width × height`.
    pub fn from_image(image: &LinearImage, width: u32, height: u32) -> Result<Self, ResumeError> {
        if (image.width(), image.height()) != (width as usize, height as usize) {
            return Err(ResumeError::Size { found_w: image.width(), found_h: image.height(), w: width, h: height });
        }
        let channel = |name: &str| image.uint_channel(name).ok_or_else(|| ResumeError::NoState(name.into()));
        let counts = channel(COUNT)?.to_vec();
        let (hi, lo): (Vec<&[u32]>, Vec<&[u32]>) = (
            SUM_HI.iter().map(|n| channel(n)).collect::<Result<_, _>>()?,
            SUM_LO.iter().map(|n| channel(n)).collect::<Result<_, _>>()?,
        );
        let mut sums = Vec::with_capacity(counts.len());
        for i in 0..counts.len() {
            let value = |k: usize| f64::from_bits((u64::from(hi[k][i]) << 32) | u64::from(lo[k][i]));
            let s = Rgb::new(value(0), value(1), value(2));
            if let Some(k) = (0..3).find(|&k| !(s[k].is_finite() && s[k] >= 0.0)) {
                let w = width as usize;
                return Err(ResumeError::BadSum { x: i % w, y: i / w, value: s[k] });
            }
            sums.push(s);
        }
        Ok(Self { width, height, sums, counts })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn state_round_trips_bit_for_bit_through_the_image() {
        let mut a = Accumulation::new(3, 2);
        // Values no f32 represents, and a sum of zero with a count (a black rendered pixel).
        a.set_pixel(0, 0, Rgb::new(0.1, 1.0 / 3.0, 1e-300), 7);
        a.set_pixel(2, 1, Rgb::new(12_345.678_901_234_5, 0.0, std::f64::consts::PI), 9);
        a.set_pixel(1, 1, Rgb::ZERO, 7);
        let full = Region::full(3, 2);
        let image = a.image(full);
        assert_eq!(Accumulation::from_image(&image, 3, 2).unwrap(), a);
        assert_eq!(a.count_range(full), (0, 9));
        assert_eq!(image.attribute("spp"), Some("0"));
        assert_eq!(image.attribute("spp_max"), Some("9"));
        // The visible means are sum/count rounded once.
        assert_eq!(image.get(2, 1), [(12_345.678_901_234_5 / 9.0) as f32, 0.0, (std::f64::consts::PI / 9.0) as f32]);
        assert_eq!(image.get(1, 0), [0.0; 3]);
        assert_eq!(a.samples_missing(full, 10), 10 * 6 - 7 - 9 - 7);
    }

    #[test]
    fn images_without_state_or_of_another_size_are_refused() {
        let plain = LinearImage::new(3, 2);
        assert!(matches!(Accumulation::from_image(&plain, 3, 2), Err(ResumeError::NoState(_))));
        let image = Accumulation::new(3, 2).image(Region::full(3, 2));
        assert!(matches!(Accumulation::from_image(&image, 4, 2), Err(ResumeError::Size { .. })));
        let mut bad = image.clone();
        bad.set_uint_channel("sum_hi.G", vec![0x7ff8_0000; 6]).unwrap();
        assert!(matches!(Accumulation::from_image(&bad, 3, 2), Err(ResumeError::BadSum { x: 0, y: 0, .. })));
    }
}
