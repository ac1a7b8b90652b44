//! `fiberlab evaluate`: the same scene, camera, lights and sample budget rendered with each
//! model, every model given the scene's hair (one absorption, mapped between the models'
//! parametrizations; Kajiya–Kay fitted to the scene's hair model under an energy bound),
//! compared with a reference — a photograph, or a high-sample render with the measured
//! scattering function from explicit geometry — with the residual Monte Carlo noise of every
//! render stated beside each metric, and assembled into a labelled grid.
//!
//! The mapping and the noise estimate are documented in [`EVALUATE_HELP`] (`--help`) and in
//! `docs/theory/hair.md`, "One absorption for every hair model".

use crate::arg_values::{self, KeyValue, NamedRect};
use crate::compare::{Image, compare, load};
use anyhow::{Context, bail};
use fiberlab_fit::Observation;
use fiberlab_io::{LinearImage, ToneMap};
use fiberlab_math::frame::direction;
use fiberlab_math::{DVec3, Rgb};
use fiberlab_render::integrator::{Region, RenderSettings, render};
use fiberlab_render::model_loader::load_model;
use fiberlab_render::scene::Scene;
use fiberlab_render::scene_file::SceneFile;
use fiberlab_scatter::hair::attenuation::PathLength;
use fiberlab_scatter::kajiya_kay_1989::{KajiyaKay, KajiyaKayParams};
use fiberlab_scatter::measured::Measured;
use fiberlab_scatter::params::{ParamSet, RawValue};
use fiberlab_scatter::{ExternalData, Model, Registered, ScatteringFunction};
use std::f64::consts::{FRAC_PI_2, PI, TAU};
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

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
  kajiya-kay    no absorption: k_d, k_s (per channel) and p are fitted to the scene's hair
                model under an energy bound: its furnace W(θ_o) = ∫ f_s cosθ_i dω_i at most
                the hair model's and at most 1, per channel, at every θ_o checked
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

/// The keys by which a hair model takes its absorption.
const ABSORPTION_KEYS: [&str; 4] = ["sigma_a", "eumelanin", "pheomelanin", "color"];

/// The scene's hair, as every model is given it.
struct SceneHair {
    /// The scene's own hair model (the first hair's material).
    model: Model,
    /// Its registry name, when it is one evaluate knows how to read.
    name: Option<&'static str>,
    /// Its absorption per unit radius, in the chord convention (one internal crossing at
    /// normal incidence is 2 radii): `None` for a model without one evaluate can read.
    sigma_a: Option<Rgb>,
}

impl SceneHair {
    fn of(model: Model) -> Self {
        let (name, sigma_a) = match &model {
            Model::Chiang(m) => (Some(fiberlab_scatter::chiang_2016::Chiang::INFO.name), Some(m.sigma_a())),
            Model::Deon(m) => (Some(fiberlab_scatter::deon_2011::Deon::INFO.name), Some(m.sigma_a())),
            Model::Marschner(m) => (
                Some(fiberlab_scatter::marschner_2003::Marschner::INFO.name),
                Some(m.params().sigma_a * chord_equivalent(m.params().absorption)),
            ),
            Model::KajiyaKay(_) => (Some(KajiyaKay::INFO.name), None),
            Model::Measured(_) => (Some(Measured::INFO.name), None),
            _ => (None, None),
        };
        Self { model, name, sigma_a }
    }
}

/// Factor turning a σ_a used with `path` into the chord-convention σ_a with the same
/// attenuation at normal incidence: the chord is 2 radii there, the printed path 4.
fn chord_equivalent(path: PathLength) -> f64 {
    path.length(1.0, 1.0) / PathLength::Chord.length(1.0, 1.0)
}

/// Replaces every hair material of `scene` by `model`.
fn set_hair_model(scene: &mut Scene, model: &Model) {
    scene.fiber_models_mut().for_each(|m| *m = model.clone());
}

/// The scene's own hair model (the first fibers' material).
fn scene_hair_model(scene: &Scene) -> Option<Model> {
    scene.fibers().first().map(|f| scene.fiber_model(f.material()).clone())
}

