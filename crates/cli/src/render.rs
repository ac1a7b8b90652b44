//! `fiberlab render`: path-trace a scene (or the built-in default scene) to linear EXR and
//! tone-mapped PNG, with a progress bar, a time limit, Ctrl-C (finishes the tiles in flight
//! and writes what is done) and `--tile I/N` / `--crop` parts for `fiberlab merge`.

use crate::arg_values::{self, PixelRect, Tile};
use fiberlab_io::ToneMap;
use fiberlab_render::integrator::{Region, RenderSettings, render};
use fiberlab_render::scene_file::SceneFile;
use indicatif::{ProgressBar, ProgressStyle};
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// Flags of `fiberlab render`, each read and validated by its value parser.
#[derive(clap::Args)]
pub struct Args {
    /// Scene file (TOML); the built-in default scene when omitted.
    scene: Option<PathBuf>,
    /// Use this .hair file for the scene's hair.
    #[arg(long)]
    hair: Option<PathBuf>,
    /// Samples per pixel, ≥ 1 (default: the scene's).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    spp: Option<u32>,
    /// Stop starting new tiles after this many seconds; writes what is done.
    #[arg(long, value_name = "SECONDS", value_parser = arg_values::seconds)]
    time_limit: Option<f64>,
    /// Worker threads (0: all cores).
    #[arg(long, default_value_t = 0)]
    threads: usize,
    /// Random seed (default: the scene's).
    #[arg(long)]
    seed: Option<u64>,
    /// Maximum path depth (default: the scene's).
    #[arg(long)]
    max_depth: Option<u32>,
    /// Render only part I of N (0-based bands of rows), for `fiberlab merge`.
    #[arg(long, value_name = "I/N", value_parser = arg_values::tile)]
    tile: Option<Tile>,
    /// Render only the pixels x0,y0,x1,y1 (half-open), for `fiberlab merge`.
    #[arg(long, value_name = "X0,Y0,X1,Y1", conflicts_with = "tile", value_parser = arg_values::pixel_rect)]
    crop: Option<PixelRect>,
    /// Output prefix: writes PREFIX.exr and PREFIX.png.
    #[arg(long, value_name = "PREFIX", default_value = "render", value_parser = arg_values::out_prefix)]
    out: arg_values::OutPrefix,
    /// Exposure for the PNG in stops (default: the scene's).
    #[arg(long, allow_hyphen_values = true, value_parser = arg_values::finite)]
    exposure: Option<f64>,
    /// No progress bar.
    #[arg(long)]
    quiet: bool,
    #[command(flatten)]
    memory: crate::memory_budget::MemoryLimit,
}

/// Which pixels to render.
#[derive(Clone, Copy, Debug)]
enum Pixels {
    All,
    Tile(Tile),
    Crop(PixelRect),
}

impl Pixels {
    /// The region of a `width × height` image (`None`: all of it).
    fn region(self, width: u32, height: u32) -> anyhow::Result<Option<Region>> {
        Ok(match self {
            Pixels::All => None,
            Pixels::Tile(t) => Some(t.region(width, height)),
            Pixels::Crop(c) => Some(c.within(width, height).map_err(|e| anyhow::anyhow!("--crop {e}"))?),
        })
    }
}

/// `fiberlab render`'s validated configuration: what the flags mean, before any file is read.
struct Config<'a> {
    args: &'a Args,
    pixels: Pixels,
    time_limit: Option<Duration>,
}

impl<'a> Config<'a> {
    fn new(args: &'a Args) -> Self {
        let pixels = match (args.tile, args.crop) {
            (Some(t), _) => Pixels::Tile(t),
            (_, Some(c)) => Pixels::Crop(c),
            _ => Pixels::All,
        };
        Self { args, pixels, time_limit: args.time_limit.map(Duration::from_secs_f64) }
    }

