//! A format-neutral set of strands — control points, a diameter per point, points per strand
//! and the curve basis — that every hair file format reads into and writes from:
//! `.hair` (module `hair`), pbrt-v4 scene files (module `pbrt_curves`) and USD
//! BasisCurves text (module `usda_curves`); module `strand_files` picks one by extension.
//!
//! # Bases
//! A strand of `n` control points `c_0 … c_{n−1}` has these spans (curve pieces):
//! * [`Basis::Linear`]: the polyline, `n − 1` spans.
//! * [`Basis::Bezier`]: cubic Bézier pieces sharing end points, `n = 3k + 1`, `k` spans; span
//!   `i` uses `c_{3i} … c_{3i+3}` and passes through `c_{3i}` and `c_{3i+3}`.
//! * [`Basis::BSpline`]: the uniform cubic B-spline, `n ≥ 4`, `n − 3` spans; span `i` uses
//!   `c_i … c_{i+3}` and interpolates none of them.
//! * [`Basis::CatmullRom`]: the uniform Catmull–Rom spline, `n ≥ 4`, `n − 3` spans; span `i`
//!   runs from `c_{i+1}` to `c_{i+2}`.
//!
//! These are the non-periodic rules of USD's `UsdGeomBasisCurves` (`vstep` 3 for Bézier, 1
//! for the others); pbrt-v4's quadratic and B-spline curves are converted to cubic Bézier pieces
//! when read (see module `pbrt_curves`).
//!
//! # Widths
//! `widths` holds one **diameter** per control point (scene units, as `.hair` thickness, pbrt's
//! `width` and USD's `widths`), interpolated along the curve with the same basis as the
//! points. Turning a cubic set into polylines ([`Strands::to_polylines`]) evaluates each span
//! at uniform parameter steps, points and widths alike, in `f64`, rounding the results to `f32`.
//!
//! # Ribbon normals
//! A [`CurveKind::Ribbon`] set carries `normals`: one per **span end** of each strand (`spans + 1`
//! per strand, strand after strand), pbrt's `"normal N"` rule and USD's `varying`
//! interpolation. Between the ends of a span the normal is interpolated spherically (pbrt-v4's
//! `Slerp`); [`Strands::to_polylines`] evaluates it at the polylines' points. A ribbon's width
//! runs along `n × t` (`t` the tangent) and its face is perpendicular to `t × (n × t)`, the part
//! of `n` perpendicular to the tangent: the normal need not be perpendicular to the curve.

use crate::hair::{HairError, HairFile};
use std::fmt;
use std::ops::Range;
use std::path::{Path, PathBuf};
use thiserror::Error;

/// How the control points of a strand make a curve (module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Basis {
    /// Polylines through the points.
    Linear,
    /// Uniform cubic B-splines.
    BSpline,
    /// Uniform Catmull–Rom splines.
    CatmullRom,
    /// Piecewise cubic Bézier curves sharing end points.
    Bezier,
}

impl Basis {
    /// Spans of a strand of `n` control points, `None` when `n` does not fit the basis
    /// (fewer than 2 points for lines; fewer than 4 for cubics; not `3k + 1` for Bézier).
    #[must_use]
    pub fn spans(self, n: usize) -> Option<usize> {
        match self {
            Self::Linear if n >= 2 => Some(n - 1),
            Self::Bezier if n >= 4 && (n - 1).is_multiple_of(3) => Some((n - 1) / 3),
            Self::BSpline | Self::CatmullRom if n >= 4 => Some(n - 3),
            _ => None,
        }
    }

