//! Cem Yuksel's binary `.hair` format (cyHair, `cyHairFile.h`), laid out as below.
//!
//! # Layout (little-endian)
//! | offset | size | field |
//! |---|---|---|
//! | 0 | 4 | magic `"HAIR"` |
//! | 4 | 4 | u32 strand count |
//! | 8 | 4 | u32 total point count |
//! | 12 | 4 | u32 array flags: 1 segments, 2 points, 4 thickness, 8 transparency, 16 colours |
//! | 16 | 4 | u32 default segment count (used when there is no segments array) |
//! | 20 | 4 | f32 default thickness |
//! | 24 | 4 | f32 default transparency |
//! | 28 | 12 | 3×f32 default colour |
//! | 40 | 88 | free text (file information) |
//!
//! Then the arrays whose flag is set, in this order: u16 segments per strand (a strand has
//! segments + 1 points), 3×f32 points, f32 thickness per point, f32 transparency per point,
//! 3×f32 colour per point.
//!
//! Reading is strict: wrong magic, unknown flag bits, a missing points array, counts that
//! disagree, truncated arrays, trailing bytes, non-finite points and negative or non-finite
//! thickness are all [`HairError`]s naming the byte offset — never a panic and never a
//! partial load. Thickness is a **diameter** in scene units, as in cyHair.

use std::path::{Path, PathBuf};
use thiserror::Error;

/// Size of the fixed header, bytes.
pub const HEADER_BYTES: usize = 128;
/// Size of the free-text field at the end of the header, bytes.
pub const INFO_BYTES: usize = 88;
/// The four magic bytes every `.hair` file starts with.
pub const MAGIC: [u8; 4] = *b"HAIR";

/// Flag bit: a u16 segment count per strand is stored.
pub const FLAG_SEGMENTS: u32 = 1;
/// Flag bit: the points array is stored (required).
pub const FLAG_POINTS: u32 = 2;
/// Flag bit: a thickness per point is stored.
pub const FLAG_THICKNESS: u32 = 4;
/// Flag bit: a transparency per point is stored.
pub const FLAG_TRANSPARENCY: u32 = 8;
/// Flag bit: an RGB colour per point is stored.
pub const FLAG_COLORS: u32 = 16;
const KNOWN_FLAGS: u32 = FLAG_SEGMENTS | FLAG_POINTS | FLAG_THICKNESS | FLAG_TRANSPARENCY | FLAG_COLORS;

/// Why a `.hair` file could not be read or written.
#[non_exhaustive]
#[derive(Debug, Error)]
pub enum HairError {
    /// The file could not be opened or read ([`crate::input_file`]: not a regular file, larger
    /// than the memory budget).
    #[error(transparent)]
    Input(#[from] crate::input_file::InputError),
    /// The file could not be opened, read or written.
    #[error("{path}: {error}")]
    Io {
        /// File path.
        path: PathBuf,
        /// Underlying error (shown in the message, not chained, so it is not printed twice).
        error: std::io::Error,
    },
    /// A parse error in a named file.
    #[error("{path}: {error}")]
    InFile {
        /// File path.
        path: PathBuf,
        /// What was wrong.
        error: Box<HairError>,
    },
    /// Fewer than 128 bytes.
    #[error("byte 0: expected a {HEADER_BYTES}-byte header, the file has only {len} bytes")]
    TruncatedHeader {
        /// File length, bytes.
        len: usize,
    },
    /// The first four bytes are not `"HAIR"`.
    #[error("byte 0: expected the magic \"HAIR\", found \"{}\"", found.escape_ascii())]
    BadMagic {
        /// The four bytes found.
        found: [u8; 4],
    },
    /// Bits other than 1, 2, 4, 8, 16 are set in the flags.
    #[error(
        "byte 12: flags {flags:#x} have unknown bits {unknown:#x} (known: 1 segments, 2 points, 4 thickness, 8 transparency, 16 colours)"
    )]
    UnknownFlags {
        /// Flags found.
        flags: u32,
        /// The unknown bits.
        unknown: u32,
    },
    /// Flag 2 (points) is not set: a file without points has no geometry.
    #[error("byte 12: flags {flags:#x} lack bit 2 (points array); a hair file must store points")]
    MissingPoints {
        /// Flags found.
        flags: u32,
    },
    /// The point count disagrees with the segments (array or default).
    #[error(
        "byte {offset}: the header says {point_count} points but the segment counts imply {implied} ({strand_count} strands)"
    )]
    CountMismatch {
        /// Offset of the evidence: 8 (point count) or of the segments array.
        offset: usize,
        /// Strand count in the header.
        strand_count: u32,
        /// Point count in the header.
        point_count: u32,
        /// Σ (segments + 1).
        implied: u64,
    },
    /// An array runs past the end of the file.
    #[error("byte {offset}: the {array} array needs {needed} bytes, only {available} remain")]
    Truncated {
        /// Which array.
        array: &'static str,
        /// Where the array starts.
        offset: usize,
        /// Bytes the array needs.
        needed: u64,
        /// Bytes left in the file.
        available: usize,
    },
    /// Bytes remain after the last array.
    #[error("byte {offset}: expected end of file after the last array, found {count} more bytes")]
    TrailingBytes {
        /// Offset of the first extra byte.
        offset: usize,
        /// How many extra bytes.
        count: usize,
    },
    /// A point coordinate, thickness, transparency or colour is NaN or infinite.
    #[error("byte {offset}: {array}[{index}] is not finite ({value})")]
    NotFinite {
        /// Which array.
        array: &'static str,
        /// Element index within the array.
        index: usize,
        /// Byte offset of the value.
        offset: usize,
        /// The value.
        value: f32,
    },
    /// A default value of the header (thickness, transparency, colour) is NaN or infinite.
    #[error("byte {offset}: the header's {field} is not finite ({value})")]
    HeaderNotFinite {
        /// Which default: `"default thickness"`, `"default transparency"`, `"default colour (r)"`, ….
        field: &'static str,
        /// Byte offset of the value.
        offset: usize,
        /// The value.
        value: f32,
    },
    /// A thickness is negative.
    #[error("byte {offset}: {array}[{index}] = {value} is negative; thickness is a diameter ≥ 0")]
    NegativeThickness {
        /// The array (`"thickness"`).
        array: &'static str,
        /// Element index.
        index: usize,
        /// Byte offset of the value.
        offset: usize,
        /// The value.
        value: f32,
    },
    /// The header's default thickness is negative.
    #[error("byte {offset}: the header's default thickness {value} is negative; thickness is a diameter ≥ 0")]
    NegativeDefaultThickness {
        /// Byte offset of the value.
        offset: usize,
        /// The value.
        value: f32,
    },
    /// The data to write is inconsistent (array lengths disagree with the counts).
    #[error("cannot write: {0}")]
    Inconsistent(String),
}