/// `r,g,b` as text that parses back to the same numbers (shortest round-trip decimals).
fn rgb_text(c: Rgb) -> RawValue {
    RawValue::Text(format!("{},{},{}", c[0], c[1], c[2]))
}

/// A model as evaluate renders it, with what it was given.
struct Entry {
    model: Model,
    /// How it got the scene's hair (printed and written to metrics.json).
    given: String,
}

/// Model `name` with its `--param MODEL:KEY=VALUE` values (`user`), through the one model
/// loader, given the scene's hair: a model built from a table gets `table` unless its
/// parameters name one; Kajiya–Kay without parameters is fitted to the scene's model; a model
/// named like the scene's, without parameters, is the scene's model; any other model that
/// takes `sigma_a` gets the scene's absorption mapped to its convention (unless `user` gives
/// an absorption).
fn build_model(
    name: &str,
    user: &[(String, RawValue)],
    table: Option<&Path>,
    hair: &SceneHair,
) -> anyhow::Result<Entry> {
    let mut pairs = user.to_vec();
    let spec = fiberlab_scatter::find(name)?;
    if let Some(ExternalData::Table { key }) = spec.data
        && !pairs.iter().any(|(k, _)| k == key)
    {
        let table = table.with_context(|| format!("model `{name}` needs --table"))?;
        pairs.push((key.to_string(), RawValue::Text(table.to_string_lossy().into_owned())));
    }
    let load = |pairs: &[(String, RawValue)]| {
        load_model(spec.name, pairs, Path::new("")).with_context(|| format!("model `{name}`"))
    };
    if spec.name == KajiyaKay::INFO.name && pairs.is_empty() {
        let fitted = fitted_kajiya_kay(&hair.model)?;
        let given = format!(
            "fitted to the scene's hair, furnace ≤ the hair's and ≤ 1: k_d {}, k_s {}, p {:.4}",
            rgb_short(fitted.k_d),
            rgb_short(fitted.k_s),
            fitted.p
        );
        return Ok(Entry { model: KajiyaKay::new(fitted)?.into(), given });
    }
    if Some(spec.name) == hair.name && pairs.is_empty() {
        return Ok(Entry { model: hair.model.clone(), given: "the scene's hair model itself".into() });
    }
    let takes_sigma_a = spec.params.iter().any(|p| p.key == "sigma_a");
    let user_absorption = pairs.iter().any(|(k, _)| ABSORPTION_KEYS.contains(&k.as_str()));
    match hair.sigma_a {
        Some(sigma) if takes_sigma_a && !user_absorption => {
            pairs.push(("sigma_a".into(), rgb_text(sigma)));
            let mut model = load(&pairs)?;
            let mapped = mapped_sigma_a(&model, sigma);
            if mapped != sigma {
                pairs.pop();
                pairs.push(("sigma_a".into(), rgb_text(mapped)));
                model = load(&pairs)?;
            }
            Ok(Entry { model, given: format!("the scene's absorption: sigma_a {} per radius", rgb_short(mapped)) })
        }
        _ if takes_sigma_a && user_absorption => {
            Ok(Entry { model: load(&pairs)?, given: "its own absorption (--param)".into() })
        }
        _ if takes_sigma_a => Ok(Entry {
            model: load(&pairs)?,
            given: "its default absorption (the scene's hair has none evaluate can read)".into(),
        }),
        _ if spec.data.is_some() => {
            Ok(Entry { model: load(&pairs)?, given: "the table's own fiber (measure it with the scene's σ_a)".into() })
        }
        _ => Ok(Entry { model: load(&pairs)?, given: "no absorption parameter".into() }),
    }
}

/// The `sigma_a` value that gives `model` the chord-convention absorption `sigma` (the same
/// single-crossing attenuation at normal incidence): σ/2 for Marschner's printed path, σ
/// for every model that uses the chord.
fn mapped_sigma_a(model: &Model, sigma: Rgb) -> Rgb {
    match model {
        Model::Marschner(m) => sigma / chord_equivalent(m.params().absorption),
        _ => sigma,
    }
}

fn rgb_short(c: Rgb) -> String {
    format!("{:.4},{:.4},{:.4}", c[0], c[1], c[2])
}

