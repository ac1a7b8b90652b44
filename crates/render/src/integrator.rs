//! Unidirectional path tracing with next-event estimation and multiple importance sampling
//! (power heuristic, Veach 1997 §9.2), Russian roulette, progressive passes of tiles in
//! parallel that can be stopped and continued, parts and merging.
//!
//! # Fiber hits (`docs/theory/conventions.md`, "Fiber scattering function versus renderer BSDF")
//! At a fiber hit the frame `(u, v, w)` and `h` come from [`fiberlab_geometry::curves`]; directions are
//! converted to that frame and the model's `f_s(ω_i, ω_o; h)` is evaluated. The throughput of
//! a light sample is `f_s·cosθ_i·L_i/pdf` with `cosθ_i = sqrt(1 − (ω_i·u)²)` measured from the
//! fiber's normal plane; a scattering sample multiplies the throughput by the model's
//! `weight = f_s·cosθ_i/pdf`. Because the tube is hit at a uniformly distributed `h` across
//! the pixel footprint, near-field models are averaged over the width as that section states;
//! far-field models ignore `h`. Delta models (`Lobes::Delta`) get no light sampling and no MIS.
//!
//! # Determinism
//! Sample values depend only on (pixel, sample index, seed) ([`crate::sampler`]), each pixel is
//! computed by one thread at a time, and the per-pixel sum is taken in sample order across
//! passes ([`crate::accumulation`]): the same seed gives the same image, bit for bit, for any
//! thread count, tile order, pass schedule, split into parts (rows bands or crops) that are
//! then merged, or stop and resume.

use crate::accumulation::{Accumulation, ResumeError};
use crate::dual_scattering::{Integrator, SurfaceBounce};
pub use crate::region::Region;
use crate::sampler::PixelSampler;
use crate::scene::{Hit, Scene, SurfaceMaterial};
use fiberlab_geometry::Ray;
use fiberlab_geometry::curves::CurveHit;
use fiberlab_geometry::mesh::ShadingFrame;
use fiberlab_io::LinearImage;
use fiberlab_math::frame::cos_theta;
use fiberlab_math::{DVec3, FiberFrame, Rgb};
use fiberlab_scatter::chiang_2016::ChiangAtVertex;
use fiberlab_scatter::{Lobes, Model, ScatteringFunction, SurfaceModel, SurfaceScattering};
use rayon::prelude::*;
use std::f64::consts::PI;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::Instant;

/// How to render.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderSettings {
    /// Samples per pixel.
    pub spp: u32,
    /// Largest number of scattering events (`u32::MAX`: no limit; Russian roulette ends paths).
    pub max_depth: u32,
    /// Depth from which Russian roulette applies.
    pub rr_depth: u32,
    /// Random seed.
    pub seed: u64,
    /// Pixels to render (`None`: all). Pixels outside are left black.
    pub region: Option<Region>,
    /// Tile edge, pixels.
    pub tile_size: u32,
    /// Worker threads (0: rayon's default, one per core); more than the machine's cores are
    /// capped at its cores ([`worker_threads`]).
    pub threads: usize,
    /// Stop after this instant (within one pixel's samples of the pass in flight).
    pub deadline: Option<Instant>,
    /// Path tracing or dual scattering ([`crate::dual_scattering`]).
    pub integrator: Integrator,
}

impl Default for RenderSettings {
    fn default() -> Self {
        Self {
            spp: 16,
            max_depth: 64,
            rr_depth: 3,
            seed: 0,
            region: None,
            tile_size: 16,
            threads: 0,
            deadline: None,
            integrator: Integrator::Path,
        }
    }
}

/// What happened during a render.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RenderStats {
    /// Passes started.
    pub passes: u32,
    /// Smallest samples per pixel over the region at the end.
    pub spp_min: u32,
    /// Largest samples per pixel over the region at the end (above `spp_min` only when
    /// stopped within a pass).
    pub spp_max: u32,
    /// Camera samples traced by this render.
    pub samples: u64,
    /// Samples whose radiance was NaN or infinite (counted as black, never added).
    pub nonfinite_samples: u64,
    /// Rays traced: camera and continuation rays plus shadow rays.
    pub rays: u64,
    /// Wall-clock seconds.
    pub seconds: f64,
    /// True when stopped (interrupt flag or deadline) before every pixel had its samples.
    pub interrupted: bool,
}

/// A rendered image, the state it was computed from, and statistics.
#[derive(Clone, Debug)]
pub struct RenderOutput {
    /// Linear RGB means, full resolution (unrendered pixels black), with the saved state
    /// ([`Accumulation::image`]).
    pub image: LinearImage,
    /// Per-pixel sums and counts.
    pub accumulation: Accumulation,
    /// Statistics.
    pub stats: RenderStats,
}

/// Power heuristic with exponent 2 for the strategy of density `a` against `b`.
#[must_use]
#[inline]
pub fn power_heuristic(a: f64, b: f64) -> f64 {
    let (a2, b2) = (a * a, b * b);
    if a2 + b2 > 0.0 { a2 / (a2 + b2) } else { 0.0 }
}

