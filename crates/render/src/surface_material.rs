//! Surface materials made of a registered surface model ([`fiberlab_scatter::SurfaceModel`])
//! and textures for any of its parameters.
//!
//! At a hit the renderer copies the material's model (a small value, no heap data) and
//! overwrites each textured parameter with the texture's bilinear value at the hit's texture
//! coordinates ([`SurfaceScattering::set_parameter`], no allocation). Texels are validated
//! once, here, when the material is made: each is set on a copy of the model, so that a texel
//! the model would refuse (NaN, out of the parameter's range) is an error naming the file and
//! the pixel. Bilinear values are convex combinations of valid texels, hence in range for the
//! interval ranges of the parameter tables.
//!
//! # Position on the surface
//! A model whose table has the number parameters `u` and `v` (the point's place in a
//! periodic pattern, e.g. the weave tile of `irawan-2012`) gets them from the hit's texture
//! coordinates times the material's uv scale (`uv_scale = [su, sv]` in a scene file, default
//! `[1, 1]`): `u = su·uv₀`, `v = sv·uv₁`, so that the pattern repeats `su × sv` times over the
//! unit square of texture coordinates. Such a material needs texture coordinates like a
//! textured one.
//!
//! # Units
//! Texels are in the parameter's unit as its table states it (degrees for angles, converted to
//! radians here); scalar parameters read the red channel. PNG textures of colour parameters
//! are sRGB-decoded by default, of scalar parameters read as linear data ([`crate::texture`]).

use crate::texture::{Encoding, Texture, TextureError, Wrap};
use fiberlab_math::Rgb;
use fiberlab_scatter::params::{ParamKind, ParamSpec};
use fiberlab_scatter::{ModelError, SurfaceModel, SurfaceScattering};
use std::path::{Path, PathBuf};

/// A texture bound to one parameter of a surface model.
#[derive(Clone, Debug)]
pub struct TexturedParameter {
    key: &'static str,
    texture: Texture,
    /// The texels are degrees (set as radians).
    degrees: bool,
    /// A scalar parameter (the red channel, set on all three).
    scalar: bool,
}

impl TexturedParameter {
    /// The parameter key.
    #[must_use]
    pub fn key(&self) -> &str {
        self.key
    }

    /// The texture.
    #[must_use]
    pub fn texture(&self) -> &Texture {
        &self.texture
    }

    /// The value to set for texel value `c` (raw, in the table's unit): a scalar parameter's
    /// red channel on all three, degrees as radians. Linear in `c`, so a texture of these values
    /// interpolates to the value of the interpolated texels.
    #[must_use]
    pub fn value(&self, c: [f64; 3]) -> Rgb {
        let c = if self.scalar { [c[0]; 3] } else { c };
        let c = if self.degrees { c.map(f64::to_radians) } else { c };
        Rgb::new(c[0], c[1], c[2])
    }
}

/// Where a texture of a parameter comes from, as a scene file gives it.
#[derive(Clone, Debug, PartialEq)]
pub struct TextureSource {
    /// The image (PNG or EXR).
    pub path: PathBuf,
    /// Wrapping (default repeat).
    pub wrap: Wrap,
    /// uv multiplier (default `[1, 1]`).
    pub scale: [f64; 2],
    /// `[lo, hi]`: texel `t` means `lo + (hi − lo)·t` (default identity).
    pub remap: Option<[f64; 2]>,
    /// PNG decoding (default: sRGB for colours, linear for scalars).
    pub encoding: Option<Encoding>,
    /// A size the image must have.
    pub size: Option<[usize; 2]>,
}

impl TextureSource {
    /// A texture from a file with the defaults.
    #[must_use]
    pub fn file(path: PathBuf) -> Self {
        Self { path, wrap: Wrap::Repeat, scale: [1.0, 1.0], remap: None, encoding: None, size: None }
    }
}

