//! `fiberlab evaluate`: the same scene, camera, lights and sample budget rendered with each
//! model (Kajiya–Kay fitted to the scene's physically based hair model), compared with a
//! reference — a photograph, or a high-sample render with the measured scattering function
//! from explicit geometry — and assembled into a labelled grid.

use crate::compare::{Image, compare, load};
use anyhow::{Context, bail};
use fiberlab_io::{LinearImage, ToneMap};
use fiberlab_math::Rgb;
use fiberlab_render::integrator::{RenderSettings, render};
use fiberlab_render::scene::{Material, Scene};
use fiberlab_render::scene_file::SceneFile;
use fiberlab_scatter::Model;
use fiberlab_scatter::kajiya_kay_1989::{KajiyaKay, KajiyaKayParams};
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

/// Flags of `fiberlab evaluate`.
#[derive(clap::Args)]
pub struct Args {
    /// Scene file (default: the built-in scene); its hair material is the physically based
    /// model Kajiya–Kay is fitted to.
    #[arg(long)]
    scene: Option<PathBuf>,
    /// Comma-separated models to render: any registered name, `measured` (needs --table).
    #[arg(long, default_value = "kajiya-kay,marschner,chiang")]
    models: String,
    /// Parameter of one model as MODEL:KEY=VALUE (repeatable).
    #[arg(long = "param", value_name = "MODEL:KEY=VALUE")]
    params: Vec<String>,
    /// Measured table (from `fiberlab measure`) for `measured` and the default reference.
    #[arg(long)]
    table: Option<PathBuf>,
    /// A reference image (e.g. a photograph) instead of the measured reference render.
    #[arg(long)]
    reference: Option<PathBuf>,
    /// Samples per pixel of each model's render (default: the scene's).
    #[arg(long)]
    spp: Option<u32>,
    /// Samples per pixel of the reference render.
    #[arg(long, default_value_t = 256)]
    reference_spp: u32,
    /// Output directory (renders, grid.png, metrics.json).
    #[arg(long, default_value = "evaluation")]
    out: PathBuf,
    /// A named region to crop from every image, NAME=X0,Y0,X1,Y1 in pixels (repeatable), e.g.
    /// the second highlight, glints, back-lit transmission: writes crop_NAME.png (all models,
    /// magnified).
    #[arg(long = "crop", value_name = "NAME=X0,Y0,X1,Y1")]
    crops: Vec<String>,
}

/// A parsed `--crop`.
#[derive(Debug)]
struct Crop {
    name: String,
    x0: usize,
    y0: usize,
    x1: usize,
    y1: usize,
}

fn parse_crop(text: &str, width: u32, height: u32) -> anyhow::Result<Crop> {
    let (name, rect) = text.split_once('=').with_context(|| format!("--crop {text}: expected NAME=X0,Y0,X1,Y1"))?;
    if name.is_empty() {
        bail!("--crop {text}: expected a non-empty name before '='");
    }
    let r = crate::render::parse_crop(rect, width, height).with_context(|| format!("--crop {text}"))?;
    let [x0, y0, x1, y1] = [r.x0, r.y0, r.x1, r.y1].map(|v| v as usize);
    Ok(Crop { name: name.to_string(), x0, y0, x1, y1 })
}

/// Replaces every hair material of `scene` by `model`.
fn set_hair_model(scene: &mut Scene, model: &Model) {
    let indices: Vec<usize> = scene.fibers.iter().map(|f| f.material).collect();
    for i in indices {
        scene.materials[i] = Material::Fiber(Box::new(model.clone()));
    }
}

/// The scene's own hair model (first fiber material).
fn scene_hair_model(scene: &Scene) -> Option<Model> {
    scene.fibers.first().and_then(|f| match &scene.materials[f.material] {
        Material::Fiber(m) => Some((**m).clone()),
        _ => None,
    })
}

