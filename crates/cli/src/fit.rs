//! `fiberlab fit`: model parameters fitted to a measured table (or a user's CSV of
//! `theta_i,phi_i,theta_r,phi_r,value[,std]`, degrees) by weighted least squares; prints the
//! parameters with uncertainties and writes them as `PREFIX.toml` (accepted by every
//! command's `--params-file`), plus a residual map `PREFIX_residuals.png`.

use crate::files::write_atomically;
use crate::plot::{Grids, Scale, write_figure};
use anyhow::{Context, bail};
use fiberlab_fit::{Observation, fit};
use fiberlab_math::frame::direction;
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
    /// A user's measurements: CSV `theta_i,phi_i,theta_r,phi_r,value[,std]` (degrees, f_s in 1/sr).
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
    /// A free parameter and its starting value, KEY=VALUE (repeatable).
    #[arg(long = "init", value_name = "KEY=VALUE")]
    init: Vec<String>,
    /// Optimizer iterations.
    #[arg(long, default_value_t = 400)]
    iterations: u64,
    /// Output prefix (PREFIX.toml, PREFIX_residuals.png).
    #[arg(long, value_name = "PREFIX", default_value = "fit", value_parser = crate::arg_values::out_prefix)]
    out: crate::arg_values::OutPrefix,
}

/// Observations from a table lobe: bin centres, luminance values, standard errors with a floor
/// (empty bins have no spread: 1 % of the largest value).
/// Observations and, for tables, the `(θ, φ)` bin grid of each incidence.
type Observations = (Vec<Observation>, Option<(usize, usize)>);

fn from_table(path: &Path, lobe: &str) -> anyhow::Result<Observations> {
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
            obs.push(Observation {
                wi,
                wo: direction(tr, t.phi_in[s] + p),
                value: t.f[s][b].luminance(),
                sigma: t.std[s][b].luminance().max(0.01 * peak),
            });
        }
    }
    Ok((obs, Some((nt, np))))
}

/// Observations of a target model on a 10° (θ_i, θ_r) × 15° φ grid, weighted by
/// cosθ_i cosθ_r: σ = s/sqrt(cosθ_i cosθ_r) with s the grid's mean value.
pub(crate) fn from_model(model: &fiberlab_scatter::Model) -> Vec<Observation> {
    use fiberlab_scatter::{Field, ScatteringFunction};
    let near = model.properties().field == Field::Near;
    let mut obs = Vec::new();
    for i in 0..17 {
        for r in 0..17 {
            for j in 0..24 {
                let (ti, tr) = (f64::to_radians(-80.0 + 10.0 * i as f64), f64::to_radians(-80.0 + 10.0 * r as f64));
                let (wi, wo) = (direction(ti, 0.0), direction(tr, f64::to_radians(-172.5 + 15.0 * j as f64)));
                let value = if near {
                    (0..8).map(|k| model.eval(wi, wo, -1.0 + (k as f64 + 0.5) / 4.0).luminance()).sum::<f64>() / 8.0
                } else {
                    model.eval(wi, wo, 0.0).luminance()
                };
                obs.push(Observation { wi, wo, value, sigma: 1.0 / (ti.cos() * tr.cos()).sqrt() });
            }
        }
    }
    let mean = obs.iter().map(|o| o.value).sum::<f64>() / obs.len() as f64;
    obs.iter_mut().for_each(|o| o.sigma *= mean.max(1e-12));
    obs
}

