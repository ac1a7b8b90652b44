//! `fiberlab compare-model`: a model evaluated on the bins of a measured table, per lobe:
//! relative L2 error, peak positions and heights, and difference figures; `--json` prints the
//! same as one object keyed by lobe.
//!
//! A surface table (`fiberlab measure --surface`) is compared with a surface model that has a
//! fiber axis (`wood`, Marschner et al. 2005) on its `fiber` class (single-fiber paths), the
//! model reduced to its fiber term (`k_d = 0`, smooth finish whose delta `eval` leaves out):
//! the highlight's locus (per φ_o column, the θ_o of the peak), its width (energy-weighted RMS
//! of ψ_h = ψ_i′ + ψ_o′ over the bins) and its strength (albedo of the class), each against a
//! stated tolerance (see [`SURFACE_TOLERANCES`]); `--out PREFIX` draws PREFIX_highlight.png.
//!
//! Any other surface model (`sadeghi-2013`, `irawan-2012`, `lambertian`) is compared with the
//! table's `all` class (every path: a cloth's BRDF as a whole) by its residual: the model
//! averaged over each bin as `fiberlab fit` does, the per-bin RMS of model − measured (sr⁻¹,
//! weighted by the bins' cosθ dω), the relative L2 error (and the table's own Monte Carlo
//! relative L2, what a perfect model would get), and the worst bins by |model − measured|/σ;
//! `--out PREFIX` draws PREFIX_slices.png (the plane of incidence and the plane across it).

use crate::model_args::ModelArgs;
use crate::plot::{Grids, Scale, write_figure};
use fiberlab_io::table::{LobeSlices, TableKind, read, read_kind};
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
    /// Surface tables: the table's θ_i, φ_i is the viewer's direction and its bins the
    /// light's (a table traced from the camera, e.g. the woven patch's); by default θ_i is the
    /// light's. Matters for a non-reciprocal model (`sadeghi-2013`).
    #[arg(long)]
    viewer_first: bool,
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
    if read_kind(&args.table)? == TableKind::Surface {
        return run_surface(args);
    }
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

/// Tolerances of the surface comparison: the locus within this many θ_o bins in every
/// column, the RMS width of ψ_h within this many θ_o bins, the strength (albedo of the
/// `fiber` class) within this relative error.
pub const SURFACE_TOLERANCES: (f64, f64, f64) = (1.0, 1.0, 0.25);

/// Fraction of the highest column's energy below which a column's peak is not located.
const COLUMN_THRESHOLD: f64 = 0.05;

/// One incidence of a surface comparison.
struct SurfaceComparison {
    theta_i: f64,
    phi_i: f64,
    /// Per column with enough energy: (φ_o°, measured peak θ_o°, model peak θ_o°).
    locus: Vec<(f64, f64, f64)>,
    /// RMS ψ_h (degrees), measured and model.
    width: (f64, f64),
    /// Albedo of the class: measured, its standard error, model.
    strength: (f64, f64, f64),
    /// The column through φ_i + 180°: (φ_o°, θ_o° bin centres, measured, std, model).
    profile: (f64, Vec<f64>, Vec<f64>, Vec<f64>, Vec<f64>),
    bin_degrees: f64,
}

impl SurfaceComparison {
    /// Largest `|θ_peak measured − θ_peak model|` over the columns, in units of the extent of
    /// the bin the model's locus crosses: one θ_o bin plus the θ_o the locus travels across
    /// the column (where the cone runs steeply through a column its peak is only defined to
    /// that travel).
    fn locus_error_bins(&self) -> f64 {
        let n = self.locus.len();
        (0..n)
            .map(|k| {
                let (prev, next) = (self.locus[k.saturating_sub(1)].2, self.locus[(k + 1).min(n - 1)].2);
                let travel = if k == 0 || k + 1 == n { (next - prev).abs() } else { 0.5 * (next - prev).abs() };
                (self.locus[k].1 - self.locus[k].2).abs() / (self.bin_degrees + travel)
            })
            .fold(0.0, f64::max)
    }