/// Observations of one quantity of the target on the fitting grid, σ = mean/weight.
fn observations(grid: &[(DVec3, DVec3, f64)], values: &[f64]) -> Vec<Observation> {
    let mean = (values.iter().sum::<f64>() / values.len() as f64).max(1e-12);
    // Each quantity is fitted with grey colours, whose luminance is that grey value.
    let channel = fiberlab_fit::Channel::Luminance;
    grid.iter()
        .zip(values)
        .map(|(&(wi, wo, w), &value)| Observation { wi, wo, value, sigma: mean / w, channel })
        .collect()
}

/// Camera-side furnace `W(θ_o) = ∫ f_s cosθ_i dω_i` of a model without φ dependence (as
/// Kajiya–Kay), `2π ∫ f_s(θ_i, θ_o) cos²θ_i dθ_i` by the midpoint rule in θ_i.
fn azimuth_free_furnace(model: &Model, theta_o: f64) -> Rgb {
    const NODES: usize = 2048;
    let wo = direction(theta_o, 0.5);
    let d = PI / NODES as f64;
    let mut sum = Rgb::ZERO;
    for k in 0..NODES {
        let ti = -FRAC_PI_2 + (k as f64 + 0.5) * d;
        sum += model.eval(direction(ti, 0.0), wo, 0.0) * (ti.cos().powi(2) * d);
    }
    sum * TAU
}

/// Outgoing inclinations at which the energy bound is checked: every 10°, and ±85°, ±89°.
fn bound_inclinations() -> Vec<f64> {
    (-8..=8)
        .map(|k| f64::to_radians(10.0 * f64::from(k)))
        .chain([-89.0, -85.0, 85.0, 89.0].map(f64::to_radians))
        .collect()
}

/// The energy bound of the Kajiya–Kay fit, per checked θ_o and channel: the target's own
/// camera-side furnace `W(θ_o)` (by quadrature), capped at 1 — Kajiya–Kay may not scatter
/// more than the hair it stands for, nor create light.
struct EnergyBound {
    /// `(θ_o, bound per channel)`.
    at: Vec<(f64, Rgb)>,
}

impl EnergyBound {
    fn of(target: &Model) -> Self {
        let quadrature = fiberlab_scatter::radiometry::Quadrature { theta: 128, phi: 128, h: 8 };
        let at = bound_inclinations()
            .into_iter()
            .map(|t| {
                let w = fiberlab_scatter::radiometry::furnace(target, direction(t, 0.5), &quadrature);
                (t, w.map(|c| c.min(1.0)))
            })
            .collect();
        Self { at }
    }

    /// Whether the azimuth-free `model` (Kajiya–Kay) stays within the bound in `channel`
    /// (`None`: luminance against the bound's luminance).
    fn admits(&self, model: &Model, channel: Option<usize>) -> bool {
        self.at.iter().all(|&(t, bound)| {
            let w = azimuth_free_furnace(model, t);
            match channel {
                Some(c) => w[c] <= bound[c],
                None => w.luminance() <= bound.luminance(),
            }
        })
    }
}