/// The scattering function at a hit, in world directions.
#[allow(clippy::large_enum_variant, reason = "one per path vertex on the stack; boxing would allocate per vertex")]
enum Local<'a> {
    /// `chiang`: the model prepared once at this vertex ([`ChiangAtVertex`]), shared by the
    /// light sample and the bounce sample; other models are evaluated from scratch each time.
    Fiber {
        model: &'a Model,
        frame: FiberFrame,
        wo: DVec3,
        h: f64,
        delta: bool,
        chiang: Option<ChiangAtVertex<'a>>,
    },
    Lambert {
        albedo: Rgb,
        n: DVec3,
    },
    Mirror {
        reflectance: Rgb,
        n: DVec3,
        wo: DVec3,
    },
    /// A surface model at the hit: its frame (z the shading normal facing `ω_o`), `ω_o` in it,
    /// and the geometric normal on `ω_o`'s side (directions below it are refused unless the
    /// model transmits, so that shading normals do not leak light through the surface).
    Surface {
        model: SurfaceModel,
        frame: ShadingFrame,
        wo: DVec3,
        ng: DVec3,
        transmits: bool,
    },
}

struct Scatter {
    wi: DVec3,
    weight: Rgb,
    pdf: f64,
    delta: bool,
}

impl<'a> Local<'a> {
    fn fiber(model: &'a Model, hit: &CurveHit, ray_d: DVec3) -> Self {
        let frame = hit.frame(ray_d);
        let delta = model.properties().lobes == Lobes::Delta;
        let wo = frame.to_local(-ray_d);
        let chiang = model.at_vertex(wo, hit.h);
        Local::Fiber { model, frame, wo, h: hit.h, delta, chiang }
    }

    fn is_delta(&self) -> bool {
        match self {
            Local::Fiber { delta, .. } => *delta,
            Local::Mirror { .. } => true,
            // A model with delta lobes may have others: light sampling evaluates those.
            Local::Lambert { .. } | Local::Surface { .. } => false,
        }
    }

    /// `f·cos` for light direction `wi` (world) and the density with which `sample` draws it.
    fn eval_cos_and_pdf(&self, wi: DVec3) -> (Rgb, f64) {
        match self {
            Local::Fiber { model, frame, wo, h, chiang, .. } => {
                let wi_l = frame.to_local(wi);
                let (f, pdf) = match chiang {
                    Some(c) => c.eval_and_pdf(wi_l),
                    None => model.eval_and_pdf(wi_l, *wo, *h),
                };
                (f * cos_theta(wi_l), pdf)
            }
            Local::Lambert { albedo, n } => {
                let cos = n.dot(wi).max(0.0);
                (*albedo * (cos / PI), cos / PI)
            }
            Local::Mirror { .. } => (Rgb::ZERO, 0.0),
            Local::Surface { model, frame, wo, ng, transmits } => {
                if !transmits && ng.dot(wi) <= 0.0 {
                    return (Rgb::ZERO, 0.0);
                }
                let wi_l = frame.to_local(wi);
                let (f, pdf) = model.eval_and_pdf(wi_l, *wo);
                (f * wi_l.z.abs(), pdf)
            }
        }
    }

    fn sample(&self, u: [f64; 4]) -> Option<Scatter> {
        match self {
            Local::Fiber { model, frame, wo, h, chiang, .. } => {
                let s = match chiang {
                    Some(c) => c.sample(u)?,
                    None => model.sample(*wo, *h, u)?,
                };
                Some(Scatter { wi: frame.to_world(s.wi).normalize(), weight: s.weight, pdf: s.pdf, delta: s.delta })
            }
            Local::Lambert { albedo, n } => {
                let t = n.any_orthonormal_vector();
                let wi = fiberlab_scatter::sampling::cosine_hemisphere(*n, t, u[0], u[1]).normalize();
                let pdf = n.dot(wi) / PI;
                (pdf > 0.0).then_some(Scatter { wi, weight: *albedo, pdf, delta: false })
            }
            Local::Mirror { reflectance, n, wo } => Some(Scatter {
                wi: (2.0 * n.dot(*wo) * *n - *wo).normalize(),
                weight: *reflectance,
                pdf: 0.0,
                delta: true,
            }),
            Local::Surface { model, frame, wo, ng, transmits } => {
                let s = model.sample(*wo, u)?;
                let wi = frame.to_world(s.wi).normalize();
                (*transmits || ng.dot(wi) > 0.0).then_some(Scatter { wi, weight: s.weight, pdf: s.pdf, delta: s.delta })
            }
        }
    }
}

/// Smallest ray distance for rays spawned at `p` (relative to the coordinates' magnitude).
fn spawn_epsilon(p: DVec3) -> f64 {
    1e-9 * (1.0 + p.abs().max_element())
}

