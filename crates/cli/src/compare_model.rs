//! `fiberlab compare-model`: a model evaluated on the bins of a measured table, per lobe:
//! relative L2 error, peak positions and heights, and difference figures.

use crate::model_args::ModelArgs;
use crate::plot::{Grids, Scale, write_figure};
use fiberlab_io::table::{LobeSlices, read};
use fiberlab_math::frame::direction;
use fiberlab_scatter::params::RawValue;
use fiberlab_scatter::{Field, Model, ScatteringFunction};
use rayon::prelude::*;
use std::f64::consts::{FRAC_PI_2, PI, TAU};
use std::path::PathBuf;

/// Flags of `fiberlab compare-model`.
#[derive(clap::Args)]
pub struct Args {
    /// Measured table (CSV written by `fiberlab measure`).
    #[arg(long)]
    table: PathBuf,
    #[command(flatten)]
    model: ModelArgs,
    /// Prefix of the difference figures (PREFIX_LOBE.png, first incidence); none if absent.
    #[arg(long, value_name = "PREFIX", value_parser = crate::arg_values::out_prefix)]
    out: Option<crate::arg_values::OutPrefix>,
}

/// Bin-averaged model `f_s` (cosθ-weighted, h-averaged for near-field models), `[θ][φ]`.
fn model_bins(model: &Model, theta_i: f64, phi_i: f64, nt: usize, np: usize) -> Vec<f64> {
    let wi = direction(theta_i, phi_i);
    let near = model.properties().field == Field::Near;
    let hs: Vec<f64> = if near { (0..8).map(|k| -1.0 + (k as f64 + 0.5) / 4.0).collect() } else { vec![0.0] };
    let sub = 3;
    (0..nt * np)
        .into_par_iter()
        .map(|b| {
            let (i, j) = (b / np, b % np);
            let (mut num, mut den) = (0.0, 0.0);
            for a in 0..sub {
                let tr = -FRAC_PI_2 + (i as f64 + (a as f64 + 0.5) / sub as f64) * PI / nt as f64;
                let w = tr.cos().powi(2);
                for c in 0..sub {
                    let p = -PI + (j as f64 + (c as f64 + 0.5) / sub as f64) * TAU / np as f64;
                    let wr = direction(tr, phi_i + p);
                    let f: f64 = hs.iter().map(|&h| model.eval(wi, wr, h).luminance()).sum::<f64>() / hs.len() as f64;
                    num += f * w;
                    den += w;
                }
            }
            num / den
        })
        .collect()
}

/// Per-lobe model: `lobes=NAME` added when the model has that parameter.
fn lobe_model(args: &ModelArgs, lobe: &str) -> anyhow::Result<Option<Model>> {
    if lobe == "all" {
        return args.build().map(Some);
    }
    let has_lobes = fiberlab_scatter::find(&args.model).map(|s| s.params.iter().any(|p| p.key == "lobes"))?;
    if !has_lobes {
        return Ok(None);
    }
    args.build_with(&[("lobes", RawValue::from(lobe))]).map(Some)
}

/// Runs the comparison and prints one line per (incidence, lobe).
pub fn run(args: &Args) -> anyhow::Result<()> {
    let table = read(&args.table)?;
    println!(
        "{:>8} {:>8} {:<6} {:>10} {:>22} {:>22} {:>12} {:>12}",
        "θ_i°",
        "φ_i°",
        "lobe",
        "rel. L2",
        "peak measured (θ_r,φ)°",
        "peak model (θ_r,φ)°",
        "height meas.",
        "height model"
    );
    for lobe in ["r", "tt", "trt", "all"] {
        let Some(slices) = table.get(lobe) else { continue };
        let Some(model) = lobe_model(&args.model, lobe)? else { continue };
        for s in 0..slices.theta_in.len() {
            let row = compare_slice(&model, slices, s);
            println!(
                "{:>8.2} {:>8.2} {:<6} {:>10.4} {:>22} {:>22} {:>12.4e} {:>12.4e}",
                slices.theta_in[s].to_degrees(),
                slices.phi_in[s].to_degrees(),
                lobe,
                row.rel_l2,
                format!("({:.1}, {:.1})", row.peak_measured.0, row.peak_measured.1),
                format!("({:.1}, {:.1})", row.peak_model.0, row.peak_model.1),
                row.height_measured,
                row.height_model
            );
            if s == 0
                && let Some(prefix) = &args.out
            {
                let path = prefix.with(&format!("_{lobe}.png"));
                let title = format!(
                    "|{} − measured| ({lobe}), θ_i = {:.1}°",
                    args.model.label(),
                    slices.theta_in[0].to_degrees()
                );
                write_figure(&path, &row.difference, &title, Scale::Log, 4.0)?;
            }
        }
    }
    Ok(())
}

struct Comparison {
    rel_l2: f64,
    peak_measured: (f64, f64),
    peak_model: (f64, f64),
    height_measured: f64,
    height_model: f64,
    difference: Grids,
}

fn compare_slice(model: &Model, t: &LobeSlices, s: usize) -> Comparison {
    let (nt, np) = (t.bins_theta, t.bins_phi);
    let modelled = model_bins(model, t.theta_in[s], t.phi_in[s], nt, np);
    let measured: Vec<f64> = t.f[s].iter().map(|v| v.luminance()).collect();
    let weight = |b: usize| {
        let a = -FRAC_PI_2 + (b / np) as f64 * PI / nt as f64;
        let prim = |x: f64| 0.5 * x + 0.25 * (2.0 * x).sin();
        prim(a + PI / nt as f64) - prim(a)
    };
    let (mut num, mut den) = (0.0, 0.0);
    for b in 0..nt * np {
        num += weight(b) * (modelled[b] - measured[b]).powi(2);
        den += weight(b) * measured[b].powi(2);
    }
    let centre = |b: usize| {
        (
            (-FRAC_PI_2 + ((b / np) as f64 + 0.5) * PI / nt as f64).to_degrees(),
            (-PI + ((b % np) as f64 + 0.5) * TAU / np as f64).to_degrees(),
        )
    };
    let argmax = |v: &[f64]| (0..v.len()).max_by(|&a, &b| v[a].total_cmp(&v[b])).unwrap_or(0);
    let (bm, bf) = (argmax(&measured), argmax(&modelled));
    let diff: Vec<Vec<f64>> =
        (0..nt).map(|i| (0..np).map(|j| (modelled[i * np + j] - measured[i * np + j]).abs()).collect()).collect();
    let azimuthal = (0..np).map(|j| (0..nt).map(|i| diff[i][j]).sum()).collect();
    let cone = diff[((FRAC_PI_2 - t.theta_in[s]) / PI * nt as f64).clamp(0.0, (nt - 1) as f64) as usize].clone();
    Comparison {
        rel_l2: if den > 0.0 { (num / den).sqrt() } else { f64::NAN },
        peak_measured: centre(bm),
        peak_model: centre(bf),
        height_measured: measured[bm],
        height_model: modelled[bf],
        difference: Grids { image: diff, azimuthal, cone },
    }
}
