//! `fiberlab dual-tables`: the dual-scattering tables of one far-field model
//! (`fiberlab_scatter::dual_scattering_tables`; Zinke, Yuksel, Weber and Keyser 2008) as CSV,
//! with a figure:
//! * `PREFIX.csv`: `theta_deg,af_r,af_g,af_b,ab_r,ab_g,ab_b,abar_b_r,abar_b_g,abar_b_b,…` — per
//!   light inclination θ (degrees), per colour channel: the average forward attenuation ā_f, the
//!   average backward attenuation ā_b, the backscatter attenuation Ā_b, then the lobe-weighted
//!   shifts and widths `alpha_f, beta2_f, alpha_b, beta2_b` (radians, rad²), the backscatter
//!   shift `delta_b` and spread `sigma_b` (weighted-mean denominator) and `sigma_b_literal`
//!   (the printed one), both without the density factor `1 + d_b ā_f²`; then per lobe
//!   (`r_…`, `tt_…`, `trt_…`, …; `all_…` for a model that does not separate its lobes) its
//!   parts of ā_f and ā_b, its shift and width, and `ng`, its `N^G_p` (rad⁻¹);
//! * `PREFIX.png`: the three quantities over θ, per channel.
//!
//! The rows' memory is checked before any work. A signal (Ctrl-C, SIGTERM, SIGHUP) starts no
//! further row: the rows finished are written to `PREFIX.partial.csv` (and `.png`; never over
//! finished outputs) and the exit status is 130 (`crate::interrupt`).

use crate::arg_values::{self, OutPrefix};
use crate::files::write_atomically;
use crate::model_args::ModelArgs;
use crate::plot::draw_png;
use anyhow::Context;
use fiberlab_math::Rgb;
use fiberlab_scatter::dual_scattering_tables::{DualTableRow, DualTables, Resolution};
use plotters::prelude::*;
use std::fmt::Write as _;

/// Flags of `fiberlab dual-tables`.
#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    model: ModelArgs,
    /// Table nodes over the light inclination (−90°, 90°) (cell midpoints).
    #[arg(long, default_value_t = 64)]
    inclinations: usize,
    /// Quadrature cells of the outgoing direction, in θ_r and in φ_r each (even).
    #[arg(long, default_value_t = 128)]
    outgoing: usize,
    /// Quadrature cells of the incident azimuth over the light's half-circle.
    #[arg(long, default_value_t = 16)]
    incident: usize,
    /// Quadrature cells of the offset h (near-field models only).
    #[arg(long, default_value_t = 16)]
    offsets: usize,
    /// Output prefix: writes PREFIX.csv and PREFIX.png.
    #[arg(long, value_parser = arg_values::out_prefix)]
    out: OutPrefix,
}

