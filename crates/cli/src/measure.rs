//! `fiberlab measure`: the virtual goniophotometer. Traces rays through an explicit fiber
//! and writes `PREFIX.csv` (one row per bin and lobe, streamed to the file) and `PREFIX.png`
//! (the `all` lobe over (φ, θ_r), like the figures of Marschner et al. 2003). The memory of
//! the bins is checked before any ray is traced.
//!
//! A signal (Ctrl-C, SIGTERM, SIGHUP) stops the measurement in flight and keeps every ray
//! traced: the tables of the incidences measured so far are written to `PREFIX.partial.csv`
//! (`.png`, `.exr`; never over finished outputs) and the exit status is 130
//! (`crate::interrupt`). The CSV's size is checked against the free space of its file system
//! before any ray is traced.
//!
//! `--surface` measures a surface instead (`fiberlab_gonio::fiber_slab`): parallel fibers
//! under a flat dielectric finish, tabulated as a BRDF over θ_o (from the normal) and the
//! absolute azimuth φ_o, `f_r = P_bin / ∫_bin cosθ_o dω_o`; the CSV's first line is the
//! comment [`fiberlab_io::table::SURFACE_HEADER`] and its lobes are the path classes
//! `finish, fiber, substrate, multiple, all`.

use crate::arg_values::OutPrefix;
use crate::arg_values::{self, Angle, Bins, KeyValue};
use crate::files::{read_toml, stream_atomically};
use crate::interrupt::Interrupted;
use crate::memory_budget::{MemoryLimit, measure_needs};
use crate::plot::{Scale, write_figure};
use anyhow::Context;
use fiberlab_compare::maps::{ScatteringMap, table_map};
use fiberlab_gonio::fiber_slab::{FiberSlab, SurfaceMeasurement, measure_surface};
use fiberlab_gonio::{Fiber, Measurement, Setup, measure};
use fiberlab_io::table::{self, TableKind, Tabulated};
use fiberlab_math::Rgb;
use fiberlab_render::toml_params::raw_pairs;
use fiberlab_scatter::params::RawValue;
use indicatif::{ProgressBar, ProgressStyle};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Flags of `fiberlab measure`, each read and validated by its value parser.
#[derive(clap::Args)]
pub struct Args {
    /// Fiber parameter as KEY=VALUE (repeatable): eta, roughness (GGX α of the interface, 0 =
    /// smooth), sigma_a, aspect, orientation (degrees or `average`), scale_angle (degrees),
    /// scale_length, medulla_radius, medulla_sigma_s, medulla_sigma_a, medulla_g, surface, albedo.
    #[arg(long = "param", value_name = "KEY=VALUE", value_parser = arg_values::key_value, conflicts_with = "surface")]
    params: Vec<KeyValue>,
    /// A TOML file with the same keys (command-line --param values override it).
    #[arg(long, conflicts_with = "surface")]
    fiber: Option<PathBuf>,
    /// Measure a surface: parallel fibers under a flat dielectric finish (the flags below);
    /// θ_i is then from the normal, in [0°, 89.9°), and --bins spans θ_o ∈ [0°, 90°].
    #[arg(long)]
    surface: bool,
    /// Surface: index of the finish (and of the matrix between the fibers).
    #[arg(long, default_value_t = 1.5, requires = "surface")]
    eta: f64,
    /// Surface: in-plane angle of the fiber axis from +x toward +y, degrees.
    #[arg(long, default_value = "0", allow_hyphen_values = true, value_parser = arg_values::degrees, requires = "surface")]
    fiber_angle: Angle,
    /// Surface: dip of the fiber axis below the surface, degrees in [0, 89).
    #[arg(long, default_value = "0", value_parser = arg_values::degrees, requires = "surface")]
    fiber_dip: Angle,
    /// Surface: area fraction of the fibers across their axis, [0, 0.5].
    #[arg(long, default_value_t = 0.3, requires = "surface")]
    packing: f64,
    /// Surface: absolute index of the fibers.
    #[arg(long, default_value_t = 1.55, requires = "surface")]
    fiber_eta: f64,
    /// Surface: absorption inside the fibers per fiber radius, one number or R,G,B.
    #[arg(long, default_value = "0", value_parser = rgb, requires = "surface")]
    sigma_a: Rgb,
    /// Surface: Lambertian albedo of the substrate below the fibers (0 = absorbing), one
    /// number or R,G,B.
    #[arg(long, default_value = "0", value_parser = rgb, requires = "surface")]
    substrate: Rgb,
    /// Surface: depth of the fiber slab's top below the finish, in fiber radii (> 0).
    #[arg(long, default_value_t = 0.5, requires = "surface")]
    depth: f64,
    /// Surface: thickness of the fiber slab, in fiber radii.
    #[arg(long, default_value_t = 10.0, requires = "surface")]
    thickness: f64,
    /// Surface: fibers per periodic cell of the random layout.
    #[arg(long, default_value_t = 24, requires = "surface")]
    fibers_per_cell: usize,
    /// Surface: measure an explicit woven patch instead of the slab (the patch flags below,
    /// lengths in mm), path traced with --fiber-model at every fiber.
    #[arg(long, requires = "surface")]
    cloth: bool,
    #[command(flatten)]
    patch: crate::mesh::PatchArgs,
    /// Cloth: fiber scattering model at every fiber hit (any fiber model of `fiberlab models`).
    #[arg(long, default_value = "chiang", requires = "cloth")]
    fiber_model: String,
    /// Cloth: parameter of the fiber model as KEY=VALUE (repeatable).
    #[arg(long = "fiber-param", value_name = "KEY=VALUE", value_parser = arg_values::key_value, requires = "cloth")]
    fiber_params: Vec<KeyValue>,
    /// Cloth: Lambertian substrate under the patch (albedo, one number or R,G,B); without it
    /// light passes through the gaps.
    #[arg(long, value_parser = rgb, requires = "cloth")]
    cloth_substrate: Option<Rgb>,
    /// Light inclination θ_i from the normal plane, degrees in (−89.9, 89.9); a
    /// comma-separated list measures several incidences into one table (what `--model
    /// measured` needs).
    #[arg(long, required = true, allow_hyphen_values = true, value_delimiter = ',', value_parser = arg_values::incidence)]
    theta_i: Vec<Angle>,
    /// Light azimuth φ_i, degrees (relative to the major axis of an elliptical fiber).
    #[arg(long, default_value = "0", allow_hyphen_values = true, value_parser = arg_values::degrees)]
    phi_i: Angle,
    /// Number of rays (≥ 1).
    #[arg(long, value_parser = arg_values::positive_count)]
    rays: usize,
    /// Bins as NT,NP over θ_r ∈ [−90°, 90°] and φ ∈ [−180°, 180°].
    #[arg(long, default_value = "180,360", value_parser = arg_values::bins)]
    bins: Bins,
    /// Seed of the rays (with --surface also of the random fiber layout).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Output prefix: PREFIX.csv and PREFIX.png are written.
    #[arg(long, value_name = "PREFIX", value_parser = crate::arg_values::out_prefix)]
    out: crate::arg_values::OutPrefix,
    #[command(flatten)]
    pub(crate) memory: MemoryLimit,
}