/// The contents of a `.hair` file. Optional arrays are `None` when their flag is unset (the
/// header defaults then apply); [`HairFile::validate`] checks the invariants that [`HairFile::write`]
/// relies on.
#[derive(Clone, Debug, PartialEq)]
pub struct HairFile {
    /// Segments per strand (`None`: every strand has `default_segments`).
    pub segments: Option<Vec<u16>>,
    /// Points, all strands concatenated (root first within each strand), scene units.
    pub points: Vec<[f32; 3]>,
    /// Diameter per point (`None`: `default_thickness`), scene units.
    pub thickness: Option<Vec<f32>>,
    /// Transparency per point (`None`: `default_transparency`).
    pub transparency: Option<Vec<f32>>,
    /// Linear RGB colour per point (`None`: `default_color`).
    pub colors: Option<Vec<[f32; 3]>>,
    /// Number of strands (the header's count; needed when `segments` is `None`).
    pub strand_count: u32,
    /// Segments of every strand when there is no segments array.
    pub default_segments: u32,
    /// Diameter when there is no thickness array.
    pub default_thickness: f32,
    /// Transparency when there is no transparency array.
    pub default_transparency: f32,
    /// Colour when there is no colour array.
    pub default_color: [f32; 3],
    /// Free-text header field (88 bytes, NUL padded).
    pub info: [u8; INFO_BYTES],
}

impl Default for HairFile {
    fn default() -> Self {
        Self {
            segments: Some(Vec::new()),
            points: Vec::new(),
            thickness: None,
            transparency: None,
            colors: None,
            strand_count: 0,
            default_segments: 0,
            default_thickness: 1.0,
            default_transparency: 0.0,
            default_color: [1.0; 3],
            info: [0; INFO_BYTES],
        }
    }
}

/// The counts a `.hair` header declares, read from its first 128 bytes without the arrays:
/// what the memory a file will take is estimated from before it is loaded. The full
/// [`HairFile::read`] still checks that the arrays agree with these counts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct HairHeader {
    /// Strands (u32 at byte 4).
    pub strand_count: u32,
    /// Points of all strands (u32 at byte 8).
    pub point_count: u32,
    /// Array flags (u32 at byte 12).
    pub flags: u32,
}

