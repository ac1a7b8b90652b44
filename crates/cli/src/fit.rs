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
use crate::plot::{Grids, Scale, write_figure};
use anyhow::{Context, bail};
use fiberlab_fit::{
    BinObservation, Channel, FitOptions, FitResult, FreeParam, Observation, SurfaceData, Uncertainty, fit_surface,
    fit_with,
};
use fiberlab_io::table::{TableKind, read_kind};
use fiberlab_math::frame::direction;
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

/// Observations and, for tables, the `(θ, φ)` bin grid of each incidence.
type Observations = (Vec<Observation>, Option<(usize, usize)>);

/// What is fitted: point observations of a fiber model, or a surface table's bins.
enum Data {
    Fiber(Vec<Observation>, Option<(usize, usize)>),
    Surface(SurfaceData, (usize, usize)),
}

/// The channels an observation of colour data is split into: the luminance alone, or r, g, b.
fn channels(per_channel: bool) -> Vec<Channel> {
    if per_channel { (0..3).map(Channel::Rgb).collect() } else { vec![Channel::Luminance] }
}

/// Observations from a table lobe: bin centres, values (per channel or luminance), standard
/// errors with a floor (empty bins have no spread: 1 % of the largest value).
fn from_table(path: &Path, lobe: &str, per_channel: bool) -> anyhow::Result<Observations> {
    let lobes = fiberlab_io::table::read(path)?;
    let t = lobes.get(lobe).with_context(|| format!("{}: no rows with lobe `{lobe}`", path.display()))?;
    let (nt, np) = (t.bins_theta, t.bins_phi);
    let peak = t.f.iter().flatten().map(|v| v.luminance()).fold(0.0, f64::max);
    let mut obs = Vec::new();
    for s in 0..t.theta_in.len() {
        let wi = direction(t.theta_in[s], t.phi_in[s]);
        for b in 0..nt * np {
            let tr = -std::f64::consts::FRAC_PI_2 + ((b / np) as f64 + 0.5) * std::f64::consts::PI / nt as f64;
            let p = -std::f64::consts::PI + ((b % np) as f64 + 0.5) * std::f64::consts::TAU / np as f64;
            for channel in channels(per_channel) {
                obs.push(Observation {
                    wi,
                    wo: direction(tr, t.phi_in[s] + p),
                    value: channel.of(t.f[s][b]),
                    sigma: channel.of(t.std[s][b]).max(0.01 * peak),
                    channel,
                });
            }
        }
    }
    Ok((obs, Some((nt, np))))
}

/// A surface table's lobe as fit data: the bins of every incidence (see
/// [`fiberlab_fit::surface_bins`]) with their values per channel (or luminance) and
/// standard errors (floored at the median positive one); and the `(θ, φ)` bin grid.
fn from_surface_table(
    path: &Path,
    lobe: &str,
    per_channel: bool,
    sub: usize,
    viewer_first: bool,
) -> anyhow::Result<(SurfaceData, (usize, usize))> {
    let lobes = fiberlab_io::table::read(path)?;
    let t = lobes.get(lobe).with_context(|| {
        format!(
            "{}: no rows with lobe `{lobe}` (this surface table has: {})",
            path.display(),
            lobes.keys().cloned().collect::<Vec<_>>().join(", ")
        )
    })?;
    let (nt, np) = (t.bins_theta, t.bins_phi);
    // The bins' midpoint nodes (a direction and a weight, 32 bytes each), before they are made.
    let nodes = (nt as u64)
        .saturating_mul(np as u64)
        .saturating_mul(t.theta_in.len() as u64)
        .saturating_mul(sub as u64)
        .saturating_mul(sub as u64);
    crate::memory_budget::check(&[crate::memory_budget::Need::items(
        format!("{nodes} bin nodes (--subsamples {sub}: {sub}² per bin)"),
        nodes,
        32,
    )])?;
    let peak = t.f.iter().flatten().map(|v| v.luminance()).fold(0.0, f64::max);
    if peak <= 0.0 {
        bail!("{}: lobe `{lobe}` is zero in every bin; nothing to fit", path.display());
    }
    let floor = std_floor(t);
    let mut data = SurfaceData::default();
    for s in 0..t.theta_in.len() {
        let first = data.bins.len();
        data.bins.extend(fiberlab_fit::surface_bins(t.theta_in[s], t.phi_in[s], nt, np, sub, viewer_first));
        for b in 0..nt * np {
            for channel in channels(per_channel) {
                data.observations.push(BinObservation {
                    bin: first + b,
                    value: channel.of(t.f[s][b]),
                    sigma: channel.of(t.std[s][b]).max(floor),
                    channel,
                });
            }
        }
    }
    Ok((data, (nt, np)))
}