/// The fiber: `--fiber FILE.toml` (through the shared TOML conversion), then `--param`
/// (which wins), converted and checked against [`fiberlab_gonio::FIBER_PARAMS`].
fn fiber(args: &Args) -> anyhow::Result<Fiber> {
    let mut pairs = match &args.fiber {
        Some(path) => raw_pairs(&read_toml(path)?).with_context(|| format!("{}", path.display()))?,
        None => Vec::new(),
    };
    for p in &args.params {
        pairs.retain(|(key, _)| *key != p.key);
        pairs.push((p.key.clone(), RawValue::Text(p.value.clone())));
    }
    let fiber = Fiber::from_raw(&pairs);
    match &args.fiber {
        Some(path) => fiber.with_context(|| format!("fiber of {} and --param", path.display())),
        None => Ok(fiber?),
    }
}

/// One number or `R,G,B`, each finite.
fn rgb(text: &str) -> Result<Rgb, String> {
    let v: Vec<f64> = text
        .split(',')
        .map(|t| t.trim().parse::<f64>().ok().filter(|x| x.is_finite()))
        .collect::<Option<_>>()
        .ok_or_else(|| format!("expected a number or R,G,B, got `{text}`"))?;
    match v[..] {
        [x] => Ok(Rgb::splat(x)),
        [r, g, b] => Ok(Rgb::new(r, g, b)),
        _ => Err(format!("expected a number or R,G,B, got `{text}`")),
    }
}