/// Radiance arriving at the camera along `ray` (one path); adds the rays traced (path and
/// shadow rays) to `rays`.
#[must_use]
pub fn radiance(scene: &Scene, ray: Ray, sampler: &mut PixelSampler, settings: &RenderSettings, rays: &mut u64) -> Rgb {
    let mut ray = ray;
    let mut l = Rgb::ZERO;
    let mut beta = Rgb::ONE;
    let mut prev_delta = true;
    let mut prev_pdf = 0.0;
    let mut prev_p = ray.o;
    let picker = scene.light_picker();
    let mut depth = 0u32;
    // The ray left a fiber shaded by dual scattering (`surface_bounce`), and the surface it
    // meets ([`crate::dual_scattering::DualScattering::bounce`] has traced it).
    let mut after_dual = false;
    let mut bounced: Option<Hit> = None;
    loop {
        let next = match bounced.take() {
            Some(h) => Some(h),
            None => {
                *rays += 1;
                scene.intersect(&ray)
            }
        };
        let Some(hit) = next else {
            if after_dual {
                // Light straight from the environment: the dual terms at the fiber.
                break;
            }
            for (i, light) in scene.lights().iter().enumerate() {
                let le = light.escaped(ray.d);
                if le.is_black() {
                    continue;
                }
                let w = if prev_delta {
                    1.0
                } else {
                    power_heuristic(prev_pdf, picker.light_probability(i) * light.pdf(ray.d))
                };
                l += beta * le * w;
            }
            break;
        };
        // Dual scattering: one light sample at the first fiber, and the path ends there, unless
        // `surface_bounce` lets one sampled ray go on toward a surface.
        let mut dual_vertex = None;
        if let (Hit::Fiber { hit, material }, Integrator::DualScattering(dual)) = (&hit, &settings.integrator) {
            if after_dual {
                // Fiber to fiber: the dual terms' share.
                break;
            }
            let [u_pick, _] = sampler.next_2d();
            let u_light = sampler.next_2d();
            let shading = dual.shade_fiber(scene, hit, *material, ray.d, u_pick, u_light, rays);
            l += beta * shading.radiance;
            if dual.settings().surface_bounce == SurfaceBounce::Off {
                break;
            }
            dual_vertex = Some((dual, *hit, *material, shading));
        }
        let (p, local) = match hit {
            Hit::Fiber { hit, material } => (hit.p, Local::fiber(scene.fiber_model(material), &hit, ray.d)),
            Hit::Surface { p, n, shading, material, emitter, .. } => {
                if let Some(i) = emitter
                    && !after_dual
                    && let Some(light) = scene.spheres()[i].light()
                    && n.dot(ray.d) < 0.0
                {
                    let w = if prev_delta {
                        1.0
                    } else {
                        power_heuristic(prev_pdf, picker.sphere_probability(i) * light.pdf(prev_p, ray.d))
                    };
                    l += beta * light.radiance * w;
                }
                let facing = if n.dot(ray.d) < 0.0 { n } else { -n };
                let local = match scene.surface_material(material) {
                    SurfaceMaterial::Lambert(albedo) => Local::Lambert { albedo: *albedo, n: facing },
                    SurfaceMaterial::Mirror(r) => Local::Mirror { reflectance: *r, n: facing, wo: -ray.d },
                    SurfaceMaterial::Model(m) => {
                        let model = m.at(shading.uv);
                        let frame = shading.frame_facing(-ray.d);
                        let transmits = model.properties().transmits;
                        Local::Surface { model, frame, wo: frame.to_local(-ray.d), ng: facing, transmits }
                    }
                };
                (p, local)
            }
        };
        if depth >= settings.max_depth {
            break;
        }
        let eps = spawn_epsilon(p);
        // Next-event estimation (two dimension pairs, always consumed; at a dual-scattering
        // fiber, `shade_fiber` has done it).
        let (u_pick, u_light) = if dual_vertex.is_some() {
            (1.0, [0.0; 2])
        } else {
            let [u_pick, _] = sampler.next_2d();
            (u_pick, sampler.next_2d())
        };
        if dual_vertex.is_none()
            && !local.is_delta()
            && let Some((emitter, select)) = picker.pick(u_pick)
            && let Some(ls) = scene.sample_emitter(emitter, p, u_light)
        {
            let (f, bsdf_pdf) = local.eval_cos_and_pdf(ls.wi);
            if !f.is_black() && !ls.radiance.is_black() {
                let t_max = if ls.distance.is_finite() { ls.distance * (1.0 - 1e-9) - eps } else { f64::INFINITY };
                let shadow = Ray { o: p, d: ls.wi, t_min: eps, t_max };
                *rays += 1;
                if scene.unoccluded(&shadow) {
                    let p_light = select * ls.pdf;
                    let w = if ls.delta { 1.0 } else { power_heuristic(p_light, bsdf_pdf) };
                    l += beta * f * ls.radiance * (w / p_light);
                }
            }
        }
        // Scattering sample (two pairs) and Russian roulette (one pair).
        let (a, b) = (sampler.next_2d(), sampler.next_2d());
        let [u_rr, u_bounce] = sampler.next_2d();
        let u = [a[0], a[1], b[0], b[1]];
        let s = match dual_vertex {
            Some((dual, fiber, material, shading)) => {
                // Russian roulette on the bounce (`bounce_probability`, in (0, 1]).
                let q = dual.settings().bounce_probability;
                if u_bounce >= q {
                    break;
                }
                let Some((wi, pdf, weight)) =
                    dual.sample_bounce(scene, &fiber, material, ray.d, shading.spread_hint, u)
                else {
                    break;
                };
                let Some((surface, factor)) =
                    dual.bounce(scene, &fiber, material, ray.d, wi, pdf, weight, shading.back_depth, rays)
                else {
                    break;
                };
                beta *= factor / q;
                bounced = Some(surface);
                Scatter { wi, weight, pdf, delta: false }
            }
            None => {
                let Some(s) = local.sample(u) else { break };
                beta *= s.weight;
                s
            }
        };
        if beta.is_black() || !beta.is_finite() {
            break;
        }
        after_dual = dual_vertex.is_some();
        prev_delta = s.delta;
        prev_pdf = s.pdf;
        prev_p = p;
        depth += 1;
        if depth >= settings.rr_depth {
            let survive = beta.max_component().min(1.0);
            if u_rr >= survive {
                break;
            }
            beta = beta / survive;
        }
        ray = Ray { o: p, d: s.wi, t_min: eps, t_max: f64::INFINITY };
    }
    l
}

