//! Hair files by their extension — `.hair`, `.pbrt`/`.pbrt.gz`, `.usda` — read into
//! [`Strands`], written from them, and counted before they are loaded.

use crate::hair::HairFile;
use crate::strands::{Basis, Strands, StrandsError};
use std::path::Path;

/// The file formats, by extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// Cem Yuksel's binary `.hair`.
    Hair,
    /// pbrt-v4 scene text, `.pbrt` or gzip-compressed `.pbrt.gz`.
    Pbrt,
    /// USD text, `.usda`.
    Usda,
}

impl Format {
    /// The format of a file name (case-insensitive extension).
    pub fn of(path: &Path) -> Result<Self, StrandsError> {
        let name = path.file_name().map(|n| n.to_string_lossy().to_lowercase()).unwrap_or_default();
        if name.ends_with(".hair") {
            Ok(Self::Hair)
        } else if name.ends_with(".pbrt") || name.ends_with(".pbrt.gz") {
            Ok(Self::Pbrt)
        } else if name.ends_with(".usda") {
            Ok(Self::Usda)
        } else {
            Err(StrandsError::UnknownFormat { path: path.into() })
        }
    }
}

/// Reads any supported hair file, by its extension.
pub fn read(path: &Path) -> Result<Strands, StrandsError> {
    match Format::of(path)? {
        Format::Hair => Ok(Strands::from(&HairFile::read(path)?)),
        Format::Pbrt => crate::pbrt_curves::read(path),
        Format::Usda => crate::usda_curves::read(path),
    }
}

/// Writes `strands` as `.hair` or `.usda`, by the extension of `path`. A cubic set written as
/// `.hair` is first turned into polylines of `segments_per_span` segments per span
/// ([`Strands::to_polylines`]); `.usda` keeps the basis.
pub fn write(path: &Path, strands: &Strands, segments_per_span: usize) -> Result<(), StrandsError> {
    match Format::of(path)? {
        Format::Hair => {
            let lines;
            let linear = if strands.basis == Basis::Linear {
                strands
            } else {
                lines = strands.to_polylines(segments_per_span)?;
                &lines
            };
            linear.to_hair()?.write(path)?;
            Ok(())
        }
        Format::Usda => crate::usda_curves::write(path, strands),
        Format::Pbrt => Err(StrandsError::Inconsistent(format!(
            "{}: writing pbrt files is not supported (write .hair or .usda)",
            path.display()
        ))),
    }
}

/// What a hair file holds, counted without building its strands: what a scene's memory
/// estimate is made from before the file is loaded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StrandCounts {
    /// Strands.
    pub strands: u64,
    /// Control points.
    pub points: u64,
    /// Spans (curve pieces; segments of a polyline).
    pub spans: u64,
    /// The basis.
    pub basis: Basis,
    /// Peak bytes of reading the file into [`Strands`]: the file's text (or bytes) and the
    /// strands (16 bytes per point, 4 per strand) twice, as a conversion holds both.
    pub read_bytes: u64,
}

impl StrandCounts {
    /// Segments once the curves become polylines of `segments_per_span` per span (a linear set
    /// is not subdivided).
    #[must_use]
    pub fn segments(&self, segments_per_span: usize) -> u64 {
        if self.basis == Basis::Linear {
            self.spans
        } else {
            self.spans.saturating_mul(segments_per_span.max(1) as u64)
        }
    }

    fn of_text(text_bytes: u64, counts: &Strands) -> Self {
        let points: u64 = counts.counts.iter().map(|&c| u64::from(c)).sum();
        let spans = counts.counts.iter().map(|&c| counts.basis.spans(c as usize).unwrap_or(0) as u64).sum();
        let strands = counts.counts.len() as u64;
        Self {
            strands,
            points,
            spans,
            basis: counts.basis,
            read_bytes: text_bytes.saturating_add(2 * (16 * points + 4 * strands)),
        }
    }
}

/// Counts the strands, points and spans of a hair file without storing its points: the header
/// of a `.hair` file; a structural pass over pbrt or USD text (numbers counted, not parsed).
pub fn count(path: &Path) -> Result<StrandCounts, StrandsError> {
    match Format::of(path)? {
        Format::Hair => {
            let h = crate::hair::HairHeader::read(path)?;
            Ok(StrandCounts {
                strands: h.strand_count.into(),
                points: h.point_count.into(),
                spans: h.segment_count(),
                basis: Basis::Linear,
                read_bytes: h.read_bytes(),
            })
        }
        Format::Pbrt => {
            let (bytes, counts) = crate::pbrt_curves::count(path)?;
            Ok(StrandCounts::of_text(bytes, &counts))
        }
        Format::Usda => {
            let (bytes, counts) = crate::usda_curves::count(path)?;
            Ok(StrandCounts::of_text(bytes, &counts))
        }
    }
}