/// The σ of a surface-table bin no path reached (which has no spread): the median of the
/// positive standard errors of the lobe (about one path's contribution to a bin), or 1 % of
/// the peak if none is positive. A floor relative to the peak (as for fiber tables) would
/// drown a cloth's diffuse bins under a sharp highlight, and the smallest σ (one weak path)
/// would give an empty bin all the weight.
pub fn std_floor(t: &fiberlab_io::table::LobeSlices) -> f64 {
    let mut spread: Vec<f64> = t.std.iter().flatten().flat_map(|v| [v[0], v[1], v[2]]).filter(|&v| v > 0.0).collect();
    spread.sort_by(f64::total_cmp);
    let peak = t.f.iter().flatten().map(|v| v.luminance()).fold(0.0, f64::max);
    spread.get(spread.len() / 2).copied().unwrap_or(0.01 * peak)
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

/// Observations of a target model on a 10° (θ_i, θ_r) × 15° φ grid, weighted by
/// cosθ_i cosθ_r: σ = s/sqrt(cosθ_i cosθ_r) with s the grid's mean value; luminances, or
/// per channel when `per_channel` (each channel's σ from its own mean).
fn from_model_in(model: &fiberlab_scatter::Model, per_channel: bool) -> Vec<Observation> {
    let mut obs = Vec::new();
    for (wi, wo, weight) in fiberlab_fit::model_grid() {
        let f = fiberlab_fit::width_averaged(model, wi, wo);
        for channel in channels(per_channel) {
            obs.push(Observation { wi, wo, value: channel.of(f), sigma: 1.0 / weight, channel });
        }
    }
    for channel in channels(per_channel) {
        let of_channel = || obs.iter().filter(|o| o.channel == channel);
        let mean = of_channel().map(|o| o.value).sum::<f64>() / of_channel().count() as f64;
        obs.iter_mut().filter(|o| o.channel == channel).for_each(|o| o.sigma *= mean.max(1e-12));
    }
    obs
}

/// The angle columns of a CSV and the range each must lie in (degrees).
const ANGLE_RANGES: [(&str, f64, f64); 4] =
    [("theta_i", -90.0, 90.0), ("phi_i", -360.0, 360.0), ("theta_r", -90.0, 90.0), ("phi_r", -360.0, 360.0)];

/// A user's CSV: `value` (luminance) or `f_r,f_g,f_b` (per channel, or their luminance when
/// `per_channel` is false), with optional standard errors `std` / `std_r,std_g,std_b`
/// (default 5 % of the value). Errors name the file, line and column.
fn from_csv(path: &Path, per_channel: bool) -> anyhow::Result<Vec<Observation>> {
    let text = fiberlab_io::input_file::read_text(path)?;
    let mut r = csv::ReaderBuilder::new().trim(csv::Trim::All).from_reader(text.as_bytes());
    let header = r.headers()?.clone();
    let col = |c: &str| header.iter().position(|h| h == c);
    let required = |c: &str| col(c).with_context(|| format!("{}: line 1: missing column `{c}`", path.display()));
    let angles: Vec<usize> = ANGLE_RANGES.iter().map(|(c, _, _)| required(c)).collect::<anyhow::Result<_>>()?;
    let rgb_cols: Option<Vec<usize>> = ["f_r", "f_g", "f_b"].iter().map(|c| col(c)).collect();
    // Value columns with their standard-error columns, and the channel each measures.
    let values: Vec<(usize, Option<usize>, Channel)> = match rgb_cols {
        Some(v) => {
            let std: Vec<Option<usize>> = ["std_r", "std_g", "std_b"].iter().map(|c| col(c)).collect();
            (0..3).map(|c| (v[c], std[c], Channel::Rgb(c))).collect()
        }
        None => vec![(required("value")?, col("std"), Channel::Luminance)],
    };
    let mut obs = Vec::new();
    for rec in r.records() {
        let rec = rec?;
        let line = rec.position().map_or(0, |p| p.line());
        let num = |i: usize| -> anyhow::Result<f64> {
            let t = rec.get(i).unwrap_or("");
            t.parse::<f64>().ok().filter(|v| v.is_finite()).with_context(|| {
                format!(
                    "{}: line {line}, column {} (`{}`): expected a finite number, got `{t}`",
                    path.display(),
                    i + 1,
                    &header[i]
                )
            })
        };
        let mut a = [0.0; 4];
        for (k, (&i, (name, lo, hi))) in angles.iter().zip(ANGLE_RANGES).enumerate() {
            a[k] = num(i)?;
            if !(lo..=hi).contains(&a[k]) {
                bail!(
                    "{}: line {line}, column {} (`{name}`): {:?} degrees is outside [{lo}, {hi}]",
                    path.display(),
                    i + 1,
                    a[k]
                );
            }
        }
        let (wi, wo) =
            (direction(a[0].to_radians(), a[1].to_radians()), direction(a[2].to_radians(), a[3].to_radians()));
        let mut row = Vec::new();
        for &(i, std, channel) in &values {
            let value = num(i)?;
            let sigma = match std {
                Some(s) => num(s)?,
                None => 0.05 * value.abs().max(1e-6),
            };
            if sigma <= 0.0 {
                bail!("{}: line {line}, column {}: std must be positive", path.display(), std.map_or(0, |s| s + 1));
            }
            row.push(Observation { wi, wo, value, sigma, channel });
        }
        if row.len() == 3 && !per_channel {
            // Luminance of the channels, σ by propagation of independent errors.
            let weights = [0.2126, 0.7152, 0.0722];
            let value = (0..3).map(|c| weights[c] * row[c].value).sum();
            let sigma = (0..3).map(|c| (weights[c] * row[c].sigma).powi(2)).sum::<f64>().sqrt();
            row = vec![Observation { wi, wo, value, sigma, channel: Channel::Luminance }];
        }
        obs.extend(row);
    }
    Ok(obs)
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
            let (d, grid) = from_surface_table(t, &args.lobe, per_channel, args.subsamples, args.viewer_first)?;
            Data::Surface(d, grid)
        }
        (Some(t), None, None, _) => {
            let (d, grid) = from_table(t, &args.lobe, per_channel)?;
            Data::Fiber(d, grid)
        }
        (None, Some(d), None, _) => Data::Fiber(from_csv(d, per_channel)?, None),
        (None, None, Some(name), _) => {
            let target = crate::model_args::ModelArgs {
                model: name.clone(),
                params: args.target_params.clone(),
                params_file: None,
            };
            Data::Fiber(from_model_in(&target.build()?, per_channel), None)
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
        stop: Some(crate::interrupt::listen(
            &format!("fitting {} parameter(s) to {observations} observations", free.len()),
            "the best point so far",
        )),
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
        write_figure(&path, &Grids { image, azimuthal, cone }, "|residual| / σ (first incidence)", Scale::Log, 3.0)?;
        println!("wrote {}", path.display());
    }
    if r.interrupted {
        return Err(crate::interrupt::Interrupted(format!("wrote {} (the best point so far)", toml_path.display())).into());
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
