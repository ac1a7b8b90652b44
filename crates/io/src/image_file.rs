//! Image files: linear OpenEXR (32-bit float RGB, optional 32-bit unsigned integer channels)
//! and tone-mapped 8-bit sRGB PNG.
//!
//! Every writer goes through [`crate::output_file`]: the bytes go to a temporary file in the
//! destination's directory, which is renamed over the destination only when complete, so an
//! interrupted program never leaves half an image behind (and never replaces a link or a
//! device). Every reader opens its file through [`crate::input_file`] (regular files only, within
//! the memory budget) and checks the image's size against the budget before decoding it.

use std::collections::BTreeMap;
use std::io::BufWriter;
use std::path::{Path, PathBuf};
use thiserror::Error;

/// Why an image could not be read or written.
#[non_exhaustive]
#[derive(Debug, Error)]
pub enum ImageError {
    /// Creating, writing or renaming the file failed.
    #[error("{path}: {error}")]
    Io {
        /// Destination path.
        path: PathBuf,
        /// Underlying error (shown in the message, not chained, so it is not printed twice).
        error: std::io::Error,
    },
    /// The EXR encoder or decoder failed.
    #[error("{path}: EXR: {message}")]
    Exr {
        /// File path.
        path: PathBuf,
        /// Decoder message.
        message: String,
    },
    /// An EXR file lacks a channel this reader needs.
    #[error("{path}: EXR: no {channel:?} channel (channels present: {present})")]
    MissingChannel {
        /// File path.
        path: PathBuf,
        /// The channel looked for.
        channel: String,
        /// The channels the file has, comma-separated.
        present: String,
    },
    /// The PNG encoder failed.
    #[error("{path}: PNG: {message}")]
    Png {
        /// File path.
        path: PathBuf,
        /// Encoder message.
        message: String,
    },
    /// A PNG, JPEG, … could not be decoded ([`decode_image`]).
    #[error("{path}: {message}")]
    Decode {
        /// File path.
        path: PathBuf,
        /// Decoder message.
        message: String,
    },
    /// The file could not be opened or read ([`crate::input_file`]).
    #[error(transparent)]
    Input(crate::input_file::InputError),
    /// The pixel buffer does not match the size.
    #[error("image of {width}×{height} needs {expected} pixels, has {found}")]
    Size {
        /// Width, pixels.
        width: usize,
        /// Height, pixels.
        height: usize,
        /// width × height.
        expected: usize,
        /// Pixels present.
        found: usize,
    },
}

/// A linear-RGB floating-point image, row-major from the top-left pixel, with text
/// attributes that travel in the EXR header (e.g. how it was rendered: samples per pixel,
/// seed, the scene's hash, the part `I/N`), so that tools can check what they combine, and
/// named 32-bit unsigned integer channels stored losslessly beside R, G, B (e.g. a renderer's
/// exact per-pixel state, so that a render can be continued).
#[derive(Clone, Debug, PartialEq)]
pub struct LinearImage {
    width: usize,
    height: usize,
    pixels: Vec<[f32; 3]>,
    attributes: BTreeMap<String, String>,
    uint_channels: BTreeMap<String, Vec<u32>>,
}

/// Prefix of fiberlab's attributes in an EXR header (other attributes are not read back).
pub const ATTRIBUTE_PREFIX: &str = "fiberlab.";

impl LinearImage {
    /// Bytes per pixel an RGB image holds while it is written as EXR and PNG: its pixels (3 ×
    /// f32, 12), the per-channel planes [`LinearImage::write_exr`] hands the encoder (12) and the
    /// 8-bit sRGB copy [`LinearImage::write_png`] encodes (3). Integer channels add 8 bytes each
    /// (the channel and the encoder's copy), counted by their owner.
    pub const BYTES_PER_PIXEL_WRITTEN: u64 = 27;

    /// Bytes a `width × height` image takes, written ([`Self::BYTES_PER_PIXEL_WRITTEN`] per
    /// pixel), counted in u64; `None` when that overflows.
    #[must_use]
    pub fn estimated_bytes(width: u64, height: u64) -> Option<u64> {
        width.checked_mul(height)?.checked_mul(Self::BYTES_PER_PIXEL_WRITTEN)
    }