/// Builds the tables and writes the files.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let model = args.model.build()?;
    let resolution = Resolution {
        inclinations: args.inclinations,
        incident_azimuths: args.incident,
        outgoing_inclinations: args.outgoing,
        outgoing_azimuths: args.outgoing,
        offsets: args.offsets,
    };
    // Each row holds its sums and one entry per lobe (at most 8): 2 KiB is an upper bound.
    crate::memory_budget::check(&[crate::memory_budget::Need::items(
        format!("{} table rows (--inclinations)", args.inclinations),
        args.inclinations as u64,
        2048,
    )])?;
    let start = std::time::Instant::now();
    let stop = crate::interrupt::listen(
        &format!("building the dual-scattering tables of `{}` ({} rows)", args.model.model, args.inclinations),
        "the rows done",
    );
    let tables = DualTables::new_until(&model, &resolution, stop)
        .with_context(|| format!("dual-scattering tables of `{}`", args.model.model))?;
    crate::interrupt::finishing();
    let out = if crate::interrupt::stopped() { args.out.partial() } else { args.out.clone() };
    eprintln!("dual-scattering tables: {} nodes, built in {:.2} s", tables.rows().len(), start.elapsed().as_secs_f64());
    let mut csv = String::from("theta_deg");
    let mut columns: Vec<String> = [
        "af",
        "ab",
        "abar_b",
        "alpha_f",
        "beta2_f",
        "alpha_b",
        "beta2_b",
        "delta_b",
        "sigma_b",
        "sigma_b_literal",
        "af_beam",
        "abar_b_at_fiber",
    ]
    .iter()
    .map(|s| (*s).to_owned())
    .collect();
    for lobe in tables.lobe_names() {
        let lobe = lobe.to_lowercase().replace('+', "plus").replace('≥', "ge");
        for q in ["af", "ab", "alpha", "beta2", "ng"] {
            columns.push(format!("{lobe}_{q}"));
        }
    }
    for c in &columns {
        write!(csv, ",{c}_r,{c}_g,{c}_b")?;
    }
    csv.push('\n');
    for row in tables.rows() {
        write!(csv, "{:.6}", row.theta.to_degrees())?;
        let mut values = vec![
            row.forward,
            row.backward,
            row.backscatter,
            row.forward_shift,
            row.forward_variance,
            row.backward_shift,
            row.backward_variance,
            row.backscatter_shift,
            row.backscatter_spread,
            row.backscatter_spread_literal,
            row.forward_beam,
            row.backscatter_at_fiber,
        ];
        for l in &row.lobes {
            values.extend([l.forward, l.backward, l.shift, l.variance, l.global_azimuthal]);
        }
        for v in values {
            write!(csv, ",{:.9e},{:.9e},{:.9e}", v[0], v[1], v[2])?;
        }
        csv.push('\n');
    }
    let path = out.with(".csv");
    write_atomically(&path, csv.as_bytes()).with_context(|| format!("writing {}", path.display()))?;
    let title = format!("dual-scattering tables: {}", args.model.label());
    draw_png(&out.with(".png"), (1500, 500), |root| draw(root, &tables, &title))?;
    if crate::interrupt::stopped() {
        return Err(crate::interrupt::Interrupted(format!(
            "wrote {out}.csv and .png with {} of {} rows",
            tables.rows().len(),
            args.inclinations
        ))
        .into());
    }
    eprintln!("wrote {out}.csv and .png");
    Ok(())
}

/// One plotted quantity of a table row.
type RowValue = fn(&DualTableRow) -> Rgb;

fn draw<DB: DrawingBackend>(
    root: DrawingArea<DB, plotters::coord::Shift>,
    tables: &DualTables,
    title: &str,
) -> anyhow::Result<()>
where
    DB::ErrorType: 'static,
{
    let err = |e: DrawingAreaErrorKind<DB::ErrorType>| anyhow::anyhow!("drawing: {e:?}");
    root.fill(&WHITE).map_err(err)?;
    let root = root.titled(title, ("sans-serif", 22)).map_err(err)?;
    let panels = root.split_evenly((1, 3));
    let quantities: [(&str, RowValue); 3] = [
        ("ā_f (forward)", |r| r.forward),
        ("ā_b (backward)", |r| r.backward),
        ("Ā_b (backscatter)", |r| r.backscatter),
    ];
    let channels = [("r", RED), ("g", GREEN), ("b", BLUE)];
    for (panel, (name, value)) in panels.iter().zip(quantities) {
        let top = tables.rows().iter().map(|r| value(r).max_component()).fold(0.0, f64::max).max(1e-12) * 1.05;
        let mut chart = ChartBuilder::on(panel)
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .caption(name, ("sans-serif", 17))
            .build_cartesian_2d(-90.0..90.0, 0.0..top)
            .map_err(err)?;
        chart
            .configure_mesh()
            .x_desc("light inclination θ (degrees)")
            .label_style(("sans-serif", 13))
            .draw()
            .map_err(err)?;
        for (c, (label, colour)) in channels.iter().enumerate() {
            let points: Vec<(f64, f64)> = tables.rows().iter().map(|r| (r.theta.to_degrees(), value(r)[c])).collect();
            let style = colour.stroke_width(2);
            chart
                .draw_series(LineSeries::new(points, style))
                .map_err(err)?
                .label(*label)
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], style));
        }
        chart.configure_series_labels().border_style(BLACK).background_style(WHITE).draw().map_err(err)?;
    }
    root.present().map_err(err)?;
    Ok(())
}
