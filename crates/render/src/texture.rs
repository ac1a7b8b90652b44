//! Image textures for surface parameters: PNG or OpenEXR files, bilinear filtering, repeat or
//! clamp wrapping, every texel validated once when loaded.
//!
//! # Coordinates
//! Texel `(x, y)` (row `y = 0` at the top of the image, as files store it) has its centre at
//! `u = (x + ½)/W`, `v = 1 − (y + ½)/H`: `v` grows upward in the image, the OBJ convention.
//! [`Texture::lookup`] interpolates bilinearly between the four texel centres around `(u, v)`
//! (after the uv `scale`), indices wrapped by the [`Wrap`] mode.
//!
//! # Values
//! EXR texels are linear and used as they are. PNG texels are `code / (2^bits − 1)` and then,
//! with [`Encoding::Srgb`], decoded by the sRGB transfer function (the right choice for
//! colours painted or photographed: `k_d`, `k_f`), with [`Encoding::Linear`] kept linear (data:
//! angles, widths). A parameter's texture is mapped by `remap = [lo, hi]` to `lo + (hi − lo)·t`
//! (identity by default), in the unit the parameter's table gives (degrees for angles).

use fiberlab_io::LinearImage;
use fiberlab_math::Rgb;
use std::path::{Path, PathBuf};

/// How texture coordinates outside `[0, 1)` map to texels.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Wrap {
    /// Periodic.
    #[default]
    Repeat,
    /// The edge texels extend outward.
    Clamp,
}

impl Wrap {
    /// The texel index for a possibly out-of-range index `i` of `n`.
    fn index(self, i: i64, n: usize) -> usize {
        let n = n as i64;
        match self {
            Wrap::Repeat => i.rem_euclid(n) as usize,
            Wrap::Clamp => i.clamp(0, n - 1) as usize,
        }
    }
}

/// How PNG codes become values (EXR is always linear).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Encoding {
    /// sRGB-encoded colour: decoded to linear.
    Srgb,
    /// Linear data.
    Linear,
}

/// A texture error, naming the file (and the pixel where one is at fault).
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum TextureError {
    /// The file could not be read or decoded.
    #[error("texture {path}: {message}")]
    Read {
        /// File.
        path: PathBuf,
        /// Why.
        message: String,
    },
    /// A pixel whose value is not allowed.
    #[error("texture {path}: pixel x = {x}, y = {y} is {value:?}: {message}")]
    Pixel {
        /// File.
        path: PathBuf,
        /// Column.
        x: usize,
        /// Row (0 at the top).
        y: usize,
        /// The texel (after `remap`).
        value: [f64; 3],
        /// What is wrong.
        message: String,
    },
    /// The image does not have the size required.
    #[error("texture {path}: {width}×{height} pixels, expected {expected_width}×{expected_height}")]
    Size {
        /// File.
        path: PathBuf,
        /// Its width.
        width: usize,
        /// Its height.
        height: usize,
        /// Required width.
        expected_width: usize,
        /// Required height.
        expected_height: usize,
    },
}

/// An RGB image texture (scalar textures use the red channel).
#[derive(Clone, Debug, PartialEq)]
pub struct Texture {
    path: PathBuf,
    width: usize,
    height: usize,
    texels: Vec<[f64; 3]>,
    wrap: Wrap,
    scale: [f64; 2],
}

impl Texture {
    /// A texture from texels in file order (row 0 at the top); `path` names it in errors.
    /// NaN or infinite texels are an error naming the pixel.
    pub fn from_texels(
        path: &Path,
        width: usize,
        height: usize,
        texels: Vec<[f64; 3]>,
        wrap: Wrap,
    ) -> Result<Self, TextureError> {
        if width == 0 || height == 0 || texels.len() != width * height {
            return Err(TextureError::Read {
                path: path.into(),
                message: format!("{} texels for {width}×{height} pixels", texels.len()),
            });
        }
        let t = Self { path: path.into(), width, height, texels, wrap, scale: [1.0, 1.0] };
        t.check(|v| v.iter().all(|c| c.is_finite()), "texels must be finite numbers")?;
        Ok(t)
    }

    /// Reads a PNG (with `encoding`) or EXR file (by extension, `.exr` being EXR).
    pub fn read(path: &Path, encoding: Encoding, wrap: Wrap) -> Result<Self, TextureError> {
        let fail = |message: String| TextureError::Read { path: path.into(), message };
        let is_exr = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr"));
        let (width, height, texels) = if is_exr {
            let img = LinearImage::read_exr(path).map_err(|e| fail(e.to_string()))?;
            let texels = img.pixels().iter().map(|p| p.map(f64::from)).collect();
            (img.width(), img.height(), texels)
        } else {
            // Opened and decoded within the memory budget (fiberlab_io::input_file).
            let img = fiberlab_io::image_file::decode_image(path).map_err(|e| fail(e.to_string()))?;
            let rgb = img.to_rgb32f();
            let decode = |c: f32| match encoding {
                Encoding::Linear => f64::from(c),
                Encoding::Srgb => srgb_to_linear(f64::from(c)),
            };
            let texels = rgb.pixels().map(|p| p.0.map(decode)).collect();
            (rgb.width() as usize, rgb.height() as usize, texels)
        };
        Self::from_texels(path, width, height, texels, wrap)
    }