    /// A black image.
    #[must_use]
    pub fn new(width: usize, height: usize) -> Self {
        Self {
            width,
            height,
            pixels: vec![[0.0; 3]; width * height],
            attributes: BTreeMap::new(),
            uint_channels: BTreeMap::new(),
        }
    }

    /// An image from its pixels (row-major, top row first).
    pub fn from_pixels(width: usize, height: usize, pixels: Vec<[f32; 3]>) -> Result<Self, ImageError> {
        if pixels.len() != width * height {
            return Err(ImageError::Size { width, height, expected: width * height, found: pixels.len() });
        }
        Ok(Self { width, height, pixels, attributes: BTreeMap::new(), uint_channels: BTreeMap::new() })
    }

    /// The unsigned integer channel `name` (one value per pixel, row-major), if present.
    #[must_use]
    pub fn uint_channel(&self, name: &str) -> Option<&[u32]> {
        self.uint_channels.get(name).map(Vec::as_slice)
    }

    /// Every unsigned integer channel, by name.
    #[must_use]
    pub fn uint_channels(&self) -> &BTreeMap<String, Vec<u32>> {
        &self.uint_channels
    }

    /// Sets the unsigned integer channel `name` (a short ASCII name; written to the EXR file
    /// as `fiberlab.NAME`), one value per pixel, row-major.
    pub fn set_uint_channel(&mut self, name: &str, values: Vec<u32>) -> Result<(), ImageError> {
        let expected = self.width * self.height;
        if values.len() != expected {
            return Err(ImageError::Size { width: self.width, height: self.height, expected, found: values.len() });
        }
        self.uint_channels.insert(name.into(), values);
        Ok(())
    }

    /// Removes every unsigned integer channel.
    pub fn clear_uint_channels(&mut self) {
        self.uint_channels.clear();
    }

    /// The text attribute `key` (written to and read from the EXR header), if set.
    #[must_use]
    pub fn attribute(&self, key: &str) -> Option<&str> {
        self.attributes.get(key).map(String::as_str)
    }

    /// Every text attribute, by key.
    #[must_use]
    pub fn attributes(&self) -> &BTreeMap<String, String> {
        &self.attributes
    }

    /// Sets the text attribute `key` (a short ASCII key such as `spp`).
    pub fn set_attribute(&mut self, key: &str, value: impl Into<String>) {
        self.attributes.insert(key.into(), value.into());
    }

    /// Width in pixels.
    #[must_use]
    pub fn width(&self) -> usize {
        self.width
    }

    /// Height in pixels.
    #[must_use]
    pub fn height(&self) -> usize {
        self.height
    }

    /// All pixels, row-major.
    #[must_use]
    pub fn pixels(&self) -> &[[f32; 3]] {
        &self.pixels
    }

    /// All pixels, mutable.
    pub fn pixels_mut(&mut self) -> &mut [[f32; 3]] {
        &mut self.pixels
    }

    /// Pixel at column `x`, row `y` (row 0 at the top).
    #[must_use]
    pub fn get(&self, x: usize, y: usize) -> [f32; 3] {
        self.pixels[y * self.width + x]
    }

    /// Sets the pixel at column `x`, row `y`.
    pub fn set(&mut self, x: usize, y: usize, rgb: [f32; 3]) {
        self.pixels[y * self.width + x] = rgb;
    }

