//! Opening input files: the one way every reader of fiberlab opens a file.
//!
//! * Only regular files are read (symbolic links to them are followed). A directory, a FIFO
//!   (named pipe), a character or block device (`/dev/zero`) or a socket is refused with a
//!   message naming the path and what it is — a FIFO would block the reader forever, a device
//!   would feed it without end. The check is made on the opened file itself (opened without
//!   blocking), so a file swapped for a FIFO in between is refused too.
//! * A file is read whole only within [`crate::memory_budget::input_bound`], the memory the
//!   process may use (`--memory-limit` or what the machine has available): larger files are
//!   refused before their first byte is read, naming the size and the budget; a file that
//!   grows while it is read is cut at the bound and refused the same way. Decompressed
//!   streams (`.pbrt.gz`) are bounded the same way ([`read_within`]).
//! * Streamed input (rows of a CSV read one at a time) may be any length, but one line may not
//!   exceed [`MAX_LINE_BYTES`] ([`LineBounded`]): a stream without line breaks is refused, not
//!   accumulated. Standard input is read only by the verbs that document it (`eval`).
//! * Text is UTF-8; the first invalid byte is reported with its line, column and byte offset
//!   ([`read_text`]). Parse errors of the readers name the file and the line (text formats) or
//!   the byte (binary formats); [`line_column`] turns a byte offset into both.

use crate::memory_budget::{bytes_text, input_bound};
use std::fs::File;
use std::io::Read;
use std::path::{Path, PathBuf};

/// The longest line a streamed input may have (1 MiB).
pub const MAX_LINE_BYTES: u64 = 1 << 20;

/// Why an input file could not be read.
#[non_exhaustive]
#[derive(Debug, thiserror::Error)]
pub enum InputError {
    /// Opening or reading failed.
    #[error("{path}: {error}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The system's error.
        error: std::io::Error,
    },
    /// The path names something other than a regular file.
    #[error("{path}: {what}, not a regular file; give a file")]
    NotAFile {
        /// The path.
        path: PathBuf,
        /// What it is: `a directory`, `a FIFO (named pipe)`, `a character device`, …
        what: &'static str,
    },
    /// The file is larger than the process may read.
    #[error("{path}: {size} is more than the memory budget ({budget}); --memory-limit SIZE to override")]
    TooLarge {
        /// The file.
        path: PathBuf,
        /// Its size, or `more than N` when it grew while read.
        size: String,
        /// The budget, in words.
        budget: String,
    },
    /// The text is not UTF-8.
    #[error("{path}:{line}:{column}: byte {byte}: not UTF-8 text")]
    NotUtf8 {
        /// The file.
        path: PathBuf,
        /// 1-based line of the first invalid byte.
        line: usize,
        /// 1-based column (characters) of it.
        column: usize,
        /// Its byte offset.
        byte: usize,
    },
}

impl InputError {
    /// The path the error concerns.
    #[must_use]
    pub fn path(&self) -> &Path {
        match self {
            InputError::Io { path, .. }
            | InputError::NotAFile { path, .. }
            | InputError::TooLarge { path, .. }
            | InputError::NotUtf8 { path, .. } => path,
        }
    }

    /// The error as an [`std::io::Error`] whose text names the path (for readers whose error
    /// types carry an I/O error).
    #[must_use]
    pub fn into_io(self) -> std::io::Error {
        match self {
            InputError::Io { error, .. } => error,
            other => std::io::Error::new(std::io::ErrorKind::InvalidInput, other.to_string()),
        }
    }
}

/// What a file type is, in words (`None` for a regular file).
#[must_use]
pub fn kind_of(file_type: std::fs::FileType) -> Option<&'static str> {
    if file_type.is_file() {
        return None;
    }
    if file_type.is_dir() {
        return Some("a directory");
    }
    if file_type.is_symlink() {
        return Some("a symbolic link");
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if file_type.is_fifo() {
            return Some("a FIFO (named pipe)");
        }
        if file_type.is_char_device() {
            return Some("a character device");
        }
        if file_type.is_block_device() {
            return Some("a block device");
        }
        if file_type.is_socket() {
            return Some("a socket");
        }
    }
    Some("not a regular file")
}

/// Opens the regular file at `path` for reading (module docs); returns it with its size.
pub fn open(path: &Path) -> Result<(File, u64), InputError> {
    let io = |error| InputError::Io { path: path.into(), error };
    let not_a_file = |what| InputError::NotAFile { path: path.into(), what };
    // Refused before opening (opening a FIFO for reading would wait for a writer)…
    if let Some(what) = kind_of(std::fs::metadata(path).map_err(io)?.file_type()) {
        return Err(not_a_file(what));
    }
    let mut options = std::fs::OpenOptions::new();
    options.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        // …and checked again on what was opened, without blocking if it became a FIFO.
        options.custom_flags(rustix::fs::OFlags::NONBLOCK.bits() as i32);
    }
    let file = options.open(path).map_err(io)?;
    let meta = file.metadata().map_err(io)?;
    if let Some(what) = kind_of(meta.file_type()) {
        return Err(not_a_file(what));
    }
    Ok((file, meta.len()))
}

/// The bytes of the regular file at `path`, at most [`input_bound`] of them.
pub fn read_bytes(path: &Path) -> Result<Vec<u8>, InputError> {
    let (file, len) = open(path)?;
    read_within(path, file, Some(len), input_bound())
}