/// Runs the measurement and writes the outputs.
pub fn run(args: &Args) -> anyhow::Result<()> {
    if args.cloth {
        return run_cloth(args);
    }
    if args.surface {
        return run_surface(args);
    }
    let fiber = fiber(args)?;
    let Bins { theta: nt, phi: np } = args.bins;
    let thetas = &args.theta_i;
    let setup_at = |t: &Angle| Setup {
        theta_i: t.radians,
        phi_i: args.phi_i.radians,
        rays: args.rays,
        bins_theta: nt,
        bins_phi: np,
        seed: args.seed,
    };
    // Before any ray: the bins' memory, then their count against the 32-bit bin indices.
    let first = setup_at(&thetas[0]);
    args.memory.check(&measure_needs(&first, thetas.len(), rayon::current_num_threads()))?;
    first.check_bins()?;
    check_table_space(&args.out, 6, nt, np, thetas.len())?;
    let stop = crate::interrupt::listen(&doing(thetas.len(), args.rays, "rays"), "what is traced");
    let bar = ProgressBar::new((args.rays as u64).saturating_mul(thetas.len() as u64)).with_style(
        ProgressStyle::with_template("{wide_bar} {pos}/{len} rays {per_sec} eta {eta}").expect("valid template"),
    );
    let start = Instant::now();
    let mut measurements = Vec::new();
    for t in thetas {
        if stop.load(std::sync::atomic::Ordering::Relaxed) {
            break;
        }
        measurements.push(measure(&fiber, &setup_at(t), stop, |n| bar.inc(n as u64))?);
    }
    bar.finish_and_clear();
    let seconds = start.elapsed().as_secs_f64();
    let out = outputs(&args.out, measurements.len())?;
    write_table(&measurements, TableKind::Fiber, &out.with(".csv"))?;
    let first = &measurements[0];
    let params: Vec<String> = args.params.iter().map(ToString::to_string).collect();
    let title = format!("measured fiber {}   θ_i = {}°", params.join(" "), thetas[0].degrees);
    write_figure(&out.with(".png"), &figure(first), &title, Scale::Log, 4.0)?;
    write_exr(first, TableKind::Fiber, &out.with(".exr"))?;
    let traced: usize = measurements.iter().map(|m| m.traced).sum();
    println!("traced {traced} rays in {seconds:.2} s: {:.3} Mrays/s", traced as f64 / seconds / 1e6);
    for m in &measurements {
        println!(
            "θ_i = {:.2}°: missed {} (beam margin for scales), dropped {} (> event limit), masked {} (rough interface)",
            m.setup.theta_i.to_degrees(),
            m.missed,
            m.dropped,
            m.masked
        );
        for (name, lobe) in Measurement::LOBE_NAMES.iter().zip(&m.lobes) {
            // The lobe's peak bin (luminance) and its relative Monte Carlo error.
            let k = (0..lobe.f.len()).max_by(|&a, &b| lobe.f[a].luminance().total_cmp(&lobe.f[b].luminance()));
            let (peak, rel) = k.map_or((0.0, f64::NAN), |k| {
                let f = lobe.f[k].luminance();
                (f, if f > 0.0 { lobe.std[k].luminance() / f } else { f64::NAN })
            });
            println!(
                "  albedo {name:<8} {:.6} {:.6} {:.6}   peak f {peak:.4e} 1/sr ± {:.2}%",
                lobe.albedo[0],
                lobe.albedo[1],
                lobe.albedo[2],
                100.0 * rel
            );
        }
    }
    let wrote = format!(
        "wrote {}, {} and {}",
        out.with(".csv").display(),
        out.with(".png").display(),
        out.with(".exr").display()
    );
    finish(wrote, measurements.len(), thetas.len())
}