fn from_csv(path: &Path) -> anyhow::Result<Vec<Observation>> {
    let text = std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    let mut r = csv::ReaderBuilder::new().trim(csv::Trim::All).from_reader(text.as_bytes());
    let header = r.headers()?.clone();
    let col = |c: &str| header.iter().position(|h| h == c);
    let idx: Vec<usize> = ["theta_i", "phi_i", "theta_r", "phi_r", "value"]
        .iter()
        .map(|c| col(c).with_context(|| format!("{}: line 1: missing column `{c}`", path.display())))
        .collect::<anyhow::Result<_>>()?;
    let std_col = col("std");
    let mut obs = Vec::new();
    for rec in r.records() {
        let rec = rec?;
        let line = rec.position().map_or(0, |p| p.line());
        let num = |i: usize| -> anyhow::Result<f64> {
            let t = rec.get(i).unwrap_or("");
            t.parse::<f64>().ok().filter(|v| v.is_finite()).with_context(|| {
                format!("{}: line {line}, column {}: expected a finite number, got `{t}`", path.display(), i + 1)
            })
        };
        let v: Vec<f64> = idx.iter().map(|&i| num(i)).collect::<anyhow::Result<_>>()?;
        let sigma = match std_col {
            Some(i) => num(i)?,
            None => 0.05 * v[4].abs().max(1e-6),
        };
        if sigma <= 0.0 {
            bail!("{}: line {line}: std must be positive", path.display());
        }
        obs.push(Observation {
            wi: direction(v[0].to_radians(), v[1].to_radians()),
            wo: direction(v[2].to_radians(), v[3].to_radians()),
            value: v[4],
            sigma,
        });
    }
    Ok(obs)
}

/// Runs the fit.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let (data, grid) = match (&args.table, &args.data, &args.target) {
        (Some(t), None, None) => from_table(t, &args.lobe)?,
        (None, Some(d), None) => (from_csv(d)?, None),
        (None, None, Some(name)) => {
            let target = crate::model_args::ModelArgs {
                model: name.clone(),
                params: args.target_params.clone(),
                params_file: None,
            };
            (from_model(&target.build()?), None)
        }
        _ => bail!("give exactly one of --table, --data and --target"),
    };
    let fixed: Vec<(String, String)> =
        args.fix.iter().map(|p| split_key_value(p).map_err(anyhow::Error::from)).collect::<anyhow::Result<_>>()?;
    let free: Vec<(String, f64)> = args
        .init
        .iter()
        .map(|p| {
            let (k, v) = split_key_value(p)?;
            let x = v.parse::<f64>().with_context(|| format!("--init {k}: `{v}` is not a number"))?;
            Ok((k, x))
        })
        .collect::<anyhow::Result<_>>()?;
    let spec = fiberlab_scatter::find(&args.model)?;
    let base = ParamSet::parse(spec.name, spec.params, &fixed).with_context(|| format!("--fix for `{}`", spec.name))?;
    let r = fit(&base, &free, &data, args.iterations)?;
    println!("model {}: {} observations, {} iterations", args.model, data.len(), r.iterations);
    for ((k, v), u) in r.params.iter().zip(&r.uncertainties) {
        println!("  {k} = {v:.6} ± {u:.6}");
    }
    println!("  χ² = {:.3}, dof = {}, reduced χ² = {:.3}", r.chi2, r.dof, r.chi2 / r.dof as f64);
    let mut toml =
        format!("# fitted by fiberlab fit; use with --params-file\nmodel = \"{}\"\n\n[params]\n", args.model);
    for (k, v) in &fixed {
        toml.push_str(&format!("{k} = \"{v}\"\n"));
    }
    for (k, v) in &r.params {
        // A TOML float (with `{:?}`, `3.0` stays a float and every digit of the value is kept).
        toml.push_str(&format!("{k} = {v:?}\n"));
    }
    let toml_path = args.out.with(".toml");
    write_atomically(&toml_path, toml.as_bytes())?;
    println!("wrote {}", toml_path.display());
    if let Some((nt, np)) = grid {
        // Residual map of the first incidence.
        let image: Vec<Vec<f64>> = (0..nt).map(|i| (0..np).map(|j| r.residuals[i * np + j].abs()).collect()).collect();
        let azimuthal = (0..np).map(|j| (0..nt).map(|i| image[i][j]).sum()).collect();
        let cone = image[nt / 2].clone();
        let path = args.out.with("_residuals.png");
        write_figure(&path, &Grids { image, azimuthal, cone }, "|residual| / σ (first incidence)", Scale::Log, 3.0)?;
        println!("wrote {}", path.display());
    }
    Ok(())
}