    /// What a strand of this basis needs, for error messages.
    #[must_use]
    pub fn rule(self) -> &'static str {
        match self {
            Self::Linear => "a linear strand needs at least 2 points",
            Self::Bezier => "a Bézier strand needs 3k + 1 points, k ≥ 1",
            Self::BSpline => "a B-spline strand needs at least 4 points",
            Self::CatmullRom => "a Catmull–Rom strand needs at least 4 points",
        }
    }

    /// The weights of the four control points of a cubic span at parameter `t ∈ [0, 1]`
    /// (`Linear`: the two end points' weights in the first two slots).
    #[must_use]
    pub fn weights(self, t: f64) -> [f64; 4] {
        let s = 1.0 - t;
        let (t2, t3) = (t * t, t * t * t);
        match self {
            Self::Linear => [s, t, 0.0, 0.0],
            Self::Bezier => [s * s * s, 3.0 * s * s * t, 3.0 * s * t2, t3],
            Self::BSpline => [
                s * s * s / 6.0,
                (3.0 * t3 - 6.0 * t2 + 4.0) / 6.0,
                (-3.0 * t3 + 3.0 * t2 + 3.0 * t + 1.0) / 6.0,
                t3 / 6.0,
            ],
            // Tangent (c_{i+2} − c_i)/2 at c_{i+1}: the Hermite form with τ = 1/2.
            Self::CatmullRom => [
                0.5 * (-t3 + 2.0 * t2 - t),
                0.5 * (3.0 * t3 - 5.0 * t2 + 2.0),
                0.5 * (-3.0 * t3 + 4.0 * t2 + t),
                0.5 * (t3 - t2),
            ],
        }
    }

    /// Index of the first control point of span `i`.
    #[must_use]
    pub fn span_start(self, i: usize) -> usize {
        if self == Self::Bezier { 3 * i } else { i }
    }
}

impl fmt::Display for Basis {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::Linear => "linear",
            Self::BSpline => "bspline",
            Self::CatmullRom => "catmull-rom",
            Self::Bezier => "bezier",
        })
    }
}

/// The cross-section a file asks for. With a fiber model every strand renders as a round tube;
/// with a surface model ribbons render as oriented ribbons and flat curves as ribbons facing
/// the camera (`fiberlab_render::ribbons`). The kind is kept so that `hair info` reports it and
/// a conversion does not silently drop it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum CurveKind {
    /// A round tube (pbrt `cylinder`, USD curves without normals, `.hair`).
    Cylinder,
    /// A flat ribbon oriented by normals (pbrt `ribbon`, USD curves with `normals`).
    Ribbon,
    /// A flat ribbon facing the viewer (pbrt `flat`, pbrt's default).
    Flat,
}

impl fmt::Display for CurveKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::Cylinder => "cylinder",
            Self::Ribbon => "ribbon",
            Self::Flat => "flat",
        })
    }
}

/// Strands of one basis (module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct Strands {
    /// Control points of all strands, concatenated, root first within each strand.
    pub points: Vec<[f32; 3]>,
    /// Diameter per control point, scene units.
    pub widths: Vec<f32>,
    /// Control points per strand.
    pub counts: Vec<u32>,
    /// How the control points make curves.
    pub basis: Basis,
    /// The cross-section asked for.
    pub kind: CurveKind,
    /// Ribbon normals, one per span end of each strand (module docs); empty when the curves
    /// have none (every kind but [`CurveKind::Ribbon`]).
    pub normals: Vec<[f32; 3]>,
}

