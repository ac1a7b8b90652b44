//! `fiberlab medulla-tables`: builds the medulla scattering tables of one medium
//! (`fiberlab_scatter::hair::medulla`) and writes their slices as CSV, with a figure:
//! * `PREFIX_azimuthal.csv`: `theta_t_deg,h,phi_q_deg,n_r,n_g,n_b,mean_path_length` — the
//!   azimuthal exit density N (1/rad) and the mean path length of that light (without
//!   absorption, unit medulla radius) at every node;
//! * `PREFIX_longitudinal.csv`: `theta_t_deg,phi_q_deg,theta_o_deg,m_r,m_g,m_b` — the
//!   normalised exit-inclination profile M (1/rad) at every node;
//! * `PREFIX_fractions.csv`: `theta_t_deg,h,scattered,escaping_r,escaping_g,escaping_b,mean_path_length`;
//! * `PREFIX.png`: N over φ_q at θ_t = 0 for several offsets, and M over θ_o at the middle
//!   inclination node for several |φ_q|.
//!
//! Angles are degrees in the files; σ per unit medulla radius.

use crate::arg_values::{self, OutPrefix};
use crate::files::write_atomically;
use crate::plot::draw_png;
use anyhow::Context;
use fiberlab_math::Rgb;
use fiberlab_scatter::hair::medulla::{MedullaParams, MedullaTables, Resolution};
use plotters::prelude::*;
use std::f64::consts::{FRAC_PI_2, PI};
use std::fmt::Write as _;

/// Flags of `fiberlab medulla-tables`.
#[derive(clap::Args)]
pub struct Args {
    /// Scattering coefficient per unit medulla radius, in [0, 40].
    #[arg(long, allow_hyphen_values = true)]
    sigma_s: f64,
    /// Absorption coefficient per unit medulla radius: one number or r,g,b, each ≥ 0.
    #[arg(long, default_value = "0", allow_hyphen_values = true, value_parser = rgb)]
    sigma_a: Rgb,
    /// Henyey–Greenstein anisotropy, in (−1, 1).
    #[arg(long, allow_hyphen_values = true)]
    g: f64,
    /// Walks per (θ_t, h') node (default: a budget that falls with σ_s).
    #[arg(long)]
    walks: Option<usize>,
    /// Output prefix: writes PREFIX_azimuthal.csv, PREFIX_longitudinal.csv,
    /// PREFIX_fractions.csv and PREFIX.png.
    #[arg(long, value_parser = arg_values::out_prefix)]
    out: OutPrefix,
}

/// `--sigma-a X` or `--sigma-a R,G,B`.
fn rgb(text: &str) -> Result<Rgb, String> {
    let parts: Result<Vec<f64>, _> = text.split(',').map(|p| p.trim().parse::<f64>()).collect();
    match parts.map_err(|e| format!("`{text}`: {e}"))?.as_slice() {
        [x] => Ok(Rgb::splat(*x)),
        [r, g, b] => Ok(Rgb::new(*r, *g, *b)),
        _ => Err(format!("expected one number or r,g,b, got `{text}`")),
    }
}

/// Builds the tables and writes the files.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let params = MedullaParams::new(args.sigma_s, args.sigma_a, args.g)?;
    let resolution = Resolution { walks: args.walks, ..Resolution::default() };
    let start = std::time::Instant::now();
    let tables = MedullaTables::new(&params, &resolution)?;
    eprintln!(
        "medulla tables: {} walks per node, built in {:.2} s",
        tables.walks_per_node(),
        start.elapsed().as_secs_f64()
    );
    let r = *tables.resolution();
    let channels = |v: Rgb| format!("{:.9e},{:.9e},{:.9e}", v[0], v[1], v[2]);

    let mut azimuthal = String::from("theta_t_deg,h,phi_q_deg,n_r,n_g,n_b,mean_path_length\n");
    let mut fractions = String::from("theta_t_deg,h,scattered,escaping_r,escaping_g,escaping_b,mean_path_length\n");
    for a in 0..r.inclinations {
        let theta_t = tables.inclination_node(a);
        for i in 0..r.offsets {
            let h = tables.offset_node(i);
            for j in 0..r.azimuths {
                let p = tables.azimuth_node(j);
                let n = tables.azimuthal(theta_t, h, p);
                let l = tables.mean_path_length_toward(theta_t, h, p);
                writeln!(
                    azimuthal,
                    "{:.6},{h:.6},{:.6},{},{l:.9e}",
                    theta_t.to_degrees(),
                    p.to_degrees(),
                    channels(n)
                )?;
            }
            writeln!(
                fractions,
                "{:.6},{h:.6},{:.9e},{},{:.9e}",
                theta_t.to_degrees(),
                tables.scattered_fraction(theta_t, h),
                channels(tables.escaping_fraction(theta_t, h)),
                tables.mean_path_length(theta_t, h)
            )?;
        }
    }
    let mut longitudinal = String::from("theta_t_deg,phi_q_deg,theta_o_deg,m_r,m_g,m_b\n");
    for a in 0..r.inclinations {
        let theta_t = tables.inclination_node(a);
        for q in 0..r.profile_azimuths {
            let p = PI * q as f64 / (r.profile_azimuths - 1) as f64;
            for k in 0..r.exit_inclinations {
                let x = tables.exit_inclination_node(k);
                let m = tables.longitudinal(theta_t, p, x);
                writeln!(
                    longitudinal,
                    "{:.6},{:.6},{:.6},{}",
                    theta_t.to_degrees(),
                    p.to_degrees(),
                    x.to_degrees(),
                    channels(m)
                )?;
            }
        }
    }
    for (suffix, text) in
        [("_azimuthal.csv", &azimuthal), ("_longitudinal.csv", &longitudinal), ("_fractions.csv", &fractions)]
    {
        let path = args.out.with(suffix);
        write_atomically(&path, text.as_bytes()).with_context(|| format!("writing {}", path.display()))?;
    }
    let title = format!("medulla tables: σ_s = {}, σ_a = {}, g = {}", args.sigma_s, args.sigma_a, args.g);
    draw_png(&args.out.with(".png"), (1400, 560), |root| draw(root, &tables, &title))?;
    eprintln!("wrote {}_azimuthal.csv, _longitudinal.csv, _fractions.csv and .png", args.out);
    Ok(())
}

