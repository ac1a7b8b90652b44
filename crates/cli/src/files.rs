//! Output files are written to a temporary file beside the target and renamed into place
//! ([`fiberlab_io::output_file`]), so a failed command never leaves a partial file and no
//! output replaces a link, a device or a directory; long outputs (CSV rows) are streamed into
//! it through a buffer rather than built in memory, and when a signal stops them the rows
//! written go to `NAME.partial.EXT` ([`stream_output`]). Output places are checked before any
//! work ([`check_output_file`], [`check_writable_dir`]). Input files are opened through
//! [`fiberlab_io::input_file`] (regular files only, within the memory budget); TOML files are
//! read with errors naming the file, line and column.

use anyhow::Context;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// Checks that files can be created in `dir`: it exists, is a directory, and a probe file
/// can be created in it (and is removed at once). Run before any work, so that a bad output
/// place fails at once instead of after the work.
pub fn check_writable_dir(dir: &Path) -> Result<(), String> {
    if !dir.is_dir() {
        return Err(if dir.exists() {
            format!("`{}` is not a directory", dir.display())
        } else {
            format!("the directory `{}` does not exist", dir.display())
        });
    }
    tempfile::Builder::new()
        .prefix(".fiberlab-write-check")
        .tempfile_in(dir)
        .map(drop)
        .map_err(|e| format!("cannot write in `{}`: {}", dir.display(), e.kind()))
}

/// Checks that an output file can be written at `path`: `path` is not a directory (nor ends
/// with `/`), and its directory passes [`check_writable_dir`].
pub fn check_output_file(path: &Path) -> Result<(), String> {
    let text = path.as_os_str().to_string_lossy();
    if text.is_empty() {
        return Err("expected an output file name".into());
    }
    if fiberlab_io::output_file::is_stream(path) {
        return Ok(());
    }
    if text.ends_with('/') || path.is_dir() {
        return Err(format!("`{}` is a directory; give a file name inside it", path.display()));
    }
    // A link, a FIFO or a device is not replaced (fiberlab_io::output_file).
    fiberlab_io::output_file::check_target(path)?;
    check_writable_dir(&directory_of(path))
}

/// Checks that `dir` can be used as an output directory: it is a writable directory, or it
/// does not exist yet and its nearest existing ancestor is a writable directory (it is then
/// created there).
pub fn check_output_dir(dir: &Path) -> anyhow::Result<()> {
    if dir.exists() {
        return check_writable_dir(dir).map_err(|e| anyhow::anyhow!("--out {}: {e}", dir.display()));
    }
    let ancestor = dir.ancestors().skip(1).find(|a| a.as_os_str().is_empty() || a.exists()).unwrap_or(Path::new(""));
    let ancestor = if ancestor.as_os_str().is_empty() { Path::new(".") } else { ancestor };
    check_writable_dir(ancestor).map_err(|e| anyhow::anyhow!("--out {}: {e}", dir.display()))
}