    fn strength_ratio(&self) -> f64 {
        self.strength.0 / self.strength.2
    }

    fn passes(&self) -> (bool, bool, bool) {
        let (l, w, s) = SURFACE_TOLERANCES;
        (
            !self.locus.is_empty() && self.locus_error_bins() <= l,
            (self.width.0 - self.width.1).abs() <= w * self.bin_degrees,
            (self.strength_ratio() - 1.0).abs() <= s,
        )
    }
}

/// Peak position of `v` (index space, parabolic interpolation about the highest sample).
fn interpolated_peak(v: &[f64]) -> f64 {
    let k = (0..v.len()).max_by(|&a, &b| v[a].total_cmp(&v[b])).unwrap_or(0);
    if k == 0 || k + 1 >= v.len() {
        return k as f64;
    }
    let (a, b, c) = (v[k - 1], v[k], v[k + 1]);
    let den = a - 2.0 * b + c;
    if den.abs() < 1e-300 { k as f64 } else { k as f64 + (0.5 * (a - c) / den).clamp(-0.5, 0.5) }
}

fn compare_surface_slice(
    wood: &fiberlab_scatter::marschner_2005::Wood,
    t: &LobeSlices,
    s: usize,
    sub: usize,
) -> SurfaceComparison {
    use fiberlab_scatter::SurfaceScattering;
    let (nt, np) = (t.bins_theta, t.bins_phi);
    let (theta_i, phi_i) = (t.theta_in[s], t.phi_in[s]);
    let dir = |th: f64, ph: f64| fiberlab_math::DVec3::new(th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos());
    let wi = dir(theta_i, phi_i);
    let dt = FRAC_PI_2 / nt as f64;
    let dp = TAU / np as f64;
    let modelled: Vec<f64> = (0..nt * np)
        .into_par_iter()
        .map(|b| {
            let (i, j) = (b / np, b % np);
            let (mut num, mut den) = (0.0, 0.0);
            for a in 0..sub {
                let th = (i as f64 + (a as f64 + 0.5) / sub as f64) * dt;
                let w = th.sin() * th.cos();
                for c in 0..PHI_SUBSAMPLES {
                    let ph = -PI + (j as f64 + (c as f64 + 0.5) / PHI_SUBSAMPLES as f64) * dp;
                    num += wood.eval(wi, dir(th, ph)).luminance() * w;
                    den += w;
                }
            }
            num / den
        })
        .collect();
    let measured: Vec<f64> = t.f[s].iter().map(|v| v.luminance()).collect();
    let std: Vec<f64> = t.std[s].iter().map(|v| v.luminance()).collect();
    let omega = |i: usize| 0.5 * (((i + 1) as f64 * dt).sin().powi(2) - (i as f64 * dt).sin().powi(2)) * dp;
    let centre = |i: usize, j: usize| ((i as f64 + 0.5) * dt, -PI + (j as f64 + 0.5) * dp);
    // ψ_h of each bin centre, on the directions refracted into the finish.
    let u = wood.axis();
    let psi_i = wood.refract_in(wi).dot(u).clamp(-1.0, 1.0).asin();
    let psi_h = |i: usize, j: usize| {
        let (th, ph) = centre(i, j);
        psi_i + wood.refract_in(dir(th, ph)).dot(u).clamp(-1.0, 1.0).asin()
    };
    let (mut a_meas, mut var, mut a_mod) = (0.0, 0.0, 0.0);
    let (mut w2_meas, mut w2_mod) = (0.0, 0.0);
    for i in 0..nt {
        for j in 0..np {
            let b = i * np + j;
            let h2 = psi_h(i, j).powi(2);
            a_meas += measured[b] * omega(i);
            var += (std[b] * omega(i)).powi(2);
            a_mod += modelled[b] * omega(i);
            w2_meas += measured[b] * omega(i) * h2;
            w2_mod += modelled[b] * omega(i) * h2;
        }
    }
    let rms = |w2: f64, a: f64| if a > 0.0 { (w2 / a).sqrt().to_degrees() } else { f64::NAN };
    let column = |v: &[f64], j: usize| -> Vec<f64> { (0..nt).map(|i| v[i * np + j]).collect() };
    let energy = |v: &[f64], j: usize| (0..nt).map(|i| v[i * np + j] * omega(i)).sum::<f64>();
    let max_meas = (0..np).map(|j| energy(&measured, j)).fold(0.0, f64::max);
    let max_mod = (0..np).map(|j| energy(&modelled, j)).fold(0.0, f64::max);
    let locus = (0..np)
        .filter(|&j| {
            energy(&measured, j) > COLUMN_THRESHOLD * max_meas && energy(&modelled, j) > COLUMN_THRESHOLD * max_mod
        })
        .map(|j| {
            let to_deg = |k: f64| ((k + 0.5) * dt).to_degrees();
            (
                centre(0, j).1.to_degrees(),
                to_deg(interpolated_peak(&column(&measured, j))),
                to_deg(interpolated_peak(&column(&modelled, j))),
            )
        })
        .collect();
    let back = fiberlab_math::frame::wrap_pi(phi_i + PI);
    let jb = (((back + PI) / dp) as usize).min(np - 1);
    let thetas = (0..nt).map(|i| centre(i, jb).0.to_degrees()).collect();
    let profile =
        (centre(0, jb).1.to_degrees(), thetas, column(&measured, jb), column(&std, jb), column(&modelled, jb));
    SurfaceComparison {
        theta_i,
        phi_i,
        locus,
        width: (rms(w2_meas, a_meas), rms(w2_mod, a_mod)),
        strength: (a_meas, var.sqrt(), a_mod),
        profile,
        bin_degrees: dt.to_degrees(),
    }
}

