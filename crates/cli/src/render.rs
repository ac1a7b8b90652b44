//! `fiberlab render`: path-trace a scene (or the built-in default scene) to linear EXR and
//! tone-mapped PNG, progressively (passes over the whole image), with a progress bar, a time
//! limit, Ctrl-C, `--resume` and `--tile I/N` / `--crop` parts for `fiberlab merge`.
//!
//! # Stopping and continuing
//! Ctrl-C (SIGINT), SIGTERM, SIGHUP or `--time-limit` stops the render within one pixel's
//! samples of the pass in flight and keeps every sample taken. A render that stopped before
//! every pixel had its samples is written to `PREFIX.partial.exr` / `.png` (never over a
//! finished `PREFIX.exr`); the exit status is 130 after a signal (`crate::interrupt`) and 0
//! after the time limit. A second signal quits at once, writing nothing (and leaving no
//! temporary file). A time limit too long to count (`1e300` seconds) means no limit. `--resume FILE.exr` continues the render saved in FILE (partial or
//! finished: its per-pixel sums and counts travel in the EXR, `fiberlab_render::accumulation`)
//! to `--spp`; the result is bit-identical to one uninterrupted render. When the continued
//! render finishes, the `.partial` files it continued are removed.

use crate::arg_values::{self, PixelRect, Tile};
use anyhow::Context;
use fiberlab_io::LinearImage;
use fiberlab_io::ToneMap;
use fiberlab_render::accumulation::Accumulation;
use fiberlab_render::dual_scattering::Integrator;
use fiberlab_render::integrator::{Progress, Region, RenderSettings};
use fiberlab_render::render_request::RenderOptions;
use fiberlab_render::scene_file::SceneFile;
use indicatif::{ProgressBar, ProgressStyle};
use std::path::{Path, PathBuf};
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