/// Refuses a table whose rows (`lobes` per bin and incidence, at least 40 bytes each: the
/// shortest row the writer prints) would not fit on the file system of `PREFIX.csv`.
fn check_table_space(out: &OutPrefix, lobes: u64, nt: usize, np: usize, incidences: usize) -> anyhow::Result<()> {
    let rows = (nt as u64).saturating_mul(np as u64).saturating_mul(lobes).saturating_mul(incidences as u64);
    fiberlab_io::output_file::check_free_space(&out.with(".csv"), rows.saturating_mul(40)).map_err(anyhow::Error::msg)
}

/// What `measure` says it does when it starts.
fn doing(incidences: usize, rays: usize, what: &str) -> String {
    format!("measuring {incidences} incidence(s) × {rays} {what}")
}

/// Where the outputs go: `PREFIX`, or `PREFIX.partial` after a signal (`crate::interrupt`);
/// an error when a signal came before any measurement finished. From here on, signals wait
/// until the outputs are written.
fn outputs(prefix: &OutPrefix, measured: usize) -> anyhow::Result<OutPrefix> {
    if measured == 0 {
        return Err(Interrupted("stopped before the first measurement; nothing written".into()).into());
    }
    crate::interrupt::finishing();
    Ok(if crate::interrupt::stopped() { prefix.partial() } else { prefix.clone() })
}

/// Prints what was written; after a signal, the error that exits with status 130.
fn finish(wrote: String, measured: usize, asked: usize) -> anyhow::Result<()> {
    if crate::interrupt::stopped() {
        return Err(Interrupted(format!("{wrote} ({measured} of {asked} incidences, the last one in part)")).into());
    }
    println!("{wrote}");
    Ok(())
}

/// Streams the table of every measurement into `path` (atomically; [`table::write`]).
fn write_table<T: Tabulated>(measurements: &[T], kind: TableKind, path: &Path) -> anyhow::Result<()> {
    stream_atomically(path, |out| Ok(table::write(out, kind, measurements)?))
}

/// The `all` lobe (the last) as an EXR image ([`table::lobe_image`]).
fn write_exr<T: Tabulated>(m: &T, kind: TableKind, path: &Path) -> anyhow::Result<()> {
    let all = m.lobe_tables().len() - 1;
    table::lobe_image(m, all, kind).write_exr(path).with_context(|| format!("writing {}", path.display()))
}

/// The `all` lobe as a figure: image, azimuthal distribution and the specular-cone row.
fn figure(m: &Measurement) -> ScatteringMap {
    let values: Vec<f64> = m.lobes[5].f.iter().map(|v| v.luminance()).collect();
    table_map(&values, m.setup.bins_theta, m.setup.bins_phi, m.setup.theta_i)
}

/// The sample of `--surface`, from the flags (radius 1: lengths in fiber radii).
fn slab(args: &Args) -> FiberSlab {
    FiberSlab {
        eta: args.eta,
        fiber_angle: args.fiber_angle.radians,
        fiber_dip: args.fiber_dip.radians,
        radius: 1.0,
        packing: args.packing,
        fiber_eta: args.fiber_eta,
        sigma_a: args.sigma_a,
        depth: args.depth,
        thickness: args.thickness,
        substrate: args.substrate,
        fibers_per_cell: args.fibers_per_cell,
        layout_seed: args.seed,
    }
}

