//! `fiberlab compare-model`: a model evaluated on the bins of a measured table, per lobe:
//! relative L2 error, peak positions and heights, and difference figures; `--json` prints the
//! same as one object keyed by lobe.

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
    /// Print one JSON object keyed by lobe (`r`, `tt`, `trt`, `medulla`, `all`; lobes the table
    /// or the model lacks are left out) instead of the text table. Each entry is
    /// `{"rel_l2", "mc_rel_l2", "peak_measured": [θ_r°, φ°, f], "peak_model": [θ_r°, φ°, f],
    /// "per_theta_i": [...]}`: with several incidences, `rel_l2` and `mc_rel_l2` pool every
    /// incidence (sums of squares over all bins of all incidences), the peaks are the highest
    /// bin over all incidences, and `per_theta_i` lists the same per incidence (with
    /// `theta_i`, `phi_i` in degrees). `mc_rel_l2` is the relative L2 norm of the table's
    /// Monte Carlo standard errors: the `rel_l2` a perfect model would get on average. A lobe
    /// whose measured table is zero has `rel_l2` null.
    #[arg(long)]
    json: bool,
    /// Midpoint sub-samples per bin along θ_r for the model's bin average (≥ 1; φ takes 3):
    /// raise it for longitudinal lobes narrower than a bin (the midpoint rule is accurate to
    /// about 1e-4 for a Gaussian of standard deviation ≥ 0.7 sub-sample spacings).
    #[arg(long, default_value_t = 3, value_parser = crate::arg_values::positive_count)]
    subsamples: usize,
}

/// The measured lobes compared and the model's `lobes=` value for each (`None`: the whole model).
const LOBES: [(&str, Option<&str>); 5] =
    [("r", Some("r")), ("tt", Some("tt")), ("trt", Some("trt")), ("medulla", Some("tts,trts")), ("all", None)];

/// Midpoint sub-samples per bin along φ (the azimuthal lobes are wide; `--subsamples` sets θ_r's).
const PHI_SUBSAMPLES: usize = 3;

