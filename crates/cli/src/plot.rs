//! `fiberlab plot`: a scattering function as an image over (φ, θ_r) at fixed θ_i, like the
//! figures of Marschner et al. 2003, beside polar plots of its azimuthal distribution. For a
//! surface model the image is f_r over (φ_o, θ_o) of the hemisphere (θ from the normal) for
//! light at (θ_i, φ_i = 0), with the azimuthal distribution `∫ f_r cosθ_o sinθ_o dθ_o` and
//! f_r on the ring θ_o = θ_i (through the mirror direction φ_o = 180°).

use crate::arg_values::{self, Angle};
use crate::files::write_atomically;
use crate::model_args::AnyModel;
use crate::model_args::ModelArgs;
use anyhow::Context;
use fiberlab_compare::maps::{ScatteringMap as Grids, fiber_map, surface_map};
use plotters::prelude::*;
use plotters::style::colors::colormaps::ViridisRGB;
use std::f64::consts::PI;
use std::path::{Path, PathBuf};

/// Flags of `fiberlab plot`.
#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    model: ModelArgs,
    /// Inclination θ_i of the light from the normal plane, degrees in (−90, 90) (positive
    /// toward the tip); for surface models the angle from the surface normal, in [0, 90).
    #[arg(long, allow_hyphen_values = true, value_parser = arg_values::inclination)]
    theta_i: Angle,
    /// Output file; the extension (.png or .svg) selects the format. Checked (extension,
    /// writable directory) before anything is computed.
    #[arg(long, value_parser = figure_file)]
    out: PathBuf,
    /// Colour scale of the image.
    #[arg(long, value_enum, default_value_t = Scale::Log)]
    scale: Scale,
    /// Decades shown by the log scale (> 0).
    #[arg(long, default_value = "4", value_parser = arg_values::positive)]
    decades: f64,
}

/// `--out FILE.png|svg`: a figure file name in a writable directory.
fn figure_file(text: &str) -> Result<PathBuf, String> {
    let path = crate::files::output_file(text)?;
    match path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref() {
        Some("png" | "svg") => Ok(path),
        _ => Err(format!("expected a .png or .svg file name, got `{text}`")),
    }
}

/// Colour scale of the (φ, θ_r) image.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scale {
    /// Linear in f_s.
    Linear,
    /// Logarithmic in f_s.
    Log,
}

/// Draws the figure.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let title = format!("{}   θ_i = {}°", args.model.label(), args.theta_i.degrees);
    match args.model.build_any()? {
        AnyModel::Fiber(model) => {
            let grids = fiber_map(&model, args.theta_i.radians);
            write_figure(&args.out, &grids, &title, args.scale, args.decades)
        }
        AnyModel::Surface(model) => {
            anyhow::ensure!(
                args.theta_i.degrees >= 0.0,
                "--theta-i {}: for a surface model the light's angle from the normal, in [0, 90)",
                args.theta_i.degrees
            );
            let grids = surface_map(&model, args.theta_i.radians);
            write_figure_with(&args.out, &grids, &title, args.scale, args.decades, &SURFACE_AXES)
        }
    }
}

/// The labels and θ range of a figure.
struct Axes {
    caption: &'static str,
    x_desc: &'static str,
    y_desc: &'static str,
    /// θ range of the image rows, degrees.
    y_range: (f64, f64),
    value: &'static str,
    azimuthal: &'static str,
    cone: &'static str,
}

const FIBER_AXES: Axes = Axes {
    caption: "f_s (luminance, 1/sr) over relative azimuth φ and θ_r",
    x_desc: "φ = φ_r − φ_i (degrees; 0 = backscatter)",
    y_desc: "θ_r (degrees; + toward tip)",
    y_range: (-90.0, 90.0),
    value: "f_s",
    azimuthal: "∫ f_s cos²θ_r dθ_r",
    cone: "f_s on the specular cone θ_r = −θ_i",
};