impl HairHeader {
    /// Parses the header at the start of `bytes` (at least [`HEADER_BYTES`] of them): the
    /// magic and the counts; the arrays are not looked at.
    pub fn parse(bytes: &[u8]) -> Result<Self, HairError> {
        if bytes.len() < HEADER_BYTES {
            return Err(HairError::TruncatedHeader { len: bytes.len() });
        }
        let found: [u8; 4] = bytes[0..4].try_into().expect("4 bytes");
        if found != MAGIC {
            return Err(HairError::BadMagic { found });
        }
        let u32_at = |o: usize| u32::from_le_bytes(bytes[o..o + 4].try_into().expect("4 bytes"));
        Ok(Self { strand_count: u32_at(4), point_count: u32_at(8), flags: u32_at(12) })
    }

    /// Reads only the header of the file at `path`; errors carry the path.
    pub fn read(path: &Path) -> Result<Self, HairError> {
        use std::io::Read;
        let io = |error| HairError::Io { path: path.into(), error };
        let mut head = Vec::with_capacity(HEADER_BYTES);
        let (file, _) = crate::input_file::open(path)?;
        file.take(HEADER_BYTES as u64).read_to_end(&mut head).map_err(io)?;
        Self::parse(&head).map_err(|e| HairError::InFile { path: path.into(), error: Box::new(e) })
    }

    /// Segments of all strands (a strand of `n` points has `n − 1`): points − strands.
    #[must_use]
    pub fn segment_count(&self) -> u64 {
        u64::from(self.point_count).saturating_sub(u64::from(self.strand_count))
    }

    /// Bytes of the file these counts and flags describe: the header, then 2 per strand
    /// (segments), 12 per point (points), 4 (thickness), 4 (transparency) and 12 (colours) per
    /// point for each array whose flag is set. Exact, and at most about 137 GiB (32-bit counts).
    #[must_use]
    pub fn file_bytes(&self) -> u64 {
        let per_point = 12
            + if self.flags & FLAG_THICKNESS != 0 { 4 } else { 0 }
            + if self.flags & FLAG_TRANSPARENCY != 0 { 4 } else { 0 }
            + if self.flags & FLAG_COLORS != 0 { 12 } else { 0 };
        let per_strand = if self.flags & FLAG_SEGMENTS != 0 { 2 } else { 0 };
        HEADER_BYTES as u64 + per_strand * u64::from(self.strand_count) + per_point * u64::from(self.point_count)
    }

    /// Peak bytes [`HairFile::read`] holds: the whole file read into memory, and its arrays
    /// parsed beside it (the same size as the file's arrays), i.e. about twice the file.
    #[must_use]
    pub fn read_bytes(&self) -> u64 {
        2 * self.file_bytes()
    }
}

/// A little-endian cursor over the file bytes that reports offsets.
struct Reader<'a> {
    bytes: &'a [u8],
    pos: usize,
}

impl Reader<'_> {
    fn u32_at(&self, offset: usize) -> u32 {
        u32::from_le_bytes(self.bytes[offset..offset + 4].try_into().expect("4 bytes"))
    }
    fn f32_at(&self, offset: usize) -> f32 {
        f32::from_le_bytes(self.bytes[offset..offset + 4].try_into().expect("4 bytes"))
    }
    /// Claims `count × elem` bytes for `array`, returning their start offset.
    fn claim(&mut self, array: &'static str, count: u64, elem: u64) -> Result<usize, HairError> {
        let available = self.bytes.len() - self.pos;
        let needed = count.saturating_mul(elem);
        if needed > available as u64 {
            return Err(HairError::Truncated { array, offset: self.pos, needed, available });
        }
        let start = self.pos;
        self.pos += needed as usize;
        Ok(start)
    }
    fn f32s(&mut self, array: &'static str, count: usize, finite: bool) -> Result<Vec<f32>, HairError> {
        let start = self.claim(array, count as u64, 4)?;
        let mut out = Vec::with_capacity(count);
        for i in 0..count {
            let offset = start + 4 * i;
            let value = self.f32_at(offset);
            if finite && !value.is_finite() {
                return Err(HairError::NotFinite { array, index: i, offset, value });
            }
            out.push(value);
        }
        Ok(out)
    }
    fn vec3s(&mut self, array: &'static str, count: usize) -> Result<Vec<[f32; 3]>, HairError> {
        let flat = self.f32s(array, count * 3, false)?;
        let start = self.pos - 12 * count;
        let mut out = Vec::with_capacity(count);
        for (i, c) in flat.chunks_exact(3).enumerate() {
            for (k, &value) in c.iter().enumerate() {
                if !value.is_finite() {
                    return Err(HairError::NotFinite { array, index: i, offset: start + 12 * i + 4 * k, value });
                }
            }
            out.push([c[0], c[1], c[2]]);
        }
        Ok(out)
    }
}

impl HairFile {
    /// Number of strands.
    #[must_use]
    pub fn strand_count(&self) -> usize {
        self.strand_count as usize
    }