/// Kajiya–Kay fitted to `target`: first `(k_d, k_s, p)` to its luminance, then, with that
/// p, `(k_d, k_s)` to each channel; every fit is weighted least squares on the fitting grid,
/// constrained to the energy bound ([`EnergyBound`]: at every checked θ_o, Kajiya–Kay's
/// furnace at most the target's and at most 1), so the result obeys it in every channel.
fn fitted_kajiya_kay(target: &Model) -> anyhow::Result<KajiyaKayParams> {
    let grid = fiberlab_fit::model_grid();
    let values: Vec<Rgb> = grid.iter().map(|&(wi, wo, _)| fiberlab_fit::width_averaged(target, wi, wo)).collect();
    let bound = EnergyBound::of(target);
    let info = KajiyaKay::INFO;
    let base = ParamSet::parse::<&str, &str>(info.name, info.params, &[])?;
    let lum: Vec<f64> = values.iter().map(|v| v.luminance()).collect();
    let value =
        |r: &fiberlab_fit::FitResult, key: &str| r.params.iter().find(|(k, _)| k == key).map_or(0.0, |(_, v)| *v);
    // A start inside the bound: the default shape, scaled down until it is admitted.
    let mut scale = 1.0;
    let start_kk = |scale: f64| build_kajiya_kay(0.02 * scale, 0.1 * scale, 10.0);
    while !bound.admits(&start_kk(scale)?, None) && scale > 1e-6 {
        scale *= 0.5;
    }
    let free = [("k_d".to_string(), 0.02 * scale), ("k_s".to_string(), 0.1 * scale), ("p".to_string(), 10.0)];
    let admits_grey = |m: &Model| bound.admits(m, None);
    let grey = fiberlab_fit::fit_constrained(&base, &free, &observations(&grid, &lum), 400, Some(&admits_grey))
        .context("fitting kajiya-kay to the scene's hair model")?;
    let p = value(&grey, "p");
    let with_p = ParamSet::parse(info.name, info.params, &[("p", format!("{p}"))])?;
    let mut k_d = [0.0; 3];
    let mut k_s = [0.0; 3];
    for c in 0..3 {
        let admits = |m: &Model| bound.admits(m, Some(c));
        // A start inside this channel's bound (W is linear in k_d, k_s).
        let mut start = [value(&grey, "k_d"), value(&grey, "k_s")];
        while !admits(&build_kajiya_kay(start[0], start[1], p)?) && start[1] + start[0] > 1e-9 {
            start = start.map(|k| 0.5 * k);
        }
        let start = [("k_d".to_string(), start[0]), ("k_s".to_string(), start[1])];
        let channel: Vec<f64> = values.iter().map(|v| v[c]).collect();
        let r = fiberlab_fit::fit_constrained(&with_p, &start, &observations(&grid, &channel), 300, Some(&admits))
            .with_context(|| format!("fitting kajiya-kay to channel {c} of the scene's hair model"))?;
        (k_d[c], k_s[c]) = (value(&r, "k_d"), value(&r, "k_s"));
    }
    Ok(KajiyaKayParams { k_d: Rgb::new(k_d[0], k_d[1], k_d[2]), k_s: Rgb::new(k_s[0], k_s[1], k_s[2]), p })
}

/// A grey Kajiya–Kay fiber as a model.
fn build_kajiya_kay(k_d: f64, k_s: f64, p: f64) -> anyhow::Result<Model> {
    Ok(KajiyaKay::new(KajiyaKayParams { k_d: Rgb::splat(k_d), k_s: Rgb::splat(k_s), p })?.into())
}

fn to_image(l: &LinearImage) -> Image {
    Image {
        width: l.width(),
        height: l.height(),
        pixels: l.pixels().iter().map(|p| [f64::from(p[0]), f64::from(p[1]), f64::from(p[2])]).collect(),
    }
}

/// A render as the mean of two halves with different seeds, and their difference for the
/// noise estimate.
struct NoisyRender {
    /// The mean of the halves.
    mean: Image,
    /// Per pixel and channel, the estimated variance of `mean`: `(half₁ − half₂)²/4`.
    variance: Vec<[f64; 3]>,
}

impl NoisyRender {
    /// Noise of the image: `sqrt(mean variance)` = RMSE(half₁, half₂)/2.
    fn noise(&self) -> f64 {
        (self.variance.iter().map(|v| v.iter().sum::<f64>() / 3.0).sum::<f64>() / self.variance.len() as f64).sqrt()
    }

    /// From two independent halves of equal sample counts.
    fn from_halves(a: &Image, b: &Image) -> Self {
        let mean = Image {
            width: a.width,
            height: a.height,
            pixels: a.pixels.iter().zip(&b.pixels).map(|(p, q)| [0, 1, 2].map(|c| 0.5 * (p[c] + q[c]))).collect(),
        };
        let variance =
            a.pixels.iter().zip(&b.pixels).map(|(p, q)| [0, 1, 2].map(|c| 0.25 * (p[c] - q[c]).powi(2))).collect();
        Self { mean, variance }
    }

    /// An image without noise (a photograph given as the reference).
    fn exact(image: Image) -> Self {
        let variance = vec![[0.0; 3]; image.pixels.len()];
        Self { mean: image, variance }
    }
}

