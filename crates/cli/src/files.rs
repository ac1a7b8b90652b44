//! Output files are written to a temporary file beside the target and renamed into place,
//! so a failed or interrupted command never leaves a partial file; TOML input files are read
//! with errors naming the file, line and column.

use anyhow::Context;
use std::io::Write;
use std::path::Path;

/// Writes `bytes` to `path` atomically (temporary file in the same directory, then rename;
/// [`fiberlab_io::image_file::write_atomically`]).
pub fn write_atomically(path: &Path, bytes: &[u8]) -> anyhow::Result<()> {
    fiberlab_io::image_file::write_atomically(path, |f| f.write_all(bytes))
        .with_context(|| format!("writing {}", path.display()))
}

/// Writes to `path`, or to standard output when `path` is `None` or `-`.
pub fn write_output(path: Option<&Path>, bytes: &[u8]) -> anyhow::Result<()> {
    match path {
        Some(p) if p != Path::new("-") => write_atomically(p, bytes),
        _ => {
            let mut out = std::io::stdout().lock();
            out.write_all(bytes)?;
            out.flush()?;
            Ok(())
        }
    }
}

/// Checks that `w` is a finite unit vector (|w| within 1e−3 of 1).
pub fn require_unit(w: fiberlab_math::DVec3, what: &str) -> anyhow::Result<fiberlab_math::DVec3> {
    let len = w.length();
    anyhow::ensure!(
        w.is_finite() && (len - 1.0).abs() <= 1e-3,
        "{what}: expected a unit vector, got ({}, {}, {}) of length {len}",
        w.x,
        w.y,
        w.z
    );
    Ok(w / len)
}

/// Reads and parses a TOML file; a syntax error names the file, line and column.
pub fn read_toml(path: &Path) -> anyhow::Result<toml::Table> {
    let text = std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    text.parse().map_err(|e: toml::de::Error| {
        let (line, col) = e.span().map_or((0, 0), |s| line_col(&text, s.start));
        anyhow::anyhow!("{}: line {line}, column {col}: {}", path.display(), e.message())
    })
}

/// 1-based line and column of byte offset `at` in `text`.
fn line_col(text: &str, at: usize) -> (usize, usize) {
    let before = &text[..at.min(text.len())];
    let line = before.matches('\n').count() + 1;
    let col = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, col)
}