/// `measure --surface`: the slab's BRDF at every --theta-i into one surface table.
fn run_surface(args: &Args) -> anyhow::Result<()> {
    let slab = slab(args);
    slab.validate()?;
    let Bins { theta: nt, phi: np } = args.bins;
    let bins = (nt as u64).checked_mul(np as u64);
    let per_incidence = bins.and_then(|b| b.checked_mul(4 * fiberlab_gonio::RESULT_BYTES_PER_BIN));
    let needs = vec![crate::memory_budget::Need {
        what: format!("surface goniophotometer bins {nt}×{np} of {} incidences", args.theta_i.len()),
        bytes: per_incidence.and_then(|b| b.checked_mul(args.theta_i.len() as u64)),
    }];
    args.memory.check(&needs)?;
    check_table_space(&args.out, 5, nt, np, args.theta_i.len())?;
    let stop = crate::interrupt::listen(&doing(args.theta_i.len(), args.rays, "rays"), "what is traced");
    let bar = ProgressBar::new((args.rays as u64).saturating_mul(args.theta_i.len() as u64)).with_style(
        ProgressStyle::with_template("{wide_bar} {pos}/{len} rays {per_sec} eta {eta}").expect("valid template"),
    );
    let start = Instant::now();
    let mut measurements = Vec::new();
    for t in &args.theta_i {
        if stop.load(std::sync::atomic::Ordering::Relaxed) {
            break;
        }
        let setup = Setup {
            theta_i: t.radians,
            phi_i: args.phi_i.radians,
            rays: args.rays,
            bins_theta: nt,
            bins_phi: np,
            seed: args.seed,
        };
        measurements.push(measure_surface(&slab, &setup, stop, |n| bar.inc(n as u64))?);
    }
    bar.finish_and_clear();
    let seconds = start.elapsed().as_secs_f64();
    let out = outputs(&args.out, measurements.len())?;
    let path = out.with(".csv");
    write_table(&measurements, TableKind::Surface, &path)?;
    write_exr(&measurements[0], TableKind::Surface, &out.with(".exr"))?;
    let traced: usize = measurements.iter().map(|m| m.traced).sum();
    println!("traced {traced} rays in {seconds:.2} s: {:.3} Mrays/s", traced as f64 / seconds / 1e6);
    for m in &measurements {
        println!("θ_i = {:.2}°: dropped {} (> event limit)", m.setup.theta_i.to_degrees(), m.dropped);
        for (name, lobe) in SurfaceMeasurement::LOBE_NAMES.iter().zip(&m.lobes) {
            println!("  albedo {name:<9} {:.6} {:.6} {:.6}", lobe.albedo[0], lobe.albedo[1], lobe.albedo[2]);
        }
    }
    finish(
        format!("wrote {} and {}", path.display(), out.with(".exr").display()),
        measurements.len(),
        args.theta_i.len(),
    )
}