/// One tile's share of the accumulation, rendered by one thread at a time.
struct TileState {
    region: Region,
    sums: Vec<Rgb>,
    counts: Vec<u32>,
}

/// What one job (a tile brought to a pass's sample count) did.
#[derive(Default)]
struct JobStats {
    samples: u64,
    nonfinite: u64,
    rays: u64,
    seconds: f64,
}

/// Brings every pixel of `tile` to `target` samples, in sample order, unless `stop` says
/// otherwise (checked before each pixel, so a job ends within one pixel's samples).
fn render_tile(
    scene: &Scene,
    settings: &RenderSettings,
    tile: &mut TileState,
    target: u32,
    stop: &dyn Fn() -> bool,
) -> JobStats {
    let start = Instant::now();
    let mut job = JobStats::default();
    let t = tile.region;
    let mut k = 0;
    for y in t.y0..t.y1 {
        for x in t.x0..t.x1 {
            let (sum, count) = (&mut tile.sums[k], &mut tile.counts[k]);
            k += 1;
            if *count >= target {
                continue;
            }
            if stop() {
                job.seconds = start.elapsed().as_secs_f64();
                return job;
            }
            let mut sampler = PixelSampler::new(x, y, settings.seed);
            for i in *count..target {
                sampler.start(u64::from(i));
                let [jx, jy] = sampler.next_2d();
                let ray = scene.camera().ray(f64::from(x) + jx, f64::from(y) + jy);
                let l = radiance(scene, ray, &mut sampler, settings, &mut job.rays);
                if l.is_finite() {
                    *sum += l;
                } else {
                    job.nonfinite += 1;
                }
            }
            job.samples += u64::from(target - *count);
            *count = target;
        }
    }
    job.seconds = start.elapsed().as_secs_f64();
    job
}

/// Splits a region into tiles, row-major.
#[must_use]
pub fn tiles(region: Region, size: u32) -> Vec<Region> {
    let size = size.max(1);
    let mut out = Vec::new();
    let mut y = region.y0;
    while y < region.y1 {
        let mut x = region.x0;
        while x < region.x1 {
            out.push(Region { x0: x, y0: y, x1: (x + size).min(region.x1), y1: (y + size).min(region.y1) });
            x += size;
        }
        y += size;
    }
    out
}

/// Where a render is, reported after every job (a tile brought to the pass's sample count).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Progress {
    /// Pixel samples taken so far by this render.
    pub samples_done: u64,
    /// Pixel samples this render takes to bring every pixel to the target.
    pub samples_total: u64,
    /// The current pass, from 1.
    pub pass: u32,
    /// Samples per pixel every pixel has when this pass ends.
    pub pass_spp: u32,
}

/// A job (one tile through one pass) is sized to take about this long, so that passes
/// interleave the whole image often and the pass schedule adapts to the scene.
const JOB_SECONDS: f64 = 0.25;

/// Samples per pixel added by the next pass: about [`JOB_SECONDS`] per job judged from the
/// slowest job of the last pass (`seconds_per_spp`: its seconds per sample per pixel), at most
/// four times the last pass, at least one.
fn next_pass_spp(last: u32, seconds_per_spp: f64) -> u32 {
    let fit = if seconds_per_spp > 0.0 { JOB_SECONDS / seconds_per_spp } else { f64::INFINITY };
    (fit.floor().min(f64::from(last.saturating_mul(4)))).max(1.0) as u32
}

/// Renders the scene from scratch; see [`render_continuing`].
pub fn render(
    scene: &Scene,
    settings: &RenderSettings,
    progress: &(dyn Fn(&Progress) + Sync),
    stop: &AtomicBool,
) -> RenderOutput {
    let (w, h) = (scene.camera().width, scene.camera().height);
    render_continuing(scene, settings, Accumulation::new(w, h), progress, stop)
        .expect("a new accumulation has the camera's size")
}