/// `compare-model` on a surface table.
fn run_surface(args: &Args) -> anyhow::Result<()> {
    let table = read(&args.table)?;
    if args.model.model != "wood" {
        return run_surface_residual(args, &table);
    }
    let Some(fiber) = table.get("fiber") else {
        anyhow::bail!("{}: a surface table needs its `fiber` lobe (single-fiber paths)", args.table.display())
    };
    let mut pairs = args.model.pairs()?;
    pairs.retain(|(k, _)| k != "k_d" && k != "roughness");
    pairs.push(("k_d".into(), RawValue::from("0")));
    pairs.push(("roughness".into(), RawValue::from("0")));
    let model = fiberlab_scatter::build_surface_raw(&args.model.model, &pairs)
        .map_err(|e| anyhow::anyhow!("model `{}`: {e}", args.model.model))?;
    let fiberlab_scatter::SurfaceModel::Wood(wood) = &model else {
        return run_surface_residual(args, &table);
    };
    let k_f = wood.params().k_f.luminance();
    let rows: Vec<SurfaceComparison> =
        (0..fiber.theta_in.len()).map(|s| compare_surface_slice(wood, fiber, s, args.subsamples)).collect();
    let (tl, tw, ts) = SURFACE_TOLERANCES;
    let verdict = |ok: bool| if ok { "pass" } else { "FAIL" };
    let mut json = Vec::new();
    for r in &rows {
        let (pl, pw, ps) = r.passes();
        let ratio = r.strength_ratio();
        let back = &r.profile;
        let k = |v: &[f64]| interpolated_peak(v);
        // No peak in a column without highlight.
        let peak_deg = |v: &[f64]| if v.iter().any(|&x| x > 0.0) { (k(v) + 0.5) * r.bin_degrees } else { f64::NAN };
        let (back_meas, back_mod) = (peak_deg(&back.2), peak_deg(&back.4));
        if !args.json {
            println!(
                "surface table {}: θ_i = {:.2}°, φ_i = {:.2}°, `fiber` class vs {} (k_d = 0)",
                args.table.display(),
                r.theta_i.to_degrees(),
                r.phi_i.to_degrees(),
                args.model.label()
            );
            println!(
                "  locus: {} columns, max |θ_peak measured − model| = {:.2} of the crossed bin's extent, tolerance {tl}: {}",
                r.locus.len(),
                r.locus_error_bins(),
                verdict(pl)
            );
            println!(
                "  highlight in the column φ_o = {:.1}°: θ_o = {back_meas:.2}° measured, {back_mod:.2}° model",
                back.0
            );
            println!(
                "  width: RMS ψ_h = {:.3}° measured, {:.3}° model (bins {:.2}°), tolerance {tw} bin: {}",
                r.width.0,
                r.width.1,
                r.bin_degrees,
                verdict(pw)
            );
            println!(
                "  strength: albedo {:.5} ± {:.5} measured, {:.5} model; ratio {ratio:.3} (k_f fitting it {:.5}), tolerance {:.0}%: {}",
                r.strength.0,
                r.strength.1,
                r.strength.2,
                k_f * ratio,
                100.0 * ts,
                verdict(ps)
            );
        }
        json.push(serde_json::json!({
            "theta_i": number(r.theta_i.to_degrees()),
            "phi_i": number(r.phi_i.to_degrees()),
            "locus_max_error_bins": number(r.locus_error_bins()),
            "locus_columns": r.locus.len(),
            "locus_pass": pl,
            "back_column_phi": number(back.0),
            "back_peak_measured": number(back_meas),
            "back_peak_model": number(back_mod),
            "width_measured": number(r.width.0),
            "width_model": number(r.width.1),
            "width_pass": pw,
            "albedo_measured": number(r.strength.0),
            "albedo_std": number(r.strength.1),
            "albedo_model": number(r.strength.2),
            "k_f_fit": number(k_f * ratio),
            "strength_pass": ps,
        }));
    }
    if args.json {
        println!("{}", serde_json::json!({ "fiber": json }));
    }
    if let Some(prefix) = &args.out {
        let path = prefix.with("_highlight.png");
        let title = format!("{} vs {} (fiber class)", args.table.display(), args.model.label());
        draw_highlight(&path, &rows, &title)?;
        if !args.json {
            println!("wrote {}", path.display());
        }
    }
    Ok(())
}