    /// The render settings: the scene's, overridden by the flags; the time limit starts now.
    fn settings(&self, scene: RenderSettings, region: Option<Region>) -> RenderSettings {
        let a = self.args;
        RenderSettings {
            spp: a.spp.unwrap_or(scene.spp),
            seed: a.seed.unwrap_or(scene.seed),
            max_depth: a.max_depth.unwrap_or(scene.max_depth),
            threads: a.threads,
            region,
            deadline: self.time_limit.map(|limit| Instant::now() + limit),
            ..scene
        }
    }
}

/// A stable 64-bit hash (FNV-1a) of what determines the image besides seed, spp and pixels:
/// the scene text (the default scene's when none is given), the `--hair` file's bytes and
/// the maximum depth. Written as hex into each part's header and compared by `merge`.
fn scene_hash(args: &Args) -> anyhow::Result<String> {
    use anyhow::Context;
    fn fnv1a(mut h: u64, bytes: &[u8]) -> u64 {
        for &b in bytes {
            h = (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3);
        }
        h
    }
    let read = |p: &PathBuf| std::fs::read(p).with_context(|| format!("reading {}", p.display()));
    let mut h = 0xcbf2_9ce4_8422_2325;
    h = match &args.scene {
        Some(p) => fnv1a(h, &read(p)?),
        None => fnv1a(h, fiberlab_render::scene_file::DEFAULT_SCENE.as_bytes()),
    };
    if let Some(p) = &args.hair {
        h = fnv1a(fnv1a(h, b"hair"), &read(p)?);
    }
    h = fnv1a(h, format!("max_depth={:?}", args.max_depth).as_bytes());
    Ok(format!("{h:016x}"))
}

/// Runs `fiberlab render`.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let config = Config::new(args);
    let t0 = Instant::now();
    let mut file = match &args.scene {
        Some(p) => SceneFile::read(p)?,
        None => SceneFile::default_scene(),
    };
    // Pixels are checked against the camera as written, before hair and BVHs are built.
    let (w, h) = file.image_size();
    let region = config.pixels.region(w, h)?;
    if let Some(h) = &args.hair {
        file.override_hair(h.clone())?;
    }
    args.memory.check_scene(&file)?;
    let scene_hash = scene_hash(args)?;
    let (scene, scene_settings) = file.build()?;
    let build_seconds = t0.elapsed().as_secs_f64();
    let settings = config.settings(scene_settings, region);
    let stop = Arc::new(AtomicBool::new(false));
    {
        let stop = Arc::clone(&stop);
        // Only one handler per process; if one is already set, Ctrl-C keeps its default.
        let _ = ctrlc::set_handler(move || stop.store(true, Ordering::Relaxed));
    }
    let bar = if args.quiet { ProgressBar::hidden() } else { ProgressBar::new(0) };
    bar.set_style(
        ProgressStyle::with_template("{spinner} [{elapsed_precise}] {wide_bar} {pos}/{len} tiles, ETA {eta}")
            .expect("valid template"),
    );
    let out = render(
        &scene,
        &settings,
        &|done, total| {
            bar.set_length(total as u64);
            bar.set_position(done as u64);
        },
        &stop,
    );
    bar.finish_and_clear();
    let s = &out.stats;
    let (exr, png) = (args.out.with(".exr"), args.out.with(".png"));
    let mut image = out.image;
    // What the image is, in its header, so that `fiberlab merge` can check its parts.
    image.set_attribute("scene", scene_hash);
    image.set_attribute("seed", settings.seed.to_string());
    image.set_attribute("spp", settings.spp.to_string());
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
    eprintln!(
        "{}×{} at {} spp: scene {:.2} s, render {:.2} s ({:.0} samples/s, {} rays, {:.3} Mrays/s), {}/{} tiles{}, {} non-finite samples dropped → {}, {}",
        w,
        h,
        settings.spp,
        build_seconds,
        s.seconds,
        s.samples as f64 / s.seconds.max(1e-9),
        s.rays,
        s.rays as f64 / s.seconds.max(1e-9) / 1e6,
        s.tiles_done,
        s.tiles_total,
        if s.interrupted { " (stopped early)" } else { "" },
        s.nonfinite_samples,
        exr.display(),
        png.display()
    );
    Ok(())
}