/// Why a surface material cannot be made.
#[derive(Debug, thiserror::Error)]
pub enum MaterialError {
    /// A texture that cannot be read or has a bad texel.
    #[error("{key}: {source}")]
    Texture {
        /// The parameter.
        key: String,
        /// The texture's error.
        source: TextureError,
    },
    /// A texel the model refuses.
    #[error("{key}: texture {path}: pixel x = {x}, y = {y}: {source}")]
    Texel {
        /// The parameter.
        key: String,
        /// File.
        path: PathBuf,
        /// Column.
        x: usize,
        /// Row (0 at the top).
        y: usize,
        /// The model's error.
        source: Box<ModelError>,
    },
    /// A key the model does not have, or cannot texture.
    #[error("{key}: {message}")]
    Parameter {
        /// The parameter.
        key: String,
        /// Why.
        message: String,
    },
}

/// A surface model and its textured parameters.
#[derive(Clone, Debug)]
pub struct ModelMaterial {
    name: &'static str,
    model: SurfaceModel,
    textures: Vec<TexturedParameter>,
    /// The uv scale of a model that takes its position (`u`, `v`), see the module docs.
    uv_position: Option<[f64; 2]>,
}

/// True when a model with parameter table `params` takes the point's position as its number
/// parameters `u` and `v` (module documentation).
#[must_use]
pub fn takes_uv_position(params: &[ParamSpec]) -> bool {
    ["u", "v"].iter().all(|k| params.iter().any(|s| s.key == *k && matches!(s.kind, ParamKind::Number(_))))
}

impl ModelMaterial {
    /// The material of `model` (registry name `name`, parameter table `params`) with textures
    /// read from `sources` (key, where from); every texel is checked (module documentation).
    pub fn new(
        name: &'static str,
        params: &'static [ParamSpec],
        model: SurfaceModel,
        sources: &[(String, TextureSource)],
    ) -> Result<Self, MaterialError> {
        let mut textures = Vec::with_capacity(sources.len());
        for (key, source) in sources {
            let fail = |message: String| MaterialError::Parameter { key: key.clone(), message };
            let Some(spec) = params.iter().find(|s| s.key == key) else {
                let known: Vec<&str> = params.iter().map(|s| s.key).collect();
                return Err(fail(format!("model `{name}` has no parameter `{key}` (known: {})", known.join(", "))));
            };
            let scalar = match spec.kind {
                ParamKind::Color(_) => false,
                ParamKind::Number(_) => true,
                _ => return Err(fail(format!("parameter `{key}` of model `{name}` is not a number or colour"))),
            };
            let encoding = source.encoding.unwrap_or(if scalar { Encoding::Linear } else { Encoding::Srgb });
            let as_texture_error = |source: TextureError| MaterialError::Texture { key: key.clone(), source };
            let mut texture = Texture::read(&source.path, encoding, source.wrap).map_err(as_texture_error)?;
            if let Some([w, h]) = source.size {
                texture.require_size(w, h).map_err(as_texture_error)?;
            }
            if let Some([lo, hi]) = source.remap {
                texture = texture.remapped(lo, hi);
            }
            let bound = TexturedParameter {
                key: spec.key,
                texture: texture.with_scale(source.scale),
                degrees: spec.unit == "degrees",
                scalar,
            };
            check_texels(&model, &bound)?;
            textures.push(bound);
        }
        let uv_position = takes_uv_position(params).then_some([1.0, 1.0]);
        Ok(Self { name, model, textures, uv_position })
    }

    /// The material with the uv scale `[su, sv]` of the model's position (module docs):
    /// refused when the model takes no position, or a scale is not finite and non-zero.
    pub fn with_uv_scale(mut self, scale: [f64; 2]) -> Result<Self, MaterialError> {
        let fail = |message: String| MaterialError::Parameter { key: "uv_scale".into(), message };
        if self.uv_position.is_none() {
            return Err(fail(format!("model `{}` has no position parameters u, v to scale", self.name)));
        }
        if !scale.iter().all(|s| s.is_finite() && *s != 0.0) {
            return Err(fail(format!("uv_scale = {scale:?} must be finite and non-zero")));
        }
        self.uv_position = Some(scale);
        Ok(self)
    }

    /// The uv scale of the model's position, when it takes one.
    #[must_use]
    pub fn uv_scale(&self) -> Option<[f64; 2]> {
        self.uv_position
    }

