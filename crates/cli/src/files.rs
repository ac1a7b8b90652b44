//! Output files are written to a temporary file beside the target and renamed into place,
//! so a failed or interrupted command never leaves a partial file.

use anyhow::Context;
use std::io::Write;
use std::path::Path;

/// Writes `bytes` to `path` atomically (temporary file in the same directory, then rename).
pub fn write_atomically(path: &Path, bytes: &[u8]) -> anyhow::Result<()> {
    let dir = path.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let mut tmp =
        tempfile::NamedTempFile::new_in(dir).with_context(|| format!("creating a file in {}", dir.display()))?;
    tmp.write_all(bytes).with_context(|| format!("writing {}", path.display()))?;
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        // tempfile creates 0600; outputs are ordinary files.
        tmp.as_file().set_permissions(std::fs::Permissions::from_mode(0o644))?;
    }
    tmp.persist(path).with_context(|| format!("renaming into {}", path.display()))?;
    Ok(())
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

/// Parses `x,y,z` into a vector, naming `what` in errors.
pub fn parse_vec3(text: &str, what: &str) -> anyhow::Result<fiberlab_math::DVec3> {
    let parts: Vec<&str> = text.split(',').map(str::trim).collect();
    let [x, y, z] = parts.as_slice() else {
        anyhow::bail!("{what}: expected three numbers x,y,z, got `{text}`");
    };
    let n = |s: &str| s.parse::<f64>().with_context(|| format!("{what}: cannot read `{s}` as a number"));
    Ok(fiberlab_math::DVec3::new(n(x)?, n(y)?, n(z)?))
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
