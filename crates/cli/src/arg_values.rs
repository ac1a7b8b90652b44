//! Command-line values as clap value parsers (`#[arg(value_parser = …)]`): each flag's text is
//! read and validated while the command line is parsed, into a type that can only hold a
//! valid value, before any file is loaded. Degrees are read here and held as [`Angle`]s
//! (radians inside); checks that need a file's contents (a pixel rectangle inside the
//! scene's image) are methods of these types, run once the file is parsed.

use fiberlab_math::DVec3;
use fiberlab_render::integrator::Region;
use std::path::{Path, PathBuf};

/// An angle written in degrees: the radians the code uses, and the degrees as written
/// (for titles and messages).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Angle {
    /// The angle in radians.
    pub radians: f64,
    /// The angle as written, in degrees.
    pub degrees: f64,
}

fn number<T: std::str::FromStr>(text: &str, what: &str) -> Result<T, String> {
    text.trim().parse().map_err(|_| format!("expected {what}, got `{text}`"))
}

/// Finite degrees.
pub fn degrees(text: &str) -> Result<Angle, String> {
    let d: f64 = number(text, "degrees")?;
    if !d.is_finite() {
        return Err(format!("expected finite degrees, got `{text}`"));
    }
    Ok(Angle { radians: d.to_radians(), degrees: d })
}

/// An inclination from the normal plane strictly inside (−90°, 90°), degrees.
pub fn inclination(text: &str) -> Result<Angle, String> {
    let a = degrees(text)?;
    if a.degrees.abs() >= 90.0 {
        return Err(format!("expected degrees in (-90, 90), got `{text}`"));
    }
    Ok(a)
}

/// An incidence of the goniophotometer, within (−89.9°, 89.9°), degrees.
pub fn incidence(text: &str) -> Result<Angle, String> {
    let a = degrees(text)?;
    if a.degrees.abs() >= 89.9 {
        return Err(format!("expected degrees in (-89.9, 89.9), got `{text}`"));
    }
    Ok(a)
}

/// A count ≥ 1.
pub fn positive_count(text: &str) -> Result<usize, String> {
    match number::<usize>(text, "a positive integer")? {
        0 => Err("expected a positive integer, got 0".into()),
        n => Ok(n),
    }
}

/// An output prefix (`--out PREFIX`), the one rule of every verb that writes files: the
/// files are `PREFIX` plus their suffix (`.exr`, `.png`, `_residuals.png`, …). A given
/// extension of an output kind (`render.exr`) is dropped, a directory is refused (it would
/// otherwise become hidden files `dir/.exr`), and the directory the files go to must exist
/// and be writable — checked here, before any work is done.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct OutPrefix(PathBuf);

/// Output extensions an `--out` prefix may carry by mistake; they are dropped.
const OUTPUT_EXTENSIONS: [&str; 7] = ["exr", "png", "csv", "toml", "svg", "json", "jpg"];

impl OutPrefix {
    /// The output file `PREFIX` + `suffix`.
    #[must_use]
    pub fn with(&self, suffix: &str) -> PathBuf {
        let mut s = self.0.clone().into_os_string();
        s.push(suffix);
        s.into()
    }

    /// The prefix of a render that stopped early: `PREFIX.partial`.
    #[must_use]
    pub fn partial(&self) -> OutPrefix {
        OutPrefix(self.with(".partial"))
    }
}

impl std::fmt::Display for OutPrefix {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}", self.0.display())
    }
}

/// `--out PREFIX`: see [`OutPrefix`].
pub fn out_prefix(text: &str) -> Result<OutPrefix, String> {
    if text.is_empty() {
        return Err("expected an output prefix such as `out/render`".into());
    }
    let path = PathBuf::from(text);
    if text.ends_with('/') || path.is_dir() {
        let inside = Path::new(text.trim_end_matches('/')).join("render");
        return Err(format!("`{text}` is a directory; give a prefix inside it, e.g. `{}`", inside.display()));
    }
    let path = match path.extension().and_then(|e| e.to_str()) {
        Some(e) if OUTPUT_EXTENSIONS.contains(&e.to_ascii_lowercase().as_str()) => path.with_extension(""),
        _ => path,
    };
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    crate::files::check_writable_dir(&dir)?;
    Ok(OutPrefix(path))
}

/// A finite number (e.g. an exposure in stops, which may be negative).
pub fn finite(text: &str) -> Result<f64, String> {
    let x: f64 = number(text, "a finite number")?;
    if !x.is_finite() {
        return Err(format!("expected a finite number, got `{text}`"));
    }
    Ok(x)
}

