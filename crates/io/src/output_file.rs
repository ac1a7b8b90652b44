//! Writing output files: the one way every writer of fiberlab creates a file.
//!
//! * An output is written to a hidden temporary file beside the target (`.NAME.XXXXXX.tmp`),
//!   flushed and synced, and renamed over the target only when complete ([`AtomicFile`],
//!   [`write_atomically`]): a reader never sees half a file, and a failed or interrupted writer
//!   leaves the target as it was.
//! * A target that exists must be a regular file: a directory, a FIFO, a device node (as root,
//!   renaming over `/dev/full` would replace the device with a file) or a symbolic link (the
//!   rename would replace the link, not the file it points to) is refused, saying what it is
//!   ([`check_target`]), before any work and again before the rename.
//! * The standard streams are written through, not renamed: `-` and `/dev/stdout` (standard
//!   output), `/dev/stderr` ([`is_stream`]), for the verbs that document them.
//! * Every live temporary file is registered, so that a signal handler can remove them before
//!   the process exits ([`remove_temporaries`]): no hidden file outlives an interrupted
//!   command.
//! * A streamed output whose size is known in advance is checked against the free space of
//!   its file system first ([`check_free_space`]).

use std::fs::File;
use std::io::{Seek, Write};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// The temporary files being written now (see [`remove_temporaries`]).
static LIVE: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

fn register(path: &Path) {
    LIVE.lock().unwrap_or_else(std::sync::PoisonError::into_inner).push(path.to_path_buf());
}

fn unregister(path: &Path) {
    LIVE.lock().unwrap_or_else(std::sync::PoisonError::into_inner).retain(|p| p != path);
}

/// Removes every temporary file still being written (for a signal handler that is about to
/// end the process); returns how many were removed.
pub fn remove_temporaries() -> usize {
    let live = std::mem::take(&mut *LIVE.lock().unwrap_or_else(std::sync::PoisonError::into_inner));
    live.iter().filter(|p| std::fs::remove_file(p).is_ok()).count()
}

/// Whether `path` names a standard stream that is written through: `-`, `/dev/stdout`,
/// `/dev/stderr`.
#[must_use]
pub fn is_stream(path: &Path) -> bool {
    matches!(path.to_str(), Some("-" | "/dev/stdout" | "/dev/stderr"))
}

/// Refuses an output target that exists and is not a regular file (module docs); the message
/// names the path and what it is. A missing target, a regular file and a stream pass.
pub fn check_target(path: &Path) -> Result<(), String> {
    if is_stream(path) {
        return Ok(());
    }
    let Ok(meta) = std::fs::symlink_metadata(path) else { return Ok(()) };
    let Some(what) = crate::input_file::kind_of(meta.file_type()) else { return Ok(()) };
    Err(if meta.file_type().is_symlink() {
        let to = std::fs::read_link(path).map(|t| format!(" to {}", t.display())).unwrap_or_default();
        format!(
            "{}: a symbolic link{to}, which an output would replace; give the path of a regular file (or remove the link)",
            path.display()
        )
    } else {
        format!("{}: {what}, not a regular file; an output replaces only regular files", path.display())
    })
}

/// An output being written: a temporary file beside the target, or a stream written through.
/// Dropped without [`AtomicFile::commit`], the temporary file is removed and the target is
/// left as it was.
pub struct AtomicFile {
    target: PathBuf,
    /// `None` once committed.
    inner: Option<Inner>,
}

enum Inner {
    Temporary(tempfile::NamedTempFile),
    Stream(File),
}

fn refused(message: String) -> std::io::Error {
    std::io::Error::new(std::io::ErrorKind::InvalidInput, message)
}