/// Renders `scene` with `spp` samples per pixel as two halves of ⌈spp/2⌉, seeds `seed` and
/// `seed + 1`.
fn render_in_halves(scene: &Scene, settings: &RenderSettings, spp: u32, seed: u64) -> (LinearImage, NoisyRender) {
    let half = spp.div_ceil(2).max(1);
    let run = |seed: u64| {
        let s = RenderSettings { spp: half, seed, ..settings.clone() };
        render(scene, &s, &|_| {}, &AtomicBool::new(false)).image
    };
    let (a, b) = (run(seed), run(seed.wrapping_add(1)));
    let noisy = NoisyRender::from_halves(&to_image(&a), &to_image(&b));
    let mean = LinearImage::from_pixels(
        a.width(),
        a.height(),
        noisy.mean.pixels.iter().map(|p| [p[0] as f32, p[1] as f32, p[2] as f32]).collect(),
    )
    .expect("the halves have the image's size");
    (mean, noisy)
}

/// Noise floors of a comparison of `model` with `reference`: what the RMSE and the relative
/// MSE would be from the noise of both alone.
#[derive(Clone, Copy, Debug, PartialEq)]
struct NoiseFloor {
    rmse: f64,
    relmse: f64,
}

/// The floors, per pixel `var_model + var_reference`, averaged (relative MSE: divided by
/// `reference² + 0.01` as `compare` does).
fn noise_floor(model: &NoisyRender, reference: &NoisyRender) -> NoiseFloor {
    let n = model.variance.len() as f64;
    let (mut se, mut rel) = (0.0, 0.0);
    for ((vm, vr), r) in model.variance.iter().zip(&reference.variance).zip(&reference.mean.pixels) {
        for c in 0..3 {
            se += (vm[c] + vr[c]) / 3.0;
            rel += (vm[c] + vr[c]) / (r[c] * r[c] + 1e-2) / 3.0;
        }
    }
    NoiseFloor { rmse: (se / n).sqrt(), relmse: rel / n }
}

/// The RMSE the model explains beyond the noise: `sqrt(max(0, rmse² − floor²))`.
fn excess(rmse: f64, floor: f64) -> f64 {
    (rmse * rmse - floor * floor).max(0.0).sqrt()
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
    let hair = SceneHair::of(scene_hair_model(&scene).context("the scene has no hair with a fiber model")?);
    match hair.sigma_a {
        Some(s) => println!("scene hair: sigma_a {} per radius (TT at normal incidence: exp(−2σ_a))", rgb_short(s)),
        None => println!("scene hair: no absorption evaluate can read; models keep their own"),
    }
    let spp = args.spp.unwrap_or(settings.spp);
    let user = |name: &str| -> Vec<(String, RawValue)> {
        args.params
            .iter()
            .filter(|p| p.model.as_deref() == Some(name))
            .map(|p| (p.key.clone(), RawValue::Text(p.value.clone())))
            .collect()
    };
    // Every model is built (and Kajiya–Kay fitted) before anything is rendered or written.
    let names: Vec<&str> = args.models.split(',').map(str::trim).filter(|n| !n.is_empty()).collect();
    let entries: Vec<Entry> = names
        .iter()
        .map(|name| build_model(name, &user(name), args.table.as_deref(), &hair))
        .collect::<anyhow::Result<_>>()?;
    let reference_model = match (&args.reference, &args.table) {
        (Some(_), _) => None,
        (None, Some(t)) => Some(build_model(Measured::INFO.name, &[], Some(t), &hair)?.model),
        (None, None) => bail!("give --table (measured reference render) or --reference IMAGE"),
    };
    std::fs::create_dir_all(&args.out).with_context(|| format!("creating {}", args.out.display()))?;
    // The reference's seeds (seed + 2, seed + 3) differ from the models' (seed, seed + 1).
    let reference = match (&args.reference, reference_model) {
        (Some(p), _) => NoisyRender::exact(load(p)?),
        (None, Some(m)) => {
            set_hair_model(&mut scene, &m);
            let (img, noisy) = render_in_halves(&scene, &settings, args.reference_spp, settings.seed.wrapping_add(2));
            write(&img, &args.out, "reference")?;
            noisy
        }
        (None, None) => unreachable!("checked above"),
    };
    println!("reference      noise {:.5}", reference.noise());
    let mut rows = Vec::new();
    let mut tiles = vec![Tile {
        name: "reference".into(),
        image: reference.mean.clone(),
        lines: vec![format!("noise {:.4}", reference.noise())],
    }];
    for (name, entry) in names.iter().zip(&entries) {
        println!("{name:<14} {}", entry.given);
        set_hair_model(&mut scene, &entry.model);
        let (img, noisy) = render_in_halves(&scene, &settings, spp, settings.seed);
        write(&img, &args.out, name)?;
        let (m, _) = compare(&reference.mean, &noisy.mean, None, false)?;
        let floor = noise_floor(&noisy, &reference);
        let over = excess(m.rmse, floor.rmse);
        println!(
            "{name:<14} rmse {:.5} (noise {:.5}, excess {:.5})  relmse {:.5} (noise {:.5})  ssim {:.4}  flip {:.4}  \
             image noise {:.5}",
            m.rmse,
            floor.rmse,
            over,
            m.relmse,
            floor.relmse,
            m.ssim,
            m.flip,
            noisy.noise()
        );
        rows.push(serde_json::json!({
            "model": name,
            "given": entry.given,
            "rmse": m.rmse,
            "rmse_noise": floor.rmse,
            "rmse_excess": over,
            "relmse": m.relmse,
            "relmse_noise": floor.relmse,
            "ssim": m.ssim,
            "flip": m.flip,
            "image_noise": noisy.noise(),
            "reference_noise": reference.noise(),
        }));
        tiles.push(Tile {
            name: (*name).to_string(),
            image: noisy.mean,
            lines: vec![
                format!("rmse {:.4} ±{:.4}", m.rmse, floor.rmse),
                format!("excess {over:.4}"),
                format!("relmse {:.3} ±{:.3}", m.relmse, floor.relmse),
                format!("ssim {:.3} flip {:.3}", m.ssim, m.flip),
            ],
        });
    }
    crate::files::write_atomically(&args.out.join("metrics.json"), serde_json::to_string_pretty(&rows)?.as_bytes())?;
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
    let mut buf = vec![255u8; (size.0 * size.1 * 3) as usize];
    {
        crate::plot::register_font();
        let root = BitMapBackend::with_buffer(&mut buf, size).into_drawing_area();
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
    }
    crate::plot::write_png(path, &buf, size)
}