/// Seconds ≥ 0, finite.
pub fn seconds(text: &str) -> Result<f64, String> {
    let s: f64 = number(text, "seconds")?;
    if !(s.is_finite() && s >= 0.0) {
        return Err(format!("expected seconds ≥ 0, got `{text}`"));
    }
    Ok(s)
}

/// A finite number > 0.
pub fn positive(text: &str) -> Result<f64, String> {
    let x: f64 = number(text, "a number > 0")?;
    if !(x.is_finite() && x > 0.0) {
        return Err(format!("expected a number > 0, got `{text}`"));
    }
    Ok(x)
}

/// An offset across a fiber, in [−1, 1].
pub fn offset(text: &str) -> Result<f64, String> {
    let h: f64 = number(text, "a number in [-1, 1]")?;
    if !(-1.0..=1.0).contains(&h) {
        return Err(format!("expected a number in [-1, 1], got `{text}`"));
    }
    Ok(h)
}

/// A unit direction `x,y,z` (|w| within 1e−3 of 1, then normalized).
pub fn unit_vector(text: &str) -> Result<DVec3, String> {
    let parts: Vec<f64> = text
        .split(',')
        .map(|s| s.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("expected three numbers x,y,z, got `{text}`"))?;
    let [x, y, z] = parts[..] else { return Err(format!("expected three numbers x,y,z, got `{text}`")) };
    let w = DVec3::new(x, y, z);
    let len = w.length();
    if !(w.is_finite() && (len - 1.0).abs() <= 1e-3) {
        return Err(format!("expected a unit vector, got ({x}, {y}, {z}) of length {len}"));
    }
    Ok(w / len)
}

/// A parameter `KEY=VALUE`, optionally for one model (`MODEL:KEY=VALUE`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct KeyValue {
    /// The model it is for (`MODEL:` prefix), if any.
    pub model: Option<String>,
    /// The key.
    pub key: String,
    /// The value, as written.
    pub value: String,
}

impl std::fmt::Display for KeyValue {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match &self.model {
            Some(m) => write!(f, "{m}:{}={}", self.key, self.value),
            None => write!(f, "{}={}", self.key, self.value),
        }
    }
}

/// `KEY=VALUE` with a non-empty key.
pub fn key_value(text: &str) -> Result<KeyValue, String> {
    let (key, value) = text.split_once('=').ok_or_else(|| format!("expected KEY=VALUE, got `{text}`"))?;
    let key = key.trim();
    if key.is_empty() {
        return Err(format!("expected KEY=VALUE with a non-empty key, got `{text}`"));
    }
    Ok(KeyValue { model: None, key: key.into(), value: value.trim().into() })
}

/// `MODEL:KEY=VALUE` with a non-empty model name and key.
pub fn model_key_value(text: &str) -> Result<KeyValue, String> {
    let expected = || format!("expected MODEL:KEY=VALUE, got `{text}`");
    let (model, kv) = text.split_once(':').ok_or_else(expected)?;
    if model.trim().is_empty() {
        return Err(expected());
    }
    Ok(KeyValue { model: Some(model.trim().into()), ..key_value(kv).map_err(|_| expected())? })
}

/// Histogram bins `NT,NP` of the goniophotometer (θ_r and φ).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Bins {
    /// Bins in θ_r.
    pub theta: usize,
    /// Bins in φ.
    pub phi: usize,
}

/// `NT,NP`, two positive integers.
pub fn bins(text: &str) -> Result<Bins, String> {
    let expected = || format!("expected two positive integers NT,NP, got `{text}`");
    let (a, b) = text.split_once(',').ok_or_else(expected)?;
    let (theta, phi) =
        (a.trim().parse::<usize>().map_err(|_| expected())?, b.trim().parse::<usize>().map_err(|_| expected())?);
    if theta == 0 || phi == 0 {
        return Err(expected());
    }
    Ok(Bins { theta, phi })
}

/// Part `index` of `count` bands of rows (`--tile I/N`), `0 ≤ I < N`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Tile {
    /// I.
    pub index: u32,
    /// N.
    pub count: u32,
}

impl Tile {
    /// The band of a `width × height` image; every band of the split must hold at least one
    /// row, so `N` may not exceed the image's height.
    pub fn region(self, width: u32, height: u32) -> Result<Region, String> {
        if self.count > height {
            return Err(format!(
                "{}/{}: the image has only {height} rows, so it splits into at most {height} parts (N ≤ {height})",
                self.index, self.count
            ));
        }
        Ok(Region::part(self.index, self.count, width, height))
    }
}