impl AtomicFile {
    /// Starts writing `path` (refused, with [`check_target`]'s message, when it is not a
    /// regular file or a stream).
    pub fn create(path: &Path) -> std::io::Result<Self> {
        check_target(path).map_err(refused)?;
        if is_stream(path) {
            let name = if path == Path::new("-") { Path::new("/dev/stdout") } else { path };
            let file = std::fs::OpenOptions::new().append(true).open(name)?;
            return Ok(Self { target: path.into(), inner: Some(Inner::Stream(file)) });
        }
        let dir = match path.parent() {
            Some(p) if !p.as_os_str().is_empty() => p,
            _ => Path::new("."),
        };
        let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
        let tmp = tempfile::Builder::new().prefix(&format!(".{name}.")).suffix(".tmp").tempfile_in(dir)?;
        register(tmp.path());
        Ok(Self { target: path.into(), inner: Some(Inner::Temporary(tmp)) })
    }

    /// The file to write to.
    pub fn file(&mut self) -> &mut File {
        match self.inner.as_mut().expect("not yet committed") {
            Inner::Temporary(t) => t.as_file_mut(),
            Inner::Stream(f) => f,
        }
    }

    /// The target's path.
    #[must_use]
    pub fn target(&self) -> &Path {
        &self.target
    }

    /// Finishes the output: flushes and syncs the temporary file and renames it over the
    /// target (a stream is flushed).
    pub fn commit(self) -> std::io::Result<()> {
        let target = self.target.clone();
        self.commit_as(&target)
    }

    /// Finishes the output under another name (e.g. `NAME.partial.csv` for the rows of an
    /// interrupted command), with the checks of [`AtomicFile::commit`].
    pub fn commit_as(mut self, path: &Path) -> std::io::Result<()> {
        match self.inner.take().expect("not yet committed") {
            Inner::Stream(mut f) => f.flush(),
            Inner::Temporary(mut tmp) => {
                let result = (|| -> std::io::Result<()> {
                    let file = tmp.as_file_mut();
                    file.flush()?;
                    file.rewind()?;
                    file.sync_all()?;
                    #[cfg(unix)]
                    {
                        use std::os::unix::fs::PermissionsExt;
                        // tempfile creates files readable by the owner only; outputs are ordinary files.
                        file.set_permissions(std::fs::Permissions::from_mode(0o644))?;
                    }
                    // Checked again: the target may have become a link or device meanwhile.
                    check_target(path).map_err(refused)?;
                    Ok(())
                })();
                unregister(tmp.path());
                result?;
                tmp.persist(path).map_err(|e| e.error)?;
                Ok(())
            }
        }
    }
}

impl Drop for AtomicFile {
    fn drop(&mut self) {
        if let Some(Inner::Temporary(t)) = &self.inner {
            unregister(t.path());
        }
    }
}

/// Creates `path` by writing a temporary file in the same directory and renaming it into
/// place once `write` succeeds and the data is synced ([`AtomicFile`]). On error the
/// temporary file is removed and `path` is untouched. A target that is not a regular file is
/// refused ([`check_target`]); a stream ([`is_stream`]) is written through.
pub fn write_atomically<F>(path: &Path, write: F) -> std::io::Result<()>
where
    F: FnOnce(&mut File) -> std::io::Result<()>,
{
    let mut out = AtomicFile::create(path)?;
    write(out.file())?;
    out.commit()
}

/// `NAME.partial.EXT` for `NAME.EXT` (`NAME.partial` without an extension): where the
/// finished part of an interrupted output goes.
#[must_use]
pub fn partial_name(path: &Path) -> PathBuf {
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let partial = match name.rsplit_once('.') {
        Some((stem, ext)) if !stem.is_empty() => format!("{stem}.partial.{ext}"),
        _ => format!("{name}.partial"),
    };
    path.with_file_name(partial)
}

/// Refuses an output of `bytes` bytes at `path` when the file system it goes to has less free
/// space (for the unprivileged user); passes when the free space cannot be read, and for
/// streams.
pub fn check_free_space(path: &Path, bytes: u64) -> Result<(), String> {
    if is_stream(path) {
        return Ok(());
    }
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let Some(free) = free_bytes(dir) else { return Ok(()) };
    if bytes > free {
        return Err(format!(
            "{}: the output needs ~ {}, more than the {} free on its file system",
            path.display(),
            crate::memory_budget::bytes_text(bytes),
            crate::memory_budget::bytes_text(free)
        ));
    }
    Ok(())
}