const SURFACE_AXES: Axes = Axes {
    caption: "f_r (luminance, 1/sr) over azimuth φ_o and θ_o from the normal",
    x_desc: "φ_o (degrees; light at φ_i = 0, mirror direction at ±180)",
    y_desc: "θ_o (degrees from the normal)",
    y_range: (0.0, 90.0),
    value: "f_r",
    azimuthal: "∫ f_r cosθ_o sinθ_o dθ_o",
    cone: "f_r on the ring θ_o = θ_i",
};

/// Writes the figure as PNG or SVG according to the extension of `path`.
pub(crate) fn write_figure(path: &Path, grids: &Grids, title: &str, scale: Scale, decades: f64) -> anyhow::Result<()> {
    write_figure_with(path, grids, title, scale, decades, &FIBER_AXES)
}

fn write_figure_with(
    path: &Path,
    grids: &Grids,
    title: &str,
    scale: Scale,
    decades: f64,
    axes: &Axes,
) -> anyhow::Result<()> {
    let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    register_font();
    let size = (1500u32, 620u32);
    match ext.as_deref() {
        Some("svg") => {
            let mut svg = String::new();
            draw(SVGBackend::with_string(&mut svg, size).into_drawing_area(), grids, title, scale, decades, axes)?;
            write_atomically(path, svg.as_bytes())
        }
        Some("png") => draw_png(path, size, |root| draw(root, grids, title, scale, decades, axes)),
        _ => anyhow::bail!("--out {}: expected a .png or .svg file name", path.display()),
    }
}

pub(crate) fn register_font() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, dejavu::sans::regular());
    });
}

/// Draws a figure of `size` pixels with `draw` and writes it to `path` as a PNG.
pub(crate) fn draw_png(
    path: &Path,
    size: (u32, u32),
    draw: impl FnOnce(DrawingArea<BitMapBackend<'_>, plotters::coord::Shift>) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    register_font();
    let mut buf = vec![0u8; (size.0 * size.1 * 3) as usize];
    draw(BitMapBackend::with_buffer(&mut buf, size).into_drawing_area())?;
    write_png(path, &buf, size)
}

pub(crate) fn write_png(path: &Path, rgb: &[u8], (w, h): (u32, u32)) -> anyhow::Result<()> {
    let mut bytes = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut bytes, w, h);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        enc.write_header()?.write_image_data(rgb).context("encoding PNG")?;
    }
    write_atomically(path, &bytes)
}