/// `I/N` with `0 ≤ I < N`.
pub fn tile(text: &str) -> Result<Tile, String> {
    let (i, n) = text.split_once('/').ok_or_else(|| format!("expected I/N, e.g. 0/4, got `{text}`"))?;
    let index = i.trim().parse().map_err(|_| format!("`{text}`: I is not a number"))?;
    let count = n.trim().parse().map_err(|_| format!("`{text}`: N is not a number"))?;
    if count == 0 || index >= count {
        return Err(format!("`{text}`: need 0 ≤ I < N"));
    }
    Ok(Tile { index, count })
}

/// An image size `W×H` in pixels (`--size`), both at least 1.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ImageSize {
    /// W.
    pub width: u32,
    /// H.
    pub height: u32,
}

/// `WxH` (or `W×H`), two whole numbers of pixels, each at least 1.
pub fn image_size(text: &str) -> Result<ImageSize, String> {
    let expected = || format!("expected WxH in pixels, e.g. 256x256, got `{text}`");
    let (w, h) = text.split_once(['x', 'X', '×']).ok_or_else(expected)?;
    let side = |s: &str| s.trim().parse::<u32>().map_err(|_| expected());
    let (width, height) = (side(w)?, side(h)?);
    if width == 0 || height == 0 {
        return Err(format!("`{text}`: width and height must be at least 1 pixel"));
    }
    Ok(ImageSize { width, height })
}

/// A non-empty half-open pixel rectangle `x0,y0,x1,y1` (`x0 < x1`, `y0 < y1`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PixelRect(Region);

impl PixelRect {
    /// The rectangle as given.
    #[must_use]
    pub fn region(self) -> Region {
        self.0
    }

    /// The rectangle, checked to lie inside a `width × height` image.
    pub fn within(self, width: u32, height: u32) -> Result<Region, String> {
        let r = self.0;
        if r.x1 > width || r.y1 > height {
            return Err(format!("{},{},{},{}: need x0 < x1 ≤ {width} and y0 < y1 ≤ {height}", r.x0, r.y0, r.x1, r.y1));
        }
        Ok(r)
    }
}

/// `x0,y0,x1,y1`, four integers with `x0 < x1` and `y0 < y1`.
pub fn pixel_rect(text: &str) -> Result<PixelRect, String> {
    let expected = || format!("expected four integers x0,y0,x1,y1, got `{text}`");
    let v: Vec<u32> =
        text.split(',').map(|s| s.trim().parse::<u32>()).collect::<Result<_, _>>().map_err(|_| expected())?;
    let [x0, y0, x1, y1] = v[..] else { return Err(expected()) };
    if x0 >= x1 || y0 >= y1 {
        return Err(format!("`{text}`: need x0 < x1 and y0 < y1"));
    }
    Ok(PixelRect(Region { x0, y0, x1, y1 }))
}

/// A named pixel rectangle `NAME=X0,Y0,X1,Y1`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct NamedRect {
    /// The name (non-empty).
    pub name: String,
    /// The rectangle.
    pub rect: PixelRect,
}

