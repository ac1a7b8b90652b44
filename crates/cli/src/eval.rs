//! `fiberlab eval`: f_s (fiber models) or f_r (surface models) and pdf for direction pairs
//! read as CSV.
//!
//! Input columns (header required): `wi_x,wi_y,wi_z,wo_x,wo_y,wo_z` and optionally `h`
//! (fiber models: the offset across the fiber) or `u,v` (surface models: texture
//! coordinates; with no texture given they change nothing, but must be finite); other
//! columns are copied through. Fiber directions are in the fiber frame (x = tangent),
//! surface directions in the local frame (z = normal, x = tangent along u). Output: the
//! input columns plus `f_r,f_g,f_b,pdf` (for surfaces f_r in sr⁻¹ with θ from the normal).
//! Rows are read and written one at a time (constant memory for any input; a line longer
//! than [`fiberlab_io::input_file::MAX_LINE_BYTES`] is refused, so `/dev/zero` as standard
//! input ends in an error, not in exhausted memory); the output appears only if every row is
//! valid. `--input` must be a regular file (standard input, the default or `-`, is the
//! verb's one stream input); an output file is checked against the free space of its file
//! system (at least the input's size) first.

use crate::files::{output_file_or_stdout, require_unit, stream_output};
use crate::model_args::AnyModel;
use crate::model_args::ModelArgs;
use anyhow::{Context, bail};
use fiberlab_math::{DVec3, Rgb};
use fiberlab_scatter::{ScatteringFunction, SurfaceScattering};
use std::io::{Read, Write};
use std::path::PathBuf;

/// Flags of `fiberlab eval`.
///
/// Surface models: directions in the local frame (z = normal); optional `u,v` columns are
/// texture coordinates, which change nothing when no texture is given (none can be, yet).
#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    model: ModelArgs,
    /// Input CSV (default: standard input): columns wi_x,wi_y,wi_z,wo_x,wo_y,wo_z; fiber models
    /// (fiber frame) optionally h; surface models (local frame, z = normal) optionally u,v
    /// texture coordinates, which change nothing when no texture is given. Output adds
    /// f_r,f_g,f_b,pdf.
    #[arg(long)]
    input: Option<PathBuf>,
    /// Output CSV (default: standard output); written only when every row is valid. Its
    /// directory is checked writable first.
    #[arg(long, value_parser = output_file_or_stdout)]
    output: Option<PathBuf>,
}

const COLUMNS: [&str; 6] = ["wi_x", "wi_y", "wi_z", "wo_x", "wo_y", "wo_z"];

/// Evaluates every row; any malformed row is an error naming its line and column.
pub fn run(args: &Args) -> anyhow::Result<()> {
    use fiberlab_io::input_file::{LineBounded, MAX_LINE_BYTES, open};
    let model = args.model.build_any()?;
    let (name, input): (String, Box<dyn Read>) = match &args.input {
        Some(p) if p.as_os_str() != "-" => {
            let (file, len) = open(p)?;
            if let Some(out) = &args.output {
                fiberlab_io::output_file::check_free_space(out, len).map_err(anyhow::Error::msg)?;
            }
            let name = p.display().to_string();
            (name.clone(), Box::new(LineBounded::new(std::io::BufReader::new(file), name, MAX_LINE_BYTES)))
        }
        _ => ("<stdin>".to_string(), Box::new(LineBounded::new(std::io::stdin().lock(), "<stdin>", MAX_LINE_BYTES))),
    };
    stream_output(args.output.as_deref(), true, |out| match &model {
        AnyModel::Fiber(m) => evaluate(m, &name, input, out),
        AnyModel::Surface(m) => evaluate_surface(m, &name, input, out),
    })
}

/// Evaluates the CSV read from `input` (named `name` in errors), writing the output CSV to
/// `out` row by row.
pub fn evaluate(model: &impl ScatteringFunction, name: &str, input: impl Read, out: impl Write) -> anyhow::Result<()> {
    evaluate_rows(name, input, out, Columns::Fiber, |wi, wo, h| (model.eval(wi, wo, h), model.pdf(wi, wo, h)))
}

