//! `fiberlab measure`: the virtual goniophotometer. Traces rays through an explicit fiber
//! and writes `PREFIX.csv` (one row per bin and lobe) and `PREFIX.png` (the `all` lobe over
//! (φ, θ_r), like the figures of Marschner et al. 2003).

use crate::files::write_atomically;
use crate::plot::{Grids, Scale, write_figure};
use anyhow::Context;
use fiberlab_gonio::{FIBER_KEYS, Fiber, Measurement, Setup, measure};
use fiberlab_scatter::params::split_key_value;
use indicatif::{ProgressBar, ProgressStyle};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

/// Flags of `fiberlab measure`.
#[derive(clap::Args)]
pub struct Args {
    /// Fiber parameter as KEY=VALUE (repeatable): eta, sigma_a, aspect, orientation (degrees
    /// or `average`), scale_angle (degrees), scale_length, medulla_radius, medulla_sigma_s,
    /// medulla_sigma_a, medulla_g.
    #[arg(long = "param", value_name = "KEY=VALUE")]
    params: Vec<String>,
    /// A TOML file with the same keys (command-line --param values override it).
    #[arg(long)]
    fiber: Option<PathBuf>,
    /// Light inclination θ_i from the normal plane, degrees; a comma-separated list measures
    /// several incidences into one table (what `--model measured` needs).
    #[arg(long, allow_hyphen_values = true)]
    theta_i: String,
    /// Light azimuth φ_i, degrees (relative to the major axis of an elliptical fiber).
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    phi_i: f64,
    /// Number of rays.
    #[arg(long)]
    rays: usize,
    /// Bins as NT,NP over θ_r ∈ [−90°, 90°] and φ ∈ [−180°, 180°].
    #[arg(long, default_value = "180,360")]
    bins: String,
    /// Seed.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Output prefix: PREFIX.csv and PREFIX.png are written.
    #[arg(long)]
    out: PathBuf,
}

/// Reads `--fiber FILE.toml` into key/value pairs, errors naming the file, line and column.
fn toml_pairs(path: &Path) -> anyhow::Result<Vec<(String, String)>> {
    let text = std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    let table: toml::Table = text.parse().map_err(|e: toml::de::Error| {
        let (line, col) = e.span().map_or((0, 0), |s| line_col(&text, s.start));
        anyhow::anyhow!("{}: line {line}, column {col}: {}", path.display(), e.message())
    })?;
    table
        .into_iter()
        .map(|(k, v)| {
            let value = match &v {
                toml::Value::Float(x) => x.to_string(),
                toml::Value::Integer(x) => x.to_string(),
                toml::Value::String(s) => s.clone(),
                toml::Value::Array(a) => a.iter().map(|x| x.to_string()).collect::<Vec<_>>().join(","),
                _ => anyhow::bail!("{}: key `{k}`: expected a number, a string or an array", path.display()),
            };
            anyhow::ensure!(
                FIBER_KEYS.contains(&k.as_str()),
                "{}: unknown key `{k}`; valid keys: {}",
                path.display(),
                FIBER_KEYS.join(", ")
            );
            Ok((k, value))
        })
        .collect()
}

/// 1-based line and column of byte offset `at` in `text`.
pub(crate) fn line_col(text: &str, at: usize) -> (usize, usize) {
    let before = &text[..at.min(text.len())];
    let line = before.matches('\n').count() + 1;
    let col = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, col)
}