    /// The file it came from.
    #[must_use]
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Width, pixels.
    #[must_use]
    pub fn width(&self) -> usize {
        self.width
    }

    /// Height, pixels.
    #[must_use]
    pub fn height(&self) -> usize {
        self.height
    }

    /// Texel `(x, y)`, row 0 at the top.
    #[must_use]
    pub fn texel(&self, x: usize, y: usize) -> [f64; 3] {
        self.texels[y * self.width + x]
    }

    /// The wrapping of coordinates outside `[0, 1)`.
    #[must_use]
    pub fn wrap(&self) -> Wrap {
        self.wrap
    }

    /// The uv multiplier applied before the lookup.
    #[must_use]
    pub fn scale(&self) -> [f64; 2] {
        self.scale
    }

    /// Multiplies texture coordinates by `scale` before the lookup (tiling).
    #[must_use]
    pub fn with_scale(mut self, scale: [f64; 2]) -> Self {
        self.scale = scale;
        self
    }

    /// Maps every texel `t` to `lo + (hi − lo)·t`.
    #[must_use]
    pub fn remapped(mut self, lo: f64, hi: f64) -> Self {
        for t in &mut self.texels {
            *t = t.map(|c| lo + (hi - lo) * c);
        }
        self
    }

    /// An error naming the size unless the texture is `width × height`.
    pub fn require_size(&self, width: usize, height: usize) -> Result<(), TextureError> {
        if (self.width, self.height) == (width, height) {
            return Ok(());
        }
        Err(TextureError::Size {
            path: self.path.clone(),
            width: self.width,
            height: self.height,
            expected_width: width,
            expected_height: height,
        })
    }

    /// The first texel (row by row from the top) for which `ok` fails, as an error with
    /// `message`.
    pub fn check(&self, ok: impl Fn(&[f64; 3]) -> bool, message: &str) -> Result<(), TextureError> {
        match self.texels.iter().position(|t| !ok(t)) {
            None => Ok(()),
            Some(i) => Err(TextureError::Pixel {
                path: self.path.clone(),
                x: i % self.width,
                y: i / self.width,
                value: self.texels[i],
                message: message.into(),
            }),
        }
    }

    /// The bilinearly filtered value at texture coordinates `uv` (see the module
    /// documentation).
    #[must_use]
    pub fn lookup(&self, uv: [f64; 2]) -> Rgb {
        let s = uv[0] * self.scale[0] * self.width as f64 - 0.5;
        let t = (1.0 - uv[1] * self.scale[1]) * self.height as f64 - 0.5;
        if !(s.is_finite() && t.is_finite()) {
            let c = self.texels[0];
            return Rgb::new(c[0], c[1], c[2]);
        }
        let (x0, y0) = (s.floor(), t.floor());
        let (fx, fy) = (s - x0, t - y0);
        // Far-out coordinates lose their fraction but stay in i64.
        let (x0, y0) = (x0.clamp(-1e15, 1e15) as i64, y0.clamp(-1e15, 1e15) as i64);
        let (xa, xb) = (self.wrap.index(x0, self.width), self.wrap.index(x0 + 1, self.width));
        let (ya, yb) = (self.wrap.index(y0, self.height), self.wrap.index(y0 + 1, self.height));
        let mut out = [0.0; 3];
        for (x, y, w) in
            [(xa, ya, (1.0 - fx) * (1.0 - fy)), (xb, ya, fx * (1.0 - fy)), (xa, yb, (1.0 - fx) * fy), (xb, yb, fx * fy)]
        {
            let c = self.texel(x, y);
            for k in 0..3 {
                out[k] += w * c[k];
            }
        }
        Rgb::new(out[0], out[1], out[2])
    }
}