/// `NAME=X0,Y0,X1,Y1` with a non-empty name.
pub fn named_rect(text: &str) -> Result<NamedRect, String> {
    let (name, rect) = text.split_once('=').ok_or_else(|| format!("expected NAME=X0,Y0,X1,Y1, got `{text}`"))?;
    if name.is_empty() {
        return Err(format!("`{text}`: expected a non-empty name before '='"));
    }
    Ok(NamedRect { name: name.to_string(), rect: pixel_rect(rect)? })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn angles_are_degrees_in_and_radians_out_with_their_ranges() {
        let a = degrees("-30").unwrap();
        assert_eq!((a.degrees, a.radians), (-30.0, -std::f64::consts::PI / 6.0));
        assert!(degrees("inf").is_err() && degrees("x").is_err());
        assert!(inclination("89.99").is_ok() && inclination("90").is_err() && inclination("-90").is_err());
        assert!(incidence("89.8").is_ok() && incidence("89.9").unwrap_err().contains("(-89.9, 89.9)"));
    }

    #[test]
    fn numbers_offsets_and_directions() {
        assert_eq!(positive("2.5"), Ok(2.5));
        assert!(positive("0").is_err() && positive("inf").is_err());
        assert_eq!(offset("-1"), Ok(-1.0));
        assert!(offset("1.01").unwrap_err().contains("[-1, 1]") && offset("NaN").is_err());
        assert_eq!(unit_vector("0, 0.6, 0.8"), Ok(DVec3::new(0.0, 0.6, 0.8) / DVec3::new(0.0, 0.6, 0.8).length()));
        assert!(unit_vector("0,1").unwrap_err().contains("x,y,z"));
        assert!(unit_vector("0,2,0").unwrap_err().contains("length 2"));
    }

    #[test]
    fn key_values_with_and_without_a_model() {
        let kv = key_value(" sigma_a = 0.1,0.2,0.3").unwrap();
        assert_eq!((kv.model, kv.key.as_str(), kv.value.as_str()), (None, "sigma_a", "0.1,0.2,0.3"));
        assert!(key_value("sigma_a").unwrap_err().contains("KEY=VALUE") && key_value("=1").is_err());
        let kv = model_key_value("chiang:eumelanin=0.5").unwrap();
        assert_eq!(kv.to_string(), "chiang:eumelanin=0.5");
        for bad in ["eumelanin=0.5", ":a=1", "chiang:=1", "chiang:a"] {
            assert!(model_key_value(bad).unwrap_err().contains("MODEL:KEY=VALUE"), "{bad}");
        }
    }

    #[test]
    fn counts_seconds_and_bins() {
        assert_eq!(positive_count("3"), Ok(3));
        assert!(positive_count("0").is_err() && positive_count("-1").is_err());
        assert_eq!(seconds("0"), Ok(0.0));
        assert!(seconds("-1").is_err() && seconds("NaN").is_err());
        assert_eq!(bins("18, 36"), Ok(Bins { theta: 18, phi: 36 }));
        for bad in ["18", "0,36", "18,x", "18,36,2"] {
            assert!(bins(bad).unwrap_err().contains("NT,NP"), "{bad}");
        }
    }

    #[test]
    fn tiles_and_rectangles_say_what_was_expected() {
        assert_eq!(tile("1/3"), Ok(Tile { index: 1, count: 3 }));
        assert_eq!(tile("2/3").unwrap().region(10, 9), Ok(Region { x0: 0, y0: 6, x1: 10, y1: 9 }));
        assert!(tile("0/10").unwrap().region(10, 9).unwrap_err().contains("only 9 rows"));
        for (bad, expected) in [("3/3", "0 ≤ I < N"), ("0/0", "0 ≤ I < N"), ("a/3", "I is not"), ("1", "I/N")] {
            assert!(tile(bad).unwrap_err().contains(expected), "{bad}");
        }
        let r = pixel_rect("2,3,10,12").unwrap();
        assert_eq!(r.within(16, 16), Ok(Region { x0: 2, y0: 3, x1: 10, y1: 12 }));
        assert!(r.within(9, 16).unwrap_err().contains("x0 < x1 ≤ 9"));
        assert!(pixel_rect("10,3,2,12").unwrap_err().contains("x0 < x1"));
        assert!(pixel_rect("1,2,3").unwrap_err().contains("four integers"));
        assert_eq!(named_rect("g=0,0,1,1").unwrap().name, "g");
        assert!(named_rect("=0,0,1,1").unwrap_err().contains("non-empty name"));
        assert!(named_rect("0,0,1,1").unwrap_err().contains("NAME=X0,Y0,X1,Y1"));
    }

    #[test]
    fn image_sizes_are_two_positive_whole_numbers() {
        assert_eq!(image_size("320x180"), Ok(ImageSize { width: 320, height: 180 }));
        assert_eq!(image_size("64×48"), Ok(ImageSize { width: 64, height: 48 }));
        assert_eq!(image_size("1X1"), Ok(ImageSize { width: 1, height: 1 }));
        for (bad, expected) in [
            ("0x10", "at least 1"),
            ("10x0", "at least 1"),
            ("256", "WxH"),
            ("ax4", "WxH"),
            ("4x-1", "WxH"),
            ("1.5x2", "WxH"),
            ("4x4x4", "WxH"),
            ("99999999999x1", "WxH"),
        ] {
            assert!(image_size(bad).unwrap_err().contains(expected), "{bad}");
        }
    }

    #[test]
    fn out_prefixes_drop_output_extensions_and_refuse_directories_and_missing_places() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path().display().to_string();
        let p = out_prefix(&format!("{d}/render.exr")).unwrap();
        assert_eq!(p.with(".png"), dir.path().join("render.png"));
        assert_eq!(out_prefix(&format!("{d}/v1.2")).unwrap().with(".exr"), dir.path().join("v1.2.exr"));
        let e = out_prefix(&d).unwrap_err();
        assert!(e.contains("is a directory") && e.contains("render"), "{e}");
        assert!(out_prefix(&format!("{d}/")).unwrap_err().contains("is a directory"));
        let e = out_prefix(&format!("{d}/missing/r")).unwrap_err();
        assert!(e.contains("does not exist") && e.contains("missing"), "{e}");
        assert!(out_prefix("").is_err());
        // The check leaves nothing behind.
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    }
}