/// Flags of `fiberlab render`, each read and validated by its value parser.
#[derive(clap::Args)]
pub struct Args {
    /// Scene file (TOML); the built-in default scene when omitted.
    scene: Option<PathBuf>,
    /// Use this hair file (`.hair`, `.pbrt`, `.pbrt.gz` or `.usda`) for the scene's hair.
    #[arg(long)]
    hair: Option<PathBuf>,
    /// Samples per pixel, ≥ 1 (default: the scene's).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    spp: Option<u32>,
    /// Stop after this many seconds (within a pass); writes what is done to PREFIX.partial.exr.
    #[arg(long, value_name = "SECONDS", value_parser = arg_values::seconds)]
    time_limit: Option<f64>,
    /// Worker threads (0: all cores; more than the machine's cores run as many as it has).
    #[arg(long, default_value_t = 0)]
    threads: usize,
    /// Random seed (default: the scene's).
    #[arg(long)]
    seed: Option<u64>,
    /// Maximum path depth (default: the scene's).
    #[arg(long)]
    max_depth: Option<u32>,
    /// `path` or `dual-scattering` (default: the scene's `[render] integrator`).
    #[arg(long, value_name = "NAME", value_parser = ["path", "dual-scattering"])]
    integrator: Option<String>,
    /// With dual scattering: count the fibers toward the light `exact`ly (a walk through the
    /// BVH) or from a density `grid` (default: the scene's `[render] fiber_count`).
    #[arg(long, value_name = "exact|grid", value_parser = ["exact", "grid"])]
    fiber_count: Option<String>,
    /// With dual scattering, a constant or choice (defaults shown): `d_f=0.5`, `bounce_d_f=1` (d_f of the light off a surface that the through bounce finds), `d_b=1`, `k_back=0.25`,
    /// `pi=on|off` (on), `spread=weighted|literal`, `global=energy|forward-mean`, `grid=64`
    /// (cells along the longest side), `grid_near=1` (grid count: the first this many cells of a ray
    /// walked exactly, the grid beyond; 0 = grid only), `cutoff=1e-4` (the exact count stops below this ∏ā_f),
    /// `bounce_cutoff=0.01` (the same for the count toward a surface), `bounce_p=1` (Russian roulette:
    /// the bounce toward a surface is traced with this probability, weight 1/p), `bounce_sampling=mixture|model` (how the bounce toward a surface draws its direction: the mixture of the fiber's sampler and the dual lobes, or the fiber's sampler alone), `back_depth=counted|infinite` (the hair behind a fiber that its backscatter assumes: the fibers the camera ray meets beyond it, or a half-space), `a_f=beam|averaged` (the factors of ∏a_f on a counted line: light from the line's own azimuth, or the paper's average over a half-circle), `back_series=at-fiber|paper` (the backscatter series: the returning light ends at the fiber, or the paper's), `bounce_back=on|off` (on: the light the through bounce finds gets the local backscatter term as a light's does), `surface_bounce=through|on|off` (through: light off surfaces
    /// reaches the hair through the fibers in between; on: only with no fiber in between; off:
    /// left out). Repeatable.
    #[arg(long = "dual", value_name = "KEY=VALUE")]
    dual: Vec<String>,
    /// Image size in pixels instead of the scene camera's (a quick preview: `--size 128x128`);
    /// the vertical field of view stays the scene's.
    #[arg(long, value_name = "WxH", value_parser = arg_values::image_size)]
    size: Option<arg_values::ImageSize>,
    /// Render only part I of N (0-based bands of rows), for `fiberlab merge`.
    #[arg(long, value_name = "I/N", value_parser = arg_values::tile)]
    tile: Option<Tile>,
    /// Render only the pixels x0,y0,x1,y1 (half-open), for `fiberlab merge`.
    #[arg(long, value_name = "X0,Y0,X1,Y1", conflicts_with = "tile", value_parser = arg_values::pixel_rect)]
    crop: Option<PixelRect>,
    /// Continue the render saved in this EXR (written by `fiberlab render`, finished or
    /// `.partial`) up to --spp: same scene, seed and part; bit-identical to one long render.
    #[arg(long, value_name = "FILE.exr")]
    resume: Option<PathBuf>,
    /// Output prefix: writes PREFIX.exr and PREFIX.png (PREFIX.partial.* when stopped early).
    /// Default: `render`, or the prefix of the --resume file.
    #[arg(long, value_name = "PREFIX", value_parser = arg_values::out_prefix)]
    out: Option<arg_values::OutPrefix>,
    /// Exposure for the PNG in stops (default: the scene's).
    #[arg(long, allow_hyphen_values = true, value_parser = arg_values::finite)]
    exposure: Option<f64>,
    /// Where to render: `cpu`, `gpu` (the GPU path tracer; software Vulkan counts) or `auto`
    /// (a hardware GPU when there is one, else the CPU). `fiberlab devices` lists the GPUs.
    #[arg(long, value_name = "cpu|gpu|auto", default_value = "cpu", value_parser = ["cpu", "gpu", "auto"])]
    device: String,
    /// No progress bar.
    #[arg(long)]
    quiet: bool,
    #[command(flatten)]
    pub(crate) memory: crate::memory_budget::MemoryLimit,
}

/// Which pixels to render.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Pixels {
    All,
    Tile(Tile),
    Crop(PixelRect),
}

impl std::fmt::Display for Pixels {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Pixels::All => write!(f, "the whole image"),
            Pixels::Tile(t) => write!(f, "part {}/{}", t.index, t.count),
            Pixels::Crop(c) => {
                let r = c.region();
                write!(f, "crop {},{},{},{}", r.x0, r.y0, r.x1, r.y1)
            }
        }
    }
}

impl Pixels {
    /// The region of a `width × height` image (`None`: all of it).
    fn region(self, width: u32, height: u32) -> anyhow::Result<Option<Region>> {
        Ok(match self {
            Pixels::All => None,
            Pixels::Tile(t) => Some(t.region(width, height).map_err(|e| anyhow::anyhow!("--tile {e}"))?),
            Pixels::Crop(c) => Some(c.within(width, height).map_err(|e| anyhow::anyhow!("--crop {e}"))?),
        })
    }
}

/// `fiberlab render`'s validated configuration: what the flags mean, before the scene is read.
struct Config<'a> {
    args: &'a Args,
    pixels: Pixels,
    time_limit: Option<Duration>,
    out: arg_values::OutPrefix,
    resume: Option<Resumed>,
}