    /// Writes a 32-bit float RGB OpenEXR file (lossless ZIP compression) with the attributes
    /// and unsigned integer channels, atomically.
    pub fn write_exr(&self, path: &Path) -> Result<(), ImageError> {
        use exr::prelude::*;
        let plane = |k: usize| FlatSamples::F32(self.pixels.iter().map(|p| p[k]).collect());
        let mut list: SmallVec<[AnyChannel<FlatSamples>; 4]> = SmallVec::new();
        for (k, name) in ["R", "G", "B"].into_iter().enumerate() {
            list.push(AnyChannel::new(name, plane(k)));
        }
        for (name, values) in &self.uint_channels {
            list.push(AnyChannel::new(format!("{ATTRIBUTE_PREFIX}{name}").as_str(), FlatSamples::U32(values.clone())));
        }
        let mut image = Image::from_channels((self.width, self.height), AnyChannels::sort(list));
        for (k, v) in &self.attributes {
            image.attributes.other.insert(
                Text::from(format!("{ATTRIBUTE_PREFIX}{k}").as_str()),
                AttributeValue::Text(Text::from(v.as_str())),
            );
        }
        let mut exr_error = None;
        write_atomically(path, |file| {
            image.write().to_buffered(BufWriter::new(file)).map_err(|e| {
                exr_error = Some(e.to_string());
                std::io::Error::other("EXR encoding failed")
            })
        })
        .map_err(|source| match exr_error.take() {
            Some(message) => ImageError::Exr { path: path.into(), message },
            None => ImageError::Io { path: path.into(), error: source },
        })
    }

    /// Reads the first layer of an OpenEXR file: its R, G, B channels (any sample type,
    /// converted to 32-bit float), fiberlab's attributes and fiberlab's unsigned integer
    /// channels (other channels, such as alpha, are ignored).
    pub fn read_exr(path: &Path) -> Result<Self, ImageError> {
        use exr::prelude::*;
        let exr_error = |e: exr::error::Error| ImageError::Exr { path: path.into(), message: e.to_string() };
        let bytes = crate::input_file::read_bytes(path).map_err(ImageError::Input)?;
        // The decoded size, checked against the memory budget before decoding.
        let meta = exr::meta::MetaData::read_from_buffered(std::io::Cursor::new(&bytes), false).map_err(exr_error)?;
        let mut decoded = 0u64;
        for header in meta.headers.iter() {
            let pixels = (header.layer_size.width() as u64).saturating_mul(header.layer_size.height() as u64);
            let sample_bytes: u64 = header.channels.list.iter().map(|c| c.sample_type.bytes_per_sample() as u64).sum();
            decoded = decoded.saturating_add(pixels.saturating_mul(sample_bytes + 12));
        }
        crate::memory_budget::check_needs(&[crate::memory_budget::Need::new(
            format!("{}: its decoded image", path.display()),
            Some(decoded),
        )])
        .map_err(|e| ImageError::Exr { path: path.into(), message: e.to_string() })?;
        let image = read()
            .no_deep_data()
            .largest_resolution_level()
            .all_channels()
            .first_valid_layer()
            .all_attributes()
            .from_buffered(std::io::Cursor::new(bytes))
            .map_err(exr_error)?;
        let layer = &image.layer_data;
        let (width, height) = (layer.size.width(), layer.size.height());
        let channels = &layer.channel_data.list;
        let find = |name: &str| {
            channels.iter().find(|c| c.name.to_string() == name).ok_or_else(|| ImageError::MissingChannel {
                path: path.into(),
                channel: name.into(),
                present: channels.iter().map(|c| c.name.to_string()).collect::<Vec<_>>().join(", "),
            })
        };
        let (r, g, b) = (find("R")?, find("G")?, find("B")?);
        let pixels = r
            .sample_data
            .values_as_f32()
            .zip(g.sample_data.values_as_f32())
            .zip(b.sample_data.values_as_f32())
            .map(|((r, g), b)| [r, g, b])
            .collect();
        let mut out = LinearImage::from_pixels(width, height, pixels)?;
        for c in channels {
            if let (Some(name), FlatSamples::U32(values)) =
                (c.name.to_string().strip_prefix(ATTRIBUTE_PREFIX), &c.sample_data)
            {
                out.set_uint_channel(name, values.clone())?;
            }
        }
        for (k, v) in image.attributes.other.iter().chain(&layer.attributes.other) {
            if let (Some(key), AttributeValue::Text(text)) = (k.to_string().strip_prefix(ATTRIBUTE_PREFIX), v) {
                out.attributes.insert(key.to_string(), text.to_string());
            }
        }
        Ok(out)
    }

