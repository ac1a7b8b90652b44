//! The range of strand diameters a scene accepts, checked on every `.hair` file and every
//! generated hair before it becomes tubes.
//!
//! A strand is rendered as tubes whose segment `k` has the diameter `(d_k + d_{k+1})/2` of
//! its two end points (see [`fiberlab_geometry::curves`]), so the rule applies to that segment diameter
//! (a pointed tip, `d = 0` at the last point, is allowed). Each segment diameter `d` must be
//! * finite and `> 0` — a tube of diameter 0 (or NaN) is never hit, the strand vanishes;
//! * at most [`MAX_FRACTION_OF_EXTENT`] of the diagonal of the hair's bounding box (of its
//!   points): a "strand" thicker than a tenth of the whole hair is a unit mistake (a
//!   diameter in micrometres given to a head in metres), not a fibre;
//! * at least [`MIN_FRACTION_OF_COORDINATES`]` · (1 + |p|_max)`, with `|p|_max` the largest
//!   coordinate magnitude of the segment's end points: rays leaving a surface start
//!   `1e-9 · (1 + |p|_max)` away from it and the points are stored in `f32` (relative
//!   precision 6e-8), so a thinner tube is missed or self-intersected at random.

use fiberlab_io::HairFile;

/// Largest segment diameter as a fraction of the diagonal of the hair's bounding box.
pub const MAX_FRACTION_OF_EXTENT: f64 = 0.1;

/// Smallest segment diameter relative to `1 + |p|_max` (the scale of the ray epsilons).
pub const MIN_FRACTION_OF_COORDINATES: f64 = 1e-6;

/// A segment whose diameter is outside the accepted range; the message names the strand,
/// the segment, the value and the bound it breaks.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("strand {strand}, segment {segment}: diameter {value:?} {problem}")]
pub struct DiameterError {
    /// Strand index (0-based, file order).
    pub strand: usize,
    /// Segment index within the strand (0 = at the root).
    pub segment: usize,
    /// The segment's diameter (mean of its end points').
    pub value: f64,
    /// The rule it breaks, with the bound.
    pub problem: String,
}

/// Checks every segment diameter of `hair` against the rules of this module.
pub fn check(hair: &HairFile) -> Result<(), DiameterError> {
    let point = |i: usize| hair.points[i].map(f64::from);
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for p in &hair.points {
        for k in 0..3 {
            lo[k] = lo[k].min(f64::from(p[k]));
            hi[k] = hi[k].max(f64::from(p[k]));
        }
    }
    let diagonal =
        if hair.points.is_empty() { 0.0 } else { (0..3).map(|k| (hi[k] - lo[k]).powi(2)).sum::<f64>().sqrt() };
    let max_diameter = MAX_FRACTION_OF_EXTENT * diagonal;
    for (strand, range) in hair.strand_ranges().into_iter().enumerate() {
        for (segment, i) in (range.start..range.end.saturating_sub(1)).enumerate() {
            let (a, b) = (point(i), point(i + 1));
            if a == b {
                // A zero-length segment is not rendered (curves drops it).
                continue;
            }
            let value = 0.5 * (f64::from(hair.thickness_at(i)) + f64::from(hair.thickness_at(i + 1)));
            let bad = |problem: String| Err(DiameterError { strand, segment, value, problem });
            if !(value.is_finite() && value > 0.0) {
                return bad("must be finite and > 0 (a tube of diameter 0 is never hit)".into());
            }
            if value > max_diameter {
                return bad(format!(
                    "is larger than {} % of the hair's bounding-box diagonal {diagonal:?} (at most {max_diameter:?}); \
                     is it in another unit than the points?",
                    MAX_FRACTION_OF_EXTENT * 100.0
                ));
            }
            let magnitude = a.iter().chain(&b).fold(0.0f64, |m, c| m.max(c.abs()));
            let min_diameter = MIN_FRACTION_OF_COORDINATES * (1.0 + magnitude);
            if value < min_diameter {
                return bad(format!(
                    "is too small for coordinates of magnitude {magnitude:?}: below {min_diameter:?} \
                     (1e-6 · (1 + |p|max)) rays cannot hit it reliably"
                ));
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two straight strands along x of length 1 (bounding-box diagonal √(1 + 0.5²)), four
    /// points each, every point of diameter `d` except point `at` of strand 1 with `bad`.
    fn hair(d: f32, at: usize, bad: f32) -> HairFile {
        let mut points = Vec::new();
        let mut thickness = Vec::new();
        for s in 0..2 {
            for k in 0..4 {
                points.push([k as f32 / 3.0, 0.5 * s as f32, 0.0]);
                thickness.push(if s == 1 && k == at { bad } else { d });
            }
        }
        HairFile {
            segments: Some(vec![3, 3]),
            points,
            thickness: Some(thickness),
            strand_count: 2,
            default_segments: 3,
            ..HairFile::default()
        }
    }

    #[test]
    fn ordinary_hair_and_a_pointed_tip_pass() {
        check(&hair(0.01, 0, 0.01)).unwrap();
        check(&hair(0.01, 3, 0.0)).unwrap();
    }

    #[test]
    fn zero_nan_huge_and_tiny_diameters_name_strand_segment_and_value() {
        // Both end points of segment 1 (points 1 and 2) at 0: the segment vanishes.
        let mut h = hair(0.01, 1, 0.0);
        h.thickness.as_mut().unwrap()[6] = 0.0;
        let e = check(&h).unwrap_err();
        assert_eq!((e.strand, e.segment, e.value), (1, 1, 0.0), "{e}");
        let e = check(&hair(0.01, 2, f32::NAN)).unwrap_err();
        assert_eq!((e.strand, e.segment), (1, 1), "{e}");
        assert!(e.to_string().contains("NaN"), "{e}");
        // 1e30: far beyond a tenth of the diagonal √1.25 ≈ 1.118; printed in exponent form.
        let e = check(&hair(0.01, 0, 1e30)).unwrap_err().to_string();
        assert!(e.starts_with("strand 1, segment 0: diameter 5.0") && e.contains("e29 is larger than 10 %"), "{e}");
        // Just above and below the bound 0.1·√1.25 (the segment mean of 0.01 and x).
        let limit = 0.1 * 1.25f64.sqrt();
        assert!(check(&hair(0.01, 0, (2.0 * limit - 0.01 - 1e-4) as f32)).is_ok());
        assert!(check(&hair(0.01, 0, (2.0 * limit - 0.01 + 1e-4) as f32)).is_err());
        // Coordinates ≤ 1: the lower bound is 1e-6 · (1 + |p|max) ∈ [1e-6, 2e-6].
        let e = check(&hair(5e-7, 9, 0.0)).unwrap_err();
        assert_eq!((e.strand, e.segment), (0, 0), "{e}");
        assert!(e.to_string().contains("too small"), "{e}");
        assert!(check(&hair(2.5e-6, 9, 0.0)).is_ok());
    }
}