fn build_model(name: &str, args: &Args, target: &Model) -> anyhow::Result<Model> {
    let mut pairs = Vec::new();
    for p in &args.params {
        let (m, kv) = p.split_once(':').with_context(|| format!("--param {p}: expected MODEL:KEY=VALUE"))?;
        if m == name {
            pairs.push(fiberlab_scatter::params::split_key_value(kv)?);
        }
    }
    match name {
        "measured" => {
            let t = args.table.as_ref().context("model `measured` needs --table")?;
            Ok(fiberlab_render::measured_table::load_measured(t).map_err(anyhow::Error::msg)?.into())
        }
        "kajiya-kay" if pairs.is_empty() => {
            // Fitted to the scene's physically based model (models.md §3).
            let data = crate::fit::from_model(target);
            let free = [("k_d".to_string(), 0.02), ("k_s".to_string(), 0.1), ("p".to_string(), 10.0)];
            let spec = &fiberlab_scatter::kajiya_kay_1989::SPEC;
            let base = fiberlab_scatter::params::ParamSet::parse::<&str, &str>(spec.name, spec.params, &[])?;
            let r = fiberlab_fit::fit(&base, &free, &data, 400)?;
            let value = |key: &str| r.params.iter().find(|(k, _)| k == key).map_or(0.0, |(_, v)| *v);
            // The fit is in luminance; colour k_d and k_s by the target's mean colour.
            let tint = mean_colour(target);
            let fitted = KajiyaKayParams {
                k_d: Rgb::new(tint[0], tint[1], tint[2]) * value("k_d"),
                k_s: Rgb::new(tint[0], tint[1], tint[2]) * value("k_s"),
                p: value("p"),
            };
            let fitted = KajiyaKayParams {
                k_d: fitted.k_d.map(|c| c.min(10.0)),
                k_s: fitted.k_s.map(|c| c.min(10.0)),
                ..fitted
            };
            eprintln!("kajiya-kay fitted to the scene's hair model: {fitted:?}");
            Ok(KajiyaKay::new(fitted)?.into())
        }
        _ => Ok(fiberlab_scatter::build(name, &pairs)?),
    }
}

/// Mean colour of `f_s` over directions, divided by its luminance (a tint with luminance 1).
fn mean_colour(model: &Model) -> [f64; 3] {
    use fiberlab_scatter::ScatteringFunction;
    let mut sum = fiberlab_math::Rgb::ZERO;
    for i in 0..12 {
        for j in 0..24 {
            let wi = fiberlab_math::frame::direction(-1.2 + 0.2 * i as f64, 0.0);
            let wo = fiberlab_math::frame::direction(1.1 - 0.1 * j as f64, 0.27 * j as f64);
            sum +=
                (0..4).map(|k| model.eval(wi, wo, -0.75 + 0.5 * k as f64)).fold(fiberlab_math::Rgb::ZERO, |a, b| a + b);
        }
    }
    let l = sum.luminance().max(1e-300);
    [sum[0] / l, sum[1] / l, sum[2] / l]
}

fn to_image(l: &LinearImage) -> Image {
    Image {
        width: l.width(),
        height: l.height(),
        pixels: l.pixels().iter().map(|p| [f64::from(p[0]), f64::from(p[1]), f64::from(p[2])]).collect(),
    }
}

fn render_with(scene: &Scene, settings: &RenderSettings, spp: u32) -> LinearImage {
    let s = RenderSettings { spp, ..settings.clone() };
    render(scene, &s, &|_, _| {}, &AtomicBool::new(false)).image
}

/// Runs the evaluation.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let file = match &args.scene {
        Some(p) => SceneFile::read(p)?,
        None => SceneFile::default_scene(),
    };
    let (mut scene, settings) = file.build()?;
    let target = scene_hair_model(&scene).context("the scene has no hair with a fiber model")?;
    let spp = args.spp.unwrap_or(settings.spp);
    let crops: Vec<Crop> = args
        .crops
        .iter()
        .map(|c| parse_crop(c, scene.camera.width, scene.camera.height))
        .collect::<anyhow::Result<_>>()?;
    std::fs::create_dir_all(&args.out).with_context(|| format!("creating {}", args.out.display()))?;
    let reference = match (&args.reference, &args.table) {
        (Some(p), _) => load(p)?,
        (None, Some(_)) => {
            set_hair_model(&mut scene, &build_model("measured", args, &target)?);
            let img = render_with(&scene, &settings, args.reference_spp);
            write(&img, &args.out, "reference")?;
            to_image(&img)
        }
        (None, None) => bail!("give --table (measured reference render) or --reference IMAGE"),
    };
    let mut rows = Vec::new();
    let mut tiles = vec![("reference".to_string(), reference.clone())];
    for name in args.models.split(',').map(str::trim).filter(|n| !n.is_empty()) {
        let model = build_model(name, args, &target)?;
        set_hair_model(&mut scene, &model);
        let img = render_with(&scene, &settings, spp);
        write(&img, &args.out, name)?;
        let img = to_image(&img);
        let (m, _) = compare(&reference, &img, None, false)?;
        println!("{name:<14} rmse {:.5}  relmse {:.5}  ssim {:.4}  flip {:.4}", m.rmse, m.relmse, m.ssim, m.flip);
        rows.push(
            serde_json::json!({ "model": name, "rmse": m.rmse, "relmse": m.relmse, "ssim": m.ssim, "flip": m.flip }),
        );
        tiles.push((name.to_string(), img));
    }
    crate::files::write_atomically(&args.out.join("metrics.json"), serde_json::to_string_pretty(&rows)?.as_bytes())?;
    grid(&tiles, &args.out.join("grid.png"), 1)?;
    for c in &crops {
        let cropped: Vec<(String, Image)> = tiles
            .iter()
            .map(|(name, img)| {
                let (w, h) = (c.x1 - c.x0, c.y1 - c.y0);
                let pixels = (0..w * h).map(|k| img.pixels[(c.y0 + k / w) * img.width + c.x0 + k % w]).collect();
                (name.clone(), Image { width: w, height: h, pixels })
            })
            .collect();
        let scale = (256 / (c.x1 - c.x0).max(c.y1 - c.y0)).max(1) as u32;
        grid(&cropped, &args.out.join(format!("crop_{}.png", c.name)), scale)?;
    }
    println!("wrote {}", args.out.display());
    Ok(())
}