    /// 8-bit sRGB pixels after `exposure` (stops) and the tone map.
    #[must_use]
    pub fn to_srgb8(&self, exposure: f64, tone_map: ToneMap) -> Vec<u8> {
        let scale = exposure.exp2();
        self.pixels.iter().flat_map(|p| p.map(|c| encode_srgb8(tone_map.apply(f64::from(c) * scale)))).collect()
    }

    /// Writes an 8-bit sRGB PNG after `exposure` (stops) and the tone map, atomically.
    pub fn write_png(&self, path: &Path, exposure: f64, tone_map: ToneMap) -> Result<(), ImageError> {
        let bytes = self.to_srgb8(exposure, tone_map);
        let mut png_error = None;
        write_atomically(path, |file| {
            image::write_buffer_with_format(
                &mut BufWriter::new(file),
                &bytes,
                self.width as u32,
                self.height as u32,
                image::ExtendedColorType::Rgb8,
                image::ImageFormat::Png,
            )
            .map_err(|e| {
                png_error = Some(e.to_string());
                std::io::Error::other("PNG encoding failed")
            })
        })
        .map_err(|source| match png_error.take() {
            Some(message) => ImageError::Png { path: path.into(), message },
            None => ImageError::Io { path: path.into(), error: source },
        })
    }
}

/// Decodes an image file of any format the `image` crate reads (PNG, JPEG, …; by its
/// content), opened through [`crate::input_file`] and decoded within the memory budget (the
/// decoder refuses an image whose pixels would exceed it).
pub fn decode_image(path: &Path) -> Result<image::DynamicImage, ImageError> {
    let bytes = crate::input_file::read_bytes(path).map_err(ImageError::Input)?;
    let fail = |message: String| ImageError::Decode { path: path.into(), message };
    let mut reader =
        image::ImageReader::new(std::io::Cursor::new(bytes)).with_guessed_format().map_err(|e| fail(e.to_string()))?;
    let mut limits = image::Limits::default();
    limits.max_alloc = crate::memory_budget::budget().bytes();
    limits.max_image_width = None;
    limits.max_image_height = None;
    reader.limits(limits);
    reader.decode().map_err(|e| fail(e.to_string()))
}

/// Display transform from scene-linear values to [0, 1].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ToneMap {
    /// Clamp to [0, 1].
    Clamp,
    /// Reinhard 2002 global operator `x/(1 + x)`.
    Reinhard,
    /// Narkowicz 2015 rational fit to the ACES filmic curve
    /// `x(ax + b)/(x(cx + d) + e)`, clamped to [0, 1].
    #[default]
    Filmic,
}

/// Coefficients of Narkowicz's 2015 ACES fit ("ACES Filmic Tone Mapping Curve", blog post).
const ACES_FIT: [f64; 5] = [2.51, 0.03, 2.43, 0.59, 0.14];

impl ToneMap {
    /// Maps a linear value ≥ 0 to [0, 1]; NaN maps to 0.
    #[must_use]
    pub fn apply(self, x: f64) -> f64 {
        let x = if x.is_nan() { 0.0 } else { x.max(0.0) };
        let y = match self {
            ToneMap::Clamp => x,
            ToneMap::Reinhard => x / (1.0 + x),
            ToneMap::Filmic => {
                let [a, b, c, d, e] = ACES_FIT;
                if x.is_infinite() { 1.0 } else { x * (a * x + b) / (x * (c * x + d) + e) }
            }
        };
        y.clamp(0.0, 1.0)
    }
}

/// Decodes an 8-bit sRGB code (IEC 61966-2-1) to a linear value in [0, 1].
#[must_use]
pub fn decode_srgb8(v: u8) -> f64 {
    let c = f64::from(v) / 255.0;
    if c <= 0.04045 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) }
}

/// The sRGB transfer function (IEC 61966-2-1) of a value in [0, 1], rounded to 8 bits; the
/// inverse of [`decode_srgb8`].
#[must_use]
pub fn encode_srgb8(linear: f64) -> u8 {
    let x = linear.clamp(0.0, 1.0);
    let v = if x <= 0.003_130_8 { 12.92 * x } else { 1.055 * x.powf(1.0 / 2.4) - 0.055 };
    (v * 255.0 + 0.5).floor().clamp(0.0, 255.0) as u8
}