/// Bin-averaged model `f_s` (cosθ-weighted, h-averaged for near-field models), `[θ][φ]`.
fn model_bins(model: &Model, theta_i: f64, phi_i: f64, nt: usize, np: usize, sub: usize) -> Vec<f64> {
    let wi = direction(theta_i, phi_i);
    let near = model.properties().field == Field::Near;
    let hs: Vec<f64> = if near { (0..8).map(|k| -1.0 + (k as f64 + 0.5) / 4.0).collect() } else { vec![0.0] };
    (0..nt * np)
        .into_par_iter()
        .map(|b| {
            let (i, j) = (b / np, b % np);
            let (mut num, mut den) = (0.0, 0.0);
            for a in 0..sub {
                let tr = -FRAC_PI_2 + (i as f64 + (a as f64 + 0.5) / sub as f64) * PI / nt as f64;
                let w = tr.cos().powi(2);
                for c in 0..PHI_SUBSAMPLES {
                    let p = -PI + (j as f64 + (c as f64 + 0.5) / PHI_SUBSAMPLES as f64) * TAU / np as f64;
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

/// Per-lobe model: `lobes=NAMES` added when the model has that parameter and accepts those
/// names (a hair model without `tts`, `trts` has no medulla lobe); `None` the whole model.
fn lobe_model(args: &ModelArgs, lobes: Option<&str>) -> anyhow::Result<Option<Model>> {
    let Some(lobes) = lobes else { return args.build().map(Some) };
    let spec = fiberlab_scatter::find(&args.model)?;
    let Some(param) = spec.params.iter().find(|p| p.key == "lobes") else { return Ok(None) };
    if let fiberlab_scatter::params::ParamKind::Subset(names) = param.kind
        && !lobes.split(',').all(|l| names.contains(&l))
    {
        return Ok(None);
    }
    args.build_with(&[("lobes", RawValue::from(lobes))]).map(Some)
}

/// Runs the comparison and prints one line per (incidence, lobe), or the JSON object.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let table = read(&args.table)?;
    if !args.json {
        println!(
            "{:>8} {:>8} {:<8} {:>10} {:>10} {:>22} {:>22} {:>12} {:>12}",
            "θ_i°",
            "φ_i°",
            "lobe",
            "rel. L2",
            "MC rel. L2",
            "peak measured (θ_r,φ)°",
            "peak model (θ_r,φ)°",
            "height meas.",
            "height model"
        );
    }
    let mut json = serde_json::Map::new();
    for (lobe, model_lobes) in LOBES {
        let Some(slices) = table.get(lobe) else { continue };
        let Some(model) = lobe_model(&args.model, model_lobes)? else { continue };
        let rows: Vec<Comparison> =
            (0..slices.theta_in.len()).map(|s| compare_slice(&model, slices, s, args.subsamples)).collect();
        for (s, row) in rows.iter().enumerate() {
            if !args.json {
                println!(
                    "{:>8.2} {:>8.2} {:<8} {:>10.4} {:>10.4} {:>22} {:>22} {:>12.4e} {:>12.4e}",
                    slices.theta_in[s].to_degrees(),
                    slices.phi_in[s].to_degrees(),
                    lobe,
                    row.rel_l2(),
                    row.mc_rel_l2(),
                    format!("({:.1}, {:.1})", row.peak_measured.0, row.peak_measured.1),
                    format!("({:.1}, {:.1})", row.peak_model.0, row.peak_model.1),
                    row.height_measured,
                    row.height_model
                );
            }
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
        json.insert(lobe.to_string(), lobe_json(slices, &rows));
    }
    if args.json {
        println!("{}", serde_json::Value::Object(json));
    }
    Ok(())
}

/// A finite number, or JSON null.
fn number(x: f64) -> serde_json::Value {
    serde_json::Number::from_f64(x).map_or(serde_json::Value::Null, serde_json::Value::Number)
}

/// `[θ_r°, φ°, f]`.
fn peak(position: (f64, f64), height: f64) -> serde_json::Value {
    serde_json::Value::Array(vec![number(position.0), number(position.1), number(height)])
}

/// One lobe's JSON entry: pooled over the incidences, and per incidence.
fn lobe_json(slices: &LobeSlices, rows: &[Comparison]) -> serde_json::Value {
    let pooled = |part: fn(&Comparison) -> f64| {
        let den: f64 = rows.iter().map(|r| r.den).sum();
        if den > 0.0 { (rows.iter().map(part).sum::<f64>() / den).sqrt() } else { f64::NAN }
    };
    let highest = |height: fn(&Comparison) -> f64| {
        (0..rows.len()).max_by(|&a, &b| height(&rows[a]).total_cmp(&height(&rows[b]))).unwrap_or(0)
    };
    let (m, f) = (highest(|r| r.height_measured), highest(|r| r.height_model));
    let per: Vec<serde_json::Value> = rows
        .iter()
        .enumerate()
        .map(|(s, r)| {
            serde_json::json!({
                "theta_i": number(slices.theta_in[s].to_degrees()),
                "phi_i": number(slices.phi_in[s].to_degrees()),
                "rel_l2": number(r.rel_l2()),
                "mc_rel_l2": number(r.mc_rel_l2()),
                "peak_measured": peak(r.peak_measured, r.height_measured),
                "peak_model": peak(r.peak_model, r.height_model),
            })
        })
        .collect();
    let (peak_measured, peak_model) = match (rows.get(m), rows.get(f)) {
        (Some(a), Some(b)) => (peak(a.peak_measured, a.height_measured), peak(b.peak_model, b.height_model)),
        _ => (serde_json::Value::Null, serde_json::Value::Null),
    };
    serde_json::json!({
        "rel_l2": number(pooled(|r| r.num)),
        "mc_rel_l2": number(pooled(|r| r.mc)),
        "peak_measured": peak_measured,
        "peak_model": peak_model,
        "per_theta_i": per,
    })
}

struct Comparison {
    /// Σ w (model − measured)², Σ w measured², Σ w std² over the bins (w: the bin's cos²θ measure).
    num: f64,
    den: f64,
    mc: f64,
    peak_measured: (f64, f64),
    peak_model: (f64, f64),
    height_measured: f64,
    height_model: f64,
    difference: Grids,
}

impl Comparison {
    fn rel_l2(&self) -> f64 {
        if self.den > 0.0 { (self.num / self.den).sqrt() } else { f64::NAN }
    }

    fn mc_rel_l2(&self) -> f64 {
        if self.den > 0.0 { (self.mc / self.den).sqrt() } else { f64::NAN }
    }
}

fn compare_slice(model: &Model, t: &LobeSlices, s: usize, sub: usize) -> Comparison {
    let (nt, np) = (t.bins_theta, t.bins_phi);
    let modelled = model_bins(model, t.theta_in[s], t.phi_in[s], nt, np, sub);
    let measured: Vec<f64> = t.f[s].iter().map(|v| v.luminance()).collect();
    let std: Vec<f64> = t.std[s].iter().map(|v| v.luminance()).collect();
    let weight = |b: usize| {
        let a = -FRAC_PI_2 + (b / np) as f64 * PI / nt as f64;
        let prim = |x: f64| 0.5 * x + 0.25 * (2.0 * x).sin();
        prim(a + PI / nt as f64) - prim(a)
    };
    let (mut num, mut den, mut mc) = (0.0, 0.0, 0.0);
    for b in 0..nt * np {
        num += weight(b) * (modelled[b] - measured[b]).powi(2);
        den += weight(b) * measured[b].powi(2);
        mc += weight(b) * std[b].powi(2);
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
        num,
        den,
        mc,
        peak_measured: centre(bm),
        peak_model: centre(bf),
        height_measured: measured[bm],
        height_model: modelled[bf],
        difference: Grids { image: diff, azimuthal, cone },
    }
}
