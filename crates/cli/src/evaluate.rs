//! `fiberlab evaluate`: the same scene, camera, lights and sample budget rendered with each
//! model, every model given the scene's hair, compared with a reference — a photograph, or a
//! high-sample render with the measured scattering function from explicit geometry — with the
//! residual Monte Carlo noise of every render stated beside each metric, and assembled into a
//! labelled grid. The evaluation is `fiberlab_compare::evaluation`; this verb parses, prints
//! and writes the images, the grid and `metrics.json`.

use crate::arg_values::{self, KeyValue, NamedRect};
use crate::compare::{Image, load};
use anyhow::Context;
use fiberlab_compare::evaluation::{EvaluationRequest, KajiyaKayColour, Progress, evaluate, rgb_short};
use fiberlab_io::{LinearImage, ToneMap};
use fiberlab_render::integrator::Region;
use fiberlab_render::scene_file::SceneFile;
use fiberlab_scatter::params::RawValue;
use std::path::{Path, PathBuf};

/// The long help of `fiberlab evaluate`: how each model gets the scene's hair, and how the
/// noise beside each metric is estimated.
pub const EVALUATE_HELP: &str = "\
One absorption for every model (docs/theory/hair.md, \"One absorption for every hair model\"):
the scene's hair material (the first hair's) defines σ_a per unit fiber radius: chiang/deon
its sigma_a, its melanin through d'Eon 2011's pigment table, or its color through Chiang 2016's
inversion at its own beta_n; marschner its sigma_a (doubled if it uses absorption=paper). Every
model gets that σ_a in its own parametrization, chosen so that light crossing the fiber once
at normal incidence (TT at h = 0) is attenuated by the same exp(−σ_a·2 radii):
  chiang, deon  sigma_a = σ_a (already resolved: a colour's inversion depends on beta_n)
  marschner     sigma_a = σ_a with absorption=chord (default); σ_a/2 with absorption=paper,
                whose printed path is 4 radii at normal incidence
  kajiya-kay    no absorption: k_d, k_s and p are fitted to the scene's hair model's luminance
                under an energy bound (its furnace W(θ_o) = ∫ f_s cosθ_i dω_i at most the hair
                model's and at most 1, per channel, at every θ_o checked), coloured by what the
                hair scatters toward the viewer's side, then (--kajiya-kay-colour scene, the
                default) scaled per channel until its hair is as bright as the hair model's
                rendered in the same scene, within the bound
  measured      the table's fiber has its own absorption: measure it with the scene's σ_a
                (fiberlab measure --param sigma_a=r,g,b)
A model named like the scene's hair model, without --param, is the scene's model itself;
--param MODEL:sigma_a=… (or eumelanin/pheomelanin/color) replaces the scene's absorption for
that model; other parameters are each model's defaults unless given.

Noise: every render is the mean of two halves of its samples with different seeds, and its
noise is RMSE(half 1, half 2)/2; the reference's seeds differ from the models'. Beside each
metric: its noise floor (what noise alone gives: RMSE sqrt(noise_model² + noise_reference²),
relMSE the same per pixel) and the excess RMSE sqrt(rmse² − floor²), the part the model, not
the noise, explains.";

/// Flags of `fiberlab evaluate`.
#[derive(clap::Args)]
#[command(after_long_help = EVALUATE_HELP)]
pub struct Args {
    /// Scene file (default: the built-in scene); its hair material defines the hair every
    /// model gets (absorption) and the model Kajiya–Kay is fitted to.
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
    /// Samples per pixel of each model's render (default: the scene's), in two halves with
    /// different seeds for the noise estimate.
    #[arg(long)]
    spp: Option<u32>,
    /// Samples per pixel of the reference render (two halves, like the models').
    #[arg(long, default_value_t = 256)]
    reference_spp: u32,
    /// How the fitted Kajiya–Kay gets its colour: `scene` (default: per channel, as bright as
    /// the scene's hair model rendered in the scene, multiple scattering included, within the
    /// energy bound; a few renders at a quarter of --spp) or `fiber` (the colour one fiber
    /// scatters toward the viewer's side).
    #[arg(long, default_value = "scene", value_parser = KajiyaKayColour::parse)]
    kajiya_kay_colour: KajiyaKayColour,
    /// Output directory (renders, grid.png, metrics.json).
    #[arg(long, default_value = "evaluation")]
    out: PathBuf,
    #[command(flatten)]
    pub(crate) memory: crate::memory_budget::MemoryLimit,
    /// A named region to crop from every image, NAME=X0,Y0,X1,Y1 in pixels (repeatable), e.g.
    /// the second highlight, glints, back-lit transmission: writes crop_NAME.png (all models,
    /// magnified).
    #[arg(long = "crop", value_name = "NAME=X0,Y0,X1,Y1", value_parser = arg_values::named_rect)]
    crops: Vec<NamedRect>,
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
    let names: Vec<&str> = args.models.split(',').map(str::trim).filter(|n| !n.is_empty()).collect();
    let user = |name: &str| -> Vec<(String, RawValue)> {
        args.params
            .iter()
            .filter(|p| p.model.as_deref() == Some(name))
            .map(|p| (p.key.clone(), RawValue::Text(p.value.clone())))
            .collect()
    };
    let request = EvaluationRequest {
        models: names.iter().map(|n| ((*n).to_string(), user(n))).collect(),
        table: args.table.clone(),
        reference_image: args.reference.as_deref().map(load).transpose()?,
        spp: args.spp,
        reference_spp: args.reference_spp,
        kajiya_kay_colour: args.kajiya_kay_colour,
    };
    // Every model is built (and Kajiya–Kay fitted) before anything is rendered or written.
    fiberlab_compare::evaluation::entries(&scene, &request)?;
    std::fs::create_dir_all(&args.out).with_context(|| format!("creating {}", args.out.display()))?;
    let mut written = Ok(());
    let (reference, results) = evaluate(&mut scene, &settings, &request, |event| match event {
        Progress::SceneHair(Some(s)) => {
            println!("scene hair: sigma_a {} per radius (TT at normal incidence: exp(−2σ_a))", rgb_short(s));
        }
        Progress::SceneHair(None) => println!("scene hair: no absorption evaluate can read; models keep their own"),
        Progress::Reference(r) => {
            println!("reference      noise {:.5}", r.noise());
            if args.reference.is_none() && written.is_ok() {
                written = write(&r.linear_image(), &args.out, "reference");
            }
        }
        Progress::Calibrating(entry) => println!("{:<14} matching its colour in the scene", entry.name),
        Progress::Rendering(entry) => println!("{:<14} {}", entry.name, entry.given),
        Progress::Model(r) => {
            let (m, floor, c) = (&r.metrics, &r.floor, r.hair_colour);
            println!(
                "{:<14} rmse {:.5} (noise {:.5}, excess {:.5} = {:.1}× noise)  relmse {:.5} (noise {:.5})  ssim {:.4}  \
                 flip {:.4}  image noise {:.5}  hair R/G/B over reference {:.3}/{:.3}/{:.3}",
                r.entry.name,
                m.rmse,
                floor.rmse,
                r.excess_rmse(),
                r.excess_over_floor(),
                m.relmse,
                floor.relmse,
                m.ssim,
                m.flip,
                r.render.noise(),
                c[0],
                c[1],
                c[2]
            );
            if written.is_ok() {
                written = write(&r.render.linear_image(), &args.out, &r.entry.name);
            }
        }
    })?;
    written?;
    let rows = results.iter().map(|r| serde_json::to_value(r.row(reference.noise()))).collect::<Result<Vec<_>, _>>()?;
    crate::files::write_atomically(&args.out.join("metrics.json"), serde_json::to_string_pretty(&rows)?.as_bytes())?;
    let mut tiles = vec![Tile {
        name: "reference".into(),
        image: reference.mean.clone(),
        lines: vec![format!("noise {:.4}", reference.noise())],
    }];
    tiles.extend(results.iter().map(|r| Tile {
        name: r.entry.name.clone(),
        image: r.render.mean.clone(),
        lines: vec![
            format!("rmse {:.4} ±{:.4}", r.metrics.rmse, r.floor.rmse),
            format!("excess {:.4} = {:.1}× noise", r.excess_rmse(), r.excess_over_floor()),
            format!("relmse {:.3} ±{:.3}", r.metrics.relmse, r.floor.relmse),
            format!("ssim {:.3} flip {:.3}", r.metrics.ssim, r.metrics.flip),
            format!("hair R/G/B {:.2}/{:.2}/{:.2}", r.hair_colour[0], r.hair_colour[1], r.hair_colour[2]),
        ],
    }));
    let scale = 224u32.div_ceil(tiles[0].image.width as u32).max(1);
    grid(&tiles, &args.out.join("grid.png"), scale)?;
    for (name, r) in &crops {
        let [x0, y0, x1, y1] = [r.x0, r.y0, r.x1, r.y1].map(|v| v as usize);
        let cropped: Vec<Tile> = tiles
            .iter()
            .map(|t| {
                let (w, h) = (x1 - x0, y1 - y0);
                let pixels = (0..w * h).map(|k| t.image.pixels[(y0 + k / w) * t.image.width + x0 + k % w]).collect();
                Tile { name: t.name.clone(), image: Image { width: w, height: h, pixels }, lines: Vec::new() }
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

/// One image of a grid: its label above, text lines (metrics) below.
struct Tile {
    name: String,
    image: Image,
    lines: Vec<String>,
}

/// The images side by side, each labelled with its model and its metrics, magnified
/// `scale`× (nearest pixel).
fn grid(tiles: &[Tile], path: &Path, scale: u32) -> anyhow::Result<()> {
    use plotters::prelude::*;
    let (iw, ih) = (tiles[0].image.width as u32, tiles[0].image.height as u32);
    let (w, h) = (iw * scale, ih * scale);
    let label = 28u32;
    let line = 17u32;
    let text_rows = tiles.iter().map(|t| t.lines.len() as u32).max().unwrap_or(0);
    let footer = if text_rows > 0 { text_rows * line + 8 } else { 0 };
    let size = (w * tiles.len() as u32, h + label + footer);
    crate::plot::draw_png_over(path, size, vec![255u8; (size.0 * size.1 * 3) as usize], |root| {
        let err = |e: DrawingAreaErrorKind<_>| anyhow::anyhow!("drawing: {e:?}");
        let small = ("sans-serif", 14).into_text_style(&root);
        for (k, tile) in tiles.iter().enumerate() {
            let img = &tile.image;
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
            root.draw_text(&tile.name, &("sans-serif", 20).into_text_style(&root), ((x0 + 8) as i32, 4))
                .map_err(err)?;
            for (j, text) in tile.lines.iter().enumerate() {
                let y = label + h + 4 + j as u32 * line;
                root.draw_text(text, &small, ((x0 + 6) as i32, y as i32)).map_err(err)?;
            }
        }
        root.present().map_err(err)?;
        Ok(())
    })
}
