//! `fiberlab render`: path-trace a scene (or the built-in default scene) to linear EXR and
//! tone-mapped PNG, with a progress bar, a time limit, Ctrl-C (finishes the tiles in flight
//! and writes what is done) and `--tile I/N` / `--crop` parts for `fiberlab merge`.

use anyhow::{Context, bail};
use fiberlab_io::ToneMap;
use fiberlab_render::integrator::{Region, render};
use fiberlab_render::scene_file::SceneFile;
use indicatif::{ProgressBar, ProgressStyle};
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// Flags of `fiberlab render`.
#[derive(clap::Args)]
pub struct Args {
    /// Scene file (TOML); the built-in default scene when omitted.
    scene: Option<PathBuf>,
    /// Use this .hair file for the scene's hair.
    #[arg(long)]
    hair: Option<PathBuf>,
    /// Samples per pixel (default: the scene's).
    #[arg(long)]
    spp: Option<u32>,
    /// Stop starting new tiles after this many seconds; writes what is done.
    #[arg(long, value_name = "SECONDS")]
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
    #[arg(long, value_name = "I/N")]
    tile: Option<String>,
    /// Render only the pixels x0,y0,x1,y1 (half-open), for `fiberlab merge`.
    #[arg(long, value_name = "X0,Y0,X1,Y1", conflicts_with = "tile")]
    crop: Option<String>,
    /// Output prefix: writes PREFIX.exr and PREFIX.png.
    #[arg(long, default_value = "render")]
    out: String,
    /// Exposure for the PNG in stops (default: the scene's).
    #[arg(long)]
    exposure: Option<f64>,
    /// No progress bar.
    #[arg(long)]
    quiet: bool,
}

fn parse_tile(text: &str, w: u32, h: u32) -> anyhow::Result<Region> {
    let (i, n) = text.split_once('/').with_context(|| format!("--tile {text}: expected I/N, e.g. 0/4"))?;
    let (i, n): (u32, u32) = (
        i.trim().parse().with_context(|| format!("--tile {text}: I is not a number"))?,
        n.trim().parse().with_context(|| format!("--tile {text}: N is not a number"))?,
    );
    if n == 0 || i >= n {
        bail!("--tile {text}: need 0 ≤ I < N");
    }
    Ok(Region::part(i, n, w, h))
}

/// A pixel rectangle `x0,y0,x1,y1` (half-open) inside a `w`×`h` image, for `--crop`.
pub(crate) fn parse_crop(text: &str, w: u32, h: u32) -> anyhow::Result<Region> {
    let v: Vec<u32> = text
        .split(',')
        .map(|s| s.trim().parse::<u32>())
        .collect::<Result<_, _>>()
        .with_context(|| format!("--crop {text}: expected four integers x0,y0,x1,y1"))?;
    let [x0, y0, x1, y1] = v[..] else { bail!("--crop {text}: expected four integers x0,y0,x1,y1") };
    if x0 >= x1 || y0 >= y1 || x1 > w || y1 > h {
        bail!("--crop {text}: need x0 < x1 ≤ {w} and y0 < y1 ≤ {h}");
    }
    Ok(Region { x0, y0, x1, y1 })
}

/// Runs `fiberlab render`.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let t0 = Instant::now();
    let mut file = match &args.scene {
        Some(p) => SceneFile::read(p)?,
        None => SceneFile::default_scene(),
    };
    if let Some(h) = &args.hair {
        file.override_hair(h.clone());
    }
    let (scene, mut settings) = file.build()?;
    let build_seconds = t0.elapsed().as_secs_f64();
    let (w, h) = (scene.camera().width, scene.camera().height);
    if let Some(spp) = args.spp {
        settings.spp = spp.max(1);
    }
    if let Some(seed) = args.seed {
        settings.seed = seed;
    }
    if let Some(d) = args.max_depth {
        settings.max_depth = d;
    }
    settings.threads = args.threads;
    settings.region = match (&args.tile, &args.crop) {
        (Some(t), _) => Some(parse_tile(t, w, h)?),
        (_, Some(c)) => Some(parse_crop(c, w, h)?),
        _ => None,
    };
    if let Some(limit) = args.time_limit {
        if !(limit.is_finite() && limit >= 0.0) {
            bail!("--time-limit {limit}: expected seconds ≥ 0");
        }
        settings.deadline = Some(Instant::now() + Duration::from_secs_f64(limit));
    }
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
    let exr = PathBuf::from(format!("{}.exr", args.out));
    let png = PathBuf::from(format!("{}.png", args.out));
    out.image.write_exr(&exr)?;
    let exposure = args.exposure.unwrap_or(file.render_settings().exposure);
    out.image.write_png(&png, exposure, ToneMap::Filmic)?;
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
