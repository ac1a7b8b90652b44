//! The colour-matched evaluation of hair models (`fiberlab evaluate`): the same scene, camera,
//! lights and sample budget rendered with each model, every model given the scene's hair (one
//! absorption, mapped between the models' parametrizations; Kajiya–Kay fitted to the scene's
//! hair model under an energy bound), compared with a reference — a photograph, or a
//! high-sample render with the measured scattering function from explicit geometry — with the
//! residual Monte Carlo noise of every render stated beside each metric
//! (`docs/theory/hair.md`, "One absorption for every hair model").
//!
//! # Noise
//! Every render is the mean of two halves of its samples with different seeds; its noise is
//! `RMSE(half₁, half₂)/2`. The reference's seeds differ from the models'. Beside each metric
//! stand its noise floor — what noise alone gives: RMSE `sqrt(noise_model² + noise_reference²)`,
//! relative MSE the same per pixel — and the excess RMSE `sqrt(rmse² − floor²)`, the part the
//! model, not the noise, explains.

use crate::CompareError;
use fiberlab_fit::Observation;
use fiberlab_io::LinearImage;
use fiberlab_io::image_metrics::{Image, Metrics, compare};
use fiberlab_math::frame::direction;
use fiberlab_math::{DVec3, Rgb};
use fiberlab_render::integrator::{RenderSettings, render};
use fiberlab_render::model_loader::load_model;
use fiberlab_render::scene::Scene;
use fiberlab_scatter::kajiya_kay_1989::{KajiyaKay, KajiyaKayParams};
use fiberlab_scatter::measured::Measured;
use fiberlab_scatter::params::{ParamSet, RawValue};
use fiberlab_scatter::{ExternalData, Model, ModelError, Registered, ScatteringFunction};
use std::f64::consts::{FRAC_PI_2, PI, TAU};
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

/// The keys by which a hair model takes its absorption.
pub const ABSORPTION_KEYS: [&str; 4] = ["sigma_a", "eumelanin", "pheomelanin", "color"];

/// What to evaluate.
#[derive(Clone, Debug)]
pub struct EvaluationRequest {
    /// The models, each with the parameters the user gave it (`--param MODEL:KEY=VALUE`).
    pub models: Vec<(String, Vec<(String, RawValue)>)>,
    /// Measured table for models built from a table and for the measured reference render.
    pub table: Option<PathBuf>,
    /// A reference image (a photograph) instead of the measured reference render.
    pub reference_image: Option<Image>,
    /// Samples per pixel of each model's render (default: the scene's), in two halves.
    pub spp: Option<u32>,
    /// Samples per pixel of the reference render (two halves).
    pub reference_spp: u32,
    /// How a fitted Kajiya–Kay gets its colour ([`KajiyaKayColour`]).
    pub kajiya_kay_colour: KajiyaKayColour,
}

/// How the fitted Kajiya–Kay gets its colour and brightness.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum KajiyaKayColour {
    /// From one fiber: the colour the hair scatters toward the viewer's side
    /// ([`reflected_colour`]), within the energy bound (`fiber`).
    Fiber,
    /// Then, in the scene: each channel of `k_d` and `k_s` scaled until Kajiya–Kay's hair
    /// is as bright as the scene's hair model rendered in the same scene, multiple
    /// scattering included ([`colour_in_scene`]), within the energy bound (`scene`, the
    /// default). One fiber's colour is not the colour of many: light that crosses several
    /// fibers takes their colour again at each, and Kajiya–Kay's lobe, which scatters as much
    /// back as forward, does not do that the way the hair does.
    #[default]
    Scene,
}

impl KajiyaKayColour {
    /// `fiber` or `scene`.
    pub fn parse(name: &str) -> Result<Self, String> {
        match name {
            "fiber" => Ok(Self::Fiber),
            "scene" => Ok(Self::Scene),
            other => Err(format!("Kajiya–Kay colour `{other}` (known: scene, fiber)")),
        }
    }
}

/// A model as evaluate renders it, with what it was given.
#[derive(Clone, Debug)]
pub struct Entry {
    /// The model's name as requested.
    pub name: String,
    /// The model.
    pub model: Model,
    /// How it got the scene's hair.
    pub given: String,
    /// The fitted parameters, where the model is Kajiya–Kay fitted to the scene's hair.
    pub kajiya_kay_fit: Option<KajiyaKayParams>,
}

/// A render as the mean of two halves with different seeds, and the per-pixel variance
/// estimate of that mean, `(half₁ − half₂)²/4`.
#[derive(Clone, Debug)]
pub struct NoisyRender {
    /// The mean of the halves.
    pub mean: Image,
    /// Per pixel and channel, the estimated variance of `mean`.
    pub variance: Vec<[f64; 3]>,
}

