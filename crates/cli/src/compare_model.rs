//! `fiberlab compare-model`: a model evaluated on the bins of a measured table, per lobe:
//! relative L2 error, peak positions and heights, and difference figures; `--json` prints the
//! same as one object keyed by lobe.
//!
//! A surface table (`fiberlab measure --surface`) is compared with a surface model that has a
//! fiber axis (`wood`, Marschner et al. 2005) on its `fiber` class (single-fiber paths), the
//! model reduced to its fiber term (`k_d = 0`, smooth finish whose delta `eval` leaves out):
//! the highlight's locus (per φ_o column, the θ_o of the peak), its width (energy-weighted RMS
//! of ψ_h = ψ_i′ + ψ_o′ over the bins) and its strength (albedo of the class), each against a
//! stated tolerance ([`SURFACE_TOLERANCES`]); `--out PREFIX` draws PREFIX_highlight.png.
//!
//! Any other surface model (`sadeghi-2013`, `irawan-2012`, `lambertian`) is compared with the
//! table's `all` class (every path: a cloth's BRDF as a whole) by its residual: the model
//! averaged over each bin as `fiberlab fit` does, the per-bin RMS of model − measured (sr⁻¹,
//! weighted by the bins' cosθ dω), the relative L2 error (and the table's own Monte Carlo
//! relative L2, what a perfect model would get), and the worst bins by |model − measured|/σ;
//! `--out PREFIX` draws PREFIX_slices.png (the plane of incidence and the plane across it).
//!
//! The comparisons are `fiberlab_compare::{fiber_table, surface_table}`; this verb reads the
//! table, prints and draws.

use crate::model_args::ModelArgs;
use crate::plot::{Scale, write_figure};
use fiberlab_compare::fiber_table::compare_fiber_table;
use fiberlab_compare::surface_table::{
    HighlightComparison, HighlightJson, ResidualComparison, ResidualJson, SURFACE_TOLERANCES, SurfaceComparison,
    compare_surface_table,
};
use fiberlab_io::table::{TableKind, read, read_kind};
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

/// Runs the comparison and prints one line per (incidence, lobe), or the JSON object.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let request = args.model.request()?;
    if read_kind(&args.table)? == TableKind::Surface {
        let table = read(&args.table)?;
        return match compare_surface_table(&table, &request, args.subsamples, args.viewer_first)
            .map_err(|e| anyhow::anyhow!("{}: {e}", args.table.display()))?
        {
            SurfaceComparison::Highlight(rows) => print_highlight(args, &rows),
            SurfaceComparison::Residual(rows) => print_residual(args, &rows),
        };
    }
    let table = read(&args.table)?;
    let lobes = compare_fiber_table(&table, &request, args.subsamples)?;
    if args.json {
        let json: serde_json::Map<String, serde_json::Value> =
            lobes.iter().map(|l| (l.lobe.clone(), serde_json::to_value(l).expect("plain numbers"))).collect();
        println!("{}", serde_json::Value::Object(json));
        return Ok(());
    }
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
    for lobe in &lobes {
        for (s, row) in lobe.per_theta_i.iter().enumerate() {
            println!(
                "{:>8.2} {:>8.2} {:<8} {:>10.4} {:>10.4} {:>22} {:>22} {:>12.4e} {:>12.4e}",
                row.theta_i,
                row.phi_i,
                lobe.lobe,
                row.rel_l2,
                row.mc_rel_l2,
                format!("({:.1}, {:.1})", row.peak_measured[0], row.peak_measured[1]),
                format!("({:.1}, {:.1})", row.peak_model[0], row.peak_model[1]),
                row.peak_measured[2],
                row.peak_model[2]
            );
            if s == 0
                && let Some(prefix) = &args.out
            {
                let path = prefix.with(&format!("_{}.png", lobe.lobe));
                let title = format!("|{} − measured| ({}), θ_i = {:.1}°", args.model.label(), lobe.lobe, row.theta_i);
                write_figure(&path, &row.difference, &title, Scale::Log, 4.0)?;
            }
        }
    }
    Ok(())
}

/// Prints (or writes as JSON) and draws a highlight comparison.
fn print_highlight(args: &Args, rows: &[HighlightComparison]) -> anyhow::Result<()> {
    let (tl, tw, ts) = SURFACE_TOLERANCES;
    let verdict = |ok: bool| if ok { "pass" } else { "FAIL" };
    if args.json {
        let json: Vec<HighlightJson> = rows.iter().map(HighlightJson::from).collect();
        println!("{}", serde_json::json!({ "fiber": json }));
    } else {
        for r in rows {
            let (pl, pw, ps) = r.passes();
            let ratio = r.strength_ratio();
            let (back_meas, back_mod) = r.back_column_peaks();
            println!(
                "surface table {}: θ_i = {:.2}°, φ_i = {:.2}°, `fiber` class vs {} (its fiber term)",
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
                r.profile.0
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
                r.k_f * ratio,
                100.0 * ts,
                verdict(ps)
            );
        }
    }
    if let Some(prefix) = &args.out {
        let path = prefix.with("_highlight.png");
        let title = format!("{} vs {} (fiber class)", args.table.display(), args.model.label());
        draw_highlight(&path, rows, &title)?;
        if !args.json {
            println!("wrote {}", path.display());
        }
    }
    Ok(())
}

/// Prints (or writes as JSON) and draws a residual comparison.
fn print_residual(args: &Args, rows: &[ResidualComparison]) -> anyhow::Result<()> {
    if args.json {
        let json: Vec<ResidualJson> = rows.iter().map(ResidualJson::from).collect();
        println!("{}", serde_json::json!({ "all": json }));
    } else {
        for r in rows {
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
    }
    if let Some(prefix) = &args.out {
        let path = prefix.with("_slices.png");
        let title = format!("{} vs {} (all paths)", args.table.display(), args.model.label());
        draw_slices(&path, rows, &title)?;
        if !args.json {
            println!("wrote {}", path.display());
        }
    }
    Ok(())
}

/// Measured vs model highlight, one row per incidence: its locus θ_peak(φ_o) and the
/// profile through φ_i + 180°.
fn draw_highlight(path: &std::path::Path, rows: &[HighlightComparison], title: &str) -> anyhow::Result<()> {
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
                .label("model (fiber term)")
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
                .label("model (fiber term)")
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

/// Measured (± 1σ) vs model `f_r` along the two planes of each incidence.
fn draw_slices(path: &std::path::Path, rows: &[ResidualComparison], title: &str) -> anyhow::Result<()> {
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