/// The directory a file `path` goes to (`.` for a bare name).
fn directory_of(path: &Path) -> PathBuf {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

/// An output file flag (`--out FILE`), checked by [`check_output_file`] while the command
/// line is read.
pub fn output_file(text: &str) -> Result<PathBuf, String> {
    let path = PathBuf::from(text);
    check_output_file(&path)?;
    Ok(path)
}

/// An output file flag that may name a standard stream (`--output FILE`): `-` or
/// `/dev/stdout` for standard output, `/dev/stderr`, written through.
pub fn output_file_or_stdout(text: &str) -> Result<PathBuf, String> {
    if fiberlab_io::output_file::is_stream(Path::new(text)) { Ok(PathBuf::from(text)) } else { output_file(text) }
}

/// What a streamed output's rows are written to.
pub type Sink<'a> = &'a mut dyn Write;

/// Writes `path` atomically, streaming: `write` writes the contents through a buffer into the
/// temporary file, which is renamed into place only if `write` succeeds (on error nothing is
/// left). When `write` stops for a signal (it returns `Ok` with
/// [`crate::interrupt::stopped_in_flight`]), what it wrote is kept as `NAME.partial.EXT` and the
/// [`crate::interrupt::Interrupted`] error says so; a verb that already chose its outputs'
/// names after a signal ([`crate::interrupt::finishing`]) writes them as named.
pub fn stream_atomically(path: &Path, write: impl FnOnce(Sink) -> anyhow::Result<()>) -> anyhow::Result<()> {
    let context = || format!("writing {}", path.display());
    let mut file = fiberlab_io::output_file::AtomicFile::create(path).with_context(context)?;
    {
        let mut out = BufWriter::with_capacity(1 << 16, file.file());
        write(&mut out)?;
        out.flush().with_context(context)?;
    }
    if crate::interrupt::stopped_in_flight() {
        crate::interrupt::finishing();
        let partial = fiberlab_io::output_file::partial_name(path);
        file.commit_as(&partial).with_context(|| format!("writing {}", partial.display()))?;
        return Err(crate::interrupt::Interrupted(format!("wrote the rows done to {}", partial.display())).into());
    }
    file.commit().with_context(context)
}

/// Streams to `path` atomically ([`stream_atomically`]), or to standard output when `path` is
/// `None` or `-`. With `all_or_nothing`, standard output receives nothing unless `write`
/// succeeds: the rows are spooled to an anonymous temporary file and copied out at the end
/// (disk, not memory); otherwise they go out as they are written.
pub fn stream_output(
    path: Option<&Path>,
    all_or_nothing: bool,
    write: impl FnOnce(Sink) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    let interrupted = || -> anyhow::Result<()> {
        if crate::interrupt::stopped() {
            return Err(crate::interrupt::Interrupted("wrote the rows done to standard output".into()).into());
        }
        Ok(())
    };
    match path {
        Some(p) if !fiberlab_io::output_file::is_stream(p) => stream_atomically(p, write),
        Some(p) if p != Path::new("-") => {
            // `/dev/stdout`, `/dev/stderr`: written through (fiberlab_io::output_file).
            let mut file =
                fiberlab_io::output_file::AtomicFile::create(p).with_context(|| format!("writing {}", p.display()))?;
            {
                let mut out = BufWriter::with_capacity(1 << 16, file.file());
                write(&mut out)?;
                out.flush()?;
            }
            file.commit()?;
            interrupted()
        }
        _ if all_or_nothing => {
            use std::io::Seek;
            let mut spool = tempfile::tempfile().context("creating a temporary file for standard output")?;
            {
                let mut out = BufWriter::with_capacity(1 << 16, &mut spool);
                write(&mut out)?;
                out.flush()?;
            }
            spool.rewind()?;
            let mut stdout = std::io::stdout().lock();
            std::io::copy(&mut spool, &mut stdout)?;
            stdout.flush()?;
            interrupted()
        }
        _ => {
            let mut out = BufWriter::with_capacity(1 << 16, std::io::stdout().lock());
            write(&mut out)?;
            out.flush()?;
            interrupted()
        }
    }
}

/// Writes `bytes` to `path` atomically (temporary file in the same directory, then rename;
/// [`fiberlab_io::image_file::write_atomically`]).
pub fn write_atomically(path: &Path, bytes: &[u8]) -> anyhow::Result<()> {
    fiberlab_io::output_file::write_atomically(path, |f| f.write_all(bytes))
        .with_context(|| format!("writing {}", path.display()))
}

/// Checks that `w` is a finite unit vector ([`fiberlab_math::frame::unit_direction`]: |w|
/// within 1e−3 of 1) and normalizes it.
pub fn require_unit(w: fiberlab_math::DVec3, what: &str) -> anyhow::Result<fiberlab_math::DVec3> {
    fiberlab_math::frame::unit_direction(w).ok_or_else(|| {
        anyhow::anyhow!("{what}: expected a unit vector, got ({}, {}, {}) of length {}", w.x, w.y, w.z, w.length())
    })
}

/// Reads and parses a TOML file; a syntax error names the file, line and column.
pub fn read_toml(path: &Path) -> anyhow::Result<toml::Table> {
    let text = fiberlab_io::input_file::read_text(path)?;
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