    /// Segments of strand `i`.
    #[must_use]
    pub fn strand_segments(&self, i: usize) -> usize {
        match &self.segments {
            Some(s) => usize::from(s[i]),
            None => self.default_segments as usize,
        }
    }

    /// Point index ranges of every strand, in order.
    #[must_use]
    pub fn strand_ranges(&self) -> Vec<std::ops::Range<usize>> {
        let mut start = 0;
        (0..self.strand_count())
            .map(|i| {
                let n = self.strand_segments(i) + 1;
                start += n;
                start - n..start
            })
            .collect()
    }

    /// Diameter at point `i` (the array value or the default).
    #[must_use]
    pub fn thickness_at(&self, i: usize) -> f32 {
        self.thickness.as_ref().map_or(self.default_thickness, |t| t[i])
    }

    /// The strands as round tubes (radius = thickness/2) in a curve BVH, for the renderer.
    #[must_use]
    pub fn curve_set(&self) -> fiberlab_geometry::CurveSet {
        fiberlab_geometry::CurveSet::from_f32_strands(&self.points, &self.strand_ranges(), |i| {
            0.5 * f64::from(self.thickness_at(i))
        })
    }

    /// [`Self::curve_set`] of a file no longer needed: its arrays are freed once the tubes are
    /// made, before their tree is built (the peak of a load: the 5M-segment head's points and
    /// thicknesses are 82 MiB of it).
    #[must_use]
    pub fn into_curve_set(self) -> fiberlab_geometry::CurveSet {
        let tubes = fiberlab_geometry::CurveSet::tubes_of_f32_strands(&self.points, &self.strand_ranges(), |i| {
            0.5 * f64::from(self.thickness_at(i))
        });
        drop(self);
        fiberlab_geometry::CurveSet::from_tubes(tubes)
    }

    /// The flags word this file is written with.
    #[must_use]
    pub fn flags(&self) -> u32 {
        FLAG_POINTS
            | if self.segments.is_some() { FLAG_SEGMENTS } else { 0 }
            | if self.thickness.is_some() { FLAG_THICKNESS } else { 0 }
            | if self.transparency.is_some() { FLAG_TRANSPARENCY } else { 0 }
            | if self.colors.is_some() { FLAG_COLORS } else { 0 }
    }

    /// Sets the free-text header field (truncated to 87 bytes plus a NUL).
    pub fn set_info(&mut self, text: &str) {
        self.info = [0; INFO_BYTES];
        let n = text.len().min(INFO_BYTES - 1);
        self.info[..n].copy_from_slice(&text.as_bytes()[..n]);
    }

    /// Parses a whole file held in memory.
    pub fn parse(bytes: &[u8]) -> Result<Self, HairError> {
        if bytes.len() < HEADER_BYTES {
            return Err(HairError::TruncatedHeader { len: bytes.len() });
        }
        let mut r = Reader { bytes, pos: HEADER_BYTES };
        let found: [u8; 4] = bytes[0..4].try_into().expect("4 bytes");
        if found != MAGIC {
            return Err(HairError::BadMagic { found });
        }
        let strand_count = r.u32_at(4);
        let point_count = r.u32_at(8);
        let flags = r.u32_at(12);
        if flags & !KNOWN_FLAGS != 0 {
            return Err(HairError::UnknownFlags { flags, unknown: flags & !KNOWN_FLAGS });
        }
        if flags & FLAG_POINTS == 0 {
            return Err(HairError::MissingPoints { flags });
        }
        let default_segments = r.u32_at(16);
        let default_thickness = r.f32_at(20);
        let default_transparency = r.f32_at(24);
        let default_color = [r.f32_at(28), r.f32_at(32), r.f32_at(36)];
        const FIELDS: [&str; 5] = [
            "default thickness",
            "default transparency",
            "default colour (r)",
            "default colour (g)",
            "default colour (b)",
        ];
        for (k, &value) in [default_thickness, default_transparency].iter().chain(default_color.iter()).enumerate() {
            if !value.is_finite() {
                return Err(HairError::HeaderNotFinite { field: FIELDS[k], offset: 20 + 4 * k, value });
            }
        }
        if default_thickness < 0.0 {
            return Err(HairError::NegativeDefaultThickness { offset: 20, value: default_thickness });
        }
        let info: [u8; INFO_BYTES] = bytes[40..HEADER_BYTES].try_into().expect("88 bytes");

        let segments = if flags & FLAG_SEGMENTS != 0 {
            let start = r.claim("segments", u64::from(strand_count), 2)?;
            let segs: Vec<u16> =
                bytes[start..r.pos].chunks_exact(2).map(|c| u16::from_le_bytes([c[0], c[1]])).collect();
            let implied: u64 = segs.iter().map(|&s| u64::from(s) + 1).sum();
            if implied != u64::from(point_count) {
                return Err(HairError::CountMismatch { offset: start, strand_count, point_count, implied });
            }
            Some(segs)
        } else {
            let implied = u64::from(strand_count) * (u64::from(default_segments) + 1);
            if implied != u64::from(point_count) {
                return Err(HairError::CountMismatch { offset: 8, strand_count, point_count, implied });
            }
            None
        };
        let n = point_count as usize;
        let points = r.vec3s("points", n)?;
        let thickness = if flags & FLAG_THICKNESS != 0 {
            let start = r.pos;
            let t = r.f32s("thickness", n, true)?;
            if let Some((index, &value)) = t.iter().enumerate().find(|(_, v)| **v < 0.0) {
                return Err(HairError::NegativeThickness {
                    array: "thickness",
                    index,
                    offset: start + 4 * index,
                    value,
                });
            }
            Some(t)
        } else {
            None
        };
        let transparency = if flags & FLAG_TRANSPARENCY != 0 { Some(r.f32s("transparency", n, true)?) } else { None };
        let colors = if flags & FLAG_COLORS != 0 { Some(r.vec3s("colors", n)?) } else { None };
        if r.pos != bytes.len() {
            return Err(HairError::TrailingBytes { offset: r.pos, count: bytes.len() - r.pos });
        }
        Ok(Self {
            segments,
            points,
            thickness,
            transparency,
            colors,
            strand_count,
            default_segments,
            default_thickness,
            default_transparency,
            default_color,
            info,
        })
    }

