//! Reading `fiberlab measure` tables back: CSV rows
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

use fiberlab_math::Rgb;
use std::collections::BTreeMap;
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
    const COLS: [&str; 11] =
        ["lobe", "theta_i", "phi_i", "theta_r", "phi_r", "f_r", "f_g", "f_b", "std_r", "std_g", "std_b"];
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
}
