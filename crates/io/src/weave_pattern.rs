//! The text format of Irawan & Marschner weave patterns (`fiberlab_scatter::irawan_2012`):
//! read and written. Angles are in degrees in the file, radians in the model.
//!
//! ```text
//! # a plain weave
//! tile 2 2                 # width (along u) and height (along v), in cells
//! alpha 0.015              # uniform scattering
//! beta 4                   # forward-scattering concentration
//! ss 0.5                   # filament smoothing, [0, 1)
//! hwidth 0.5               # highlight width fraction
//! warp_area 1
//! weft_area 1
//! yarn 1 warp psi=0 umax=22 kappa=-0.7 width=1 length=1 center=0.5,0.5 kd=0.25,0.25,0.3 ks=0.075
//! yarn 2 weft psi=0 umax=16 kappa=-0.7 width=1 length=1 center=1.5,0.5 kd=0.25 ks=0.075
//! pattern                  # then `height` rows of `width` 1-based yarn ids, row 0 at v = 0
//! 1 2
//! 2 1
//! ```
//! `yarn N` lines must number the yarns 1, 2, … in order; `psi` = 0 is a filament yarn. Every
//! key of a yarn line is required. Every error names the file, the line and the field.

use fiberlab_math::Rgb;
use fiberlab_scatter::irawan_2012::{PatternError, WeavePattern, YarnKind, YarnSegment};
use std::fmt::Write as _;
use std::path::Path;
use thiserror::Error;

/// Why a weave-pattern file cannot be read.
#[non_exhaustive]
#[derive(Debug, Error)]
pub enum WeavePatternError {
    /// The file could not be opened or read ([`crate::input_file`]); the error names it.
    #[error(transparent)]
    Input(crate::input_file::InputError),
    /// A line could not be read.
    #[error("{file}:{line}: field `{field}`: {message}")]
    Syntax {
        /// The file.
        file: String,
        /// 1-based line number (0: the end of the file).
        line: usize,
        /// The field.
        field: String,
        /// What is wrong.
        message: String,
    },
    /// The pattern is complete but invalid (grid size, ids, ranges).
    #[error("{file}:{line}: {error}")]
    Invalid {
        /// The file.
        file: String,
        /// The line that the error concerns: the line giving the field (the `pattern` line for
        /// grid errors).
        line: usize,
        /// The model's validation error (names the field). Shown in the message, not chained,
        /// so that it is not printed twice.
        error: PatternError,
    },
}

/// Reads a pattern file.
pub fn read_weave_pattern(path: &Path) -> Result<WeavePattern, WeavePatternError> {
    let file = path.display().to_string();
    let text = crate::input_file::read_text(path).map_err(WeavePatternError::Input)?;
    parse_weave_pattern(&text, &file)
}

struct Reader<'a> {
    file: &'a str,
}

impl Reader<'_> {
    fn err(&self, line: usize, field: &str, message: impl Into<String>) -> WeavePatternError {
        WeavePatternError::Syntax { file: self.file.into(), line, field: field.into(), message: message.into() }
    }

    fn number(&self, line: usize, field: &str, text: &str) -> Result<f64, WeavePatternError> {
        let x: f64 = text.parse().map_err(|_| self.err(line, field, format!("cannot read `{text}` as a number")))?;
        if !x.is_finite() {
            return Err(self.err(line, field, format!("`{text}` is not finite")));
        }
        Ok(x)
    }

    fn numbers(&self, line: usize, field: &str, text: &str) -> Result<Vec<f64>, WeavePatternError> {
        text.split(',').map(|t| self.number(line, field, t.trim())).collect()
    }

    fn color(&self, line: usize, field: &str, text: &str) -> Result<Rgb, WeavePatternError> {
        match self.numbers(line, field, text)?.as_slice() {
            [x] => Ok(Rgb::splat(*x)),
            [r, g, b] => Ok(Rgb::new(*r, *g, *b)),
            _ => Err(self.err(line, field, "expected one number or r,g,b")),
        }
    }
}