    /// Reads and parses a file; errors carry the path.
    pub fn read(path: &Path) -> Result<Self, HairError> {
        let bytes = crate::input_file::read_bytes(path)?;
        Self::parse(&bytes).map_err(|e| HairError::InFile { path: path.into(), error: Box::new(e) })
    }

    /// Checks that array lengths agree with the counts and values are finite, so the file
    /// written by [`HairFile::to_bytes`] parses back to `self`.
    pub fn validate(&self) -> Result<(), HairError> {
        let bad = |m: String| Err(HairError::Inconsistent(m));
        let implied: u64 = match &self.segments {
            Some(s) => {
                if s.len() != self.strand_count as usize {
                    return bad(format!("{} segment counts for {} strands", s.len(), self.strand_count));
                }
                s.iter().map(|&x| u64::from(x) + 1).sum()
            }
            None => u64::from(self.strand_count) * (u64::from(self.default_segments) + 1),
        };
        if implied != self.points.len() as u64 || self.points.len() > u32::MAX as usize {
            return bad(format!("{} points but the segments imply {implied}", self.points.len()));
        }
        let n = self.points.len();
        for (name, len) in [
            ("thickness", self.thickness.as_ref().map(Vec::len)),
            ("transparency", self.transparency.as_ref().map(Vec::len)),
            ("colors", self.colors.as_ref().map(Vec::len)),
        ] {
            if let Some(len) = len
                && len != n
            {
                return bad(format!("{name} has {len} entries for {n} points"));
            }
        }
        let finite = self.points.iter().flatten().all(|v| v.is_finite())
            && self.thickness.iter().flatten().all(|v| v.is_finite() && *v >= 0.0)
            && self.transparency.iter().flatten().all(|v| v.is_finite())
            && self.colors.iter().flatten().flatten().all(|v| v.is_finite())
            && self.default_thickness.is_finite()
            && self.default_thickness >= 0.0
            && self.default_transparency.is_finite()
            && self.default_color.iter().all(|v| v.is_finite());
        if !finite {
            return bad("a value is NaN, infinite or a negative thickness".into());
        }
        Ok(())
    }

    /// Serializes to the binary format (after [`HairFile::validate`]).
    pub fn to_bytes(&self) -> Result<Vec<u8>, HairError> {
        self.validate()?;
        let n = self.points.len();
        let mut out = Vec::with_capacity(HEADER_BYTES + 2 * self.strand_count as usize + 28 * n);
        out.extend_from_slice(&MAGIC);
        for v in [self.strand_count, n as u32, self.flags(), self.default_segments] {
            out.extend_from_slice(&v.to_le_bytes());
        }
        for v in [self.default_thickness, self.default_transparency] {
            out.extend_from_slice(&v.to_le_bytes());
        }
        for v in self.default_color {
            out.extend_from_slice(&v.to_le_bytes());
        }
        out.extend_from_slice(&self.info);
        if let Some(s) = &self.segments {
            s.iter().for_each(|v| out.extend_from_slice(&v.to_le_bytes()));
        }
        self.points.iter().flatten().for_each(|v| out.extend_from_slice(&v.to_le_bytes()));
        for arr in [&self.thickness, &self.transparency].into_iter().flatten() {
            arr.iter().for_each(|v| out.extend_from_slice(&v.to_le_bytes()));
        }
        if let Some(c) = &self.colors {
            c.iter().flatten().for_each(|v| out.extend_from_slice(&v.to_le_bytes()));
        }
        Ok(out)
    }