/// Runs the measurement and writes the outputs.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let mut pairs = match &args.fiber {
        Some(p) => toml_pairs(p)?,
        None => Vec::new(),
    };
    for p in &args.params {
        let (k, v) = split_key_value(p)?;
        pairs.retain(|(key, _)| *key != k);
        pairs.push((k, v));
    }
    let fiber = Fiber::from_pairs(&pairs)?;
    let (nt, np) = args
        .bins
        .split_once(',')
        .and_then(|(a, b)| Some((a.trim().parse::<usize>().ok()?, b.trim().parse::<usize>().ok()?)))
        .filter(|&(a, b)| a > 0 && b > 0)
        .with_context(|| format!("--bins: expected two positive integers NT,NP, got `{}`", args.bins))?;
    anyhow::ensure!(args.rays > 0, "--rays must be positive");
    let thetas: Vec<f64> =
        args.theta_i
            .split(',')
            .map(|t| {
                t.trim().parse::<f64>().ok().filter(|v| v.abs() < 89.9).with_context(|| {
                    format!("--theta-i: expected degrees in (-89.9, 89.9), comma-separated; got `{t}`")
                })
            })
            .collect::<anyhow::Result<_>>()?;
    let stop = Arc::new(AtomicBool::new(false));
    {
        let stop = stop.clone();
        // A second Ctrl-C is not caught again: the handler only asks the loop to stop.
        let _ = ctrlc::set_handler(move || stop.store(true, Ordering::Relaxed));
    }
    let bar = ProgressBar::new((args.rays * thetas.len()) as u64).with_style(
        ProgressStyle::with_template("{wide_bar} {pos}/{len} rays {per_sec} eta {eta}").expect("valid template"),
    );
    let start = Instant::now();
    let mut measurements = Vec::new();
    for &t in &thetas {
        if stop.load(Ordering::Relaxed) {
            break;
        }
        let setup = Setup {
            theta_i: t.to_radians(),
            phi_i: args.phi_i.to_radians(),
            rays: args.rays,
            bins_theta: nt,
            bins_phi: np,
            seed: args.seed,
        };
        measurements.push(measure(&fiber, &setup, &stop, |n| bar.inc(n as u64))?);
    }
    bar.finish_and_clear();
    let seconds = start.elapsed().as_secs_f64();
    if stop.load(Ordering::Relaxed) {
        eprintln!("interrupted: writing what was traced so far");
    }
    write_csv(&measurements, &args.out.with_extension("csv"))?;
    let first = &measurements[0];
    let title = format!("measured fiber {}   θ_i = {}°", args.params.join(" "), thetas[0]);
    write_figure(&args.out.with_extension("png"), &figure(first), &title, Scale::Log, 4.0)?;
    write_exr(first, &args.out.with_extension("exr"))?;
    let traced: usize = measurements.iter().map(|m| m.traced).sum();
    println!("traced {traced} rays in {seconds:.2} s: {:.3} Mrays/s", traced as f64 / seconds / 1e6);
    for m in &measurements {
        println!(
            "θ_i = {:.2}°: missed {} (beam margin for scales), dropped {} (> event limit)",
            m.setup.theta_i.to_degrees(),
            m.missed,
            m.dropped
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
    println!(
        "wrote {}, {} and {}",
        args.out.with_extension("csv").display(),
        args.out.with_extension("png").display(),
        args.out.with_extension("exr").display()
    );
    Ok(())
}

fn write_csv(measurements: &[Measurement], path: &Path) -> anyhow::Result<()> {
    let mut w = csv::Writer::from_writer(Vec::new());
    w.write_record(["lobe", "theta_i", "phi_i", "theta_r", "phi_r", "f_r", "f_g", "f_b", "std_r", "std_g", "std_b"])?;
    for m in measurements {
        write_rows(m, &mut w)?;
    }
    write_atomically(path, &w.into_inner()?)
}

fn write_rows(m: &Measurement, w: &mut csv::Writer<Vec<u8>>) -> anyhow::Result<()> {
    let (ti, pi) = (m.setup.theta_i.to_degrees().to_string(), m.setup.phi_i.to_degrees().to_string());
    for (name, lobe) in Measurement::LOBE_NAMES.iter().zip(&m.lobes) {
        for i in 0..m.setup.bins_theta {
            for j in 0..m.setup.bins_phi {
                let (tr, p) = m.bin_centre(i, j);
                let k = i * m.setup.bins_phi + j;
                let (f, s) = (lobe.f[k], lobe.std[k]);
                w.write_record([
                    name.to_string(),
                    ti.clone(),
                    pi.clone(),
                    tr.to_degrees().to_string(),
                    p.to_degrees().to_string(),
                    f[0].to_string(),
                    f[1].to_string(),
                    f[2].to_string(),
                    s[0].to_string(),
                    s[1].to_string(),
                    s[2].to_string(),
                ])?;
            }
        }
    }
    Ok(())
}

/// The `all` lobe's f_s (linear RGB, sr⁻¹) as an image over (φ, θ_r): φ from −180° left to
/// 180° right, θ_r from +90° at the top to −90° at the bottom.
fn write_exr(m: &Measurement, path: &Path) -> anyhow::Result<()> {
    let (nt, np) = (m.setup.bins_theta, m.setup.bins_phi);
    let mut img = fiberlab_io::LinearImage::new(np, nt);
    for i in 0..nt {
        for j in 0..np {
            let f = m.lobes[5].f[i * np + j];
            img.set(j, nt - 1 - i, [f[0] as f32, f[1] as f32, f[2] as f32]);
        }
    }
    img.write_exr(path).with_context(|| format!("writing {}", path.display()))
}

/// The `all` lobe as a figure: image, azimuthal distribution and the specular-cone row.
fn figure(m: &Measurement) -> Grids {
    let (nt, np) = (m.setup.bins_theta, m.setup.bins_phi);
    let all = &m.lobes[5];
    let image: Vec<Vec<f64>> = (0..nt).map(|i| (0..np).map(|j| all.f[i * np + j].luminance()).collect()).collect();
    let azimuthal =
        (0..np).map(|j| (0..nt).map(|i| image[i][j] * m.bin_centre(i, j).0.cos().powi(2)).sum::<f64>()).collect();
    let cone_row =
        ((((-m.setup.theta_i) + std::f64::consts::FRAC_PI_2) / std::f64::consts::PI * nt as f64) as usize).min(nt - 1);
    Grids { azimuthal, cone: image[cone_row].clone(), image }
}