fn draw<DB: DrawingBackend>(
    root: DrawingArea<DB, plotters::coord::Shift>,
    g: &Grids,
    title: &str,
    scale: Scale,
    decades: f64,
    axes: &Axes,
) -> anyhow::Result<()>
where
    DB::ErrorType: 'static,
{
    let err = |e: DrawingAreaErrorKind<DB::ErrorType>| anyhow::anyhow!("drawing: {e:?}");
    root.fill(&WHITE).map_err(err)?;
    let root = root.titled(title, ("sans-serif", 24)).map_err(err)?;
    let (left, right) = root.split_horizontally(950);
    let (heat, bar) = left.split_horizontally(860);

    // Image over (φ, θ_r).
    let max = g.image.iter().flatten().copied().fold(0.0, f64::max);
    let (lo, hi) = match scale {
        Scale::Linear => (0.0, max.max(1e-300)),
        Scale::Log => {
            let hi = max.max(1e-300).log10();
            (hi - decades, hi)
        }
    };
    let map = |v: f64| match scale {
        Scale::Linear => v,
        Scale::Log => v.max(1e-300).log10(),
    };
    let mut chart = ChartBuilder::on(&heat)
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(50)
        .caption(axes.caption, ("sans-serif", 18))
        .build_cartesian_2d(-180.0..180.0, axes.y_range.0..axes.y_range.1)
        .map_err(err)?;
    chart
        .configure_mesh()
        .x_desc(axes.x_desc)
        .y_desc(axes.y_desc)
        .label_style(("sans-serif", 13))
        .axis_desc_style(("sans-serif", 14))
        .disable_mesh()
        .draw()
        .map_err(err)?;
    let rows = g.image.len().max(1);
    let cols = g.image.first().map_or(1, Vec::len).max(1);
    let (dx, dy) = (360.0 / cols as f64, (axes.y_range.1 - axes.y_range.0) / rows as f64);
    chart
        .draw_series(g.image.iter().enumerate().flat_map(|(r, row)| {
            row.iter().enumerate().map(move |(c, &v)| {
                let x0 = -180.0 + c as f64 * dx;
                let y0 = axes.y_range.0 + r as f64 * dy;
                let color = ViridisRGB::get_color_normalized(map(v).clamp(lo, hi), lo, hi);
                Rectangle::new([(x0, y0), (x0 + dx, y0 + dy)], color.filled())
            })
        }))
        .map_err(err)?;

    // Colour bar.
    let mut cb = ChartBuilder::on(&bar)
        .margin_top(45)
        .margin_bottom(50)
        .y_label_area_size(55)
        .build_cartesian_2d(0.0..1.0, lo..hi)
        .map_err(err)?;
    let log_desc = format!("log10 {}", axes.value);
    let ydesc = match scale {
        Scale::Linear => axes.value,
        Scale::Log => log_desc.as_str(),
    };
    cb.configure_mesh()
        .disable_x_axis()
        .disable_mesh()
        .y_desc(ydesc)
        .y_label_style(("sans-serif", 13))
        .axis_desc_style(("sans-serif", 14))
        .draw()
        .map_err(err)?;
    let steps = 100;
    cb.draw_series((0..steps).map(|k| {
        let a = lo + (hi - lo) * k as f64 / steps as f64;
        let b = lo + (hi - lo) * (k + 1) as f64 / steps as f64;
        Rectangle::new([(0.0, a), (1.0, b)], ViridisRGB::get_color_normalized(a, lo, hi).filled())
    }))
    .map_err(err)?;

    // Polar plots of the azimuthal distributions, each normalized to its maximum.
    let mut polar = ChartBuilder::on(&right)
        .margin(20)
        .caption("azimuthal distribution (polar, φ = 0 at right)", ("sans-serif", 18))
        .build_cartesian_2d(-1.15..1.15, -1.15..1.15)
        .map_err(err)?;
    for r in [0.25, 0.5, 0.75, 1.0] {
        polar
            .draw_series(LineSeries::new(
                (0..=120).map(|k| {
                    let a = 2.0 * PI * k as f64 / 120.0;
                    (r * a.cos(), r * a.sin())
                }),
                RGBColor(200, 200, 200),
            ))
            .map_err(err)?;
    }
    for k in 0..12 {
        let a = PI * k as f64 / 6.0;
        polar.draw_series(LineSeries::new([(0.0, 0.0), (a.cos(), a.sin())], RGBColor(220, 220, 220))).map_err(err)?;
    }
    let curves: [(&[f64], RGBColor, &str); 2] =
        [(&g.azimuthal, RGBColor(31, 119, 180), axes.azimuthal), (&g.cone, RGBColor(214, 39, 40), axes.cone)];
    for (data, color, label) in curves {
        let m = data.iter().copied().fold(0.0, f64::max);
        if m <= 0.0 {
            continue;
        }
        let n = data.len();
        let pts: Vec<(f64, f64)> = (0..=n)
            .map(|j| {
                let v = data[j % n] / m;
                let a = -PI + (j % n) as f64 / n as f64 * 2.0 * PI + PI / n as f64;
                (v * a.cos(), v * a.sin())
            })
            .collect();
        polar
            .draw_series(LineSeries::new(pts, color.stroke_width(2)))
            .map_err(err)?
            .label(label)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2)));
    }
    polar
        .configure_series_labels()
        .position(SeriesLabelPosition::LowerLeft)
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .label_font(("sans-serif", 14))
        .draw()
        .map_err(err)?;
    root.present().map_err(err)?;
    Ok(())
}