    /// Writes the file atomically (temporary file in the same directory, then rename).
    pub fn write(&self, path: &Path) -> Result<(), HairError> {
        let bytes = self.to_bytes()?;
        crate::image_file::write_atomically(path, |file| {
            use std::io::Write;
            file.write_all(&bytes)
        })
        .map_err(|source| HairError::Io { path: path.into(), error: source })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn two_strands() -> HairFile {
        let mut h = HairFile {
            segments: Some(vec![1, 2]),
            points: vec![[0.0; 3], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [1.0, 2.0, 0.5]],
            thickness: Some(vec![0.1, 0.09, 0.1, 0.08, 0.05]),
            strand_count: 2,
            ..HairFile::default()
        };
        h.set_info("test");
        h
    }

    fn u32_at(bytes: &mut [u8], offset: usize, v: u32) {
        bytes[offset..offset + 4].copy_from_slice(&v.to_le_bytes());
    }

    #[test]
    fn hand_built_bytes_parse_field_by_field() {
        // Build the bytes independently of `to_bytes`, from the documented layout.
        let mut b = vec![0u8; HEADER_BYTES];
        b[0..4].copy_from_slice(b"HAIR");
        u32_at(&mut b, 4, 1);
        u32_at(&mut b, 8, 3);
        u32_at(&mut b, 12, FLAG_POINTS);
        u32_at(&mut b, 16, 2);
        b[20..24].copy_from_slice(&0.5f32.to_le_bytes());
        for v in [1.0f32, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0] {
            b.extend_from_slice(&v.to_le_bytes());
        }
        let h = HairFile::parse(&b).unwrap();
        assert_eq!(h.strand_count(), 1);
        assert_eq!(h.strand_ranges(), vec![0..3]);
        assert_eq!(h.points[2], [7.0, 8.0, 9.0]);
        assert_eq!(h.thickness_at(1), 0.5);
        assert_eq!(h.segments, None);
    }

    /// The tubes of a consumed file are those of a borrowed one: the same segment records,
    /// pieces and tree, and the same hits (rays across each strand's segments).
    #[test]
    fn into_curve_set_builds_what_curve_set_builds() {
        let h = two_strands();
        let borrowed = h.curve_set();
        let consumed = h.clone().into_curve_set();
        assert_eq!(consumed.segment_count(), 3);
        assert_eq!(consumed.segment_words(), borrowed.segment_words());
        assert_eq!((consumed.piece_count(), consumed.bytes()), (borrowed.piece_count(), borrowed.bytes()));
        for (x, y) in [(0.0, 0.5), (1.0, 0.5), (1.0, 1.5)] {
            let ray = fiberlab_geometry::Ray::new(fiberlab_math::DVec3::new(x, y, 5.0), -fiberlab_math::DVec3::Z);
            let (a, b) = (consumed.intersect(&ray), borrowed.intersect(&ray));
            assert!(a.is_some(), "a ray at ({x}, {y}) crosses a strand");
            assert_eq!(a, b);
        }
    }

    #[test]
    fn round_trip_of_a_small_file() {
        let h = two_strands();
        assert_eq!(HairFile::parse(&h.to_bytes().unwrap()).unwrap(), h);
        assert_eq!(h.strand_ranges(), vec![0..2, 2..5]);
    }

    #[test]
    fn wrong_magic() {
        let mut b = two_strands().to_bytes().unwrap();
        b[0] = b'X';
        let e = HairFile::parse(&b).unwrap_err();
        assert!(matches!(e, HairError::BadMagic { found } if &found == b"XAIR"));
        assert_eq!(e.to_string(), "byte 0: expected the magic \"HAIR\", found \"XAIR\"");
        b[1] = 0;
        assert!(HairFile::parse(&b).unwrap_err().to_string().ends_with("found \"X\\x00IR\""));
    }

    #[test]
    fn the_header_alone_gives_the_counts_and_the_file_size() {
        let h = two_strands();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("two.hair");
        h.write(&path).unwrap();
        let header = HairHeader::read(&path).unwrap();
        assert_eq!(header, HairHeader { strand_count: 2, point_count: 5, flags: h.flags() });
        // Strands of 1 and 2 segments.
        assert_eq!(header.segment_count(), 3);
        // The exact size on disk: 128 + 2·2 (segments) + 5·(12 + 4) (points, thickness).
        assert_eq!(header.file_bytes(), 128 + 4 + 5 * 16);
        assert_eq!(header.file_bytes(), std::fs::metadata(&path).unwrap().len());
        assert_eq!(header.read_bytes(), 2 * header.file_bytes());
        // Every flag: 2 per strand, 12 + 4 + 4 + 12 per point.
        let all = HairHeader { strand_count: 10, point_count: 100, flags: KNOWN_FLAGS };
        assert_eq!(all.file_bytes(), 128 + 20 + 3200);
        // u32::MAX points of every array: computed in u64, no overflow.
        let big = HairHeader { strand_count: u32::MAX, point_count: u32::MAX, flags: KNOWN_FLAGS };
        assert_eq!(big.file_bytes(), 128 + 34 * u64::from(u32::MAX));
        assert_eq!(big.segment_count(), 0);
        assert!(matches!(HairHeader::parse(b"HAIR"), Err(HairError::TruncatedHeader { len: 4 })));
        let mut bytes = h.to_bytes().unwrap();
        bytes[0] = b'X';
        assert!(matches!(HairHeader::parse(&bytes), Err(HairError::BadMagic { .. })));
        let e = HairHeader::read(&dir.path().join("missing.hair")).unwrap_err().to_string();
        assert!(e.contains("missing.hair"), "{e}");
    }

    #[test]
    fn header_defaults_are_named_in_errors() {
        let mut b = two_strands().to_bytes().unwrap();
        b[20..24].copy_from_slice(&f32::NAN.to_le_bytes());
        let e = HairFile::parse(&b).unwrap_err().to_string();
        assert_eq!(e, "byte 20: the header's default thickness is not finite (NaN)");
        b[20..24].copy_from_slice(&(-1.0f32).to_le_bytes());
        let e = HairFile::parse(&b).unwrap_err().to_string();
        assert!(e.starts_with("byte 20: the header's default thickness -1 is negative"), "{e}");
        let mut b = two_strands().to_bytes().unwrap();
        b[36..40].copy_from_slice(&f32::INFINITY.to_le_bytes());
        let e = HairFile::parse(&b).unwrap_err().to_string();
        assert_eq!(e, "byte 36: the header's default colour (b) is not finite (inf)");
    }

    #[test]
    fn short_header() {
        let b = two_strands().to_bytes().unwrap();
        let e = HairFile::parse(&b[..100]).unwrap_err();
        assert!(matches!(e, HairError::TruncatedHeader { len: 100 }));
        assert!(e.to_string().contains("byte 0"));
    }

    #[test]
    fn truncated_arrays_name_the_array_and_offset() {
        let b = two_strands().to_bytes().unwrap();
        // Cut inside the segments array (offset 128, 4 bytes), then inside points, then thickness.
        let seg = HairFile::parse(&b[..129]).unwrap_err();
        assert!(matches!(seg, HairError::Truncated { array: "segments", offset: 128, needed: 4, available: 1 }));
        let pts = HairFile::parse(&b[..140]).unwrap_err();
        assert!(matches!(pts, HairError::Truncated { array: "points", offset: 132, needed: 60, .. }));
        let th = HairFile::parse(&b[..b.len() - 1]).unwrap_err();
        assert!(matches!(th, HairError::Truncated { array: "thickness", offset: 192, needed: 20, available: 19 }));
        assert!(th.to_string().contains("byte 192"), "{th}");
    }

    #[test]
    fn counts_that_disagree() {
        let mut b = two_strands().to_bytes().unwrap();
        u32_at(&mut b, 8, 6);
        assert!(matches!(
            HairFile::parse(&b),
            Err(HairError::CountMismatch { offset: 128, point_count: 6, implied: 5, .. })
        ));
        // Without a segments array the default segment count must explain the points.
        let mut h = two_strands();
        h.segments = None;
        h.default_segments = 1;
        h.strand_count = 2;
        h.points.truncate(4);
        h.thickness = None;
        let mut b = h.to_bytes().unwrap();
        u32_at(&mut b, 16, 2);
        assert!(matches!(HairFile::parse(&b), Err(HairError::CountMismatch { offset: 8, implied: 6, .. })));
    }

    #[test]
    fn nan_and_infinite_points() {
        let mut b = two_strands().to_bytes().unwrap();
        // points start at 132; point 1, coordinate y is at 132 + 12 + 4.
        b[148..152].copy_from_slice(&f32::NAN.to_le_bytes());
        let e = HairFile::parse(&b).unwrap_err();
        assert!(matches!(e, HairError::NotFinite { array: "points", index: 1, offset: 148, .. }), "{e}");
        b[148..152].copy_from_slice(&f32::INFINITY.to_le_bytes());
        assert!(matches!(HairFile::parse(&b), Err(HairError::NotFinite { offset: 148, .. })));
    }

    #[test]
    fn missing_points_array_and_unknown_flags() {
        let mut b = two_strands().to_bytes().unwrap();
        u32_at(&mut b, 12, FLAG_SEGMENTS | FLAG_THICKNESS);
        assert!(matches!(HairFile::parse(&b), Err(HairError::MissingPoints { flags: 5 })));
        u32_at(&mut b, 12, FLAG_POINTS | 64);
        assert!(matches!(HairFile::parse(&b), Err(HairError::UnknownFlags { unknown: 64, .. })));
    }

    #[test]
    fn trailing_bytes_and_negative_thickness() {
        let mut b = two_strands().to_bytes().unwrap();
        let len = b.len();
        b.push(0);
        assert!(matches!(HairFile::parse(&b), Err(HairError::TrailingBytes { offset, count: 1 }) if offset == len));
        b.pop();
        b[len - 4..].copy_from_slice(&(-1.0f32).to_le_bytes());
        assert!(matches!(HairFile::parse(&b), Err(HairError::NegativeThickness { index: 4, .. })));
    }

    #[test]
    fn huge_counts_do_not_allocate_or_panic() {
        let mut b = two_strands().to_bytes().unwrap();
        u32_at(&mut b, 4, u32::MAX);
        assert!(HairFile::parse(&b).is_err());
        let mut b = two_strands().to_bytes().unwrap();
        u32_at(&mut b, 12, FLAG_POINTS);
        u32_at(&mut b, 4, u32::MAX);
        u32_at(&mut b, 16, u32::MAX);
        u32_at(&mut b, 8, 0);
        assert!(matches!(HairFile::parse(&b), Err(HairError::CountMismatch { .. })));
    }

    #[test]
    fn write_refuses_inconsistent_data() {
        let mut h = two_strands();
        h.points.pop();
        assert!(matches!(h.to_bytes(), Err(HairError::Inconsistent(_))));
        let mut h = two_strands();
        h.points[0][0] = f32::NAN;
        assert!(h.to_bytes().is_err());
    }

    #[test]
    fn file_round_trip_and_missing_file_error_names_the_path() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.hair");
        two_strands().write(&path).unwrap();
        assert_eq!(HairFile::read(&path).unwrap(), two_strands());
        let e = HairFile::read(&dir.path().join("missing.hair")).unwrap_err();
        assert!(e.to_string().contains("missing.hair"));
        std::fs::write(&path, b"HAIR").unwrap();
        assert!(HairFile::read(&path).unwrap_err().to_string().contains("a.hair: byte 0"));
    }

