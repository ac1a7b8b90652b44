//! Writing and reading `fiberlab measure` tables: CSV rows
//! `lobe,theta_i,phi_i,theta_r,phi_r,f_r,f_g,f_b,std_r,std_g,std_b` (degrees at bin centres;
//! inclinations θ in [−90°, 90°], azimuths φ in [−360°, 360°], one turn either way, so that
//! both the (−180°, 180°] and the [0°, 360°) conventions are read). Errors name the file and
//! the line (and column).
//!
//! A surface table (`fiberlab measure --surface`) has the same columns, preceded by the
//! comment line [`SURFACE_HEADER`]: θ is then measured from the surface normal (θ_r in
//! [0°, 90°]), φ is the absolute azimuth from the tangent `x` toward `y`, the values are a
//! BRDF `f_r` (sr⁻¹), and the lobes are the path classes `finish, fiber, substrate,
//! multiple, all`. Lines starting with `#` are comments.

use crate::LinearImage;
use fiberlab_math::Rgb;
use std::collections::BTreeMap;
use std::io::Write;
use std::path::Path;

/// First line of a surface table.
pub const SURFACE_HEADER: &str = "# fiberlab surface table: BRDF f_r (1/sr) = power fraction per cos-weighted solid angle of the bin; theta from the normal, phi from +x toward +y (degrees)";

/// What a table tabulates.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TableKind {
    /// A fiber's `f_s` (θ from the normal plane, φ relative to the light).
    Fiber,
    /// A surface BRDF (θ from the normal, absolute φ).
    Surface,
}

/// The kind of table `text` is: a surface table starts with [`SURFACE_HEADER`]'s prefix
/// `# fiberlab surface table`.
#[must_use]
pub fn kind_of(text: &str) -> TableKind {
    if text.trim_start().starts_with("# fiberlab surface table") { TableKind::Surface } else { TableKind::Fiber }
}

/// Reads the kind of the table at `path` (its first line).
pub fn read_kind(path: &Path) -> Result<TableKind, TableError> {
    let text = crate::input_file::read_text(path).map_err(|e| TableError(e.to_string()))?;
    Ok(kind_of(&text))
}

/// A malformed or unreadable table.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct TableError(String);

macro_rules! bail {
    ($($t:tt)*) => { return Err(TableError(format!($($t)*))) };
}

/// One lobe's bins for every incidence: `(f, std)` per bin, row-major `[θ_r][φ]`.
#[derive(Clone, Debug)]
pub struct LobeSlices {
    /// Incidence inclinations θ_i (radians), increasing.
    pub theta_in: Vec<f64>,
    /// Light azimuth φ_i (radians) of each slice.
    pub phi_in: Vec<f64>,
    /// Bins in θ_r.
    pub bins_theta: usize,
    /// Bins in φ.
    pub bins_phi: usize,
    /// Values per slice.
    pub f: Vec<Vec<Rgb>>,
    /// Standard errors per slice.
    pub std: Vec<Vec<Rgb>>,
}

/// Reads every lobe of a measurement CSV; errors name the file and line.
pub fn read(path: &Path) -> Result<BTreeMap<String, LobeSlices>, TableError> {
    let text = crate::input_file::read_text(path).map_err(|e| TableError(e.to_string()))?;
    parse(&text, &path.display().to_string())
}