fn draw<DB: DrawingBackend>(
    root: DrawingArea<DB, plotters::coord::Shift>,
    tables: &MedullaTables,
    title: &str,
) -> anyhow::Result<()>
where
    DB::ErrorType: 'static,
{
    let err = |e: DrawingAreaErrorKind<DB::ErrorType>| anyhow::anyhow!("drawing: {e:?}");
    root.fill(&WHITE).map_err(err)?;
    let root = root.titled(title, ("sans-serif", 22)).map_err(err)?;
    let (left, right) = root.split_horizontally(700);
    let n = 361;
    let offsets = [0.0, 0.25, 0.5, 0.75, 0.95];
    let curves: Vec<Vec<(f64, f64)>> = offsets
        .iter()
        .map(|&h| {
            (0..n)
                .map(|k| {
                    let p = -PI + 2.0 * PI * k as f64 / (n - 1) as f64;
                    (p.to_degrees(), tables.azimuthal(0.0, h, p).average())
                })
                .collect()
        })
        .collect();
    let top = curves.iter().flatten().map(|c| c.1).fold(0.0, f64::max).max(1e-12) * 1.05;
    let mut chart = ChartBuilder::on(&left)
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .caption("N(θ_t = 0, h', φ_q) (1/rad, channel mean)", ("sans-serif", 17))
        .build_cartesian_2d(-180.0..180.0, 0.0..top)
        .map_err(err)?;
    chart
        .configure_mesh()
        .x_desc("φ_q (degrees; 0 = back, ±180 = forward)")
        .label_style(("sans-serif", 13))
        .draw()
        .map_err(err)?;
    for (k, (c, h)) in curves.into_iter().zip(offsets).enumerate() {
        let colour = Palette99::pick(k).to_rgba();
        chart
            .draw_series(LineSeries::new(c, colour.stroke_width(2)))
            .map_err(err)?
            .label(format!("h' = {h}"))
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], colour.stroke_width(2)));
    }
    chart.configure_series_labels().border_style(BLACK).background_style(WHITE).draw().map_err(err)?;

    let a = tables.resolution().inclinations / 2;
    let theta_t = tables.inclination_node(a);
    let azimuths = [0.0, 90.0, 180.0];
    let curves: Vec<Vec<(f64, f64)>> = azimuths
        .iter()
        .map(|&p: &f64| {
            (0..n)
                .map(|k| {
                    let x = -FRAC_PI_2 + PI * k as f64 / (n - 1) as f64;
                    (x.to_degrees(), tables.longitudinal(theta_t, p.to_radians(), x).average())
                })
                .collect()
        })
        .collect();
    let top = curves.iter().flatten().map(|c| c.1).fold(0.0, f64::max).max(1e-12) * 1.05;
    let mut chart = ChartBuilder::on(&right)
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .caption(format!("M(θ_t = {:.1}°, θ_o | φ_q) (1/rad)", theta_t.to_degrees()), ("sans-serif", 17))
        .build_cartesian_2d(-90.0..90.0, 0.0..top)
        .map_err(err)?;
    chart.configure_mesh().x_desc("θ_o (degrees)").label_style(("sans-serif", 13)).draw().map_err(err)?;
    for (k, (c, p)) in curves.into_iter().zip(azimuths).enumerate() {
        let colour = Palette99::pick(k).to_rgba();
        chart
            .draw_series(LineSeries::new(c, colour.stroke_width(2)))
            .map_err(err)?
            .label(format!("|φ_q| = {p}°"))
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], colour.stroke_width(2)));
    }
    chart.configure_series_labels().border_style(BLACK).background_style(WHITE).draw().map_err(err)?;
    root.present().map_err(err)?;
    Ok(())
}