impl NoisyRender {
    /// Noise of the image: `sqrt(mean variance)` = RMSE(half₁, half₂)/2.
    #[must_use]
    pub fn noise(&self) -> f64 {
        (self.variance.iter().map(|v| v.iter().sum::<f64>() / 3.0).sum::<f64>() / self.variance.len() as f64).sqrt()
    }

    /// From two independent halves of equal sample counts.
    #[must_use]
    pub fn from_halves(a: &Image, b: &Image) -> Self {
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
    #[must_use]
    pub fn exact(image: Image) -> Self {
        let variance = vec![[0.0; 3]; image.pixels.len()];
        Self { mean: image, variance }
    }

    /// The mean as a linear image.
    #[must_use]
    pub fn linear_image(&self) -> LinearImage {
        LinearImage::from_pixels(
            self.mean.width,
            self.mean.height,
            self.mean.pixels.iter().map(|p| [p[0] as f32, p[1] as f32, p[2] as f32]).collect(),
        )
        .expect("the mean has its own size")
    }
}

/// Noise floors of a comparison: what the RMSE and the relative MSE would be from the noise of
/// the model's render and the reference alone.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NoiseFloor {
    /// RMSE floor.
    pub rmse: f64,
    /// Relative MSE floor.
    pub relmse: f64,
}

/// The floors, per pixel `var_model + var_reference`, averaged (relative MSE: divided by
/// `reference² + 0.01` as the image metrics do).
#[must_use]
pub fn noise_floor(model: &NoisyRender, reference: &NoisyRender) -> NoiseFloor {
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
#[must_use]
pub fn excess(rmse: f64, floor: f64) -> f64 {
    (rmse * rmse - floor * floor).max(0.0).sqrt()
}

/// [`excess`] in units of the noise floor: the difference stands clear of the noise where this
/// is at least 3 (infinite against a noiseless floor, 0 without excess).
#[must_use]
pub fn excess_over_floor(rmse: f64, floor: f64) -> f64 {
    let e = excess(rmse, floor);
    if floor > 0.0 {
        e / floor
    } else if e > 0.0 {
        f64::INFINITY
    } else {
        0.0
    }
}

/// One model's result.
#[derive(Clone, Debug)]
pub struct ModelResult {
    /// The model and how it got the scene's hair.
    pub entry: Entry,
    /// Its render.
    pub render: NoisyRender,
    /// Metrics against the reference.
    pub metrics: Metrics,
    /// Their noise floors.
    pub floor: NoiseFloor,
    /// Per channel, the render's mean over the pixels the hair covers over the reference's
    /// ([`hair_colour`]): brightness and colour of the hair alone.
    pub hair_colour: Rgb,
}

impl ModelResult {
    /// The RMSE beyond the noise floor.
    #[must_use]
    pub fn excess_rmse(&self) -> f64 {
        excess(self.metrics.rmse, self.floor.rmse)
    }

    /// The excess RMSE over its noise floor: the model's difference from the reference stands
    /// clear of the noise where this is at least 3 (infinite against a noiseless reference and
    /// render, 0 without excess).
    #[must_use]
    pub fn excess_over_floor(&self) -> f64 {
        excess_over_floor(self.metrics.rmse, self.floor.rmse)
    }

    /// Its row of `metrics.json` (`fiberlab evaluate`; Python's `evaluate` returns the same),
    /// beside the reference's noise.
    #[must_use]
    pub fn row(&self, reference_noise: f64) -> MetricsRow {
        MetricsRow {
            model: self.entry.name.clone(),
            given: self.entry.given.clone(),
            rmse: self.metrics.rmse,
            rmse_noise: self.floor.rmse,
            rmse_excess: self.excess_rmse(),
            relmse: self.metrics.relmse,
            relmse_noise: self.floor.relmse,
            ssim: self.metrics.ssim,
            flip: self.metrics.flip,
            image_noise: self.render.noise(),
            reference_noise,
            hair_colour: [self.hair_colour[0], self.hair_colour[1], self.hair_colour[2]],
        }
    }
}

/// One model's metrics against the reference, with the noise beside each.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct MetricsRow {
    /// The model's name.
    pub model: String,
    /// How it got the scene's hair.
    pub given: String,
    /// RMSE against the reference.
    pub rmse: f64,
    /// The RMSE noise alone gives.
    pub rmse_noise: f64,
    /// The RMSE beyond the noise.
    pub rmse_excess: f64,
    /// Relative MSE against the reference.
    pub relmse: f64,
    /// The relative MSE noise alone gives.
    pub relmse_noise: f64,
    /// SSIM of the sRGB-encoded luminance.
    pub ssim: f64,
    /// Mean ꟻLIP error.
    pub flip: f64,
    /// The model render's own noise.
    pub image_noise: f64,
    /// The reference's noise.
    pub reference_noise: f64,
    /// Per channel, the hair pixels' mean over the reference's ([`ModelResult::hair_colour`]).
    pub hair_colour: [f64; 3],
}