fn write(img: &LinearImage, dir: &Path, name: &str) -> anyhow::Result<()> {
    img.write_exr(&dir.join(format!("{name}.exr")))?;
    img.write_png(&dir.join(format!("{name}.png")), 0.0, ToneMap::Filmic)?;
    Ok(())
}

/// The images side by side, each labelled with its model, magnified `scale`× (nearest pixel).
fn grid(tiles: &[(String, Image)], path: &Path, scale: u32) -> anyhow::Result<()> {
    use plotters::prelude::*;
    let (iw, ih) = (tiles[0].1.width as u32, tiles[0].1.height as u32);
    let (w, h) = (iw * scale, ih * scale);
    let label = 28u32;
    let size = (w * tiles.len() as u32, h + label);
    let mut buf = vec![255u8; (size.0 * size.1 * 3) as usize];
    {
        crate::plot::register_font();
        let root = BitMapBackend::with_buffer(&mut buf, size).into_drawing_area();
        let err = |e: DrawingAreaErrorKind<_>| anyhow::anyhow!("drawing: {e:?}");
        for (k, (name, img)) in tiles.iter().enumerate() {
            let x0 = k as u32 * w;
            let lin = LinearImage::from_pixels(
                img.width,
                img.height,
                img.pixels.iter().map(|p| [p[0] as f32, p[1] as f32, p[2] as f32]).collect(),
            )?;
            let rgb = lin.to_srgb8(0.0, ToneMap::Filmic);
            for y in 0..h {
                for x in 0..w {
                    let i = (((y / scale) * iw + x / scale) * 3) as usize;
                    root.draw_pixel(((x0 + x) as i32, (label + y) as i32), &RGBColor(rgb[i], rgb[i + 1], rgb[i + 2]))
                        .map_err(err)?;
                }
            }
            root.draw_text(name, &("sans-serif", 20).into_text_style(&root), ((x0 + 8) as i32, 4)).map_err(err)?;
        }
        root.present().map_err(err)?;
    }
    crate::plot::write_png(path, &buf, size)
}

#[cfg(test)]
mod crop_tests {
    use super::parse_crop;

    #[test]
    fn crops_parse_and_bad_ones_say_what_was_expected() {
        let c = parse_crop("glint=2,3,10,12", 16, 16).unwrap();
        assert_eq!((c.name.as_str(), c.x0, c.y0, c.x1, c.y1), ("glint", 2, 3, 10, 12));
        for (bad, expected) in [
            ("2,3,10,12", "NAME=X0,Y0,X1,Y1"),
            ("=2,3,10,12", "non-empty name"),
            ("a=2,3,10", "four integers"),
            ("a=2,x,10,12", "four integers"),
            ("a=10,3,2,12", "x0 < x1 ≤ 16"),
            ("a=2,3,10,17", "y1 ≤ 16"),
        ] {
            let err = format!("{:#}", parse_crop(bad, 16, 16).unwrap_err());
            assert!(err.contains(expected), "{bad}: {err}");
        }
    }
}