/// `measure --surface --cloth`: the woven patch's BRDF at every --theta-i into one surface
/// table (classes `fiber` (one fiber event), `multiple`, `substrate`, `all`).
fn run_cloth(args: &Args) -> anyhow::Result<()> {
    use fiberlab_gonio::cloth::{ClothMeasurement, PeriodicPatch, measure_cloth};
    let patch = args.patch.patch()?;
    let pairs: Vec<(String, RawValue)> =
        args.fiber_params.iter().map(|p| (p.key.clone(), RawValue::Text(p.value.clone()))).collect();
    let model = fiberlab_render::model_loader::load_model(&args.fiber_model, &pairs, Path::new(""))
        .with_context(|| format!("--fiber-model {}", args.fiber_model))?;
    let Bins { theta: nt, phi: np } = args.bins;
    let bins = (nt as u64).checked_mul(np as u64);
    let (segments, _, _) = patch.estimated_segments(3, 3);
    let needs = vec![
        crate::memory_budget::Need {
            what: format!("cloth goniophotometer bins {nt}×{np} of {} incidences", args.theta_i.len()),
            bytes: bins
                .and_then(|b| b.checked_mul(4 * fiberlab_gonio::RESULT_BYTES_PER_BIN))
                .and_then(|b| b.checked_mul(args.theta_i.len() as u64)),
        },
        crate::memory_budget::Need {
            what: format!("3 × 3 repeats of the woven patch ({segments} segments)"),
            bytes: fiberlab_geometry::curves::CurveSet::estimated_bytes(segments),
        },
    ];
    args.memory.check(&needs)?;
    check_table_space(&args.out, 4, nt, np, args.theta_i.len())?;
    let built = Instant::now();
    let periodic = PeriodicPatch::from_repeats(
        &patch.fibers(3, 3)?.polylines(),
        (patch.period(), patch.period()),
        args.cloth_substrate,
    );
    println!(
        "patch: {} segments over 3 × 3 repeats of {:.4} mm, built in {:.2} s",
        periodic.curves.segment_count(),
        patch.period(),
        built.elapsed().as_secs_f64()
    );
    let stop = crate::interrupt::listen(&doing(args.theta_i.len(), args.rays, "paths"), "what is traced");
    let bar = ProgressBar::new((args.rays as u64).saturating_mul(args.theta_i.len() as u64)).with_style(
        ProgressStyle::with_template("{wide_bar} {pos}/{len} paths {per_sec} eta {eta}").expect("valid template"),
    );
    let start = Instant::now();
    let mut measurements: Vec<ClothMeasurement> = Vec::new();
    for t in &args.theta_i {
        if stop.load(std::sync::atomic::Ordering::Relaxed) {
            break;
        }
        let setup = Setup {
            theta_i: t.radians,
            phi_i: args.phi_i.radians,
            rays: args.rays,
            bins_theta: nt,
            bins_phi: np,
            seed: args.seed,
        };
        measurements.push(measure_cloth(&periodic, &model, &setup, stop, |n| bar.inc(n as u64))?);
    }
    bar.finish_and_clear();
    let seconds = start.elapsed().as_secs_f64();
    let out = outputs(&args.out, measurements.len())?;
    let path = out.with(".csv");
    write_table(&measurements, TableKind::Surface, &path)?;
    let traced: usize = measurements.iter().map(|m| m.traced).sum();
    println!("traced {traced} paths in {seconds:.2} s: {:.4} Mpaths/s", traced as f64 / seconds / 1e6);
    for m in &measurements {
        println!(
            "θ_i = {:.2}°: {:.2} fiber events per path, dropped {}, transmitted {:.5} {:.5} {:.5}",
            m.setup.theta_i.to_degrees(),
            m.mean_events,
            m.dropped,
            m.transmitted[0],
            m.transmitted[1],
            m.transmitted[2]
        );
        for (name, lobe) in ClothMeasurement::LOBE_NAMES.iter().zip(&m.lobes) {
            println!("  albedo {name:<9} {:.6} {:.6} {:.6}", lobe.albedo[0], lobe.albedo[1], lobe.albedo[2]);
        }
    }
    // A fiber model whose albedo exceeds 1 (sadeghi-thread's volume term) gains energy at
    // every bounce: the multiple scattering of a patch then diverges. Say so.
    if measurements.iter().any(|m| (m.lobes[3].albedo + m.transmitted).max_component() > 1.05) {
        eprintln!(
            "warning: reflected + transmitted exceeds 1: the fiber model `{}` gains energy (its albedo is above 1), \
             so multiple scattering in the patch diverges; use an energy-conserving fiber model (e.g. chiang)",
            args.fiber_model
        );
    }
    finish(format!("wrote {}", path.display()), measurements.len(), args.theta_i.len())
}