/// Measured vs model highlight, one row per incidence: its locus θ_peak(φ_o) and the
/// profile through φ_i + 180°.
fn draw_highlight(path: &std::path::Path, rows: &[SurfaceComparison], title: &str) -> anyhow::Result<()> {
    use plotters::prelude::*;
    crate::plot::register_font();
    let size = (1400u32, 40 + 480 * rows.len().max(1) as u32);
    let mut buf = vec![0u8; (size.0 * size.1 * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, size).into_drawing_area();
        let err = |e: DrawingAreaErrorKind<_>| anyhow::anyhow!("drawing: {e:?}");
        root.fill(&WHITE).map_err(err)?;
        let root = root.titled(title, ("sans-serif", 20)).map_err(err)?;
        for (r, area) in rows.iter().zip(root.split_evenly((rows.len().max(1), 1))) {
            let (left, right) = area.split_horizontally(700);
            let mut chart = ChartBuilder::on(&left)
                .margin(15)
                .x_label_area_size(40)
                .y_label_area_size(50)
                .caption(
                    format!("θ_i = {:.0}°: highlight locus, θ_o of the peak per φ_o column", r.theta_i.to_degrees()),
                    ("sans-serif", 16),
                )
                .build_cartesian_2d(-180.0..180.0, 0.0..90.0)
                .map_err(err)?;
            chart
                .configure_mesh()
                .x_desc("φ_o (degrees)")
                .y_desc("θ_o (degrees)")
                .label_style(("sans-serif", 13))
                .draw()
                .map_err(err)?;
            chart
                .draw_series(r.locus.iter().map(|&(p, _, m)| Circle::new((p, m), 3, RGBColor(214, 39, 40).filled())))
                .map_err(err)?
                .label("model (wood)")
                .legend(|(x, y)| Circle::new((x, y), 3, RGBColor(214, 39, 40).filled()));
            chart
                .draw_series(r.locus.iter().map(|&(p, t, _)| Cross::new((p, t), 4, RGBColor(31, 119, 180))))
                .map_err(err)?
                .label("measured (explicit fibers)")
                .legend(|(x, y)| Cross::new((x, y), 4, RGBColor(31, 119, 180)));
            chart
                .configure_series_labels()
                .background_style(WHITE.mix(0.8))
                .border_style(BLACK)
                .label_font(("sans-serif", 13))
                .draw()
                .map_err(err)?;
            let (phi, thetas, meas, std, model) = &r.profile;
            let top = meas.iter().chain(model.iter()).copied().fold(0.0, f64::max).max(1e-12) * 1.1;
            let mut chart = ChartBuilder::on(&right)
                .margin(15)
                .x_label_area_size(40)
                .y_label_area_size(70)
                .caption(format!("f_r (1/sr) along θ_o at φ_o = {phi:.1}°"), ("sans-serif", 16))
                .build_cartesian_2d(0.0..90.0, 0.0..top)
                .map_err(err)?;
            chart
                .configure_mesh()
                .x_desc("θ_o (degrees)")
                .y_desc("f_r (1/sr)")
                .label_style(("sans-serif", 13))
                .draw()
                .map_err(err)?;
            chart
                .draw_series(LineSeries::new(thetas.iter().copied().zip(model.iter().copied()), RGBColor(214, 39, 40)))
                .map_err(err)?
                .label("model (wood)")
                .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], RGBColor(214, 39, 40)));
            chart
                .draw_series(
                    thetas
                        .iter()
                        .zip(meas.iter().zip(std.iter()))
                        .map(|(&t, (&m, &s))| PathElement::new(vec![(t, m - s), (t, m + s)], RGBColor(31, 119, 180))),
                )
                .map_err(err)?;
            chart
                .draw_series(
                    thetas.iter().zip(meas.iter()).map(|(&t, &m)| Cross::new((t, m), 4, RGBColor(31, 119, 180))),
                )
                .map_err(err)?
                .label("measured ± 1σ")
                .legend(|(x, y)| Cross::new((x, y), 4, RGBColor(31, 119, 180)));
            chart
                .configure_series_labels()
                .background_style(WHITE.mix(0.8))
                .border_style(BLACK)
                .label_font(("sans-serif", 13))
                .draw()
                .map_err(err)?;
        }
        root.present().map_err(err)?;
    }
    crate::plot::write_png(path, &buf, size)
}