/// Parses pattern text; `file` names it in errors.
pub fn parse_weave_pattern(text: &str, file: &str) -> Result<WeavePattern, WeavePatternError> {
    let r = Reader { file };
    let (mut tile, mut tile_line) = (None, 0);
    // Each scalar with its value and the line that gave it.
    let mut scalars: [(&str, Option<(f64, usize)>); 6] =
        [("alpha", None), ("beta", None), ("ss", None), ("hwidth", None), ("warp_area", None), ("weft_area", None)];
    let mut yarns: Vec<YarnSegment> = Vec::new();
    let mut yarn_lines: Vec<usize> = Vec::new();
    let mut rows: Vec<(usize, Vec<usize>)> = Vec::new();
    let (mut in_pattern, mut pattern_line) = (false, 0);
    for (k, raw) in text.lines().enumerate() {
        let line = k + 1;
        let content = raw.split('#').next().unwrap_or("").trim();
        if content.is_empty() {
            continue;
        }
        let mut words = content.split_whitespace();
        let key = words.next().unwrap_or("");
        if in_pattern {
            let ids = content
                .split_whitespace()
                .map(|w| {
                    w.parse::<usize>().map_err(|_| r.err(line, "pattern", format!("cannot read `{w}` as a yarn id")))
                })
                .collect::<Result<Vec<_>, _>>()?;
            rows.push((line, ids));
            continue;
        }
        match key {
            "tile" => {
                if tile.is_some() {
                    return Err(r.err(line, "tile", format!("given twice (first at line {tile_line})")));
                }
                let vals: Vec<&str> = words.collect();
                let [w, h] = vals.as_slice() else {
                    return Err(r.err(line, "tile", "expected `tile WIDTH HEIGHT`"));
                };
                let parse = |t: &str| t.parse::<usize>().ok().filter(|&n| n > 0);
                match (parse(w), parse(h)) {
                    (Some(w), Some(h)) => tile = Some((w, h)),
                    _ => return Err(r.err(line, "tile", "width and height must be whole numbers ≥ 1")),
                }
                tile_line = line;
            }
            "pattern" => {
                if words.next().is_some() {
                    return Err(r.err(line, "pattern", "expected `pattern` alone on its line, the rows below it"));
                }
                in_pattern = true;
                pattern_line = line;
            }
            "yarn" => {
                let id = words.next().ok_or_else(|| r.err(line, "yarn", "missing the yarn number"))?;
                if id.parse::<usize>().ok() != Some(yarns.len() + 1) {
                    return Err(r.err(line, "yarn", format!("expected yarn number {}, found `{id}`", yarns.len() + 1)));
                }
                let kind = match words.next() {
                    Some("warp") => YarnKind::Warp,
                    Some("weft") => YarnKind::Weft,
                    other => return Err(r.err(line, "kind", format!("expected warp or weft, found {other:?}"))),
                };
                let mut fields: [(&str, Option<&str>); 8] = [
                    ("psi", None),
                    ("umax", None),
                    ("kappa", None),
                    ("width", None),
                    ("length", None),
                    ("center", None),
                    ("kd", None),
                    ("ks", None),
                ];
                for w in words {
                    let (k, v) = w.split_once('=').ok_or_else(|| r.err(line, w, "expected key=value"))?;
                    let slot = fields
                        .iter_mut()
                        .find(|(name, _)| *name == k)
                        .ok_or_else(|| r.err(line, k, "unknown field of a yarn"))?;
                    if slot.1.replace(v).is_some() {
                        return Err(r.err(line, k, "given twice"));
                    }
                }
                let get = |name: &str| {
                    fields
                        .iter()
                        .find(|(n, _)| *n == name)
                        .and_then(|(_, v)| *v)
                        .ok_or_else(|| r.err(line, name, "missing"))
                };
                let center = r.numbers(line, "center", get("center")?)?;
                let [cu, cv] = center.as_slice() else {
                    return Err(r.err(line, "center", "expected u,v"));
                };
                yarns.push(YarnSegment {
                    kind,
                    psi: r.number(line, "psi", get("psi")?)?.to_radians(),
                    u_max: r.number(line, "umax", get("umax")?)?.to_radians(),
                    kappa: r.number(line, "kappa", get("kappa")?)?,
                    width: r.number(line, "width", get("width")?)?,
                    length: r.number(line, "length", get("length")?)?,
                    center: [*cu, *cv],
                    k_d: r.color(line, "kd", get("kd")?)?,
                    k_s: r.color(line, "ks", get("ks")?)?,
                });
                yarn_lines.push(line);
            }
            _ => {
                let slot = scalars
                    .iter_mut()
                    .find(|(name, _)| *name == key)
                    .ok_or_else(|| r.err(line, key, "unknown keyword"))?;
                if let Some((_, first)) = slot.1 {
                    return Err(r.err(line, key, format!("given twice (first at line {first})")));
                }
                let value = words.next().ok_or_else(|| r.err(line, key, "missing value"))?;
                if words.next().is_some() {
                    return Err(r.err(line, key, "expected one value"));
                }
                slot.1 = Some((r.number(line, key, value)?, line));
            }
        }
    }
    let (width, height) = tile.ok_or_else(|| r.err(0, "tile", "missing"))?;
    let scalar = |name: &str| {
        scalars
            .iter()
            .find(|(n, _)| *n == name)
            .and_then(|(_, v)| *v)
            .map(|(x, _)| x)
            .ok_or_else(|| r.err(0, name, "missing"))
    };
    if !in_pattern {
        return Err(r.err(0, "pattern", "missing"));
    }
    if rows.len() != height {
        return Err(r.err(
            pattern_line,
            "pattern",
            format!("{} rows, the tile (line {tile_line}) has height {height}", rows.len()),
        ));
    }
    for (line, ids) in &rows {
        if ids.len() != width {
            return Err(r.err(
                *line,
                "pattern",
                format!("{} ids, the tile (line {tile_line}) has width {width}", ids.len()),
            ));
        }
        if let Some(&id) = ids.iter().find(|&&id| id == 0 || id > yarns.len()) {
            return Err(r.err(*line, "pattern", format!("yarn id {id} out of range 1..={}", yarns.len())));
        }
    }
    let pattern = WeavePattern {
        width,
        height,
        cells: rows.into_iter().flat_map(|(_, ids)| ids).collect(),
        yarns,
        alpha: scalar("alpha")?,
        beta: scalar("beta")?,
        ss: scalar("ss")?,
        h_width: scalar("hwidth")?,
        warp_area: scalar("warp_area")?,
        weft_area: scalar("weft_area")?,
    };
    pattern.validate().map_err(|error| {
        // Point at the line that gave the field: the yarn's for per-yarn errors, the scalar's
        // for the scalars, the tile's or the pattern's for the grid.
        let line = match &error {
            PatternError::Value { field, .. } => match field.strip_prefix("yarn ") {
                Some(rest) => rest
                    .split(':')
                    .next()
                    .and_then(|n| n.parse::<usize>().ok())
                    .and_then(|n| yarn_lines.get(n.wrapping_sub(1)).copied())
                    .unwrap_or(pattern_line),
                None => scalars.iter().find(|(n, _)| n == field).and_then(|(_, v)| *v).map_or(pattern_line, |(_, l)| l),
            },
            PatternError::Empty("tile") => tile_line,
            _ => pattern_line,
        };
        WeavePatternError::Invalid { file: file.into(), line, error }
    })?;
    Ok(pattern)
}