/// Why a hair file could not be read, converted or written. Parse errors name the file, the
/// line and the column (text formats) or the byte (`.hair`).
#[non_exhaustive]
#[derive(Debug, Error)]
pub enum StrandsError {
    /// The file could not be opened or read ([`crate::input_file`]: not a regular file, larger
    /// than the memory budget).
    #[error(transparent)]
    Input(#[from] crate::input_file::InputError),
    /// The file could not be opened, read or written.
    #[error("{path}: {error}")]
    Io {
        /// File path.
        path: PathBuf,
        /// Underlying error.
        error: std::io::Error,
    },
    /// A malformed text file: where, and what was expected.
    #[error("{path}:{line}:{column}: {message}")]
    Syntax {
        /// File path (the included file, for an error inside an `Include`).
        path: PathBuf,
        /// 1-based line.
        line: usize,
        /// 1-based column (characters).
        column: usize,
        /// What was wrong.
        message: String,
    },
    /// A `.hair` file error (it names the file and the byte).
    #[error(transparent)]
    Hair(#[from] HairError),
    /// A file name whose extension is not a hair format.
    #[error("{path}: unknown hair file format; the name must end in .hair, .pbrt, .pbrt.gz or .usda")]
    UnknownFormat {
        /// File path.
        path: PathBuf,
    },
    /// Strands that break an invariant, or cannot be stored in the format asked for.
    #[error("{0}")]
    Inconsistent(String),
}

impl From<&HairFile> for Strands {
    /// The polylines of a `.hair` file, widths from its thickness (per point or default).
    fn from(hair: &HairFile) -> Self {
        let counts = hair.strand_ranges().into_iter().map(|r| r.len() as u32).collect();
        let widths = (0..hair.points.len()).map(|i| hair.thickness_at(i)).collect();
        Self {
            points: hair.points.clone(),
            widths,
            counts,
            basis: Basis::Linear,
            kind: CurveKind::Cylinder,
            normals: Vec::new(),
        }
    }
}

impl Strands {
    /// Number of strands.
    #[must_use]
    pub fn strand_count(&self) -> usize {
        self.counts.len()
    }

    /// The control points of each strand, as index ranges into `points`.
    #[must_use]
    pub fn strand_ranges(&self) -> Vec<Range<usize>> {
        let mut start = 0;
        self.counts
            .iter()
            .map(|&c| {
                let r = start..start + c as usize;
                start = r.end;
                r
            })
            .collect()
    }

    /// Spans of all strands (module docs).
    #[must_use]
    pub fn span_count(&self) -> u64 {
        self.counts.iter().map(|&c| self.basis.spans(c as usize).unwrap_or(0) as u64).sum()
    }

    /// Span ends of all strands: how many ribbon normals the set takes (module docs).
    #[must_use]
    pub fn span_end_count(&self) -> u64 {
        self.counts.iter().map(|&c| self.basis.spans(c as usize).map_or(0, |s| s as u64 + 1)).sum()
    }

    /// Smallest and largest corner of the control points' box (`None` without points).
    #[must_use]
    pub fn bounds(&self) -> Option<([f32; 3], [f32; 3])> {
        let first = *self.points.first()?;
        Some(self.points.iter().fold((first, first), |(mut lo, mut hi), p| {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
            (lo, hi)
        }))
    }

    /// Smallest and largest width (`None` without points).
    #[must_use]
    pub fn width_range(&self) -> Option<(f32, f32)> {
        let first = *self.widths.first()?;
        Some(self.widths.iter().fold((first, first), |(a, b), &w| (a.min(w), b.max(w))))
    }

    /// Checks the invariants the readers guarantee: lengths agree, every strand fits its basis,
    /// points are finite, widths finite and ≥ 0, and normals (if any) one per span end, finite
    /// and non-zero.
    pub fn validate(&self) -> Result<(), StrandsError> {
        let bad = |m: String| Err(StrandsError::Inconsistent(m));
        let total: u64 = self.counts.iter().map(|&c| u64::from(c)).sum();
        if total != self.points.len() as u64 {
            return bad(format!(
                "the strands' point counts add up to {total}, but there are {} points",
                self.points.len()
            ));
        }
        if self.widths.len() != self.points.len() {
            return bad(format!("{} widths for {} points", self.widths.len(), self.points.len()));
        }
        if let Some((i, &c)) = self.counts.iter().enumerate().find(|&(_, &c)| self.basis.spans(c as usize).is_none()) {
            return bad(format!("strand {i} has {c} points: {}", self.basis.rule()));
        }
        if let Some(i) = self.points.iter().position(|p| !p.iter().all(|v| v.is_finite())) {
            return bad(format!("point {i} is not finite ({:?})", self.points[i]));
        }
        if let Some(i) = self.widths.iter().position(|w| !(w.is_finite() && *w >= 0.0)) {
            return bad(format!("width {i} = {} must be finite and ≥ 0", self.widths[i]));
        }
        if !self.normals.is_empty() && self.normals.len() as u64 != self.span_end_count() {
            return bad(format!(
                "{} ribbon normals for {} span ends (one per span end of each strand)",
                self.normals.len(),
                self.span_end_count()
            ));
        }
        if let Some(i) =
            self.normals.iter().position(|n| !(n.iter().all(|v| v.is_finite()) && n.iter().any(|&v| v != 0.0)))
        {
            return bad(format!("normal {i} = {:?} must be finite and non-zero", self.normals[i]));
        }
        Ok(())
    }

    /// The curves as polylines: each span evaluated at `segments_per_span` uniform steps of
    /// its parameter (points and widths with the basis' weights, in `f64`, rounded to `f32`;
    /// normals spherically between the span's end normals), consecutive spans sharing their
    /// end point. A linear set is returned unchanged.
    pub fn to_polylines(&self, segments_per_span: usize) -> Result<Self, StrandsError> {
        self.validate()?;
        if self.basis == Basis::Linear {
            return Ok(self.clone());
        }
        let steps = segments_per_span.max(1);
        // Each span becomes `steps` points of 16 bytes (point and width): checked against the
        // memory budget before they are made (a large cubic file times 1024 steps would not fit).
        let points = self.span_count().saturating_mul(steps as u64).saturating_add(self.counts.len() as u64);
        crate::memory_budget::check_needs(&[crate::memory_budget::Need::items(
            format!("{points} polyline points ({steps} per span)"),
            points,
            16,
        )])
        .map_err(|e| StrandsError::Inconsistent(e.to_string()))?;
        let mut out = Self {
            points: Vec::new(),
            widths: Vec::new(),
            counts: Vec::new(),
            basis: Basis::Linear,
            kind: self.kind,
            normals: Vec::new(),
        };
        let mut first_normal = 0;
        for r in self.strand_ranges() {
            let (c, w) = (&self.points[r.clone()], &self.widths[r]);
            let spans = self.basis.spans(c.len()).unwrap_or(0);
            let mut count = 0u32;
            for i in 0..spans {
                let s = self.basis.span_start(i);
                for j in usize::from(i > 0)..=steps {
                    let weights = self.basis.weights(j as f64 / steps as f64);
                    let mut p = [0.0f64; 3];
                    let mut width = 0.0f64;
                    for (m, &b) in weights.iter().enumerate() {
                        for (k, pk) in p.iter_mut().enumerate() {
                            *pk += f64::from(c[s + m][k]) * b;
                        }
                        width += f64::from(w[s + m]) * b;
                    }
                    out.points.push(p.map(|v| v as f32));
                    // Catmull–Rom weights can be negative: a width can dip below 0 between
                    // thin control points; a diameter is ≥ 0.
                    out.widths.push((width as f32).max(0.0));
                    if !self.normals.is_empty() {
                        let (a, b) = (self.normals[first_normal + i], self.normals[first_normal + i + 1]);
                        out.normals.push(slerp(a, b, j as f64 / steps as f64));
                    }
                    count += 1;
                }
            }
            first_normal += spans + 1;
            out.counts.push(count);
        }
        Ok(out)
    }

    /// The `.hair` file of a linear set: a segment count per strand (at most 65 535 segments,
    /// cyHair's u16; none when all strands have the same count, the header's default then
    /// holds it) and a thickness per point (none when all widths are equal, likewise).
    pub fn to_hair(&self) -> Result<HairFile, StrandsError> {
        self.validate()?;
        if !self.normals.is_empty() {
            return Err(StrandsError::Inconsistent(
                "ribbon normals cannot be stored in .hair (it holds round strands); write .usda".into(),
            ));
        }
        if self.basis != Basis::Linear {
            return Err(StrandsError::Inconsistent(format!(
                "{} curves cannot be stored in .hair as they are; turn them into polylines first",
                self.basis
            )));
        }
        let segments = self
            .counts
            .iter()
            .enumerate()
            .map(|(i, &c)| {
                u16::try_from(c - 1).map_err(|_| {
                    StrandsError::Inconsistent(format!(
                        "strand {i} has {} segments; .hair holds at most 65535 per strand",
                        c - 1
                    ))
                })
            })
            .collect::<Result<Vec<u16>, _>>()?;
        let strand_count = u32::try_from(self.counts.len()).map_err(|_| {
            StrandsError::Inconsistent(format!("{} strands do not fit .hair's u32 count", self.counts.len()))
        })?;
        let uniform = self.widths.first().filter(|&&w0| self.widths.iter().all(|&w| w.to_bits() == w0.to_bits()));
        // Strands of one length need no segments array: the header's default holds it.
        let same = segments.first().copied().filter(|&s0| segments.iter().all(|&s| s == s0));
        let hair = HairFile {
            segments: if same.is_some() { None } else { Some(segments) },
            default_segments: same.map_or(0, u32::from),
            points: self.points.clone(),
            thickness: if uniform.is_some() { None } else { Some(self.widths.clone()) },
            strand_count,
            default_thickness: uniform.copied().unwrap_or(1.0),
            ..HairFile::default()
        };
        hair.validate()?;
        Ok(hair)
    }
}

/// The spherical interpolation of the directions of `a` and `b` at `t ∈ [0, 1]` (a unit
/// vector; pbrt-v4's `Slerp` of normals): along the great circle from `â` to `b̂`. Nearly
/// equal directions, and opposite ones (no unique great circle), fall back to the normalised
/// linear blend, then to `â`.
#[must_use]
pub fn slerp(a: [f32; 3], b: [f32; 3], t: f64) -> [f32; 3] {
    let unit = |v: [f32; 3]| {
        let v = v.map(f64::from);
        let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        v.map(|x| x / l)
    };
    let (a, b) = (unit(a), unit(b));
    let cos = (a[0] * b[0] + a[1] * b[1] + a[2] * b[2]).clamp(-1.0, 1.0);
    let theta = cos.acos();
    let blend = if theta > 1e-6 && theta < std::f64::consts::PI - 1e-6 {
        let (wa, wb) = (((1.0 - t) * theta).sin() / theta.sin(), (t * theta).sin() / theta.sin());
        [0, 1, 2].map(|k| wa * a[k] + wb * b[k])
    } else {
        [0, 1, 2].map(|k| (1.0 - t) * a[k] + t * b[k])
    };
    let l = (blend[0] * blend[0] + blend[1] * blend[1] + blend[2] * blend[2]).sqrt();
    if l > 1e-9 { blend.map(|x| (x / l) as f32) } else { a.map(|x| x as f32) }
}

/// Line and column (1-based, in characters) of byte `offset` of `text`.
#[must_use]
pub fn line_column(text: &str, offset: usize) -> (usize, usize) {
    let offset = offset.min(text.len());
    let before = &text.as_bytes()[..offset];
    let line = before.iter().filter(|&&b| b == b'\n').count() + 1;
    let start = before.iter().rposition(|&b| b == b'\n').map_or(0, |p| p + 1);
    let column = String::from_utf8_lossy(&before[start..]).chars().count() + 1;
    (line, column)
}

/// The text of a file: UTF-8 required (the error names the line and column of the first bad
/// byte).
pub(crate) fn utf8_text(path: &Path, bytes: Vec<u8>) -> Result<String, StrandsError> {
    String::from_utf8(bytes).map_err(|e| {
        let good = e.utf8_error().valid_up_to();
        let text = String::from_utf8_lossy(&e.as_bytes()[..good]).into_owned();
        let (line, column) = line_column(&text, good);
        StrandsError::Syntax { path: path.into(), line, column, message: format!("byte {good} is not UTF-8 text") }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn one_bezier() -> Strands {
        Strands {
            points: vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 1.0, 0.0], [3.0, 1.0, 0.0]],
            widths: vec![0.1, 0.1, 0.05, 0.05],
            counts: vec![4],
            basis: Basis::Bezier,
            kind: CurveKind::Cylinder,
            normals: Vec::new(),
        }
    }

    #[test]
    fn weights_sum_to_one_and_interpolate_where_the_basis_does() {
        for basis in [Basis::Linear, Basis::Bezier, Basis::BSpline, Basis::CatmullRom] {
            for k in 0..=10 {
                let w = basis.weights(f64::from(k) / 10.0);
                assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-14, "{basis} {w:?}");
            }
        }
        assert_eq!(Basis::Bezier.weights(0.0), [1.0, 0.0, 0.0, 0.0]);
        assert_eq!(Basis::Bezier.weights(1.0), [0.0, 0.0, 0.0, 1.0]);
        assert_eq!(Basis::CatmullRom.weights(0.0), [0.0, 1.0, 0.0, 0.0]);
        assert_eq!(Basis::CatmullRom.weights(1.0), [0.0, 0.0, 1.0, 0.0]);
        // B-spline at a knot: (1, 4, 1)/6.
        let b = Basis::BSpline.weights(0.0);
        assert_eq!(b, [1.0 / 6.0, 4.0 / 6.0, 1.0 / 6.0, 0.0]);
    }

    #[test]
    fn catmull_rom_tangent_is_half_the_chord_of_the_neighbours() {
        // Numerical derivative of the weights at t = 0 against (c2 − c0)/2.
        let h = 1e-6;
        let d: Vec<f64> =
            (0..4).map(|m| (Basis::CatmullRom.weights(h)[m] - Basis::CatmullRom.weights(0.0)[m]) / h).collect();
        for (got, want) in d.iter().zip([-0.5, 0.0, 0.5, 0.0]) {
            assert!((got - want).abs() < 1e-5, "{d:?}");
        }
    }

    #[test]
    fn span_counts_follow_the_bases() {
        assert_eq!(Basis::Bezier.spans(7), Some(2));
        assert_eq!(Basis::Bezier.spans(6), None);
        assert_eq!(Basis::BSpline.spans(6), Some(3));
        assert_eq!(Basis::CatmullRom.spans(3), None);
        assert_eq!(Basis::Linear.spans(1), None);
    }

    #[test]
    fn a_bezier_becomes_a_polyline_through_its_end_points_and_midpoint() {
        let lines = one_bezier().to_polylines(2).unwrap();
        assert_eq!(lines.counts, vec![3]);
        assert_eq!(lines.points[0], [0.0, 0.0, 0.0]);
        assert_eq!(lines.points[2], [3.0, 1.0, 0.0]);
        // B(1/2) = (c0 + 3c1 + 3c2 + c3)/8.
        assert_eq!(lines.points[1], [(3.0 + 6.0 + 3.0) / 8.0, (3.0 + 1.0) / 8.0, 0.0]);
        assert_eq!(lines.widths[1], ((0.1f64 + 0.3 + 0.15 + 0.05) / 8.0) as f32);
    }

    #[test]
    fn hair_round_trip_through_strands() {
        let s = one_bezier().to_polylines(5).unwrap();
        let hair = s.to_hair().unwrap();
        assert_eq!(Strands::from(&hair), s);
        assert!(one_bezier().to_hair().is_err());
        let mut bad = s.clone();
        bad.widths[0] = -1.0;
        assert!(bad.validate().unwrap_err().to_string().contains("width 0"));
    }

    #[test]
    fn line_columns_count_characters() {
        assert_eq!(line_column("ab\ncé d", 7), (2, 4));
        assert_eq!(line_column("x", 0), (1, 1));
    }
}