/// The render `--resume` continues: its image and what its header says it is.
struct Resumed {
    path: PathBuf,
    image: LinearImage,
    scene: String,
    seed: u64,
    pixels: Pixels,
}

impl Resumed {
    fn read(path: &Path) -> anyhow::Result<Self> {
        let image = LinearImage::read_exr(path)?;
        let get = |key: &str| {
            image.attribute(key).map(str::to_string).with_context(|| {
                format!(
                    "--resume {}: its header has no `{key}`: not an image written by `fiberlab render`",
                    path.display()
                )
            })
        };
        let (scene, seed) = (get("scene")?, get("seed")?);
        let seed =
            seed.parse().with_context(|| format!("--resume {}: its seed `{seed}` is not a number", path.display()))?;
        let place = |e: String| anyhow::anyhow!("--resume {}: {e}", path.display());
        let pixels = match (image.attribute("part"), image.attribute("crop")) {
            (Some(part), _) => Pixels::Tile(arg_values::tile(part).map_err(place)?),
            (None, Some(crop)) => Pixels::Crop(arg_values::pixel_rect(crop).map_err(place)?),
            (None, None) => Pixels::All,
        };
        Ok(Self { path: path.to_path_buf(), image, scene, seed, pixels })
    }
}

/// The output prefix of a `--resume` file: its path without `.partial.exr` or `.exr`.
fn resumed_prefix(path: &Path) -> anyhow::Result<arg_values::OutPrefix> {
    let text = path.to_string_lossy();
    let stem = text.strip_suffix(".partial.exr").or_else(|| text.strip_suffix(".exr")).unwrap_or(&text);
    arg_values::out_prefix(stem).map_err(|e| anyhow::anyhow!("--resume {}: {e}", path.display()))
}

impl<'a> Config<'a> {
    fn new(args: &'a Args) -> anyhow::Result<Self> {
        let resume = args.resume.as_deref().map(Resumed::read).transpose()?;
        let flagged = match (args.tile, args.crop) {
            (Some(t), _) => Some(Pixels::Tile(t)),
            (_, Some(c)) => Some(Pixels::Crop(c)),
            _ => None,
        };
        let pixels = match (&resume, flagged) {
            (Some(r), Some(p)) if p != r.pixels => {
                anyhow::bail!("--resume {}: it renders {}, the flags ask for {}", r.path.display(), r.pixels, p)
            }
            (Some(r), _) => r.pixels,
            (None, p) => p.unwrap_or(Pixels::All),
        };
        if let Some(r) = &resume
            && let Some(seed) = args.seed
            && seed != r.seed
        {
            anyhow::bail!("--resume {}: it was rendered with seed {}, not --seed {seed}", r.path.display(), r.seed);
        }
        let out = match (&args.out, &resume) {
            (Some(out), _) => out.clone(),
            (None, Some(r)) => resumed_prefix(&r.path)?,
            (None, None) => arg_values::out_prefix("render").map_err(anyhow::Error::msg)?,
        };
        // A limit beyond what a Duration counts (~5.8e11 years) is no limit.
        let time_limit = args.time_limit.and_then(|s| Duration::try_from_secs_f64(s).ok());
        Ok(Self { args, pixels, time_limit, out, resume })
    }

    /// What the flags ask of the scene: the one render request the library validates (the
    /// seed of a `--resume` file unless `--seed` is given).
    fn options(&self) -> RenderOptions {
        let a = self.args;
        RenderOptions {
            spp: a.spp,
            seed: a.seed.or(self.resume.as_ref().map(|r| r.seed)),
            max_depth: a.max_depth,
            threads: a.threads,
            integrator: a.integrator.clone(),
            fiber_count: a.fiber_count.clone(),
            dual: a.dual.clone(),
        }
    }
}