/// Bytes free for unprivileged users on the file system of `dir`.
#[must_use]
pub fn free_bytes(dir: &Path) -> Option<u64> {
    #[cfg(unix)]
    {
        let s = rustix::fs::statvfs(dir).ok()?;
        s.f_bavail.checked_mul(s.f_frsize)
    }
    #[cfg(not(unix))]
    {
        let _ = dir;
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_output_is_renamed_into_place_only_when_complete() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.txt");
        write_atomically(&path, |f| f.write_all(b"one")).unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"one");
        let e = write_atomically(&path, |f| {
            f.write_all(b"half")?;
            Err(std::io::Error::other("boom"))
        });
        assert!(e.is_err());
        assert_eq!(std::fs::read(&path).unwrap(), b"one", "the earlier file stays");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1, "no temporary file is left");
        // Interrupted: the finished part goes to the partial name.
        let mut out = AtomicFile::create(&path).unwrap();
        out.file().write_all(b"rows").unwrap();
        assert_eq!(LIVE.lock().unwrap().iter().filter(|p| p.starts_with(dir.path())).count(), 1);
        out.commit_as(&partial_name(&path)).unwrap();
        assert_eq!(std::fs::read(dir.path().join("out.partial.txt")).unwrap(), b"rows");
        assert!(LIVE.lock().unwrap().iter().all(|p| !p.starts_with(dir.path())));
        assert_eq!(partial_name(Path::new("a/b")), Path::new("a/b.partial"));
        assert_eq!(partial_name(Path::new(".x")), Path::new(".x.partial"));
    }

    #[cfg(unix)]
    #[test]
    fn links_directories_fifos_and_devices_are_not_replaced() {
        let dir = tempfile::tempdir().unwrap();
        let elsewhere = tempfile::tempdir().unwrap();
        let outside = elsewhere.path().join("precious");
        std::fs::write(&outside, "keep").unwrap();
        let link = dir.path().join("link.hair");
        std::os::unix::fs::symlink(&outside, &link).unwrap();
        let e = write_atomically(&link, |f| f.write_all(b"x")).unwrap_err().to_string();
        assert!(e.contains("link.hair: a symbolic link to ") && e.contains("precious"), "{e}");
        assert!(std::fs::symlink_metadata(&link).unwrap().file_type().is_symlink());
        assert_eq!(std::fs::read(&outside).unwrap(), b"keep");
        let e = check_target(dir.path()).unwrap_err();
        assert!(e.ends_with("a directory, not a regular file; an output replaces only regular files"), "{e}");
        let fifo = dir.path().join("fifo");
        if std::process::Command::new("mkfifo").arg(&fifo).status().is_ok_and(|s| s.success()) {
            let e = write_atomically(&fifo, |f| f.write_all(b"x")).unwrap_err().to_string();
            assert!(e.contains("a FIFO (named pipe), not a regular file"), "{e}");
        }
        #[cfg(target_os = "linux")]
        assert!(check_target(Path::new("/dev/null")).unwrap_err().contains("a character device"));
        assert!(check_target(Path::new("/dev/stdout")).is_ok() && check_target(Path::new("-")).is_ok());
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 2, "nothing was written beside them");
    }

    #[test]
    fn free_space_is_checked_before_a_large_stream() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("rows.csv");
        assert_eq!(check_free_space(&path, 1), Ok(()));
        if free_bytes(dir.path()).is_some() {
            let e = check_free_space(&path, u64::MAX).unwrap_err();
            assert!(e.contains("rows.csv: the output needs ~ 16.0 EiB, more than the"), "{e}");
        }
        assert_eq!(check_free_space(Path::new("-"), u64::MAX), Ok(()));
    }
}