/// Parses measurement CSV `text` (named `name` in errors).
pub fn parse(text: &str, name: &str) -> Result<BTreeMap<String, LobeSlices>, TableError> {
    const COLS: [&str; 11] = COLUMNS;
    let mut reader = csv::ReaderBuilder::new().trim(csv::Trim::All).comment(Some(b'#')).from_reader(text.as_bytes());
    let header =
        reader.headers().map_err(|e| TableError(format!("{name}: line 1: cannot read the header: {e}")))?.clone();
    let idx: Vec<usize> = COLS
        .iter()
        .map(|c| {
            header
                .iter()
                .position(|h| h == *c)
                .ok_or_else(|| TableError(format!("{name}: line 1: missing column `{c}`")))
        })
        .collect::<Result<_, _>>()?;
    // lobe → (θ_i, φ_i) key → (θ_i, φ_i, rows of (θ_r, φ_r, f, std))
    type Rows = Vec<(f64, f64, Rgb, Rgb)>;
    type Slices = BTreeMap<(i64, i64), (f64, f64, Rows)>;
    let mut lobes: BTreeMap<String, Slices> = BTreeMap::new();
    for rec in reader.records() {
        let rec = rec.map_err(|e| TableError(format!("{name}: line {}: {e}", e.position().map_or(0, |p| p.line()))))?;
        let line = rec.position().map_or(0, |p| p.line());
        let num = |k: usize| -> Result<f64, TableError> {
            let t = rec.get(idx[k]).unwrap_or("");
            t.parse::<f64>().ok().filter(|v| v.is_finite()).ok_or_else(|| {
                TableError(format!(
                    "{name}: line {line}, column {} (`{}`): expected a finite number, got `{t}`",
                    idx[k] + 1,
                    COLS[k]
                ))
            })
        };
        let v: Vec<f64> = (1..11).map(num).collect::<Result<_, _>>()?;
        for (k, limit) in [(1, 90.0), (2, 360.0), (3, 90.0), (4, 360.0)] {
            if v[k - 1].abs() > limit {
                bail!(
                    "{name}: line {line}, column {} (`{}`): {:?} degrees is outside [-{limit}, {limit}]",
                    idx[k] + 1,
                    COLS[k],
                    v[k - 1]
                );
            }
        }
        let lobe = rec.get(idx[0]).unwrap_or("").to_string();
        // Key slices by θ_i, φ_i in millidegrees so that printed decimals group exactly.
        let key = ((v[0] * 1000.0).round() as i64, (v[1] * 1000.0).round() as i64);
        let slot = lobes.entry(lobe).or_default().entry(key).or_insert((v[0], v[1], Vec::new()));
        slot.2.push((v[2], v[3], Rgb::new(v[4], v[5], v[6]), Rgb::new(v[7], v[8], v[9])));
    }
    if lobes.is_empty() {
        bail!("{name}: no data rows");
    }
    lobes
        .into_iter()
        .map(|(lobe, slices)| {
            let mut theta_in = Vec::new();
            let mut phi_in = Vec::new();
            let mut f = Vec::new();
            let mut std = Vec::new();
            let (mut nt, mut np) = (0, 0);
            for (_, (ti, pi, mut rows)) in slices {
                let distinct = |sel: fn(&(f64, f64, Rgb, Rgb)) -> f64, rows: &Rows| {
                    let mut v: Vec<i64> = rows.iter().map(|r| (sel(r) * 1e6).round() as i64).collect();
                    v.sort_unstable();
                    v.dedup();
                    v.len()
                };
                let (t, p) = (distinct(|r| r.0, &rows), distinct(|r| r.1, &rows));
                if t * p != rows.len() {
                    bail!("{name}: lobe `{lobe}`, θ_i = {ti}°: {} rows do not form a {t}×{p} grid", rows.len());
                }
                if (nt, np) != (0, 0) && (nt, np) != (t, p) {
                    bail!("{name}: lobe `{lobe}`: θ_i = {ti}° has a {t}×{p} grid, other slices {nt}×{np}");
                }
                (nt, np) = (t, p);
                rows.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
                theta_in.push(ti.to_radians());
                phi_in.push(pi.to_radians());
                f.push(rows.iter().map(|r| r.2).collect());
                std.push(rows.iter().map(|r| r.3).collect());
            }
            Ok((lobe, LobeSlices { theta_in, phi_in, bins_theta: nt, bins_phi: np, f, std }))
        })
        .collect()
}

/// The columns of a measurement table, in order.
pub const COLUMNS: [&str; 11] =
    ["lobe", "theta_i", "phi_i", "theta_r", "phi_r", "f_r", "f_g", "f_b", "std_r", "std_g", "std_b"];