/// Writes a pattern in the format [`parse_weave_pattern`] reads.
#[must_use]
pub fn write_weave_pattern(p: &WeavePattern) -> String {
    let mut s = String::new();
    let color = |c: Rgb| format!("{},{},{}", c[0], c[1], c[2]);
    let _ = writeln!(s, "tile {} {}", p.width, p.height);
    let _ = writeln!(s, "alpha {}\nbeta {}\nss {}\nhwidth {}", p.alpha, p.beta, p.ss, p.h_width);
    let _ = writeln!(s, "warp_area {}\nweft_area {}", p.warp_area, p.weft_area);
    for (k, y) in p.yarns.iter().enumerate() {
        let kind = if y.kind == YarnKind::Warp { "warp" } else { "weft" };
        let _ = writeln!(
            s,
            "yarn {} {kind} psi={} umax={} kappa={} width={} length={} center={},{} kd={} ks={}",
            k + 1,
            y.psi.to_degrees(),
            y.u_max.to_degrees(),
            y.kappa,
            y.width,
            y.length,
            y.center[0],
            y.center[1],
            color(y.k_d),
            color(y.k_s)
        );
    }
    s.push_str("pattern\n");
    for row in p.cells.chunks(p.width) {
        let ids: Vec<String> = row.iter().map(ToString::to_string).collect();
        s.push_str(&ids.join(" "));
        s.push('\n');
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use fiberlab_scatter::irawan_2012::IRAWAN_PRESETS;

    const LINING: &str = "tile 2 2\nalpha 0.015\nbeta 4\nss 0.5\nhwidth 0.5\nwarp_area 1\nweft_area 1\n\
yarn 1 warp psi=0 umax=22 kappa=-0.7 width=1 length=1 center=0.5,0.5 kd=0.25 ks=0.075\n\
yarn 2 weft psi=0 umax=16 kappa=-0.7 width=1 length=1 center=1.5,0.5 kd=0.25 ks=0.075\n\
pattern\n1 2\n2 1\n";

    fn syntax(text: &str) -> (usize, String) {
        match parse_weave_pattern(text, "t.wv") {
            Err(WeavePatternError::Syntax { line, field, .. }) => (line, field),
            other => panic!("expected a syntax error, got {other:?}"),
        }
    }

    #[test]
    fn every_preset_round_trips() {
        for name in IRAWAN_PRESETS {
            let p = WeavePattern::preset(name).unwrap();
            let back = parse_weave_pattern(&write_weave_pattern(&p), name).unwrap();
            assert_eq!(back.cells, p.cells, "{name}");
            assert_eq!((back.width, back.height), (p.width, p.height));
            for (a, b) in back.yarns.iter().zip(&p.yarns) {
                assert!((a.psi - b.psi).abs() < 1e-12 && (a.u_max - b.u_max).abs() < 1e-12, "{name}");
                assert_eq!((a.kind, a.center, a.k_d, a.k_s), (b.kind, b.center, b.k_d, b.k_s));
            }
        }
    }

    #[test]
    fn a_written_file_reads_with_one_based_ids() {
        let p = parse_weave_pattern(LINING, "lining.wv").unwrap();
        assert_eq!(p.cells, vec![1, 2, 2, 1]);
        assert!((p.yarns[0].u_max - 22f64.to_radians()).abs() < 1e-15);
    }

    #[test]
    fn errors_name_file_line_and_field() {
        // Wrong grid size: a row too short, and a missing row.
        assert_eq!(syntax(&LINING.replace("2 1\n", "2\n")), (12, "pattern".into()));
        assert_eq!(syntax(&LINING.replace("2 1\n", "")), (10, "pattern".into()));
        // Yarn id out of range, and 0 (ids are 1-based).
        assert_eq!(syntax(&LINING.replace("1 2\n", "1 3\n")), (11, "pattern".into()));
        assert_eq!(syntax(&LINING.replace("1 2\n", "0 2\n")), (11, "pattern".into()));
        // Missing parameter of a yarn; NaN.
        assert_eq!(
            syntax(&LINING.replace(" kappa=-0.7 width=1 length=1 center=1.5", " width=1 length=1 center=1.5")),
            (9, "kappa".into())
        );
        assert_eq!(syntax(&LINING.replace("umax=16", "umax=NaN")), (9, "umax".into()));
        // Missing pattern-wide parameter.
        assert_eq!(syntax(&LINING.replace("beta 4\n", "")), (0, "beta".into()));
        let e = parse_weave_pattern(&LINING.replace("umax=16", "umax=95"), "x.wv").unwrap_err();
        assert!(matches!(e, WeavePatternError::Invalid { line: 9, .. }), "{e}");
        let text = e.to_string();
        assert!(text.starts_with("x.wv:9:") && text.contains("yarn 2: umax"), "{text}");
    }

    /// A pattern-wide value out of range is reported at the line that gives it (not at the
    /// pattern's), once; `tile` and the scalars may be given once.
    #[test]
    fn range_errors_point_at_their_line_and_keys_are_given_once() {
        let e = parse_weave_pattern(&LINING.replace("alpha 0.015", "alpha 50"), "x.wv").unwrap_err();
        let line = LINING.lines().position(|l| l.starts_with("alpha")).unwrap() + 1;
        assert!(matches!(e, WeavePatternError::Invalid { line: l, .. } if l == line), "{e}");
        let text = e.to_string();
        assert_eq!(text.matches("alpha").count(), 1, "said once: {text}");
        assert!(std::error::Error::source(&e).is_none(), "not chained, so not printed twice");
        let tile = LINING.lines().position(|l| l.starts_with("tile")).unwrap() + 1;
        let twice = LINING.replace("alpha 0.015\n", "alpha 0.015\ntile 2 2\n");
        assert_eq!(syntax(&twice), (tile + 2, "tile".into()));
        assert!(parse_weave_pattern(&twice, "x.wv").unwrap_err().to_string().contains("given twice (first at line"));
        let again = LINING.replace("beta 4\n", "beta 4\nbeta 5\n");
        assert_eq!(syntax(&again).1, "beta");
    }
}