/// The sRGB transfer function's inverse (IEC 61966-2-1): an encoded value in `[0, 1]` to linear.
#[must_use]
pub fn srgb_to_linear(c: f64) -> f64 {
    if c <= 0.04045 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn texture(w: usize, h: usize, f: impl Fn(usize, usize) -> f64, wrap: Wrap) -> Texture {
        let texels = (0..h).flat_map(|y| (0..w).map(move |x| (x, y))).map(|(x, y)| [f(x, y), 0.0, 0.0]).collect();
        Texture::from_texels(Path::new("t.exr"), w, h, texels, wrap).unwrap()
    }

    /// A texture of a linear function of the texel centre reproduces it exactly inside
    /// (bilinear interpolation is exact on affine functions) and at texel centres.
    #[test]
    fn bilinear_is_exact_on_affine_data_and_texel_centres() {
        let (w, h) = (5, 4);
        // Value at texel centre (x, y): 2·u_c + 3·v_c + 1 with u_c = (x+½)/w, v_c = 1 − (y+½)/h.
        let f = |u: f64, v: f64| 2.0 * u + 3.0 * v + 1.0;
        let tex = texture(w, h, |x, y| f((x as f64 + 0.5) / w as f64, 1.0 - (y as f64 + 0.5) / h as f64), Wrap::Clamp);
        for (u, v) in [(0.15, 0.2), (0.5, 0.5), (0.83, 0.79), (0.1 + 0.5 / 5.0, 0.875)] {
            let got = tex.lookup([u, v])[0];
            assert!((got - f(u, v)).abs() < 1e-12, "({u}, {v}): {got} vs {}", f(u, v));
        }
        assert_eq!(tex.lookup([2.5 / 5.0, 1.0 - 1.5 / 4.0])[0], tex.texel(2, 1)[0]);
    }

    /// Repeat: periodic in u and v with period 1 (after `scale`); clamp: the edge texel's value
    /// beyond the last centre; both differ across an edge where the data jump.
    #[test]
    fn wrap_modes() {
        let (w, h) = (4, 3);
        let f = |x: usize, y: usize| (x * 10 + y) as f64;
        let rep = texture(w, h, f, Wrap::Repeat);
        for (u, v) in [(0.3, 0.4), (0.01, 0.99), (0.9, 0.05)] {
            let a = rep.lookup([u, v])[0];
            for (du, dv) in [(1.0, 0.0), (-3.0, 2.0), (0.0, -1.0)] {
                assert!((rep.lookup([u + du, v + dv])[0] - a).abs() < 1e-9);
            }
        }
        // Halfway between the last and the first column (u = 0 or 1): their mean in repeat mode.
        let y_centre = 1.0 - 1.5 / 3.0;
        assert!((rep.lookup([0.0, y_centre])[0] - (f(3, 1) + f(0, 1)) / 2.0).abs() < 1e-12);
        let clamp = texture(w, h, f, Wrap::Clamp);
        assert_eq!(clamp.lookup([0.0, y_centre])[0], f(0, 1));
        assert_eq!(clamp.lookup([-7.0, y_centre])[0], f(0, 1));
        assert_eq!(clamp.lookup([1.0, y_centre])[0], f(3, 1));
        // Scale 2: period ½.
        let tiled = rep.clone().with_scale([2.0, 2.0]);
        assert!((tiled.lookup([0.1, 0.2])[0] - rep.lookup([0.2, 0.4])[0]).abs() < 1e-12);
        assert!((tiled.lookup([0.6, 0.7])[0] - rep.lookup([0.2, 0.4])[0]).abs() < 1e-12);
    }

    #[test]
    fn png_srgb_and_linear_decoding_and_bad_files() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.png");
        // 2×1: codes 0 and 188 (sRGB 188/255 ≈ linear 0.5029).
        let img = image::RgbImage::from_raw(2, 1, vec![0, 0, 0, 188, 188, 188]).unwrap();
        img.save(&path).unwrap();
        let lin = Texture::read(&path, Encoding::Linear, Wrap::Clamp).unwrap();
        assert!((lin.texel(1, 0)[0] - 188.0 / 255.0).abs() < 1e-7);
        let srgb = Texture::read(&path, Encoding::Srgb, Wrap::Clamp).unwrap();
        let c = 188.0 / 255.0;
        let expected = ((c + 0.055) / 1.055_f64).powf(2.4);
        assert!((srgb.texel(1, 0)[0] - expected).abs() < 1e-6, "{}", srgb.texel(1, 0)[0]);
        assert!(srgb.require_size(2, 1).is_ok());
        let e = srgb.require_size(4, 4).unwrap_err().to_string();
        assert!(e.contains("t.png: 2×1 pixels, expected 4×4"), "{e}");
        // Unreadable and missing files name the file.
        std::fs::write(dir.path().join("bad.png"), b"not a png").unwrap();
        let e = Texture::read(&dir.path().join("bad.png"), Encoding::Linear, Wrap::Clamp).unwrap_err().to_string();
        assert!(e.starts_with("texture ") && e.contains("bad.png"), "{e}");
        assert!(Texture::read(&dir.path().join("none.exr"), Encoding::Linear, Wrap::Clamp).is_err());
    }

    #[test]
    fn nan_and_out_of_range_texels_name_the_pixel() {
        let mut texels = vec![[0.5; 3]; 6];
        texels[4] = [0.5, f64::NAN, 0.5];
        let e = Texture::from_texels(Path::new("a.exr"), 3, 2, texels, Wrap::Repeat).unwrap_err().to_string();
        assert!(e.starts_with("texture a.exr: pixel x = 1, y = 1 is [0.5, NaN, 0.5]"), "{e}");
        let mut texels = vec![[0.5; 3]; 6];
        texels[2] = [1.5; 3];
        let t = Texture::from_texels(Path::new("a.exr"), 3, 2, texels, Wrap::Repeat).unwrap();
        let e = t.check(|v| v.iter().all(|c| (0.0..=1.0).contains(c)), "must be in [0, 1]").unwrap_err();
        assert!(e.to_string().ends_with("pixel x = 2, y = 0 is [1.5, 1.5, 1.5]: must be in [0, 1]"), "{e}");
        // Remap before the check: [0, 1] → [−90, 90].
        assert_eq!(t.remapped(-90.0, 90.0).texel(0, 0), [0.0; 3]);
    }
}