/// Most bins listed as the worst of an incidence.
const WORST_BINS: usize = 5;

/// One incidence of a residual comparison of a surface model with the `all` class.
struct Residual {
    theta_i: f64,
    phi_i: f64,
    /// Per-bin RMS of model − measured (sr⁻¹), relative L2, Monte Carlo relative L2.
    rms: f64,
    rel_l2: f64,
    mc_rel_l2: f64,
    /// Worst bins: (θ_o°, φ_o°, measured, model, (model − measured)/σ).
    worst: Vec<(f64, f64, f64, f64, f64)>,
    /// Slices through the plane of incidence and across it: (label, θ_o° signed, measured, std, model).
    slices: Vec<(String, Slice)>,
}

/// Points of a slice: (signed θ_o°, measured, std, model).
type Slice = Vec<(f64, f64, f64, f64)>;

/// Residual of a non-wood surface model on a surface table's `all` class, per incidence.
fn run_surface_residual(args: &Args, table: &std::collections::BTreeMap<String, LobeSlices>) -> anyhow::Result<()> {
    let Some(all) = table.get("all") else {
        anyhow::bail!("{}: a surface table needs its `all` lobe (every path)", args.table.display())
    };
    let pairs = args.model.pairs()?;
    let model = fiberlab_scatter::build_surface_raw(&args.model.model, &pairs)
        .map_err(|e| anyhow::anyhow!("model `{}`: {e}", args.model.model))?;
    let (nt, np) = (all.bins_theta, all.bins_phi);
    let (dt, dp) = (FRAC_PI_2 / nt as f64, TAU / np as f64);
    let omega = |i: usize| 0.5 * (((i + 1) as f64 * dt).sin().powi(2) - (i as f64 * dt).sin().powi(2)) * dp;
    let floor = crate::fit::std_floor(all);
    let rows: Vec<Residual> = (0..all.theta_in.len())
        .map(|s| {
            let (theta_i, phi_i) = (all.theta_in[s], all.phi_in[s]);
            let bins = fiberlab_fit::surface_bins(theta_i, phi_i, nt, np, args.subsamples, args.viewer_first);
            let modelled: Vec<f64> = bins.par_iter().map(|b| b.average(&model).luminance()).collect();
            let measured: Vec<f64> = all.f[s].iter().map(|v| v.luminance()).collect();
            let std: Vec<f64> = all.std[s].iter().map(|v| v.luminance()).collect();
            let (mut num, mut den, mut mc, mut area) = (0.0, 0.0, 0.0, 0.0);
            for b in 0..nt * np {
                let w = omega(b / np);
                num += w * (modelled[b] - measured[b]).powi(2);
                den += w * measured[b].powi(2);
                mc += w * std[b].powi(2);
                area += w;
            }
            let centre = |b: usize| (((b / np) as f64 + 0.5) * dt, -PI + ((b % np) as f64 + 0.5) * dp);
            let pull = |b: usize| (modelled[b] - measured[b]) / std[b].max(floor).max(1e-300);
            let mut order: Vec<usize> = (0..nt * np).collect();
            order.sort_by(|&a, &b| pull(b).abs().total_cmp(&pull(a).abs()));
            let worst = order
                .iter()
                .take(WORST_BINS)
                .map(|&b| {
                    let (t, p) = centre(b);
                    (t.to_degrees(), p.to_degrees(), measured[b], modelled[b], pull(b))
                })
                .collect();
            // A plane through the normal at azimuth `a`: θ_o > 0 toward `a`, < 0 toward `a + π`.
            let column = |a: f64| ((fiberlab_math::frame::wrap_pi(a) + PI) / dp).floor() as usize % np;
            let plane = |a: f64| -> Slice {
                let (front, back) = (column(a), column(a + PI));
                let mut v: Slice = (0..nt)
                    .rev()
                    .map(|i| {
                        let b = i * np + back;
                        (-centre(b).0.to_degrees(), measured[b], std[b], modelled[b])
                    })
                    .collect();
                v.extend((0..nt).map(|i| {
                    let b = i * np + front;
                    (centre(b).0.to_degrees(), measured[b], std[b], modelled[b])
                }));
                v
            };
            let slices = vec![
                (format!("plane of incidence (θ_o > 0 at φ_o = {:.0}°)", (phi_i + PI).to_degrees()), plane(phi_i + PI)),
                (
                    format!("plane across it (θ_o > 0 at φ_o = {:.0}°)", (phi_i + FRAC_PI_2).to_degrees()),
                    plane(phi_i + FRAC_PI_2),
                ),
            ];
            let rel = |x: f64| if den > 0.0 { (x / den).sqrt() } else { f64::NAN };
            Residual { theta_i, phi_i, rms: (num / area).sqrt(), rel_l2: rel(num), mc_rel_l2: rel(mc), worst, slices }
        })
        .collect();
    let mut json = Vec::new();
    for r in &rows {
        if !args.json {
            println!(
                "surface table {}: θ_i = {:.2}°, φ_i = {:.2}°, `all` class vs {}",
                args.table.display(),
                r.theta_i.to_degrees(),
                r.phi_i.to_degrees(),
                args.model.label()
            );
            println!(
                "  per-bin RMS of model − measured {:.4e} 1/sr; relative L2 {:.4} (Monte Carlo noise alone {:.4})",
                r.rms, r.rel_l2, r.mc_rel_l2
            );
            println!("  worst bins (θ_o°, φ_o°): measured, model, (model − measured)/σ");
            for (t, p, m, f, z) in &r.worst {
                println!("    ({t:5.1}, {p:6.1}): {m:.4e} {f:.4e} {z:+.1}");
            }
        }
        json.push(serde_json::json!({
            "theta_i": number(r.theta_i.to_degrees()),
            "phi_i": number(r.phi_i.to_degrees()),
            "rms": number(r.rms),
            "rel_l2": number(r.rel_l2),
            "mc_rel_l2": number(r.mc_rel_l2),
            "worst": r.worst.iter().map(|&(t, p, m, f, z)| serde_json::json!({
                "theta_o": number(t), "phi_o": number(p), "measured": number(m), "model": number(f), "pull": number(z)
            })).collect::<Vec<_>>(),
        }));
    }
    if args.json {
        println!("{}", serde_json::json!({ "all": json }));
    }
    if let Some(prefix) = &args.out {
        let path = prefix.with("_slices.png");
        let title = format!("{} vs {} (all paths)", args.table.display(), args.model.label());
        draw_slices(&path, &rows, &title)?;
        if !args.json {
            println!("wrote {}", path.display());
        }
    }
    Ok(())
}