/// A stable 64-bit hash (FNV-1a) of what determines the image besides seed, spp and pixels:
/// the scene text (the default scene's when none is given), the `--hair` file's bytes and
/// the maximum depth. Written as hex into each part's header and compared by `merge`.
fn scene_hash(args: &Args) -> anyhow::Result<String> {
    fn fnv1a(mut h: u64, bytes: &[u8]) -> u64 {
        for &b in bytes {
            h = (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3);
        }
        h
    }
    let read = |p: &PathBuf| fiberlab_io::input_file::read_bytes(p).map_err(anyhow::Error::from);
    let mut h = 0xcbf2_9ce4_8422_2325;
    h = match &args.scene {
        Some(p) => fnv1a(h, &read(p)?),
        None => fnv1a(h, fiberlab_render::scene_file::DEFAULT_SCENE.as_bytes()),
    };
    if let Some(p) = &args.hair {
        h = fnv1a(fnv1a(h, b"hair"), &read(p)?);
    }
    h = fnv1a(h, format!("max_depth={:?}", args.max_depth).as_bytes());
    if let Some(size) = args.size {
        h = fnv1a(h, format!("size={}x{}", size.width, size.height).as_bytes());
    }
    if args.integrator.is_some() || args.fiber_count.is_some() || !args.dual.is_empty() {
        let text = format!("integrator={:?} fiber_count={:?} dual={:?}", args.integrator, args.fiber_count, args.dual);
        h = fnv1a(h, text.as_bytes());
    }
    Ok(format!("{h:016x}"))
}