/// Renders progressively, continuing `start` (e.g. the state saved in an earlier render's
/// image): passes over the whole region, each bringing every pixel to more samples, until
/// every pixel has `settings.spp`. Setting `stop` (e.g. from a Ctrl-C handler) or passing the
/// deadline ends the render within one pixel's samples of the pass in flight, keeping every
/// sample taken; the image then records each pixel's count ([`crate::accumulation`]).
///
/// A pixel's samples are added in index order whatever the passes, tiles, threads or
/// sessions, so the image depends only on the seed and each pixel's count.
pub fn render_continuing(
    scene: &Scene,
    settings: &RenderSettings,
    start: Accumulation,
    progress: &(dyn Fn(&Progress) + Sync),
    stop: &AtomicBool,
) -> Result<RenderOutput, ResumeError> {
    let t0 = Instant::now();
    let (w, h) = (scene.camera().width, scene.camera().height);
    if (start.width(), start.height()) != (w, h) {
        return Err(ResumeError::Size { found_w: start.width() as usize, found_h: start.height() as usize, w, h });
    }
    let full = Region::full(w, h);
    let region =
        settings.region.map_or(full, |r| Region { x0: r.x0.min(w), y0: r.y0.min(h), x1: r.x1.min(w), y1: r.y1.min(h) });
    let mut state: Vec<TileState> = tiles(region, settings.tile_size)
        .into_iter()
        .map(|t| {
            let (mut sums, mut counts) = (Vec::new(), Vec::new());
            for y in t.y0..t.y1 {
                for x in t.x0..t.x1 {
                    let (s, c) = start.pixel(x, y);
                    sums.push(s);
                    counts.push(c);
                }
            }
            TileState { region: t, sums, counts }
        })
        .collect();
    let target = settings.spp;
    let samples_total = start.samples_missing(region, target);
    let stopped = || {
        if stop.load(Ordering::Relaxed) {
            return true;
        }
        let late = settings.deadline.is_some_and(|d| Instant::now() >= d);
        if late {
            stop.store(true, Ordering::Relaxed);
        }
        late
    };
    let done = AtomicU64::new(0);
    let mut stats = RenderStats::default();
    let (mut reached, _) = start.count_range(region);
    let mut pass_size = 1;
    let mut run_passes = || {
        while reached < target && !stopped() {
            let pass_spp = reached.saturating_add(pass_size).min(target);
            stats.passes += 1;
            let pass = stats.passes;
            let jobs: Vec<JobStats> = state
                .par_iter_mut()
                .map(|tile| {
                    let job = render_tile(scene, settings, tile, pass_spp, &stopped);
                    let samples_done = done.fetch_add(job.samples, Ordering::Relaxed) + job.samples;
                    progress(&Progress { samples_done, samples_total, pass, pass_spp });
                    job
                })
                .collect();
            let mut slowest: f64 = 0.0;
            for (job, tile) in jobs.iter().zip(&state) {
                stats.samples += job.samples;
                stats.nonfinite_samples += job.nonfinite;
                stats.rays += job.rays;
                let pixels = tile.region.area().max(1) as f64;
                if job.samples > 0 {
                    slowest = slowest.max(job.seconds * pixels / job.samples as f64);
                }
            }
            if stop.load(Ordering::Relaxed) {
                break;
            }
            reached = pass_spp;
            pass_size = next_pass_spp(pass_size, slowest);
        }
    };
    match rayon::ThreadPoolBuilder::new().num_threads(worker_threads(settings.threads)).build() {
        Ok(pool) => pool.install(run_passes),
        Err(_) => run_passes(),
    }
    let mut accumulation = start;
    for tile in &state {
        let mut k = 0;
        for y in tile.region.y0..tile.region.y1 {
            for x in tile.region.x0..tile.region.x1 {
                accumulation.set_pixel(x, y, tile.sums[k], tile.counts[k]);
                k += 1;
            }
        }
    }
    (stats.spp_min, stats.spp_max) = accumulation.count_range(region);
    stats.interrupted = stats.spp_min < target;
    stats.seconds = t0.elapsed().as_secs_f64();
    Ok(RenderOutput { image: accumulation.image(region), accumulation, stats })
}

/// The worker threads a render runs for `asked` (0: one per core): at most the cores this
/// process may run on (`std::thread::available_parallelism`), since more threads add no speed
/// and each costs a stack and a share of every pass's scheduling (10⁵ threads turned a 1-spp
/// 32² render into 90 s).
#[must_use]
pub fn worker_threads(asked: usize) -> usize {
    let cores = std::thread::available_parallelism().map_or(1, std::num::NonZeroUsize::get);
    if asked == 0 { cores } else { asked.min(cores) }
}

/// Why parts could not be merged.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
pub enum MergeError {
    /// No parts given.
    #[error("no parts to merge")]
    Empty,
    /// A part's size differs from the first part's.
    #[error("part {index} is {found_w}×{found_h}, expected {w}×{h}")]
    Size {
        /// Index of the part.
        index: usize,
        /// Its width.
        found_w: usize,
        /// Its height.
        found_h: usize,
        /// Expected width.
        w: usize,
        /// Expected height.
        h: usize,
    },
    /// Two parts both rendered a pixel.
    #[error("part {index} rendered pixel x = {x}, y = {y}, which an earlier part rendered too")]
    Overlap {
        /// Index of the part.
        index: usize,
        /// Column.
        x: usize,
        /// Row.
        y: usize,
    },
}