#[cfg(test)]
mod tests {
    use super::*;
    use fiberlab_scatter::hair::attenuation::hit_attenuation;

    fn build(name: &str, pairs: &[(&str, &str)]) -> Model {
        fiberlab_scatter::build(name, pairs).unwrap()
    }

    fn raw(pairs: &[(&str, &str)]) -> Vec<(String, RawValue)> {
        pairs.iter().map(|(k, v)| ((*k).to_string(), RawValue::Text((*v).to_string()))).collect()
    }

    /// Single-crossing TT attenuation at normal incidence (θ = 0, h = 0) of a mapped model,
    /// read from the model itself: Marschner's TT lobe against the same lobe without
    /// absorption (its only TT root at φ = π is h = 0, so the ratio is T); Chiang's and
    /// d'Eon's σ_a through the near-field hit attenuation `A_1/(1 − f)²`.
    fn tt_attenuation(model: &Model) -> Rgb {
        match model {
            Model::Marschner(m) => {
                let lobe = |sigma_a: Rgb| {
                    let p = fiberlab_scatter::marschner_2003::MarschnerParams {
                        sigma_a,
                        lobes: [false, true, false],
                        ..*m.params()
                    };
                    let tt = fiberlab_scatter::marschner_2003::Marschner::new(p).unwrap();
                    tt.eval(direction(0.0, 0.0), direction(0.0, PI), 0.0)
                };
                let (with, without) = (lobe(m.params().sigma_a), lobe(Rgb::ZERO));
                Rgb::new(with[0] / without[0], with[1] / without[1], with[2] / without[2])
            }
            Model::Chiang(c) => {
                let hit = hit_attenuation(c.params().eta, c.sigma_a(), 0.0, 1.0, 0.0);
                hit.a[1] / (1.0 - hit.a[0][0]).powi(2)
            }
            Model::Deon(d) => {
                let hit = hit_attenuation(d.params().fiber.eta, d.sigma_a(), 0.0, 1.0, 0.0);
                hit.a[1] / (1.0 - hit.a[0][0]).powi(2)
            }
            _ => unreachable!("not a hair model with absorption"),
        }
    }