    /// The registry name of the model.
    #[must_use]
    pub fn model_name(&self) -> &'static str {
        self.name
    }

    /// The model with its untextured parameters.
    #[must_use]
    pub fn model(&self) -> &SurfaceModel {
        &self.model
    }

    /// The textured parameters.
    #[must_use]
    pub fn textures(&self) -> &[TexturedParameter] {
        &self.textures
    }

    /// True when some parameter is textured (the surface must have texture coordinates).
    #[must_use]
    pub fn needs_uvs(&self) -> bool {
        !self.textures.is_empty() || self.uv_position.is_some()
    }

    /// The model at texture coordinates `uv`: a copy with every textured parameter set to the
    /// texture's value there and the position `u`, `v` set from `uv` (module docs); without
    /// coordinates, the untextured model.
    #[must_use]
    pub fn at(&self, uv: Option<[f64; 2]>) -> SurfaceModel {
        let mut model = self.model.clone();
        if let Some(uv) = uv {
            for t in &self.textures {
                let v = t.texture.lookup(uv);
                // Every texel was accepted at load; their interpolations are in range.
                let _ = model.set_parameter(t.key, t.value([v[0], v[1], v[2]]));
            }
            if let Some([su, sv]) = self.uv_position {
                // Finite positions are within the parameters' range of ±10⁶ for any sane uv.
                let _ = model.set_parameter("u", Rgb::splat(su * uv[0]));
                let _ = model.set_parameter("v", Rgb::splat(sv * uv[1]));
            }
        }
        model
    }
}

/// Sets every texel of `t` on a copy of `model`: the first refused names its pixel.
fn check_texels(model: &SurfaceModel, t: &TexturedParameter) -> Result<(), MaterialError> {
    let mut trial = model.clone();
    let tex = &t.texture;
    for y in 0..tex.height() {
        for x in 0..tex.width() {
            if let Err(e) = trial.set_parameter(t.key, t.value(tex.texel(x, y))) {
                let source = Box::new(e);
                return Err(MaterialError::Texel { key: t.key.into(), path: tex.path().into(), x, y, source });
            }
        }
    }
    Ok(())
}

/// Reads a texture source from a scene-file parameter value: a string naming a `.png` or
/// `.exr` file, or a table `{ file, wrap = "repeat" | "clamp", scale = [su, sv], remap =
/// [lo, hi], encoding = "srgb" | "linear", size = [w, h] }`. `None` when the value is not a
/// texture (a plain parameter value); relative paths are resolved by `resolve`.
pub fn texture_source(value: &toml::Value, resolve: &dyn Fn(&str) -> PathBuf) -> Option<Result<TextureSource, String>> {
    let is_image = |s: &str| {
        let e = Path::new(s).extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
        matches!(e.as_deref(), Some("png" | "exr"))
    };
    match value {
        toml::Value::String(s) if is_image(s) => Some(Ok(TextureSource::file(resolve(s)))),
        toml::Value::Table(t) => Some(texture_table(t, resolve)),
        _ => None,
    }
}

fn texture_table(t: &toml::Table, resolve: &dyn Fn(&str) -> PathBuf) -> Result<TextureSource, String> {
    let Some(file) = t.get("file").and_then(toml::Value::as_str) else {
        return Err("a texture table needs file = \"….png\" or \"….exr\"".into());
    };
    let mut source = TextureSource::file(resolve(file));
    let pair = |key: &str, v: &toml::Value| -> Result<[f64; 2], String> {
        let items = v.as_array().filter(|a| a.len() == 2).ok_or(format!("{key} must be [a, b]"))?;
        let num = |x: &toml::Value| x.as_float().or_else(|| x.as_integer().map(|i| i as f64));
        match (num(&items[0]), num(&items[1])) {
            (Some(a), Some(b)) if a.is_finite() && b.is_finite() => Ok([a, b]),
            _ => Err(format!("{key} = {v} must be two finite numbers")),
        }
    };
    for (key, v) in t {
        match key.as_str() {
            "file" => {}
            "wrap" => {
                source.wrap = match v.as_str() {
                    Some("repeat") => Wrap::Repeat,
                    Some("clamp") => Wrap::Clamp,
                    _ => return Err(format!("wrap = {v}: use \"repeat\" or \"clamp\"")),
                }
            }
            "encoding" => {
                source.encoding = Some(match v.as_str() {
                    Some("srgb") => Encoding::Srgb,
                    Some("linear") => Encoding::Linear,
                    _ => return Err(format!("encoding = {v}: use \"srgb\" or \"linear\"")),
                })
            }
            "scale" => source.scale = pair("scale", v)?,
            "remap" => source.remap = Some(pair("remap", v)?),
            "size" => {
                let [w, h] = pair("size", v)?;
                if !(w >= 1.0 && h >= 1.0 && w.fract() == 0.0 && h.fract() == 0.0) {
                    return Err(format!("size = {v} must be two whole numbers ≥ 1"));
                }
                source.size = Some([w as usize, h as usize]);
            }
            other => {
                return Err(format!("unknown texture key `{other}` (known: file, wrap, scale, remap, encoding, size)"));
            }
        }
    }
    Ok(source)
}