/// Merges parts rendered with disjoint regions (e.g. [`Region::part`]) and the same seed:
/// every pixel is black in all parts but the one that rendered it, so the sum reproduces the
/// one-machine render bit for bit (`x + 0 = x` exactly). The saved state channels are merged
/// the same way (each pixel's from the one part that has it, so the merged image can be
/// continued), and the attributes on which every part agrees are kept.
pub fn merge(parts: &[LinearImage]) -> Result<LinearImage, MergeError> {
    let first = parts.first().ok_or(MergeError::Empty)?;
    let (w, h) = (first.width(), first.height());
    let mut out = LinearImage::new(w, h);
    for (index, p) in parts.iter().enumerate() {
        if p.width() != w || p.height() != h {
            return Err(MergeError::Size { index, found_w: p.width(), found_h: p.height(), w, h });
        }
        for (o, q) in out.pixels_mut().iter_mut().zip(p.pixels()) {
            for k in 0..3 {
                o[k] += q[k];
            }
        }
    }
    for (key, value) in first.attributes() {
        if parts.iter().all(|p| p.attribute(key) == Some(value.as_str())) {
            out.set_attribute(key, value.clone());
        }
    }
    for name in first.uint_channels().keys() {
        let Some(channels) = parts.iter().map(|p| p.uint_channel(name)).collect::<Option<Vec<_>>>() else {
            continue;
        };
        let mut merged = vec![0u32; w * h];
        for (index, channel) in channels.iter().enumerate() {
            for (i, (m, &v)) in merged.iter_mut().zip(channel.iter()).enumerate() {
                if v != 0 && *m != 0 {
                    return Err(MergeError::Overlap { index, x: i % w, y: i / w });
                }
                *m |= v;
            }
        }
        out.set_uint_channel(name, merged).expect("one value per pixel");
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::Camera;
    use crate::light::Light;
    use crate::scene::SceneBuilder;
    use fiberlab_geometry::shapes::TriangleMesh;
    use fiberlab_procedural::generator::{HairParams, Style};

    /// Lossless models of every kind: Chiang 2016 with σ_a = 0 (near-field; its sample weight is
    /// exactly 1 on the camera side) and the ideal specular fiber (a delta lobe: no light
    /// sampling, no MIS). A hair-only white furnace renders 1 in every fiber pixel.
    #[test]
    fn white_furnace_with_lossless_chiang_and_specular_hair() {
        for (name, params) in [("chiang", vec![("sigma_a", "0")]), ("specular", vec![("azimuth", "mirror")])] {
            let mut scene = furnace_scene(1.0, false).build();
            let model = fiberlab_scatter::build(name, &params).unwrap();
            scene.fiber_models_mut().for_each(|m| *m = model.clone());
            let out = render(&scene, &settings(32), &|_| {}, &AtomicBool::new(false));
            assert_eq!(out.stats.nonfinite_samples, 0);
            let (mean, n) = fiber_pixel_mean(&scene, &out.image);
            eprintln!("{name} furnace: {n} fiber pixels, mean {mean}");
            assert!(n > 100, "only {n} fiber pixels");
            assert!((mean - 1.0).abs() < 0.01, "{name}: mean over {n} fiber pixels {mean}");
        }
    }

    /// Mean green value over pixels whose centre ray hits a fiber, and how many there are.
    fn fiber_pixel_mean(scene: &Scene, image: &LinearImage) -> (f64, usize) {
        let (mut sum, mut n) = (0.0, 0);
        for y in 0..image.height() {
            for x in 0..image.width() {
                let ray = scene.camera().ray(x as f64 + 0.5, y as f64 + 0.5);
                if let Some(Hit::Fiber { .. }) = scene.intersect(&ray) {
                    sum += f64::from(image.get(x, y)[1]);
                    n += 1;
                }
            }
        }
        (sum / n.max(1) as f64, n)
    }

    fn furnace_scene(albedo: f64, head: bool) -> SceneBuilder {
        let hair = HairParams {
            strands: 400,
            segments: 12,
            clumps: 10,
            style: Style::Curly,
            root_diameter: 0.02,
            ..HairParams::default()
        }
        .generate()
        .unwrap();
        let fiber = fiberlab_scatter::build("diffuse", &[("albedo", albedo.to_string())]).unwrap();
        let camera =
            Camera::look_at(DVec3::new(0.0, 0.3, 5.0), DVec3::new(0.0, 0.0, 0.0), DVec3::Y, 40.0, 24, 24).unwrap();
        let mut b = SceneBuilder::new(camera);
        let (fiber, skin) = (b.fiber_material(fiber), b.surface_material(SurfaceMaterial::Lambert(Rgb::splat(albedo))));
        b.fibers(hair.curve_set(), fiber).light(Light::Constant { radiance: Rgb::ONE });
        if head {
            b.sphere(DVec3::ZERO, 1.0, skin, None);
        }
        b
    }

    /// A Lambertian floor of albedo `rho` seen from straight above through a narrow view.
    fn floor_scene(rho: f64, eye_height: f64, fov: f64, side: u32) -> (SceneBuilder, crate::scene::SurfaceMaterialId) {
        let camera = Camera::look_at(DVec3::new(0.0, eye_height, 0.0), DVec3::ZERO, DVec3::Z, fov, side, side).unwrap();
        let mut b = SceneBuilder::new(camera);
        let floor = b.surface_material(SurfaceMaterial::Lambert(Rgb::splat(rho)));
        b.mesh(TriangleMesh::floor(0.0, 100.0), floor);
        (b, floor)
    }

    /// A Lambertian floor under a constant sky `L` and a sun of irradiance `E` at elevation
    /// cosine `c` has radiance `ρ(L + E·c/π)` exactly (∫_cone ω dω = axis·π sin²α). Tests the
    /// MIS weights of two overlapping lights with both strategies.
    #[test]
    fn lambert_floor_under_sky_and_sun_matches_closed_form() {
        let sun_dir = DVec3::new(1.0, 2.0, 0.5).normalize();
        let (mut b, _) = floor_scene(0.5, 3.0, 30.0, 8);
        b.light(Light::Constant { radiance: Rgb::splat(0.3) }).light(Light::sun(sun_dir, 0.1, Rgb::splat(2.0)));
        let scene = b.build();
        let out = render(&scene, &settings(256), &|_| {}, &AtomicBool::new(false));
        let px = out.image.pixels();
        let mean: f64 = px.iter().map(|p| f64::from(p[0])).sum::<f64>() / px.len() as f64;
        let expected = 0.5 * (0.3 + 2.0 * sun_dir.y / PI);
        assert!((mean / expected - 1.0).abs() < 0.01, "{mean} vs {expected}");
    }

    /// A point on a Lambertian floor straight below an emitting sphere (radius r, centre at
    /// height d, radiance L) receives `E = π L r²/d²` exactly: radiance `ρ L r²/d²`. The camera
    /// looks straight down past the sphere through a narrow field of view.
    #[test]
    fn lambert_floor_under_a_sphere_light_matches_closed_form() {
        let (r, d, l) = (0.5, 2.0, 8.0);
        let (mut b, floor) = floor_scene(0.5, 1.0, 0.5, 4);
        b.sphere(DVec3::new(0.0, d, 0.0), r, floor, Some(Rgb::splat(l)));
        let scene = b.build();
        // Depth 1: direct light only (the lit sphere's diffuse bounce would add more).
        let s = RenderSettings { max_depth: 1, ..settings(256) };
        let out = render(&scene, &s, &|_| {}, &AtomicBool::new(false));
        let px = out.image.pixels();
        let mean: f64 = px.iter().map(|p| f64::from(p[0])).sum::<f64>() / px.len() as f64;
        let expected = 0.5 * l * r * r / (d * d);
        assert!((mean / expected - 1.0).abs() < 0.01, "{mean} vs {expected}");
    }

    /// A Lambertian floor (albedo ρ) lit by a delta distant light of irradiance E at elevation
    /// θ from the normal has radiance `ρ E cosθ / π`, exactly, at any spp; three rays
    /// per sample (camera, shadow, escaping continuation).
    #[test]
    fn lambert_floor_under_a_distant_light_matches_closed_form() {
        let (rho, e, theta) = (0.5, 3.0, 0.6_f64);
        let direction = DVec3::new(theta.sin(), theta.cos(), 0.0);
        let (mut b, _) = floor_scene(rho, 1.0, 0.5, 4);
        b.light(Light::Distant { direction, irradiance: Rgb::splat(e) });
        let scene = b.build();
        let s = RenderSettings { max_depth: 1, ..settings(2) };
        let out = render(&scene, &s, &|_| {}, &AtomicBool::new(false));
        let expected = rho * e * theta.cos() / PI;
        for p in out.image.pixels() {
            assert!((f64::from(p[0]) / expected - 1.0).abs() < 1e-5, "{p:?} vs {expected}");
        }
        assert_eq!(out.stats.rays, 16 * 2 * 3, "camera, shadow and escaping continuation ray per sample");
    }

    fn settings(spp: u32) -> RenderSettings {
        RenderSettings { spp, max_depth: u32::MAX, seed: 7, ..RenderSettings::default() }
    }

    #[test]
    fn white_furnace_lossless_fibers_and_head_render_one() {
        let scene = furnace_scene(1.0, true).build();
        let out = render(&scene, &settings(64), &|_| {}, &AtomicBool::new(false));
        assert_eq!(out.stats.nonfinite_samples, 0);
        let px = out.image.pixels();
        let mean: f64 = px.iter().map(|p| f64::from(p[0] + p[1] + p[2]) / 3.0).sum::<f64>() / px.len() as f64;
        assert!((mean - 1.0).abs() < 0.01, "mean {mean}");
        for p in px {
            assert!((f64::from(p[1]) - 1.0).abs() < 0.25, "pixel {p:?}");
        }
        // Pixels that see hair (not the head): hair-only scene.
        let hair_scene = furnace_scene(1.0, false).build();
        let hair_only = render(&hair_scene, &settings(64), &|_| {}, &AtomicBool::new(false));
        let (m, n) = fiber_pixel_mean(&hair_scene, &hair_only.image);
        eprintln!("diffuse furnace: {n} fiber pixels, mean {m}");
        assert!(n > 100, "only {n} fiber pixels");
        assert!((m - 1.0).abs() < 0.01, "hair-only mean over {n} fiber pixels {m}");
        // A lossy assembly is darker: the test can fail.
        let lossy_scene = furnace_scene(0.5, false).build();
        let lossy = render(&lossy_scene, &settings(16), &|_| {}, &AtomicBool::new(false));
        let (m, _) = fiber_pixel_mean(&lossy_scene, &lossy.image);
        assert!(m < 0.9, "lossy mean {m}");
    }

    #[test]
    fn same_seed_same_image_for_any_threads_and_parts_merge_bit_for_bit() {
        let mut b = furnace_scene(0.7, true);
        b.light(Light::sun(DVec3::new(1.0, 1.0, 1.0), 0.05, Rgb::splat(2.0)));
        let scene = b.build();
        let s1 = RenderSettings { threads: 1, max_depth: 16, ..settings(4) };
        let s2 = RenderSettings { threads: 2, tile_size: 7, ..s1.clone() };
        let a = render(&scene, &s1, &|_| {}, &AtomicBool::new(false)).image;
        let b = render(&scene, &s2, &|_| {}, &AtomicBool::new(false)).image;
        assert_eq!(a, b);
        let parts: Vec<LinearImage> = (0..3)
            .map(|i| {
                let s = RenderSettings { region: Some(Region::part(i, 3, 24, 24)), ..s2.clone() };
                render(&scene, &s, &|_| {}, &AtomicBool::new(false)).image
            })
            .collect();
        assert_eq!(merge(&parts).unwrap(), a);
        assert!(matches!(merge(&[]), Err(MergeError::Empty)));
    }

    #[test]
    fn interrupt_keeps_every_sample_and_resume_is_bit_identical_to_one_render() {
        let mut b = furnace_scene(0.7, true);
        b.light(Light::sun(DVec3::new(1.0, 1.0, 1.0), 0.05, Rgb::splat(2.0)));
        let scene = b.build();
        let s = RenderSettings { threads: 2, tile_size: 5, max_depth: 16, ..settings(9) };
        let whole = render(&scene, &s, &|_| {}, &AtomicBool::new(false));
        assert!(!whole.stats.interrupted);
        assert_eq!((whole.stats.spp_min, whole.stats.spp_max), (9, 9));
        assert_eq!(whole.image.attribute("spp"), Some("9"));
        assert!(whole.stats.passes >= 2, "the first pass takes one sample per pixel");

        // Stopped before anything: nothing rendered, reported as interrupted.
        let none = render(&scene, &s, &|_| {}, &AtomicBool::new(true));
        assert!(none.stats.interrupted && none.stats.samples == 0 && none.stats.passes == 0);

        // Stopped in the middle of the first pass (after the 4th job): some pixels have a
        // sample, the rest none; every sample taken is kept.
        let stop = AtomicBool::new(false);
        let jobs = AtomicU64::new(0);
        let one_thread = RenderSettings { threads: 1, ..s.clone() };
        let cut = render(
            &scene,
            &one_thread,
            &|_| {
                if jobs.fetch_add(1, Ordering::Relaxed) == 3 {
                    stop.store(true, Ordering::Relaxed);
                }
            },
            &stop,
        );
        assert!(cut.stats.interrupted);
        assert_eq!((cut.stats.spp_min, cut.stats.spp_max), (0, 1));
        assert_eq!(cut.stats.samples, 4 * 25, "four 5×5 tiles, one sample each");
        assert_eq!(cut.image.attribute("spp_max"), Some("1"));

        // Continue it through its image (as `--resume` does: via the EXR channels) in two
        // more sessions, each with a different thread count and tile size: the same bits.
        let mut state = Accumulation::from_image(&cut.image, 24, 24).unwrap();
        for (spp, threads, tile_size) in [(4, 1, 7), (9, 2, 16)] {
            let s2 = RenderSettings { spp, threads, tile_size, ..s.clone() };
            let out = render_continuing(&scene, &s2, state, &|_| {}, &AtomicBool::new(false)).unwrap();
            assert_eq!((out.stats.spp_min, out.stats.spp_max), (spp, spp));
            state = Accumulation::from_image(&out.image, 24, 24).unwrap();
            if spp == 9 {
                assert_eq!(out.image, whole.image);
                assert_eq!(out.stats.samples, 24 * 24 * 5);
            }
        }
        let wrong = Accumulation::new(8, 8);
        assert!(matches!(
            render_continuing(&scene, &s, wrong, &|_| {}, &AtomicBool::new(false)),
            Err(ResumeError::Size { .. })
        ));
    }

    #[test]
    fn a_deadline_stops_the_render_within_a_pass() {
        let scene = furnace_scene(0.7, true).build();
        let s = RenderSettings { deadline: Some(Instant::now()), ..settings(1_000_000_000) };
        let out = render(&scene, &s, &|_| {}, &AtomicBool::new(false));
        assert!(out.stats.interrupted);
        assert!(out.stats.spp_max <= 1, "{:?}", out.stats);
    }

    #[test]
    fn pass_sizes_follow_the_job_time_and_grow_at_most_fourfold() {
        assert_eq!(next_pass_spp(1, 0.0), 4);
        assert_eq!(next_pass_spp(8, JOB_SECONDS / 10.0), 10);
        assert_eq!(next_pass_spp(8, JOB_SECONDS * 3.0), 1);
        assert_eq!(next_pass_spp(u32::MAX, 1e-12), u32::MAX);
    }
}