    /// A brown Chiang scene (melanin): every mapped model attenuates one crossing at normal
    /// incidence by `exp(−σ_a·2)`, σ_a from d'Eon's pigment table written out by hand —
    /// including Marschner with the printed path (4 radii), which needs σ_a/2.
    #[test]
    fn mapped_models_share_the_single_crossing_attenuation() {
        let (eu, pheo): (f64, f64) = (0.8, 0.4);
        let sigma = [0.419 * eu + 0.187 * pheo, 0.697 * eu + 0.4 * pheo, 1.37 * eu + 1.05 * pheo];
        let want = sigma.map(|s| (-s * 2.0).exp());
        let scenes = [
            build("chiang", &[("eumelanin", "0.8"), ("pheomelanin", "0.4"), ("beta_n", "0.4")]),
            build("deon", &[("eumelanin", "0.8"), ("pheomelanin", "0.4")]),
            build("marschner", &[("sigma_a", &format!("{},{},{}", sigma[0], sigma[1], sigma[2]))]),
            build(
                "marschner",
                &[
                    ("sigma_a", &format!("{},{},{}", sigma[0] / 2.0, sigma[1] / 2.0, sigma[2] / 2.0)),
                    ("absorption", "paper"),
                ],
            ),
        ];
        let targets: [(&str, &[(&str, &str)]); 5] = [
            ("chiang", &[("beta_m", "0.4")]),
            ("deon", &[]),
            ("marschner", &[]),
            ("marschner", &[("absorption", "paper")]),
            ("chiang", &[]),
        ];
        for scene in scenes {
            let hair = SceneHair::of(scene);
            for (name, user) in targets {
                let entry = build_model(name, &raw(user), None, &hair).unwrap();
                let got = tt_attenuation(&entry.model);
                for c in 0..3 {
                    assert!(
                        (got[c] - want[c]).abs() < 1e-12 * want[c],
                        "{name} {user:?} ch {c}: {} vs {}",
                        got[c],
                        want[c]
                    );
                }
            }
        }
    }

    /// Where the model's absorption does not come from the scene, it is not the scene's.
    #[test]
    fn an_absorption_given_on_the_command_line_wins() {
        let hair = SceneHair::of(build("chiang", &[("eumelanin", "0.8")]));
        let entry = build_model("marschner", &raw(&[("sigma_a", "2")]), None, &hair).unwrap();
        assert!((tt_attenuation(&entry.model)[0] - (-4.0f64).exp()).abs() < 1e-12);
        let itself = build_model("chiang", &[], None, &hair).unwrap();
        assert!(matches!(itself.model, Model::Chiang(ref c) if c.params().absorption == hair_absorption(0.8)));
    }

    fn hair_absorption(eu: f64) -> fiberlab_scatter::hair::absorption::Absorption {
        fiberlab_scatter::hair::absorption::Absorption::Melanin { eumelanin: eu, pheomelanin: 0.0 }
    }

    /// `W(θ_o) = π²k_d + 2πk_s ∫ max(0, cos(θ_i + θ_o))^p cosθ_i dθ_i` from the parameters
    /// alone, by composite Simpson (independent of `eval` and of the fit's own quadrature).
    fn kajiya_kay_furnace(k_d: f64, k_s: f64, p: f64, theta_o: f64) -> f64 {
        let n = 20000;
        let d = PI / n as f64;
        let g = |t: f64| (t + theta_o).cos().max(0.0).powf(p) * t.cos();
        let mut s = g(-FRAC_PI_2) + g(FRAC_PI_2);
        for k in 1..n {
            s += g(-FRAC_PI_2 + k as f64 * d) * if k % 2 == 1 { 4.0 } else { 2.0 };
        }
        PI * PI * k_d + TAU * k_s * s * d / 3.0
    }

