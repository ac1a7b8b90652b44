//! `fiberlab fit`: model parameters fitted to a measured table, a user's CSV of
//! `theta_i,phi_i,theta_r,phi_r,value[,std]` or `…,f_r,f_g,f_b[,std_r,std_g,std_b]` (degrees,
//! θ in [−90°, 90°], φ in [−360°, 360°]), or another model, by weighted least squares; shows
//! a progress bar, prints the parameters with uncertainties (or why one is undefined) and
//! flags a parameter that ended on its bound; writes them as `PREFIX.toml` (accepted by every
//! command's `--params-file`), plus a residual map `PREFIX_residuals.png`.
//!
//! A colour parameter is fitted per channel when the data has channels (a table, a CSV with
//! `f_r,f_g,f_b`, a `--target`): see `fiberlab_fit`.
//!
//! A signal (Ctrl-C, SIGTERM, SIGHUP) stops the fit after the iteration in flight: the best
//! parameters so far are written to `PREFIX.partial.toml` (never over a finished
//! `PREFIX.toml`) and the exit status is 130 (`crate::interrupt`). Data the fit cannot use is
//! refused (`fiberlab_fit`): all values zero, or values whose scale no parameter can reach.
//!
//! A **surface** model (e.g. `sadeghi-2013`, `wood`) is fitted to a surface table (`fiberlab
//! measure --surface`, lobe `all` unless `--lobe` names a path class): the model is averaged
//! over each bin (midpoint rule, `--subsamples`² nodes, in the table's cosθ_o dω_o measure)
//! rather than evaluated at the bin centres, since the tables are coarse (5°–10° bins) and
//! cloth highlights are only a few degrees wide, so a centre value can be far from the bin's
//! average. The table's standard errors are the weights (floored at the median positive one,
//! about one path's contribution, for bins no path reached). A fiber model given a surface table, and a surface model given a
//! fiber table or no table, are refused with the reason.

use crate::files::write_atomically;
use crate::plot::{Scale, write_figure};
use anyhow::{Context, bail};
use fiberlab_compare::maps::ScatteringMap;
use fiberlab_fit::{
    FitOptions, FitResult, FreeParam, Observation, SurfaceData, Uncertainty, fit_surface, fit_with, observation,
};
use fiberlab_io::table::{LobeSlices, TableKind, read_kind};
use fiberlab_scatter::ModelKind;
use fiberlab_scatter::params::{ParamSet, split_key_value};
use std::path::{Path, PathBuf};