#[cfg(test)]
mod tests {
    use super::*;
    use fiberlab_io::LinearImage;
    use fiberlab_math::DVec3;
    use fiberlab_scatter::find_surface;

    fn lambertian() -> (&'static str, &'static [ParamSpec], SurfaceModel) {
        let spec = find_surface("lambertian").unwrap();
        (spec.name, spec.params, fiberlab_scatter::build_surface::<&str, &str>("lambertian", &[]).unwrap())
    }

    /// A model with a position (`irawan-2012`) gets `u = su·uv₀`, `v = sv·uv₁` at a hit: the
    /// material's model at uv equals the model with those values set by hand, and differs from
    /// the model at another tile position; a model without a position refuses a uv scale.
    #[test]
    fn uv_position_is_the_scaled_texture_coordinate() {
        let spec = find_surface("irawan-2012").unwrap();
        assert!(takes_uv_position(spec.params));
        let model = fiberlab_scatter::build_surface::<&str, &str>("irawan-2012", &[]).unwrap();
        let m = ModelMaterial::new(spec.name, spec.params, model.clone(), &[]).unwrap();
        assert!(m.needs_uvs() && m.uv_scale() == Some([1.0, 1.0]));
        let m = m.with_uv_scale([4.0, 6.0]).unwrap();
        let (wi, wo) = (DVec3::new(0.3, -0.2, 0.93).normalize(), DVec3::new(-0.4, 0.25, 0.88).normalize());
        let mut grid_differs = false;
        for (a, b) in [(0.01, 0.02), (0.13, 0.37), (0.71, 0.9)] {
            let mut by_hand = model.clone();
            by_hand.set_parameter("u", Rgb::splat(4.0 * a)).unwrap();
            by_hand.set_parameter("v", Rgb::splat(6.0 * b)).unwrap();
            assert_eq!(m.at(Some([a, b])).eval(wi, wo), by_hand.eval(wi, wo));
            grid_differs |= m.at(Some([a, b])).eval(wi, wo) != m.at(Some([0.05, 0.05])).eval(wi, wo);
        }
        assert!(grid_differs, "the position changes nothing");
        assert!(m.clone().with_uv_scale([f64::NAN, 1.0]).is_err() && m.with_uv_scale([0.0, 1.0]).is_err());
        let (name, params, lambert) = lambertian();
        assert!(!takes_uv_position(params));
        let plain = ModelMaterial::new(name, params, lambert, &[]).unwrap();
        assert!(!plain.needs_uvs());
        assert!(plain.with_uv_scale([2.0, 2.0]).unwrap_err().to_string().contains("no position"));
    }