/// Runs `fiberlab render`.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let config = Config::new(args)?;
    let t0 = Instant::now();
    let mut file = match &args.scene {
        Some(p) => SceneFile::read(p)?,
        None => SceneFile::default_scene(),
    };
    if let Some(size) = args.size {
        file.override_image_size(size.width, size.height);
    }
    // Pixels are checked against the camera's size, before hair and BVHs are built.
    let (w, h) = file.image_size();
    let region = config.pixels.region(w, h)?;
    if let Some(h) = &args.hair {
        file.override_hair(h.clone())?;
    }
    args.memory.check_scene(&file)?;
    let scene_hash = scene_hash(args)?;
    let start = match &config.resume {
        None => Accumulation::new(w, h),
        Some(r) => {
            let context = || format!("--resume {}", r.path.display());
            anyhow::ensure!(
                r.scene == scene_hash,
                "{}: it is a render of another scene (scene hash {} against {scene_hash}: the scene file, --hair or --max-depth differ)",
                context(),
                r.scene
            );
            Accumulation::from_image(&r.image, w, h).with_context(context)?
        }
    };
    let request = config.options().validate(&file).map_err(|e| anyhow::anyhow!("--{e}"))?;
    let settings = RenderSettings { region, ..request.settings.clone() };
    if let Some(r) = &config.resume {
        let (_, most) = start.count_range(region.unwrap_or(Region::full(w, h)));
        anyhow::ensure!(
            most <= settings.spp,
            "--resume {}: it already has {most} spp, more than the {} asked for (--spp)",
            r.path.display(),
            settings.spp
        );
    }
    let (scene, _) = file.build()?;
    let t = Instant::now();
    let integrator = request.settings_for(&scene)?.integrator;
    if let Integrator::DualScattering(d) = &integrator {
        eprintln!(
            "dual scattering: tables in {:.2} s, fibers counted {}",
            t.elapsed().as_secs_f64(),
            match d.grid() {
                Some(g) => format!("from a {:?} density grid ({:.1} MB)", g.dims(), g.bytes() as f64 / 1e6),
                None => "exactly (BVH walk)".into(),
            }
        );
    }
    let settings = RenderSettings { integrator, ..settings };
    let choice = fiberlab_gpu::DeviceChoice::named(&args.device).map_err(anyhow::Error::msg)?;
    let (gpu, note) =
        fiberlab_gpu::render_device::open(choice).map_err(|e| anyhow::anyhow!("--device {}: {e}", args.device))?;
    if let Some(note) = note {
        eprintln!("{note}");
    }
    let build_seconds = t0.elapsed().as_secs_f64();
    let deadline = config.time_limit.and_then(|limit| Instant::now().checked_add(limit));
    let settings = RenderSettings { deadline, ..settings };
    let threads = fiberlab_render::integrator::worker_threads(args.threads);
    if args.threads > threads {
        eprintln!("--threads {}: rendering with {threads}, the cores of this machine", args.threads);
    }
    let doing = format!(
        "rendering {w}×{h}{} to {} spp on {} (scene built in {build_seconds:.2} s)",
        match config.pixels {
            Pixels::All => String::new(),
            p => format!(", {p}"),
        },
        settings.spp,
        gpu.as_ref().map_or("the CPU".to_string(), |g| format!("{} ({})", g.adapter().name, g.adapter().backend))
    );
    let stop = crate::interrupt::listen(&doing, "what is done");
    let bar = if args.quiet { ProgressBar::hidden() } else { ProgressBar::new(0) };
    bar.set_style(
        ProgressStyle::with_template("{spinner} [{elapsed_precise}] {wide_bar} {percent}% pass {msg}, ETA {eta}")
            .expect("valid template"),
    );
    let out = fiberlab_gpu::render_device::render_continuing(
        gpu.as_ref(),
        &scene,
        &settings,
        start,
        &|p: &Progress| {
            bar.set_length(p.samples_total);
            bar.set_position(p.samples_done);
            bar.set_message(format!("{} to {}/{} spp", p.pass, p.pass_spp, settings.spp));
        },
        stop,
    )?
    .output;
    crate::interrupt::finishing();
    bar.finish_and_clear();
    let s = &out.stats;
    let complete = !s.interrupted;
    let target = if complete { config.out.clone() } else { config.out.partial() };
    let (exr, png) = (target.with(".exr"), target.with(".png"));
    let mut image = out.image;
    // What the image is, in its header, so that `fiberlab merge` and `--resume` can check it.
    image.set_attribute("scene", scene_hash);
    image.set_attribute("seed", settings.seed.to_string());
    image.set_attribute("target_spp", settings.spp.to_string());
    match config.pixels {
        Pixels::All => {}
        Pixels::Tile(t) => image.set_attribute("part", format!("{}/{}", t.index, t.count)),
        Pixels::Crop(_) => {
            let r = region.expect("a crop has a region");
            image.set_attribute("crop", format!("{},{},{},{}", r.x0, r.y0, r.x1, r.y1));
        }
    }
    image.write_exr(&exr)?;
    let exposure = args.exposure.unwrap_or(file.render_settings().exposure);
    image.write_png(&png, exposure, ToneMap::Filmic)?;
    let samples = if s.spp_min == s.spp_max {
        format!("{} spp", s.spp_min)
    } else {
        format!("{}–{} spp", s.spp_min, s.spp_max)
    };
    eprintln!(
        "{}×{} at {samples}{}: scene {:.2} s, render {:.2} s ({:.0} samples/s, {} rays, {:.3} Mrays/s), {} passes, {} non-finite samples dropped → {}, {}",
        w,
        h,
        if complete { String::new() } else { format!(" of {}", settings.spp) },
        build_seconds,
        s.seconds,
        s.samples as f64 / s.seconds.max(1e-9),
        s.rays,
        s.rays as f64 / s.seconds.max(1e-9) / 1e6,
        s.passes,
        s.nonfinite_samples,
        exr.display(),
        png.display()
    );
    if complete {
        // The partial render this one continued is superseded.
        if let Some(r) = &config.resume
            && r.path == config.out.partial().with(".exr")
        {
            for p in [r.path.clone(), config.out.partial().with(".png")] {
                if p.exists() {
                    std::fs::remove_file(&p).with_context(|| format!("removing {}", p.display()))?;
                }
            }
        }
        return Ok(());
    }
    let how = format!("continue with `fiberlab render … --resume {}`", exr.display());
    if stop.load(Ordering::Relaxed) && settings.deadline.is_none_or(|d| Instant::now() < d) {
        return Err(crate::interrupt::Interrupted(format!(
            "wrote {} at {samples} of {}; {how}",
            exr.display(),
            settings.spp
        ))
        .into());
    }
    eprintln!("stopped by --time-limit: {how}");
    Ok(())
}