/// Measured (± 1σ) vs model `f_r` along the two planes of each incidence.
fn draw_slices(path: &std::path::Path, rows: &[Residual], title: &str) -> anyhow::Result<()> {
    use plotters::prelude::*;
    crate::plot::register_font();
    let size = (1400u32, 40 + 420 * rows.len().max(1) as u32);
    let mut buf = vec![0u8; (size.0 * size.1 * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, size).into_drawing_area();
        let err = |e: DrawingAreaErrorKind<_>| anyhow::anyhow!("drawing: {e:?}");
        root.fill(&WHITE).map_err(err)?;
        let root = root.titled(title, ("sans-serif", 20)).map_err(err)?;
        let areas = root.split_evenly((rows.len().max(1), 2));
        for (k, area) in areas.iter().enumerate() {
            let Some(r) = rows.get(k / 2) else { continue };
            let (label, v) = &r.slices[k % 2];
            let top = v.iter().map(|x| (x.1 + x.2).max(x.3)).fold(0.0, f64::max).max(1e-12) * 1.1;
            let mut chart = ChartBuilder::on(area)
                .margin(15)
                .x_label_area_size(40)
                .y_label_area_size(70)
                .caption(format!("θ_i = {:.0}°: {label}", r.theta_i.to_degrees()), ("sans-serif", 15))
                .build_cartesian_2d(-90.0..90.0, 0.0..top)
                .map_err(err)?;
            chart
                .configure_mesh()
                .x_desc("signed θ_o (degrees)")
                .y_desc("f_r (1/sr)")
                .label_style(("sans-serif", 13))
                .draw()
                .map_err(err)?;
            let red = RGBColor(214, 39, 40);
            let blue = RGBColor(31, 119, 180);
            chart
                .draw_series(LineSeries::new(v.iter().map(|x| (x.0, x.3)), red))
                .map_err(err)?
                .label("model")
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], red));
            chart
                .draw_series(v.iter().map(|x| PathElement::new(vec![(x.0, x.1 - x.2), (x.0, x.1 + x.2)], blue)))
                .map_err(err)?;
            chart
                .draw_series(v.iter().map(|x| Cross::new((x.0, x.1), 4, blue)))
                .map_err(err)?
                .label("measured ± 1σ")
                .legend(move |(x, y)| Cross::new((x, y), 4, blue));
            chart
                .configure_series_labels()
                .background_style(WHITE.mix(0.8))
                .border_style(BLACK)
                .label_font(("sans-serif", 13))
                .draw()
                .map_err(err)?;
        }
        root.present().map_err(err)?;
    }
    crate::plot::write_png(path, &buf, size)
}