/// [`evaluate`] for a surface model: optional `u,v` columns are read (and must be finite)
/// but change nothing without a texture.
pub fn evaluate_surface(
    model: &impl SurfaceScattering,
    name: &str,
    input: impl Read,
    out: impl Write,
) -> anyhow::Result<()> {
    evaluate_rows(name, input, out, Columns::Surface, |wi, wo, _| model.eval_and_pdf(wi, wo))
}

/// The optional columns a model kind reads.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Columns {
    /// `h`.
    Fiber,
    /// `u,v`.
    Surface,
}

fn evaluate_rows(
    name: &str,
    input: impl Read,
    out: impl Write,
    kind: Columns,
    eval: impl Fn(DVec3, DVec3, f64) -> (Rgb, f64),
) -> anyhow::Result<()> {
    let mut reader = csv::ReaderBuilder::new().trim(csv::Trim::All).from_reader(input);
    let header = reader.headers().with_context(|| format!("{name}: line 1: cannot read the header"))?.clone();
    let index = |col: &str| header.iter().position(|h| h == col);
    let mut idx = [0usize; 6];
    for (k, col) in COLUMNS.iter().enumerate() {
        idx[k] = index(col).with_context(|| {
            let optional = if kind == Columns::Fiber { "h" } else { "u,v" };
            format!("{name}: line 1: missing column `{col}` (need {} and optionally {optional})", COLUMNS.join(","))
        })?;
    }
    let h_idx = if kind == Columns::Fiber { index("h") } else { None };
    let uv_idx: Vec<usize> =
        if kind == Columns::Surface { ["u", "v"].iter().filter_map(|c| index(c)).collect() } else { Vec::new() };
    let mut writer = csv::Writer::from_writer(out);
    let mut out_header: Vec<&str> = header.iter().collect();
    out_header.extend(["f_r", "f_g", "f_b", "pdf"]);
    writer.write_record(&out_header)?;
    let mut record = csv::StringRecord::new();
    loop {
        let more = reader.read_record(&mut record).map_err(|e| {
            if let csv::ErrorKind::Io(io) = e.kind() {
                // The input's own error (a line without end names itself and its line).
                return anyhow::anyhow!("{io}");
            }
            let line = e.position().map_or(0, |p| p.line());
            anyhow::anyhow!("{name}: line {line}: malformed CSV record: {e}")
        })?;
        if !more {
            break;
        }
        let line = record.position().map_or(0, |p| p.line());
        let field = |i: usize| -> anyhow::Result<f64> {
            let text = record.get(i).unwrap_or("");
            match text.parse::<f64>() {
                Ok(v) if v.is_finite() => Ok(v),
                _ => bail!(
                    "{name}: line {line}, column {} (`{}`): expected a finite number, got `{text}`",
                    i + 1,
                    header.get(i).unwrap_or("?")
                ),
            }
        };
        let mut v = [0.0; 6];
        for (k, &i) in idx.iter().enumerate() {
            v[k] = field(i)?;
        }
        let wi = require_unit(DVec3::new(v[0], v[1], v[2]), &format!("{name}: line {line}, columns wi_x..wi_z"))?;
        let wo = require_unit(DVec3::new(v[3], v[4], v[5]), &format!("{name}: line {line}, columns wo_x..wo_z"))?;
        let h = match h_idx {
            Some(i) => {
                let h = field(i)?;
                if !(-1.0..=1.0).contains(&h) {
                    bail!("{name}: line {line}, column {} (`h`): expected a value in [-1, 1], got {h}", i + 1);
                }
                h
            }
            None => 0.0,
        };
        for &i in &uv_idx {
            field(i)?;
        }
        let (f, pdf) = eval(wi, wo, h);
        let values = [f[0], f[1], f[2], pdf].map(|x| x.to_string());
        writer.write_record(record.iter().chain(values.iter().map(String::as_str)))?;
    }
    writer.flush()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn evaluate(model: &impl ScatteringFunction, name: &str, text: &str) -> anyhow::Result<Vec<u8>> {
        let mut out = Vec::new();
        super::evaluate(model, name, text.as_bytes(), &mut out)?;
        Ok(out)
    }

    #[test]
    fn errors_name_line_and_column() {
        let m = fiberlab_scatter::build::<&str, &str>("diffuse", &[]).unwrap();
        let ok = "wi_x,wi_y,wi_z,wo_x,wo_y,wo_z\n0,1,0,0,0,1\n";
        let out = String::from_utf8(evaluate(&m, "t.csv", ok).unwrap()).unwrap();
        assert!(out.starts_with("wi_x,wi_y,wi_z,wo_x,wo_y,wo_z,f_r,f_g,f_b,pdf\n"), "{out}");
        let bad = "wi_x,wi_y,wi_z,wo_x,wo_y,wo_z\n0,1,0,0,0,1\n0,1,x,0,0,1\n";
        let e = evaluate(&m, "t.csv", bad).unwrap_err().to_string();
        assert!(e.contains("t.csv: line 3, column 3 (`wi_z`)"), "{e}");
        let e = evaluate(&m, "t.csv", "wi_x,wi_y\n1,2\n").unwrap_err().to_string();
        assert!(e.contains("missing column `wi_z`"), "{e}");
        let e = evaluate(&m, "t.csv", "wi_x,wi_y,wi_z,wo_x,wo_y,wo_z\n0,2,0,0,0,1\n").unwrap_err().to_string();
        assert!(e.contains("unit vector"), "{e}");
        let e = evaluate(&m, "t.csv", "wi_x,wi_y,wi_z,wo_x,wo_y,wo_z,h\n0,1,0,0,0,1,1.5\n").unwrap_err().to_string();
        assert!(e.contains("column 7 (`h`)"), "{e}");
    }

    /// Surface models: f_r and pdf per row, `u,v` read and checked but changing nothing.
    #[test]
    fn surface_rows_follow_the_contract() {
        let m = fiberlab_scatter::build_surface("lambertian", &[("k_d", "0.5")]).unwrap();
        let text =
            "wi_x,wi_y,wi_z,wo_x,wo_y,wo_z,u,v\n0,0,1,0.6,0,0.8,0.1,0.2\n0,0,1,0.6,0,0.8,0.9,0.7\n0,0,-1,0,0,1,0,0\n";
        let mut out = Vec::new();
        super::evaluate_surface(&m, "s.csv", text.as_bytes(), &mut out).unwrap();
        let out = String::from_utf8(out).unwrap();
        let lines: Vec<&str> = out.lines().collect();
        assert_eq!(lines[0], "wi_x,wi_y,wi_z,wo_x,wo_y,wo_z,u,v,f_r,f_g,f_b,pdf");
        let values = |l: &str| l.split(',').skip(8).map(|x| x.parse::<f64>().unwrap()).collect::<Vec<_>>();
        let (a, b, below) = (values(lines[1]), values(lines[2]), values(lines[3]));
        assert!((a[0] - 0.5 / std::f64::consts::PI).abs() < 1e-15 && (a[3] - 1.0 / std::f64::consts::PI).abs() < 1e-15);
        assert_eq!(a, b, "u,v change nothing without a texture");
        assert_eq!(below, vec![0.0; 4]);
        let bad = "wi_x,wi_y,wi_z,wo_x,wo_y,wo_z,u,v\n0,0,1,0,0,1,nan,0\n";
        let e = super::evaluate_surface(&m, "s.csv", bad.as_bytes(), Vec::new()).unwrap_err().to_string();
        assert!(e.contains("column 7 (`u`)"), "{e}");
        let e = super::evaluate_surface(&m, "s.csv", "wi_x\n1\n".as_bytes(), Vec::new()).unwrap_err().to_string();
        assert!(e.contains("optionally u,v"), "{e}");
    }
}
