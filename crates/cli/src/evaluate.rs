//! `fiberlab evaluate`: the same scene, camera, lights and sample budget rendered with each
//! model (Kajiya–Kay fitted to the scene's physically based hair model), compared with a
//! reference — a photograph, or a high-sample render with the measured scattering function
//! from explicit geometry — and assembled into a labelled grid.

use crate::arg_values::{self, KeyValue, NamedRect};
use crate::compare::{Image, compare, load};
use anyhow::{Context, bail};
use fiberlab_io::{LinearImage, ToneMap};
use fiberlab_math::Rgb;
use fiberlab_render::integrator::{Region, RenderSettings, render};
use fiberlab_render::model_loader::load_model;
use fiberlab_render::scene::Scene;
use fiberlab_render::scene_file::SceneFile;
use fiberlab_scatter::kajiya_kay_1989::{KajiyaKay, KajiyaKayParams};
use fiberlab_scatter::measured::Measured;
use fiberlab_scatter::params::{ParamSet, RawValue};
use fiberlab_scatter::{ExternalData, Model, Registered};
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

/// Flags of `fiberlab evaluate`.
#[derive(clap::Args)]
pub struct Args {
    /// Scene file (default: the built-in scene); its hair material is the physically based
    /// model Kajiya–Kay is fitted to.
    #[arg(long)]
    scene: Option<PathBuf>,
    /// Comma-separated models to render: any registered name (one built from a table, as
    /// `measured`, takes --table).
    #[arg(long, default_value = "kajiya-kay,marschner,chiang")]
    models: String,
    /// Parameter of one model as MODEL:KEY=VALUE (repeatable).
    #[arg(long = "param", value_name = "MODEL:KEY=VALUE", value_parser = arg_values::model_key_value)]
    params: Vec<KeyValue>,
    /// Measured table (from `fiberlab measure`) for models built from a table and for the
    /// default reference (the `measured` model).
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
    #[command(flatten)]
    memory: crate::memory_budget::MemoryLimit,
    /// A named region to crop from every image, NAME=X0,Y0,X1,Y1 in pixels (repeatable), e.g.
    /// the second highlight, glints, back-lit transmission: writes crop_NAME.png (all models,
    /// magnified).
    #[arg(long = "crop", value_name = "NAME=X0,Y0,X1,Y1", value_parser = arg_values::named_rect)]
    crops: Vec<NamedRect>,
}

/// Replaces every hair material of `scene` by `model`.
fn set_hair_model(scene: &mut Scene, model: &Model) {
    scene.fiber_models_mut().for_each(|m| *m = model.clone());
}

/// The scene's own hair model (the first fibers' material).
fn scene_hair_model(scene: &Scene) -> Option<Model> {
    scene.fibers().first().map(|f| scene.fiber_model(f.material()).clone())
}

/// Model `name` with its `--param MODEL:KEY=VALUE` values, through the one model loader; a
/// model built from a table gets `--table` unless its parameters name one. Kajiya–Kay without
/// parameters is fitted to the scene's model (`target`).
fn build_model(name: &str, args: &Args, target: &Model) -> anyhow::Result<Model> {
    let mut pairs: Vec<(String, RawValue)> = args
        .params
        .iter()
        .filter(|p| p.model.as_deref() == Some(name))
        .map(|p| (p.key.clone(), RawValue::Text(p.value.clone())))
        .collect();
    let spec = fiberlab_scatter::find(name)?;
    if let Some(ExternalData::Table { key }) = spec.data
        && !pairs.iter().any(|(k, _)| k == key)
    {
        let table = args.table.as_ref().with_context(|| format!("model `{name}` needs --table"))?;
        pairs.push((key.to_string(), RawValue::Text(table.to_string_lossy().into_owned())));
    }
    if spec.name == KajiyaKay::INFO.name && pairs.is_empty() {
        return fitted_kajiya_kay(target);
    }
    load_model(spec.name, &pairs, Path::new("")).with_context(|| format!("model `{name}`"))
}

/// Kajiya–Kay fitted to `target` (in luminance, then coloured by the target's mean colour).
fn fitted_kajiya_kay(target: &Model) -> anyhow::Result<Model> {
    let data = crate::fit::from_model(target);
    let free = [("k_d".to_string(), 0.02), ("k_s".to_string(), 0.1), ("p".to_string(), 10.0)];
    let info = KajiyaKay::INFO;
    let base = ParamSet::parse::<&str, &str>(info.name, info.params, &[])?;
    let r = fiberlab_fit::fit(&base, &free, &data, 400)?;
    let value = |key: &str| r.params.iter().find(|(k, _)| k == key).map_or(0.0, |(_, v)| *v);
    let tint = mean_colour(target);
    let fitted = KajiyaKayParams {
        k_d: Rgb::new(tint[0], tint[1], tint[2]) * value("k_d"),
        k_s: Rgb::new(tint[0], tint[1], tint[2]) * value("k_s"),
        p: value("p"),
    };
    let fitted =
        KajiyaKayParams { k_d: fitted.k_d.map(|c| c.min(10.0)), k_s: fitted.k_s.map(|c| c.min(10.0)), ..fitted };
    eprintln!("kajiya-kay fitted to the scene's hair model: {fitted:?}");
    Ok(KajiyaKay::new(fitted)?.into())
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
    render(scene, &s, &|_| {}, &AtomicBool::new(false)).image
}

/// Runs the evaluation.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let file = match &args.scene {
        Some(p) => SceneFile::read(p)?,
        None => SceneFile::default_scene(),
    };
    // Crops are checked against the camera as written, before the scene is built.
    let (width, height) = file.image_size();
    let crops: Vec<(&str, Region)> = args
        .crops
        .iter()
        .map(|c| c.rect.within(width, height).map(|r| (c.name.as_str(), r)))
        .collect::<Result<_, String>>()
        .map_err(|e| anyhow::anyhow!("--crop {e}"))?;
    crate::files::check_output_dir(&args.out)?;
    args.memory.check_evaluate(&file, &args.models)?;
    let (mut scene, settings) = file.build()?;
    let target = scene_hair_model(&scene).context("the scene has no hair with a fiber model")?;
    let spp = args.spp.unwrap_or(settings.spp);
    std::fs::create_dir_all(&args.out).with_context(|| format!("creating {}", args.out.display()))?;
    let reference = match (&args.reference, &args.table) {
        (Some(p), _) => load(p)?,
        (None, Some(_)) => {
            set_hair_model(&mut scene, &build_model(Measured::INFO.name, args, &target)?);
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
    for (name, r) in &crops {
        let [x0, y0, x1, y1] = [r.x0, r.y0, r.x1, r.y1].map(|v| v as usize);
        let cropped: Vec<(String, Image)> = tiles
            .iter()
            .map(|(model, img)| {
                let (w, h) = (x1 - x0, y1 - y0);
                let pixels = (0..w * h).map(|k| img.pixels[(y0 + k / w) * img.width + x0 + k % w]).collect();
                (model.clone(), Image { width: w, height: h, pixels })
            })
            .collect();
        let scale = (256 / (x1 - x0).max(y1 - y0)).max(1) as u32;
        grid(&cropped, &args.out.join(format!("crop_{name}.png")), scale)?;
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