    fn arb_hair() -> impl Strategy<Value = HairFile> {
        (proptest::collection::vec(0u16..6, 0..8), any::<[bool; 4]>(), -1e6f32..1e6, 0f32..1.0).prop_flat_map(
            |(segs, opt, a, t)| {
                let n: usize = segs.iter().map(|&s| usize::from(s) + 1).sum();
                let strands = segs.len() as u32;
                (
                    proptest::collection::vec(any::<[f32; 3]>().prop_map(move |p| p.map(|x| (x % 1e6) * 1e-3 + a)), n),
                    proptest::collection::vec(0f32..1.0, n),
                    proptest::collection::vec(any::<[u8; 3]>(), n),
                )
                    .prop_map(move |(points, th, col)| {
                        let uniform = opt[0] && segs.iter().all(|&s| s == segs.first().copied().unwrap_or(0));
                        HairFile {
                            segments: if uniform { None } else { Some(segs.clone()) },
                            default_segments: u32::from(segs.first().copied().unwrap_or(0)),
                            points: points
                                .into_iter()
                                .map(|p| p.map(|x| if x.is_finite() { x } else { 0.0 }))
                                .collect(),
                            thickness: opt[1].then(|| th.clone()),
                            transparency: opt[2].then(|| th.iter().map(|x| 1.0 - x).collect()),
                            colors: opt[3].then(|| col.iter().map(|c| c.map(|x| f32::from(x) / 255.0)).collect()),
                            strand_count: strands,
                            default_thickness: t,
                            ..HairFile::default()
                        }
                    })
            },
        )
    }

    proptest! {
        #[test]
        fn write_then_read_is_identity(h in arb_hair()) {
            let bytes = h.to_bytes().unwrap();
            prop_assert_eq!(HairFile::parse(&bytes).unwrap(), h);
        }

        #[test]
        fn arbitrary_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..400)) {
            let mut b = bytes;
            if b.len() >= 4 { b[0..4].copy_from_slice(b"HAIR"); }
            let _ = HairFile::parse(&b);
        }
    }
}