/// Reads `source` (the contents of `path`, `len` bytes when known) to its end, refusing more
/// than `bound` bytes ([`InputError::TooLarge`]).
pub fn read_within(path: &Path, source: impl Read, len: Option<u64>, bound: u64) -> Result<Vec<u8>, InputError> {
    let too_large = |size: String| InputError::TooLarge {
        path: path.into(),
        size,
        budget: crate::memory_budget::budget().describe(),
    };
    if let Some(len) = len.filter(|&l| l > bound) {
        return Err(too_large(bytes_text(len)));
    }
    let mut bytes = Vec::with_capacity(len.unwrap_or(0).min(bound) as usize);
    source
        .take(bound.saturating_add(1))
        .read_to_end(&mut bytes)
        .map_err(|error| InputError::Io { path: path.into(), error })?;
    if bytes.len() as u64 > bound {
        return Err(too_large(format!("more than {}", bytes_text(bound))));
    }
    Ok(bytes)
}

/// The UTF-8 text of the regular file at `path` (within the bound of [`read_bytes`]).
pub fn read_text(path: &Path) -> Result<String, InputError> {
    text_of(path, read_bytes(path)?)
}

/// `bytes` (of the file `path`) as UTF-8 text; the first invalid byte is reported with its
/// line, column and offset.
pub fn text_of(path: &Path, bytes: Vec<u8>) -> Result<String, InputError> {
    String::from_utf8(bytes).map_err(|e| {
        let byte = e.utf8_error().valid_up_to();
        let before = String::from_utf8_lossy(&e.as_bytes()[..byte]).into_owned();
        let (line, column) = line_column(&before, before.len());
        InputError::NotUtf8 { path: path.into(), line, column, byte }
    })
}

/// 1-based line and column (characters) of byte `offset` of `text` (clamped to its length,
/// and to a character boundary before it).
#[must_use]
pub fn line_column(text: &str, offset: usize) -> (usize, usize) {
    let mut at = offset.min(text.len());
    while !text.is_char_boundary(at) {
        at -= 1;
    }
    let before = &text[..at];
    let line = before.matches('\n').count() + 1;
    let column = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, column)
}

/// A streamed input that refuses a line longer than `max` bytes (an input without line
/// breaks, such as `/dev/zero` given as standard input, is refused instead of accumulated by
/// the reader above it).
pub struct LineBounded<R> {
    inner: R,
    name: String,
    max: u64,
    line: u64,
    run: u64,
}

impl<R: Read> LineBounded<R> {
    /// `inner` (named `name` in errors), lines of at most `max` bytes.
    pub fn new(inner: R, name: impl Into<String>, max: u64) -> Self {
        Self { inner, name: name.into(), max, line: 1, run: 0 }
    }
}

impl<R: Read> Read for LineBounded<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.inner.read(buf)?;
        for &b in &buf[..n] {
            if b == b'\n' {
                self.line += 1;
                self.run = 0;
            } else {
                self.run += 1;
                if self.run > self.max {
                    return Err(std::io::Error::new(
                        std::io::ErrorKind::InvalidData,
                        format!(
                            "{}: line {}: longer than {} without a line break; not a text file of rows",
                            self.name,
                            self.line,
                            bytes_text(self.max)
                        ),
                    ));
                }
            }
        }
        Ok(n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn regular_files_are_read_and_everything_else_is_named() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("a.txt");
        std::fs::write(&file, "one\ntwo\n").unwrap();
        assert_eq!(read_text(&file).unwrap(), "one\ntwo\n");
        let e = read_bytes(dir.path()).unwrap_err().to_string();
        assert!(e.contains("a directory, not a regular file"), "{e}");
        let e = read_bytes(&dir.path().join("none")).unwrap_err().to_string();
        assert!(e.contains("none"), "{e}");
        #[cfg(target_os = "linux")]
        {
            // A character device is refused before it is read.
            let e = read_bytes(Path::new("/dev/zero")).unwrap_err().to_string();
            assert_eq!(e, "/dev/zero: a character device, not a regular file; give a file");
            // A FIFO: refused at once, not waited on.
            let fifo = dir.path().join("fifo");
            if std::process::Command::new("mkfifo").arg(&fifo).status().is_ok_and(|s| s.success()) {
                let e = read_bytes(&fifo).unwrap_err().to_string();
                assert!(e.ends_with("fifo: a FIFO (named pipe), not a regular file; give a file"), "{e}");
            }
        }
    }

    #[test]
    fn reads_are_bounded_and_text_errors_name_line_column_and_byte() {
        let path = Path::new("big.bin");
        let e = read_within(path, &[0u8; 100][..], Some(100), 64).unwrap_err().to_string();
        assert!(e.starts_with("big.bin: 100 B is more than the memory budget"), "{e}");
        // A source that says nothing of its size (or grows) is cut at the bound.
        let e = read_within(path, std::io::repeat(0), None, 64).unwrap_err().to_string();
        assert!(e.starts_with("big.bin: more than 64 B is more than"), "{e}");
        assert_eq!(read_within(path, &[1u8; 64][..], None, 64).unwrap().len(), 64);
        let e = text_of(Path::new("t.txt"), b"ab\ncd\xffe".to_vec()).unwrap_err().to_string();
        assert_eq!(e, "t.txt:2:3: byte 5: not UTF-8 text");
        assert_eq!(line_column("ab\ncé\nx", 6), (2, 3));
        assert_eq!(line_column("ab\ncé\nx", 5), (2, 2), "inside a character: its start");
    }

    #[test]
    fn a_streamed_line_longer_than_the_bound_is_refused() {
        let mut text = String::new();
        LineBounded::new("a\nbb\nccc\n".as_bytes(), "s", 3).read_to_string(&mut text).unwrap();
        assert_eq!(text, "a\nbb\nccc\n");
        let mut sink = Vec::new();
        let e = LineBounded::new(std::io::repeat(b'x').take(100), "<stdin>", 10).read_to_end(&mut sink).unwrap_err();
        assert_eq!(e.to_string(), "<stdin>: line 1: longer than 10 B without a line break; not a text file of rows");
    }
}