/// A measurement at one incidence, as the table writer sees it (implemented by the
/// goniophotometers' measurements).
pub trait Tabulated {
    /// Light inclination θ_i and azimuth φ_i (radians).
    fn incidence(&self) -> (f64, f64);
    /// Bins in θ and in φ.
    fn bins(&self) -> (usize, usize);
    /// Centre `(θ, φ)` (radians) of bin `(i, j)`.
    fn bin_centre(&self, i: usize, j: usize) -> (f64, f64);
    /// Each lobe's name, values `f` and standard errors, row-major `[θ][φ]`.
    fn lobe_tables(&self) -> Vec<(&'static str, &[Rgb], &[Rgb])>;
}

/// Writes the table of `measurements` to `out`: for [`TableKind::Surface`] the comment line
/// [`SURFACE_HEADER`] first, then the header [`COLUMNS`] and one row per lobe and bin of
/// every measurement (angles in degrees at bin centres). [`parse`] reads it back.
pub fn write<T: Tabulated>(out: &mut dyn Write, kind: TableKind, measurements: &[T]) -> std::io::Result<()> {
    if kind == TableKind::Surface {
        writeln!(out, "{SURFACE_HEADER}")?;
    }
    let mut w = csv::Writer::from_writer(out);
    w.write_record(COLUMNS)?;
    for m in measurements {
        let (theta_i, phi_i) = m.incidence();
        let (ti, pi) = (theta_i.to_degrees().to_string(), phi_i.to_degrees().to_string());
        let (nt, np) = m.bins();
        for (name, f, std) in m.lobe_tables() {
            for i in 0..nt {
                for j in 0..np {
                    let (tr, p) = m.bin_centre(i, j);
                    let (f, s) = (f[i * np + j], std[i * np + j]);
                    let fields =
                        [tr.to_degrees(), p.to_degrees(), f[0], f[1], f[2], s[0], s[1], s[2]].map(|x| x.to_string());
                    w.write_record(
                        [name, ti.as_str(), pi.as_str()].into_iter().chain(fields.iter().map(String::as_str)),
                    )?;
                }
            }
        }
    }
    w.flush()
}

/// Lobe `lobe` of `m` (`f`, linear RGB) as an image over (φ, θ): φ from −180° left to 180°
/// right; a fiber table's θ_r from +90° at the top to −90° at the bottom, a surface table's θ
/// from 0° at the top to 90°.
#[must_use]
pub fn lobe_image(m: &impl Tabulated, lobe: usize, kind: TableKind) -> LinearImage {
    let (nt, np) = m.bins();
    let f = m.lobe_tables()[lobe].1;
    let mut img = LinearImage::new(np, nt);
    for i in 0..nt {
        let row = match kind {
            TableKind::Fiber => nt - 1 - i,
            TableKind::Surface => i,
        };
        for j in 0..np {
            let v = f[i * np + j];
            img.set(j, row, [v[0] as f32, v[1] as f32, v[2] as f32]);
        }
    }
    img
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_slices_and_names_bad_lines() {
        let mut text = String::from("lobe,theta_i,phi_i,theta_r,phi_r,f_r,f_g,f_b,std_r,std_g,std_b\n");
        for ti in [0.0, 30.0] {
            for tr in [-45.0, 45.0] {
                for p in [-90.0, 90.0] {
                    text.push_str(&format!("all,{ti},0,{tr},{p},1,2,3,0.1,0.1,0.1\n"));
                }
            }
        }
        let t = parse(&text, "t.csv").unwrap();
        let all = &t["all"];
        assert_eq!((all.bins_theta, all.bins_phi, all.theta_in.len()), (2, 2, 2));
        assert_eq!(all.f[1][3], Rgb::new(1.0, 2.0, 3.0));
        let bad = text.replace("all,30,0,45,90,1,2,3", "all,30,0,45,90,x,2,3");
        let e = parse(&bad, "t.csv").unwrap_err().to_string();
        assert!(e.contains("t.csv: line 9, column 6 (`f_r`)"), "{e}");
        // Angles outside their ranges (θ beyond ±90°, φ beyond ±360°) name line and column.
        let e = parse(&text.replace("all,30,0,45,90,1,2,3", "all,30,0,300,90,1,2,3"), "t.csv").unwrap_err();
        assert!(
            e.to_string().contains("t.csv: line 9, column 4 (`theta_r`): 300.0 degrees is outside [-90, 90]"),
            "{e}"
        );
        let e = parse(&text.replace("all,30,0,45,90,1,2,3", "all,30,0,45,-400,1,2,3"), "t.csv").unwrap_err();
        assert!(e.to_string().contains("line 9, column 5 (`phi_r`): -400.0 degrees"), "{e}");
        let e = parse(&text.replace("all,30,0,45,90,1,2,3", "all,1e308,0,45,90,1,2,3"), "t.csv").unwrap_err();
        assert!(e.to_string().contains("(`theta_i`): 1e308 degrees"), "{e}");
        let missing: String = text.lines().take(8).collect::<Vec<_>>().join("\n");
        assert!(parse(&missing, "t.csv").unwrap_err().to_string().contains("grid"));
        // A surface table: the header comment is skipped and names the kind.
        let surface = format!("{SURFACE_HEADER}\n{text}");
        assert_eq!(kind_of(&surface), TableKind::Surface);
        assert_eq!(kind_of(&text), TableKind::Fiber);
        assert_eq!(parse(&surface, "s.csv").unwrap()["all"].f[1][3], Rgb::new(1.0, 2.0, 3.0));
    }

    /// A two-incidence measurement on a 2 × 3 grid with distinct values in every bin.
    struct Grid {
        theta_i: f64,
        f: Vec<Rgb>,
        std: Vec<Rgb>,
    }

    impl Tabulated for Grid {
        fn incidence(&self) -> (f64, f64) {
            (self.theta_i, 0.25)
        }
        fn bins(&self) -> (usize, usize) {
            (2, 3)
        }
        fn bin_centre(&self, i: usize, j: usize) -> (f64, f64) {
            ((i as f64 + 0.5) * 0.5, -3.0 + 2.0 * j as f64)
        }
        fn lobe_tables(&self) -> Vec<(&'static str, &[Rgb], &[Rgb])> {
            vec![("r", &self.f, &self.std), ("all", &self.f, &self.std)]
        }
    }

    #[test]
    fn written_tables_read_back_and_images_orient_by_kind() {
        let grid = |theta_i: f64| Grid {
            theta_i,
            f: (0..6).map(|k| Rgb::new(k as f64, 0.5 + theta_i, 2.0)).collect(),
            std: (0..6).map(|k| Rgb::splat(0.01 * k as f64)).collect(),
        };
        let ms = [grid(0.1), grid(0.6)];
        for kind in [TableKind::Fiber, TableKind::Surface] {
            let mut out = Vec::new();
            write(&mut out, kind, &ms).unwrap();
            let text = String::from_utf8(out).unwrap();
            assert_eq!(kind_of(&text), kind);
            let t = parse(&text, "t.csv").unwrap();
            for lobe in ["r", "all"] {
                let l = &t[lobe];
                assert_eq!((l.bins_theta, l.bins_phi, l.theta_in.len()), (2, 3, 2));
                for (s, m) in ms.iter().enumerate() {
                    assert!((l.theta_in[s] - m.theta_i).abs() < 1e-12 && (l.phi_in[s] - 0.25).abs() < 1e-12);
                    for k in 0..6 {
                        assert!((l.f[s][k] - m.f[k]).map(f64::abs).max_component() < 1e-12, "{lobe} {s} {k}");
                        assert!((l.std[s][k] - m.std[k]).map(f64::abs).max_component() < 1e-12);
                    }
                }
            }
        }
        let fiber = lobe_image(&ms[0], 1, TableKind::Fiber);
        let surface = lobe_image(&ms[0], 1, TableKind::Surface);
        // Bin (θ 0, φ 2) holds f_r = 2: the bottom row of a fiber image, the top of a surface one.
        assert_eq!(fiber.get(2, 1)[0], 2.0);
        assert_eq!(surface.get(2, 0)[0], 2.0);
    }
}