/// What the evaluation reports as it goes.
pub enum Progress<'a> {
    /// The scene's hair absorption (per radius, chord convention), if it has one.
    SceneHair(Option<Rgb>),
    /// The reference is ready.
    Reference(&'a NoisyRender),
    /// Kajiya–Kay's colour is being matched in the scene ([`colour_in_scene`]).
    Calibrating(&'a Entry),
    /// A model is about to be rendered.
    Rendering(&'a Entry),
    /// A model is done.
    Model(&'a ModelResult),
}

/// The scene's hair, as every model is given it.
struct SceneHair {
    /// The scene's own hair model (the first hair's material).
    model: Model,
    /// Its absorption per unit radius in the chord convention.
    sigma_a: Option<Rgb>,
}

/// `r,g,b` as text that parses back to the same numbers (shortest round-trip decimals).
fn rgb_text(c: Rgb) -> RawValue {
    RawValue::Text(format!("{},{},{}", c[0], c[1], c[2]))
}

/// `r,g,b` with four decimals, for messages.
#[must_use]
pub fn rgb_short(c: Rgb) -> String {
    format!("{:.4},{:.4},{:.4}", c[0], c[1], c[2])
}

/// Model `name` with the user's `--param MODEL:KEY=VALUE` values, given the scene's hair: a
/// model built from a table gets `table` unless its parameters name one; Kajiya–Kay without
/// parameters is fitted to the scene's model; a model named like the scene's, without
/// parameters, is the scene's model; any other model that takes `sigma_a` gets the scene's
/// absorption mapped to its convention ([`ScatteringFunction::sigma_a_for_chord`]) unless the
/// user gives an absorption.
fn build_model(
    name: &str,
    user: &[(String, RawValue)],
    table: Option<&Path>,
    hair: &SceneHair,
) -> Result<Entry, CompareError> {
    let mut pairs = user.to_vec();
    let spec = fiberlab_scatter::find(name)?;
    if let Some(ExternalData::Table { key }) = spec.data
        && !pairs.iter().any(|(k, _)| k == key)
    {
        let table = table.ok_or_else(|| CompareError::Request(format!("model `{name}` needs --table")))?;
        pairs.push((key.to_string(), RawValue::Text(table.to_string_lossy().into_owned())));
    }
    let load = |pairs: &[(String, RawValue)]| load_model(spec.name, pairs, Path::new(""));
    let entry = |model: Model, given: String| Entry { name: name.to_string(), model, given, kajiya_kay_fit: None };
    // Kajiya–Kay has no absorption: the evaluation fits its appearance (by type, not by a name
    // typed here).
    if spec.name == KajiyaKay::INFO.name && pairs.is_empty() {
        let fitted = fitted_kajiya_kay(&hair.model)?;
        let given = format!(
            "fitted to the scene's hair, furnace ≤ the hair's and ≤ 1: k_d {}, k_s {}, p {:.4}",
            rgb_short(fitted.k_d),
            rgb_short(fitted.k_s),
            fitted.p
        );
        let model = KajiyaKay::new(fitted).map_err(ModelError::from)?.into();
        return Ok(Entry { kajiya_kay_fit: Some(fitted), ..entry(model, given) });
    }
    if pairs.is_empty() && spec.name == hair.model.name() {
        return Ok(entry(hair.model.clone(), "the scene's hair model itself".into()));
    }
    let takes_sigma_a = spec.params.iter().any(|p| p.key == "sigma_a");
    let user_absorption = pairs.iter().any(|(k, _)| ABSORPTION_KEYS.contains(&k.as_str()));
    Ok(match hair.sigma_a {
        Some(sigma) if takes_sigma_a && !user_absorption => {
            pairs.push(("sigma_a".into(), rgb_text(sigma)));
            let mut model = load(&pairs)?;
            let mapped = model.sigma_a_for_chord(sigma);
            if mapped != sigma {
                pairs.pop();
                pairs.push(("sigma_a".into(), rgb_text(mapped)));
                model = load(&pairs)?;
            }
            entry(model, format!("the scene's absorption: sigma_a {} per radius", rgb_short(mapped)))
        }
        _ if takes_sigma_a && user_absorption => entry(load(&pairs)?, "its own absorption (--param)".into()),
        _ if takes_sigma_a => {
            entry(load(&pairs)?, "its default absorption (the scene's hair has none evaluate can read)".into())
        }
        _ if spec.data.is_some() => {
            entry(load(&pairs)?, "the table's own fiber (measure it with the scene's σ_a)".into())
        }
        _ => entry(load(&pairs)?, "no absorption parameter".into()),
    })
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
#[must_use]
pub fn bound_inclinations() -> Vec<f64> {
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

    /// Per channel, the largest factor by which the azimuth-free `model`'s coefficients (its
    /// furnace is linear in them) may be scaled and stay within the bound.
    fn headroom(&self, model: &Model) -> Rgb {
        let mut room = [f64::INFINITY; 3];
        for &(t, bound) in &self.at {
            let w = azimuth_free_furnace(model, t);
            for c in 0..3 {
                if w[c] > 0.0 {
                    room[c] = room[c].min(bound[c] / w[c]);
                }
            }
        }
        Rgb(room)
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

/// The colour Kajiya–Kay is given: per channel over its luminance, the light the target
/// scatters toward the viewer's side of the fiber (`|φ_i − φ_o| < π/2`, where the reflection
/// Kajiya–Kay's lobe stands for goes), `∫ f_s cosθ_i dω_i` over that half, summed over
/// θ_o ∈ {0°, ±30°, ±60°}; midpoint rule, 96 θ_i × 48 φ_i nodes.
///
/// Kajiya–Kay's lobe does not depend on the azimuth, so it shows whatever colour it has from
/// every side. Dark hair reflects white (R) toward the viewer's side and transmits red (TT)
/// to the other: a colour fitted to both, channel by channel, is the red of the transmission
/// seen in reflection — the copper Kajiya–Kay of the gallery's black hair before this colour
/// (k_s 0.065, 0.038, 0.031 for eumelanin 3).
#[must_use]
pub fn reflected_colour(target: &Model) -> Rgb {
    const THETA: usize = 96;
    const PHI: usize = 48;
    let (dt, dp) = (PI / THETA as f64, PI / PHI as f64);
    let mut sum = Rgb::ZERO;
    for theta_o in [0.0, 30.0, -30.0, 60.0, -60.0f64] {
        let wo = direction(theta_o.to_radians(), 0.0);
        for i in 0..THETA {
            let ti = -FRAC_PI_2 + (i as f64 + 0.5) * dt;
            for j in 0..PHI {
                let phi = -FRAC_PI_2 + (j as f64 + 0.5) * dp;
                sum += target.eval_far(direction(ti, phi), wo) * (ti.cos().powi(2) * dt * dp);
            }
        }
    }
    let lum = sum.luminance();
    if lum > 0.0 { sum / lum } else { Rgb::ONE }
}

/// Kajiya–Kay fitted to `target`: `(k_d, k_s, p)` to its luminance by weighted least squares
/// on the fitting grid, then coloured by [`reflected_colour`] (`k_d` and `k_s` times that
/// colour, whose luminance is 1) and, if a channel then leaves the energy bound, scaled down
/// as a whole until every channel is inside it. The bound ([`EnergyBound`]): at every checked
/// θ_o, Kajiya–Kay's furnace at most the target's and at most 1.
pub fn fitted_kajiya_kay(target: &Model) -> Result<KajiyaKayParams, CompareError> {
    let grid = fiberlab_fit::model_grid();
    let bound = EnergyBound::of(target);
    let info = KajiyaKay::INFO;
    let base = ParamSet::parse::<&str, &str>(info.name, info.params, &[])?;
    let lum: Vec<f64> = grid.iter().map(|&(wi, wo, _)| target.eval_far(wi, wo).luminance()).collect();
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
    let grey = fiberlab_fit::fit_constrained(&base, &free, &observations(&grid, &lum), 400, Some(&admits_grey))?;
    let (k_d, k_s, p) = (value(&grey, "k_d"), value(&grey, "k_s"), value(&grey, "p"));
    let colour = reflected_colour(target);
    let coloured = |s: f64| KajiyaKayParams { k_d: colour * (k_d * s), k_s: colour * (k_s * s), p };
    let admitted = |s: f64| -> Result<bool, CompareError> {
        let m: Model = KajiyaKay::new(coloured(s)).map_err(ModelError::from)?.into();
        Ok((0..3).all(|c| bound.admits(&m, Some(c))))
    };
    // W is linear in the scale: bisect for the largest admitted one (1 if the colour fits).
    let mut s = 1.0;
    if !admitted(1.0)? {
        let (mut lo, mut hi) = (0.0, 1.0);
        for _ in 0..40 {
            let mid = 0.5 * (lo + hi);
            if admitted(mid)? { lo = mid } else { hi = mid }
        }
        s = lo;
    }
    Ok(coloured(s))
}

/// Renders of Kajiya–Kay at most [`colour_in_scene`] makes.
const COLOUR_ROUNDS: usize = 4;

/// What [`colour_in_scene`] found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SceneColour {
    /// The Kajiya–Kay parameters with the scene's colour.
    pub params: KajiyaKayParams,
    /// Per channel, the factor on the fiber fit's `k_d` and `k_s`.
    pub scale: Rgb,
    /// Per channel, the hair's mean in the last calibration render over the target's.
    pub last_ratio: Rgb,
    /// Renders of Kajiya–Kay made.
    pub rounds: usize,
}

/// Kajiya–Kay's colour in the scene ([`KajiyaKayColour::Scene`]): `target` (the scene's hair
/// model) is rendered once at `spp` and Kajiya–Kay (`fit`, from [`fitted_kajiya_kay`]) up to
/// [`COLOUR_ROUNDS`] times, all at `spp` with one seed (so the renders differ by the
/// coefficients, not by their noise); after each render, every channel's factor `s_c` on
/// `k_d` and `k_s` is moved so that the hair's coverage-weighted mean ([`hair_colour`]) meets
/// the target's: `ln s ← ln s + ln(target/mean)/g`, `g` the slope `d ln mean/d ln s` of the
/// last two rounds (1 at first; multiple scattering makes it above 1), clamped to [½, 4].
/// Each factor stays within the energy bound of the fiber fit (the target's furnace and 1,
/// [`EnergyBound`]); it stops once every channel is within ½ %.
///
/// The scene's hair materials are left set to Kajiya–Kay.
pub fn colour_in_scene(
    fit: KajiyaKayParams,
    target: &Model,
    scene: &mut Scene,
    settings: &RenderSettings,
    coverage: &LinearImage,
    spp: u32,
) -> Result<SceneColour, CompareError> {
    let render_with = |scene: &mut Scene, model: &Model| {
        set_hair_model(scene, model);
        let s = RenderSettings { spp: spp.max(1), seed: settings.seed.wrapping_add(4), ..settings.clone() };
        to_image(&render(scene, &s, &|_| {}, &AtomicBool::new(false)).image)
    };
    let kajiya_kay = |scale: Rgb| -> Result<(KajiyaKayParams, Model), CompareError> {
        let params = KajiyaKayParams { k_d: fit.k_d * scale, k_s: fit.k_s * scale, p: fit.p };
        Ok((params, KajiyaKay::new(params).map_err(ModelError::from)?.into()))
    };
    let wanted = render_with(scene, target);
    let room = EnergyBound::of(target).headroom(&kajiya_kay(Rgb::ONE)?.1);
    let (mut scale, mut last): (Rgb, Option<(Rgb, Rgb)>) = (Rgb::ONE, None);
    let mut result = SceneColour { params: fit, scale, last_ratio: Rgb::ONE, rounds: 0 };
    for round in 1..=COLOUR_ROUNDS {
        let (params, model) = kajiya_kay(scale)?;
        let ratio = hair_colour(&render_with(scene, &model), &wanted, coverage);
        result = SceneColour { params, scale, last_ratio: ratio, rounds: round };
        if (0..3).all(|c| (ratio[c] - 1.0).abs() < 0.005) || !(0..3).all(|c| ratio[c] > 0.0 && ratio[c].is_finite()) {
            break;
        }
        let mut next = [0.0; 3];
        for c in 0..3 {
            let slope = match last {
                Some((s0, r0)) if (scale[c] / s0[c]).ln().abs() > 1e-6 => {
                    ((ratio[c] / r0[c]).ln() / (scale[c] / s0[c]).ln()).clamp(0.5, 4.0)
                }
                _ => 1.0,
            };
            next[c] = (scale[c] * (-ratio[c].ln() / slope).exp()).min(room[c]);
        }
        last = Some((scale, ratio));
        if (0..3).all(|c| next[c] == scale[c]) {
            break;
        }
        scale = Rgb(next);
    }
    Ok(result)
}

/// A grey Kajiya–Kay fiber as a model.
fn build_kajiya_kay(k_d: f64, k_s: f64, p: f64) -> Result<Model, CompareError> {
    Ok(KajiyaKay::new(KajiyaKayParams { k_d: Rgb::splat(k_d), k_s: Rgb::splat(k_s), p })
        .map_err(ModelError::from)?
        .into())
}

/// A linear image as metric pixels.
#[must_use]
pub fn to_image(l: &LinearImage) -> Image {
    Image {
        width: l.width(),
        height: l.height(),
        pixels: l.pixels().iter().map(|p| [f64::from(p[0]), f64::from(p[1]), f64::from(p[2])]).collect(),
    }
}

/// Renders `scene` with `spp` samples per pixel as two halves of ⌈spp/2⌉, seeds `seed` and
/// `seed + 1`.
fn render_in_halves(scene: &Scene, settings: &RenderSettings, spp: u32, seed: u64) -> NoisyRender {
    let half = spp.div_ceil(2).max(1);
    let run = |seed: u64| {
        let s = RenderSettings { spp: half, seed, ..settings.clone() };
        render(scene, &s, &|_| {}, &AtomicBool::new(false)).image
    };
    let (a, b) = (run(seed), run(seed.wrapping_add(1)));
    NoisyRender::from_halves(&to_image(&a), &to_image(&b))
}

/// Replaces every hair material of `scene` by `model`.
fn set_hair_model(scene: &mut Scene, model: &Model) {
    scene.fiber_models_mut().for_each(|m| *m = model.clone());
}

/// The scene's hair: its first hair's model and that model's absorption.
fn scene_hair(scene: &Scene) -> Result<SceneHair, CompareError> {
    let model = scene
        .fibers()
        .first()
        .map(|f| scene.fiber_model(f.material()).clone())
        .ok_or_else(|| CompareError::Request("the scene has no hair with a fiber model".into()))?;
    Ok(SceneHair { sigma_a: model.chord_absorption(), model })
}

/// The models of `request` as the evaluation will render them (built, and Kajiya–Kay fitted,
/// before anything is rendered), with the scene's hair absorption.
pub fn entries(scene: &Scene, request: &EvaluationRequest) -> Result<(Vec<Entry>, Option<Rgb>), CompareError> {
    let hair = scene_hair(scene)?;
    let entries = request
        .models
        .iter()
        .map(|(name, user)| build_model(name, user, request.table.as_deref(), &hair))
        .collect::<Result<_, _>>()?;
    Ok((entries, hair.sigma_a))
}

/// Runs the evaluation of `request` on `scene` (rendered with `settings`; its hair materials
/// are replaced model by model), reporting as it goes.
pub fn evaluate(
    scene: &mut Scene,
    settings: &RenderSettings,
    request: &EvaluationRequest,
    mut report: impl FnMut(Progress<'_>),
) -> Result<(NoisyRender, Vec<ModelResult>), CompareError> {
    let hair = scene_hair(scene)?;
    let (entries, sigma_a) = entries(scene, request)?;
    // The reference model is built before anything is rendered, too.
    let reference_model = match (&request.reference_image, &request.table) {
        (Some(_), _) => None,
        (None, Some(t)) => Some(build_model(Measured::INFO.name, &[], Some(t), &hair)?.model),
        (None, None) => {
            return Err(CompareError::Request("give --table (measured reference render) or --reference IMAGE".into()));
        }
    };
    report(Progress::SceneHair(sigma_a));
    let reference = match (&request.reference_image, reference_model) {
        (Some(image), _) => NoisyRender::exact(image.clone()),
        (None, Some(measured)) => {
            set_hair_model(scene, &measured);
            // The reference's seeds (seed + 2, seed + 3) differ from the models' (seed, seed + 1).
            render_in_halves(scene, settings, request.reference_spp, settings.seed.wrapping_add(2))
        }
        (None, None) => unreachable!("checked above"),
    };
    report(Progress::Reference(&reference));
    let spp = request.spp.unwrap_or(settings.spp);
    // Where the hair is: the same camera and geometry for every model.
    let coverage = fiberlab_render::fiber_coverage::fiber_coverage(scene, HAIR_COVERAGE_RAYS);
    let mut results = Vec::new();
    for mut entry in entries {
        if let (Some(fit), KajiyaKayColour::Scene) = (entry.kajiya_kay_fit, request.kajiya_kay_colour) {
            report(Progress::Calibrating(&entry));
            let calibration_spp = spp.div_ceil(4).max(2);
            let c = colour_in_scene(fit, &hair.model, scene, settings, &coverage, calibration_spp)?;
            entry.given = format!(
                "{}; in the scene ×{} per channel (hair {} of the scene's model after {} renders at {calibration_spp} \
                 spp): k_d {}, k_s {}",
                entry.given,
                rgb_short(c.scale),
                rgb_short(c.last_ratio),
                c.rounds,
                rgb_short(c.params.k_d),
                rgb_short(c.params.k_s)
            );
            entry.model = KajiyaKay::new(c.params).map_err(ModelError::from)?.into();
            entry.kajiya_kay_fit = Some(c.params);
        }
        report(Progress::Rendering(&entry));
        set_hair_model(scene, &entry.model);
        let render = render_in_halves(scene, settings, spp, settings.seed);
        let (metrics, _) = compare(&reference.mean, &render.mean, None, false)?;
        let floor = noise_floor(&render, &reference);
        let hair_colour = hair_colour(&render.mean, &reference.mean, &coverage);
        let result = ModelResult { entry, render, metrics, floor, hair_colour };
        report(Progress::Model(&result));
        results.push(result);
    }
    Ok((reference, results))
}

/// Camera rays per pixel side for the hair coverage ([`hair_colour`]'s weights).
const HAIR_COVERAGE_RAYS: u32 = 4;

/// Per channel, `Σ c·model / Σ c·reference` over the pixels, weighted by the hair's coverage
/// `c` (`fiber_coverage`): how bright and what colour the hair comes out against the
/// reference (1, 1, 1: the same). 0 where the reference has nothing under the hair.
#[must_use]
pub fn hair_colour(model: &Image, reference: &Image, coverage: &LinearImage) -> Rgb {
    let mut sums = [[0.0f64; 3]; 2];
    for ((m, r), c) in model.pixels.iter().zip(&reference.pixels).zip(coverage.pixels()) {
        let w = f64::from(c[0]);
        for k in 0..3 {
            sums[0][k] += w * m[k];
            sums[1][k] += w * r[k];
        }
    }
    let ratio = |k: usize| if sums[1][k] > 0.0 { sums[0][k] / sums[1][k] } else { 0.0 };
    Rgb::new(ratio(0), ratio(1), ratio(2))
}

#[cfg(test)]
mod tests {
    use super::*;
    use fiberlab_scatter::hair::attenuation::hit_attenuation;

    /// The excess over the floor: a 3-4-5 triangle (RMSE 5 over a floor 3 leaves 4, 4/3× the
    /// floor), nothing where the RMSE is within the floor, and the noiseless ends.
    #[test]
    fn excess_over_floor_is_the_excess_in_units_of_the_floor() {
        assert!((excess_over_floor(5.0, 3.0) - 4.0 / 3.0).abs() < 1e-12);
        assert_eq!(excess_over_floor(2.0, 3.0), 0.0);
        assert_eq!(excess_over_floor(0.5, 0.0), f64::INFINITY);
        assert_eq!(excess_over_floor(0.0, 0.0), 0.0);
    }

    fn scene_hair_of(model: Model) -> SceneHair {
        SceneHair { sigma_a: model.chord_absorption(), model }
    }

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
            let hair = scene_hair_of(scene);
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
        let hair = scene_hair_of(build("chiang", &[("eumelanin", "0.8")]));
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

    /// Kajiya–Kay fitted to black hair (eumelanin 3) has the colour of the light the hair
    /// scatters toward the viewer's side, here by composite Simpson in θ_i and φ_i (an
    /// independent rule) at θ_o = 0: grey, not the copper of its transmission (the channel-by-
    /// channel fit gave k_s 0.065, 0.038, 0.031, R/B = 2.1). And it stays in the bound.
    #[test]
    fn fitted_kajiya_kay_has_the_colour_of_the_hair_s_reflection() {
        let target = build("chiang", &[("eumelanin", "3")]);
        let kk = fitted_kajiya_kay(&target).unwrap();
        let n = 120;
        let simpson = |k: usize| {
            if k == 0 || k == n {
                1.0
            } else if k % 2 == 1 {
                4.0
            } else {
                2.0
            }
        };
        let (dt, dp) = (PI / n as f64, PI / n as f64);
        let wo = direction(0.0, 0.0);
        let mut half = Rgb::ZERO;
        for i in 0..=n {
            let ti = -FRAC_PI_2 + i as f64 * dt;
            for j in 0..=n {
                let phi = -FRAC_PI_2 + j as f64 * dp;
                let w = simpson(i) * simpson(j) * ti.cos().powi(2);
                half += target.eval_far(direction(ti, phi), wo) * w;
            }
        }
        let want = half / half.luminance();
        let got = kk.k_s / kk.k_s.luminance();
        for c in 0..3 {
            assert!((got[c] - want[c]).abs() < 0.01 * want[c], "channel {c}: k_s colour {got:?}, reflected {want:?}");
        }
        assert!(got[0] / got[2] < 1.1, "not grey: {kk:?}");
        let mut brightest: f64 = 0.0;
        for t in bound_inclinations() {
            let hair = fiberlab_scatter::radiometry::furnace(
                &target,
                direction(t, 0.5),
                &fiberlab_scatter::radiometry::Quadrature { theta: 128, phi: 128, h: 8 },
            );
            for c in 0..3 {
                let w = kajiya_kay_furnace(kk.k_d[c], kk.k_s[c], kk.p, t);
                assert!(w <= hair[c] + 5e-3, "channel {c}, θ_o {t}: W = {w} > the hair's {}", hair[c]);
                brightest = brightest.max(w / hair[c]);
            }
        }
        assert!(brightest > 0.5, "trivially dark: W at most {brightest} of the hair's ({kk:?})");
    }

    /// The hair colour is a coverage-weighted ratio of channel sums: pixels the hair does not
    /// cover do not count, and a render equal to the reference gives 1, 1, 1.
    #[test]
    fn hair_colour_weighs_only_the_hair() {
        let image = |px: Vec<[f64; 3]>| Image { width: 2, height: 1, pixels: px };
        let reference = image(vec![[0.2, 0.2, 0.2], [5.0, 5.0, 5.0]]);
        let model = image(vec![[0.4, 0.2, 0.1], [1.0, 9.0, 0.0]]);
        let coverage = LinearImage::from_pixels(2, 1, vec![[1.0; 3], [0.0; 3]]).unwrap();
        let c = hair_colour(&model, &reference, &coverage);
        assert!((c[0] - 2.0).abs() < 1e-12 && (c[1] - 1.0).abs() < 1e-12 && (c[2] - 0.5).abs() < 1e-12, "{c:?}");
        let same = hair_colour(&reference, &reference, &coverage);
        assert_eq!([same[0], same[1], same[2]], [1.0; 3]);
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
        let lum: Vec<f64> = grid.iter().map(|&(wi, wo, _)| target.eval_far(wi, wo).luminance()).collect();
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

    /// Kajiya–Kay's colour in the scene: on brown hair over skin (a member of the generated
    /// scene family, 32², straight hair), the fiber fit alone leaves the hair's colour off
    /// the Chiang hair it stands for by more than 10 % in some channel (0.77, 0.98, 1.19 of
    /// it); after [`colour_in_scene`] (32 spp) a render at another seed and 64 spp is within
    /// 4 % of Chiang's (64 spp, another seed again) in every channel — the hair mean of Chiang
    /// at 32 spp varies by about 1.5 % between seeds here, the calibration inherits that — and
    /// every factor is within the energy bound's headroom.
    #[test]
    fn kajiya_kay_takes_the_hair_s_colour_in_the_scene() {
        use fiberlab_render::scene_family::{
            Density, FamilyScene, FamilySize, Floor, HairColour, LightSide, Skin, Sky,
        };
        let member = FamilyScene {
            density: Density::Dense,
            skin: Skin::Visible,
            light: LightSide::Front,
            sky: Sky::White,
            hair: HairColour::Brown,
            floor: Floor::None,
        };
        let size = FamilySize { px: 32, ..FamilySize::TEST };
        let file =
            fiberlab_render::scene_file::SceneFile::parse(&member.scene_text(&size, 4), Path::new("f.toml")).unwrap();
        let (mut scene, settings) = file.build().unwrap();
        let target = scene_hair(&scene).unwrap().model;
        let coverage = fiberlab_render::fiber_coverage::fiber_coverage(&scene, 4);
        let fit = fitted_kajiya_kay(&target).unwrap();
        let image_of = |scene: &mut Scene, model: &Model, seed: u64| {
            set_hair_model(scene, model);
            let s = RenderSettings { spp: 64, seed, ..settings.clone() };
            to_image(&render(scene, &s, &|_| {}, &AtomicBool::new(false)).image)
        };
        let kk = |p: KajiyaKayParams| -> Model { KajiyaKay::new(p).unwrap().into() };
        let wanted = image_of(&mut scene, &target, 100);
        let fiber_only = hair_colour(&image_of(&mut scene, &kk(fit), 200), &wanted, &coverage);
        assert!((0..3).any(|c| (fiber_only[c] - 1.0).abs() > 0.1), "the fiber fit is already right: {fiber_only:?}");
        let found = colour_in_scene(fit, &target, &mut scene, &settings, &coverage, 32).unwrap();
        let in_scene = hair_colour(&image_of(&mut scene, &kk(found.params), 200), &wanted, &coverage);
        for c in 0..3 {
            assert!(
                (in_scene[c] - 1.0).abs() < 0.04,
                "channel {c}: {in_scene:?} (fiber only {fiber_only:?}, {found:?})"
            );
        }
        let room = EnergyBound::of(&target).headroom(&kk(fit));
        for c in 0..3 {
            assert!(found.scale[c] <= room[c] * (1.0 + 1e-12), "channel {c}: {found:?} beyond {room:?}");
        }
    }
}