    /// Kajiya–Kay fitted to a bright blond Chiang fiber (the case that exploded before the
    /// bound): in every channel its furnace stays ≤ 1 at every inclination, by a quadrature
    /// of its closed form, and within the hair's own furnace; without the bound the same fit
    /// exceeds 1.
    #[test]
    fn fitted_kajiya_kay_obeys_the_energy_bound() {
        let target = build("chiang", &[("eumelanin", "0.15"), ("pheomelanin", "0.1"), ("beta_m", "0.25")]);
        let kk = fitted_kajiya_kay(&target).unwrap();
        let mut peak: f64 = 0.0;
        for c in 0..3 {
            for deg in -90..=90 {
                let w = kajiya_kay_furnace(kk.k_d[c], kk.k_s[c], kk.p, f64::from(deg).to_radians());
                peak = peak.max(w);
                assert!(w <= 1.0 + 2e-3, "channel {c}, θ_o {deg}°: W = {w} ({kk:?})");
            }
        }
        assert!(peak > 0.3, "the fit is not trivially dark: peak W {peak} ({kk:?})");
        // Nor more than the hair it stands for, at the inclinations the bound checks.
        let quadrature = fiberlab_scatter::radiometry::Quadrature { theta: 256, phi: 256, h: 8 };
        for t in bound_inclinations() {
            let hair = fiberlab_scatter::radiometry::furnace(&target, direction(t, 0.5), &quadrature);
            for c in 0..3 {
                let w = kajiya_kay_furnace(kk.k_d[c], kk.k_s[c], kk.p, t);
                assert!(w <= hair[c] + 5e-3, "channel {c}, θ_o {t}: W = {w} > the hair's {}", hair[c]);
            }
        }
        // The same luminance fit without the constraint leaves the bound.
        let grid = fiberlab_fit::model_grid();
        let lum: Vec<f64> =
            grid.iter().map(|&(wi, wo, _)| fiberlab_fit::width_averaged(&target, wi, wo).luminance()).collect();
        let info = KajiyaKay::INFO;
        let base = ParamSet::parse::<&str, &str>(info.name, info.params, &[]).unwrap();
        let free = [("k_d".to_string(), 0.02), ("k_s".to_string(), 0.1), ("p".to_string(), 10.0)];
        let r = fiberlab_fit::fit(&base, &free, &observations(&grid, &lum), 400).unwrap();
        let v: Vec<f64> = r.params.iter().map(|(_, v)| *v).collect();
        let free_peak =
            (-90..=90).map(|d| kajiya_kay_furnace(v[0], v[1], v[2], f64::from(d).to_radians())).fold(0.0, f64::max);
        assert!(free_peak > 1.0, "unconstrained peak W {free_peak} ({v:?})");
    }

    /// Two halves with independent Gaussian-like noise of known σ: the image noise is σ/√2
    /// and the RMSE between two such means is about the noise floor.
    #[test]
    fn noise_estimates_match_known_noise() {
        let mut u = fiberlab_check::rng::TestRng::new(3).into_uniforms();
        let mut noisy = |sigma: f64| {
            let pixels = (0..20000)
                .map(|_| [0, 1, 2].map(|_| 0.5 + sigma * ((0..4).map(|_| u()).sum::<f64>() - 2.0) * 3f64.sqrt()))
                .collect();
            Image { width: 200, height: 100, pixels }
        };
        let model = NoisyRender::from_halves(&noisy(0.1), &noisy(0.1));
        let reference = NoisyRender::from_halves(&noisy(0.05), &noisy(0.05));
        let want_model = 0.1 / 2f64.sqrt();
        assert!((model.noise() - want_model).abs() < 0.02 * want_model, "{}", model.noise());
        let floor = noise_floor(&model, &reference);
        let want = (0.1f64.powi(2) / 2.0 + 0.05f64.powi(2) / 2.0).sqrt();
        assert!((floor.rmse - want).abs() < 0.02 * want, "{floor:?} vs {want}");
        let (m, _) = compare(&reference.mean, &model.mean, None, false).unwrap();
        assert!((m.rmse - want).abs() < 0.03 * want, "rmse {} vs floor {want}", m.rmse);
        assert!(excess(m.rmse, floor.rmse) < 0.3 * want);
        assert_eq!(NoisyRender::exact(reference.mean.clone()).noise(), 0.0);
    }
}