/// Flags of `fiberlab fit`.
#[derive(clap::Args)]
pub struct Args {
    /// Model to fit.
    #[arg(long)]
    model: String,
    /// Measured table from `fiberlab measure`.
    #[arg(long, conflicts_with = "data")]
    table: Option<PathBuf>,
    /// Lobe of the table to fit (r, tt, trt, higher, all).
    #[arg(long, default_value = "all")]
    lobe: String,
    /// A user's measurements: CSV `theta_i,phi_i,theta_r,phi_r,value[,std]` or
    /// `theta_i,phi_i,theta_r,phi_r,f_r,f_g,f_b[,std_r,std_g,std_b]` (degrees: θ in [−90, 90],
    /// φ in [−360, 360]; f_s in 1/sr; std defaults to 5 % of the value).
    #[arg(long)]
    data: Option<PathBuf>,
    /// Fit to another model instead of data (e.g. Kajiya–Kay to `chiang`), over a (θ_i, θ_r, φ)
    /// grid weighted by cosθ_i cosθ_r (`docs/theory/radiometry.md`, "Kajiya–Kay as a scattering function").
    #[arg(long, conflicts_with_all = ["table", "data"])]
    target: Option<String>,
    /// Parameter of the --target model, KEY=VALUE (repeatable).
    #[arg(long = "target-param", value_name = "KEY=VALUE", requires = "target")]
    target_params: Vec<String>,
    /// A parameter held fixed, KEY=VALUE (repeatable).
    #[arg(long = "fix", value_name = "KEY=VALUE")]
    fix: Vec<String>,
    /// A free parameter and its starting value, KEY=VALUE (repeatable). A colour parameter
    /// (e.g. `sigma_a`) is fitted per channel when the data has channels (a table, a CSV with
    /// f_r,f_g,f_b, a --target): each channel is an independent measurement, so the colour
    /// itself is recovered (start with one value or r,g,b). From luminance-only data (a CSV
    /// `value` column, or --luminance) it is fitted as one grey value.
    #[arg(long = "init", value_name = "KEY=VALUE")]
    init: Vec<String>,
    /// Fit the luminance of f_s only (colour parameters as one grey value), even when the
    /// data has channels.
    #[arg(long)]
    luminance: bool,
    /// No progress bar.
    #[arg(long, short)]
    quiet: bool,
    /// Largest number of Nelder–Mead iterations (then at most 20 Levenberg–Marquardt steps).
    #[arg(long, default_value_t = 400)]
    iterations: u64,
    /// Surface tables: midpoint nodes per bin along θ_o and along φ_o (≥ 1) of the model's
    /// bin average.
    #[arg(long, default_value_t = 3, value_parser = crate::arg_values::positive_count)]
    subsamples: usize,
    /// Surface tables: the table's θ_i, φ_i is the viewer's direction and its bins the
    /// light's (a table traced from the camera, e.g. the woven patch's); by default θ_i is the
    /// light's. Matters for a non-reciprocal model (`sadeghi-2013`).
    #[arg(long)]
    viewer_first: bool,
    /// Output prefix (PREFIX.toml, PREFIX_residuals.png).
    #[arg(long, value_name = "PREFIX", default_value = "fit", value_parser = crate::arg_values::out_prefix)]
    out: crate::arg_values::OutPrefix,
}

/// What is fitted: point observations of a fiber model (with the `(θ, φ)` bin grid of a
/// table's incidences), or a surface table's bins.
enum Data {
    Fiber(Vec<Observation>, Option<(usize, usize)>),
    Surface(SurfaceData, (usize, usize)),
}

/// The lobe `lobe` of the table at `path`, with an error naming the lobes it has.
fn table_lobe(path: &Path, lobe: &str) -> anyhow::Result<LobeSlices> {
    let mut lobes = fiberlab_io::table::read(path)?;
    let names = lobes.keys().cloned().collect::<Vec<_>>().join(", ");
    lobes
        .remove(lobe)
        .with_context(|| format!("{}: no rows with lobe `{lobe}` (the table has: {names})", path.display()))
}

/// Refuses a table of the wrong kind for the model: a surface table for a fiber model, a
/// fiber table (or data that is not a surface table) for a surface model.
fn check_kinds(args: &Args, kind: ModelKind) -> anyhow::Result<Option<TableKind>> {
    let table = args.table.as_ref().map(|t| read_kind(t).map(|k| (t, k))).transpose()?;
    match (kind, table) {
        (ModelKind::Fiber, Some((t, TableKind::Surface))) => bail!(
            "{} is a surface table (BRDF over the hemisphere, from `fiberlab measure --surface`); `{}` is a fiber \
             model — fit a surface model to it ({})",
            t.display(),
            args.model,
            surface_names()
        ),
        (ModelKind::Surface, Some((t, TableKind::Fiber))) => bail!(
            "{} is a fiber table (f_s about a fiber's axis, from `fiberlab measure`); `{}` is a surface model — fit \
             a fiber model to it, or give a surface table (`fiberlab measure --surface`)",
            t.display(),
            args.model
        ),
        (ModelKind::Surface, None) => bail!(
            "`{}` is a surface model: it is fitted to a surface table (--table from `fiberlab measure --surface`); \
             --data and --target are for fiber models",
            args.model
        ),
        (_, t) => Ok(t.map(|(_, k)| k)),
    }
}