    /// A 2×2 EXR of known colours: the model at each texel centre evaluates to that colour/π,
    /// and between centres to the bilinear mix.
    #[test]
    fn textured_parameter_lookup_on_a_known_texture() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("kd.exr");
        let colours = [[0.1, 0.2, 0.3], [0.9, 0.8, 0.7], [0.5, 0.0, 1.0], [0.0, 0.4, 0.6]];
        let img = LinearImage::from_pixels(2, 2, colours.iter().map(|c| c.map(|x| x as f32)).collect()).unwrap();
        img.write_exr(&path).unwrap();
        let (name, params, model) = lambertian();
        let m = ModelMaterial::new(name, params, model, &[("k_d".into(), TextureSource::file(path))]).unwrap();
        assert!(m.needs_uvs());
        let f_at = |uv: [f64; 2]| m.at(Some(uv)).eval(DVec3::Z, DVec3::Z) * std::f64::consts::PI;
        // Texel (x, y) centre: u = (x + ½)/2, v = 1 − (y + ½)/2.
        for (i, c) in colours.iter().enumerate() {
            let (x, y) = ((i % 2) as f64, (i / 2) as f64);
            let f = f_at([(x + 0.5) / 2.0, 1.0 - (y + 0.5) / 2.0]);
            for k in 0..3 {
                assert!((f[k] - c[k]).abs() < 1e-6, "texel {i}: {f:?} vs {c:?}");
            }
        }
        // The centre of the image: the mean of the four.
        let f = f_at([0.5, 0.5]);
        for k in 0..3 {
            let mean = colours.iter().map(|c| c[k]).sum::<f64>() / 4.0;
            assert!((f[k] - mean).abs() < 1e-6);
        }
        // No coordinates: the untextured default (0.8).
        assert!((m.at(None).eval(DVec3::Z, DVec3::Z)[0] * std::f64::consts::PI - 0.8).abs() < 1e-12);
    }

    #[test]
    fn texels_the_model_refuses_and_unknown_keys_are_errors_naming_them() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("kd.exr");
        let mut px = vec![[0.5f32; 3]; 6];
        px[5] = [0.5, 1.5, 0.5];
        LinearImage::from_pixels(3, 2, px).unwrap().write_exr(&path).unwrap();
        let (name, params, model) = lambertian();
        let e = ModelMaterial::new(name, params, model.clone(), &[("k_d".into(), TextureSource::file(path.clone()))])
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("k_d: texture ") && e.contains("kd.exr: pixel x = 2, y = 1: "), "{e}");
        // Remapped into range it loads.
        let remapped = TextureSource { remap: Some([0.0, 0.5]), ..TextureSource::file(path.clone()) };
        assert!(ModelMaterial::new(name, params, model.clone(), &[("k_d".into(), remapped)]).is_ok());
        let e = ModelMaterial::new(name, params, model.clone(), &[("rho".into(), TextureSource::file(path.clone()))])
            .unwrap_err()
            .to_string();
        assert!(e.contains("no parameter `rho`") && e.contains("k_d"), "{e}");
        let sized = TextureSource { size: Some([4, 4]), ..TextureSource::file(path) };
        let e = ModelMaterial::new(name, params, model, &[("k_d".into(), sized)]).unwrap_err().to_string();
        assert!(e.contains("3×2 pixels, expected 4×4"), "{e}");
    }

    #[test]
    fn texture_sources_from_scene_values() {
        let resolve = |s: &str| PathBuf::from("base").join(s);
        let v: toml::Table = r#"
            a = "x.png"
            b = 0.5
            c = "word"
            d = { file = "y.exr", wrap = "clamp", scale = [4, 1], remap = [-90, 90], size = [8, 2] }
            e = { file = "y.exr", wrap = "mirror" }
            f = { wrap = "clamp" }
        "#
        .parse()
        .unwrap();
        assert_eq!(texture_source(&v["a"], &resolve).unwrap().unwrap().path, PathBuf::from("base/x.png"));
        assert!(texture_source(&v["b"], &resolve).is_none() && texture_source(&v["c"], &resolve).is_none());
        let d = texture_source(&v["d"], &resolve).unwrap().unwrap();
        assert_eq!((d.wrap, d.scale, d.remap, d.size), (Wrap::Clamp, [4.0, 1.0], Some([-90.0, 90.0]), Some([8, 2])));
        assert!(texture_source(&v["e"], &resolve).unwrap().unwrap_err().contains("wrap"));
        assert!(texture_source(&v["f"], &resolve).unwrap().unwrap_err().contains("file"));
    }
}