/// Writing outputs atomically lives in [`crate::output_file`]; here for the writers that name
/// it from this module.
pub use crate::output_file::write_atomically;

#[cfg(test)]
mod tests {
    use super::*;

    fn gradient() -> LinearImage {
        let (w, h) = (7, 5);
        let px = (0..w * h).map(|i| [i as f32 * 0.25, 1.0 / (1.0 + i as f32), -0.5 + (i % 3) as f32]).collect();
        LinearImage::from_pixels(w, h, px).unwrap()
    }

    #[test]
    fn exr_round_trip_is_bit_exact() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.exr");
        let mut img = gradient();
        img.write_exr(&path).unwrap();
        assert_eq!(LinearImage::read_exr(&path).unwrap(), img);
        // Attributes travel in the header.
        img.set_attribute("spp", "64");
        img.set_attribute("part", "1/4");
        img.write_exr(&path).unwrap();
        let back = LinearImage::read_exr(&path).unwrap();
        assert_eq!(
            (back.attribute("spp"), back.attribute("part"), back.attribute("seed")),
            (Some("64"), Some("1/4"), None)
        );
        assert_eq!(back, img);
        // Integer channels round-trip exactly, including values no f32 represents.
        let values: Vec<u32> = (0..35).map(|i: u32| u32::MAX - i * 977).collect();
        img.set_uint_channel("state", values.clone()).unwrap();
        img.write_exr(&path).unwrap();
        let back = LinearImage::read_exr(&path).unwrap();
        assert_eq!(back.uint_channel("state"), Some(values.as_slice()));
        assert_eq!(back, img);
        assert!(matches!(img.set_uint_channel("short", vec![0; 3]), Err(ImageError::Size { .. })));
        // Only the final file remains in the directory.
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }

    #[test]
    fn png_is_written_and_decodes_to_the_srgb_values() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.png");
        let img = gradient();
        img.write_png(&path, 0.0, ToneMap::Clamp).unwrap();
        let back = image::open(&path).unwrap().to_rgb8();
        assert_eq!(back.dimensions(), (7, 5));
        assert_eq!(back.into_raw(), img.to_srgb8(0.0, ToneMap::Clamp));
    }

    #[test]
    fn failed_write_leaves_no_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("x.bin");
        let r = write_atomically(&path, |_| Err(std::io::Error::other("boom")));
        assert!(r.is_err());
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    }

    #[test]
    fn srgb_and_tone_maps_at_known_points() {
        assert_eq!(encode_srgb8(0.0), 0);
        assert_eq!(encode_srgb8(1.0), 255);
        // sRGB(0.5) = 1.055·0.5^(1/2.4) − 0.055 = 0.7354 → 187.5… → 188.
        assert_eq!(encode_srgb8(0.5), 188);
        assert_eq!(ToneMap::Reinhard.apply(1.0), 0.5);
        assert_eq!(ToneMap::Filmic.apply(f64::INFINITY), 1.0);
        assert_eq!(ToneMap::Filmic.apply(f64::NAN), 0.0);
        assert!(ToneMap::Filmic.apply(0.18) > 0.1 && ToneMap::Filmic.apply(0.18) < 0.3);
    }

    #[test]
    fn estimated_bytes_count_pixels_and_the_srgb_copy() {
        // 12 bytes of f32 RGB, 12 of the encoder's planes and 3 of 8-bit sRGB per pixel.
        assert_eq!(LinearImage::estimated_bytes(640, 480), Some(640 * 480 * 27));
        assert_eq!(LinearImage::estimated_bytes(100_000, 100_000), Some(270_000_000_000));
        assert_eq!(LinearImage::estimated_bytes(u64::MAX, 2), None);
        assert_eq!(LinearImage::estimated_bytes(1 << 32, 1 << 32), None);
    }

    #[test]
    fn size_mismatch_is_an_error() {
        assert!(matches!(LinearImage::from_pixels(2, 2, vec![[0.0; 3]; 3]), Err(ImageError::Size { .. })));
    }
}