/// The surface models' names.
fn surface_names() -> String {
    fiberlab_scatter::SURFACE_MODELS.iter().map(|m| m.name).collect::<Vec<_>>().join(", ")
}

/// `KEY=VALUE` of `--init`: one starting number, or three (`r,g,b`) for a colour.
fn free_param(text: &str) -> anyhow::Result<FreeParam> {
    let (key, value) = split_key_value(text)?;
    let start = value
        .split(',')
        .map(|v| v.trim().parse::<f64>().ok().filter(|x| x.is_finite()))
        .collect::<Option<Vec<f64>>>()
        .filter(|v| v.len() == 1 || v.len() == 3)
        .with_context(|| format!("--init {key}: `{value}` is not one finite number or three (r,g,b)"))?;
    Ok(FreeParam { key, start })
}

/// Runs the fit.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let free: Vec<FreeParam> = args.init.iter().map(|p| free_param(p)).collect::<anyhow::Result<_>>()?;
    let entry = fiberlab_scatter::lookup(&args.model)?;
    let info = *entry.info();
    let table_kind = check_kinds(args, entry.kind())?;
    // Channels are fitted when a colour parameter is free and the data has channels.
    let colour_free = free.iter().any(|f| {
        info.params.iter().any(|s| s.key == f.key && matches!(s.kind, fiberlab_scatter::params::ParamKind::Color(_)))
    });
    let per_channel = colour_free && !args.luminance;
    let data = match (&args.table, &args.data, &args.target, table_kind) {
        (Some(t), None, None, Some(TableKind::Surface)) => {
            let lobe = table_lobe(t, &args.lobe)?;
            let d = fiberlab_fit::surface::from_surface_table(&lobe, per_channel, args.subsamples, args.viewer_first)
                .with_context(|| format!("{}: lobe `{}`", t.display(), args.lobe))?;
            Data::Surface(d, (lobe.bins_theta, lobe.bins_phi))
        }
        (Some(t), None, None, _) => {
            let lobe = table_lobe(t, &args.lobe)?;
            Data::Fiber(observation::from_fiber_table(&lobe, per_channel), Some((lobe.bins_theta, lobe.bins_phi)))
        }
        (None, Some(d), None, _) => {
            let text = fiberlab_io::input_file::read_text(d)?;
            Data::Fiber(observation::from_csv(&text, d, per_channel)?, None)
        }
        (None, None, Some(name), _) => {
            let target = crate::model_args::ModelArgs {
                model: name.clone(),
                params: args.target_params.clone(),
                params_file: None,
            };
            Data::Fiber(observation::from_model(&target.build()?, per_channel), None)
        }
        _ => bail!("give exactly one of --table, --data and --target"),
    };
    let observations = match &data {
        Data::Fiber(d, _) => d.len(),
        Data::Surface(d, _) => d.observations.len(),
    };
    let per_bin = if per_channel { 3 } else { 1 };
    let fixed: Vec<(String, String)> =
        args.fix.iter().map(|p| split_key_value(p).map_err(anyhow::Error::from)).collect::<anyhow::Result<_>>()?;
    let base = ParamSet::parse(info.name, info.params, &fixed).with_context(|| format!("--fix for `{}`", info.name))?;
    // On stderr, drawn only on a terminal: simplex iterations, then the polishing steps.
    let steps = args.iterations + fiberlab_fit::POLISH_ITERATIONS;
    let bar = if args.quiet { indicatif::ProgressBar::hidden() } else { indicatif::ProgressBar::new(steps) };
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "{spinner} fitting {msg}: step {pos}/{len} (at most) {wide_bar} {elapsed}",
        )
        .expect("valid template"),
    );
    bar.set_message(format!("{} parameter(s) to {observations} observations", free.len()));
    bar.enable_steady_tick(std::time::Duration::from_millis(250));
    let progress = bar.clone();
    let options = FitOptions {
        max_iters: args.iterations,
        progress: Some(std::sync::Arc::new(move |i| progress.set_position(i))),
        stop: Some({
            let flag = crate::interrupt::listen(
                &format!("fitting {} parameter(s) to {observations} observations", free.len()),
                "the best point so far",
            );
            std::sync::Arc::new(move || flag.load(std::sync::atomic::Ordering::Relaxed))
        }),
        ..FitOptions::default()
    };
    let (r, grid) = match &data {
        Data::Fiber(d, grid) => (fit_with(&base, &free, d, &options), *grid),
        Data::Surface(d, grid) => (fit_surface(&base, &free, d, &options), Some(*grid)),
    };
    bar.finish_and_clear();
    let r = r?;
    crate::interrupt::finishing();
    let out = if r.interrupted { args.out.partial() } else { args.out.clone() };
    if r.interrupted {
        println!("stopped after {} iterations: the best parameters so far", r.iterations);
    }
    print_result(&args.model, observations, &r);
    let mut toml =
        format!("# fitted by fiberlab fit; use with --params-file\nmodel = \"{}\"\n\n[params]\n", args.model);
    for (k, v) in &fixed {
        toml.push_str(&format!("{k} = \"{v}\"\n"));
    }
    for (k, v) in &r.values {
        // TOML floats (with `{:?}`, `3.0` stays a float and every digit of the value is kept);
        // a colour fitted per channel as an array r, g, b.
        match v.as_slice() {
            [x] => toml.push_str(&format!("{k} = {x:?}\n")),
            _ => toml.push_str(&format!("{k} = {v:?}\n")),
        }
    }
    let toml_path = out.with(".toml");
    write_atomically(&toml_path, toml.as_bytes())?;
    println!("wrote {}", toml_path.display());
    if let Some((nt, np)) = grid {
        // Residual map of the first incidence: per bin, the RMS over its observations (channels).
        let k = per_bin;
        let bin = |b: usize| (r.residuals[b * k..(b + 1) * k].iter().map(|x| x * x).sum::<f64>() / k as f64).sqrt();
        let image: Vec<Vec<f64>> = (0..nt).map(|i| (0..np).map(|j| bin(i * np + j)).collect()).collect();
        let azimuthal = (0..np).map(|j| (0..nt).map(|i| image[i][j]).sum()).collect();
        let cone = image[nt / 2].clone();
        let path = out.with("_residuals.png");
        write_figure(
            &path,
            &ScatteringMap { image, azimuthal, cone },
            "|residual| / σ (first incidence)",
            Scale::Log,
            3.0,
        )?;
        println!("wrote {}", path.display());
    }
    if r.interrupted {
        return Err(
            crate::interrupt::Interrupted(format!("wrote {} (the best point so far)", toml_path.display())).into()
        );
    }
    Ok(())
}

/// The fitted numbers with their 1σ uncertainties — or why one is undefined, never `± NaN` —
/// a warning for each that ended on its bound, and the χ².
fn print_result(model: &str, observations: usize, r: &FitResult) {
    println!("model {model}: {observations} observations, {} iterations", r.iterations);
    for (((k, v), u), bound) in r.params.iter().zip(&r.uncertainties).zip(&r.at_bound) {
        match u {
            Uncertainty::Sigma(s) => println!("  {k} = {v:.6} ± {s:.6}"),
            Uncertainty::Undefined(why) => println!("  {k} = {v:.6}   (uncertainty undefined: {why})"),
        }
        if let Some(b) = bound {
            println!("    warning: `{k}` {b}; the best fit may lie beyond it (check the model, --fix or the data)");
        }
    }
    println!("  χ² = {:.3}, dof = {}, reduced χ² = {:.3}", r.chi2, r.dof, r.chi2 / r.dof as f64);
}
