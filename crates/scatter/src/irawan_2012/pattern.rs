//! The weave pattern of [`super::Irawan2012`]: the tile grid of yarn ids, the yarn segments,
//! their validation, and the lookup of the segment under a UV point.

use fiberlab_math::Rgb;
use std::f64::consts::FRAC_PI_2;
use thiserror::Error;

use super::BETA_MAX;

/// Warp (runs along `v`) or weft (runs along `u`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum YarnKind {
    /// Runs along the tile's height (`v`).
    Warp,
    /// Runs along the tile's width (`u`).
    Weft,
}

/// One yarn segment of a pattern (angles in radians, lengths in grid cells).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct YarnSegment {
    /// Warp or weft.
    pub kind: YarnKind,
    /// Fiber twist ψ (0: filament yarn), |ψ| < 90°.
    pub psi: f64,
    /// Largest inclination along the yarn `u_max`, in (0, 90°).
    pub u_max: f64,
    /// Spine curvature κ > −1 (kept; the circular spine is used, see the module docs).
    pub kappa: f64,
    /// Width across the yarn, cells (> 0).
    pub width: f64,
    /// Length along the yarn, cells (> 0).
    pub length: f64,
    /// Centre `(u, v)` in cells, inside the tile.
    pub center: [f64; 2],
    /// Diffuse colour `k_d` ∈ [0, 1].
    pub k_d: Rgb,
    /// Specular colour `k_s` ∈ [0, 1].
    pub k_s: Rgb,
}

/// Why a weave pattern is invalid: every error names the field.
#[non_exhaustive]
#[derive(Clone, Debug, Error, PartialEq)]
pub enum PatternError {
    /// The grid has the wrong number of cells.
    #[error("field `pattern`: the grid has {found} cells, the tile {width}×{height} needs {expected}")]
    GridSize {
        /// Cells found.
        found: usize,
        /// `width·height`.
        expected: usize,
        /// Tile width.
        width: usize,
        /// Tile height.
        height: usize,
    },
    /// A cell names a yarn that does not exist.
    #[error("field `pattern`: cell {cell} holds yarn id {id}, valid ids are 1..={count}")]
    YarnId {
        /// Cell index (row-major).
        cell: usize,
        /// The id found.
        id: usize,
        /// Number of yarns.
        count: usize,
    },
    /// A value is not finite or out of its range.
    #[error("field `{field}` = {value} is not valid: {valid}")]
    Value {
        /// The field.
        field: String,
        /// The value.
        value: f64,
        /// What is valid.
        valid: &'static str,
    },
    /// The pattern has no yarns or an empty tile.
    #[error("field `{0}`: must not be empty")]
    Empty(&'static str),
}

/// A weave pattern: the tile grid of yarn ids and the yarns (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct WeavePattern {
    /// Tile width in cells (along `u`).
    pub width: usize,
    /// Tile height in cells (along `v`).
    pub height: usize,
    /// Row-major cell ids, 1-based into `yarns` (row 0 at `v = 0`).
    pub cells: Vec<usize>,
    /// The yarn segments.
    pub yarns: Vec<YarnSegment>,
    /// Uniform scattering α ≥ 0.
    pub alpha: f64,
    /// Forward-scattering concentration β ∈ [0, 20].
    pub beta: f64,
    /// Filament smoothing `ss` ∈ [0, 1).
    pub ss: f64,
    /// Highlight width fraction ∈ (0, 1].
    pub h_width: f64,
    /// Warp area (> 0).
    pub warp_area: f64,
    /// Weft area (> 0).
    pub weft_area: f64,
}

pub(super) fn check(field: impl Into<String>, x: f64, ok: bool, valid: &'static str) -> Result<(), PatternError> {
    if x.is_finite() && ok { Ok(()) } else { Err(PatternError::Value { field: field.into(), value: x, valid }) }
}

impl WeavePattern {
    /// Checks sizes, ids and every value (NaN included).
    pub fn validate(&self) -> Result<(), PatternError> {
        if self.width == 0 || self.height == 0 {
            return Err(PatternError::Empty("tile"));
        }
        if self.yarns.is_empty() {
            return Err(PatternError::Empty("yarns"));
        }
        let expected = self.width * self.height;
        if self.cells.len() != expected {
            return Err(PatternError::GridSize {
                found: self.cells.len(),
                expected,
                width: self.width,
                height: self.height,
            });
        }
        for (cell, &id) in self.cells.iter().enumerate() {
            if id == 0 || id > self.yarns.len() {
                return Err(PatternError::YarnId { cell, id, count: self.yarns.len() });
            }
        }
        check("alpha", self.alpha, self.alpha >= 0.0 && self.alpha <= 10.0, "in [0, 10]")?;
        check("beta", self.beta, (0.0..=BETA_MAX).contains(&self.beta), "in [0, 20]")?;
        check("ss", self.ss, (0.0..1.0).contains(&self.ss), "in [0, 1)")?;
        check("hwidth", self.h_width, self.h_width > 0.0 && self.h_width <= 1.0, "in (0, 1]")?;
        check("warp_area", self.warp_area, self.warp_area > 0.0, "> 0")?;
        check("weft_area", self.weft_area, self.weft_area > 0.0, "> 0")?;
        for (k, y) in self.yarns.iter().enumerate() {
            let f = |name: &str| format!("yarn {}: {name}", k + 1);
            check(f("psi"), y.psi, y.psi.abs() < FRAC_PI_2, "|ψ| < 90 degrees")?;
            check(f("umax"), y.u_max, y.u_max > 0.0 && y.u_max < FRAC_PI_2, "in (0, 90) degrees")?;
            check(f("kappa"), y.kappa, y.kappa > -1.0, "> -1")?;
            check(f("width"), y.width, y.width > 0.0, "> 0")?;
            check(f("length"), y.length, y.length > 0.0, "> 0")?;
            check(f("center"), y.center[0], (0.0..=self.width as f64).contains(&y.center[0]), "inside the tile")?;
            check(f("center"), y.center[1], (0.0..=self.height as f64).contains(&y.center[1]), "inside the tile")?;
            for c in 0..3 {
                check(f("kd"), y.k_d[c], (0.0..=1.0).contains(&y.k_d[c]), "in [0, 1]")?;
                check(f("ks"), y.k_s[c], (0.0..=1.0).contains(&y.k_s[c]), "in [0, 1]")?;
            }
        }
        Ok(())
    }
}

impl WeavePattern {
    /// The segment under UV position `(u, v)` (tiled) and the point's coordinates across
    /// (`x`) and along (`y`) it, in cells, plus the segment's frame change (weft: rotated).
    pub(super) fn locate(&self, u: f64, v: f64) -> Located<'_> {
        let (w, h) = (self.width as f64, self.height as f64);
        let (cx, cy) = (u.rem_euclid(1.0) * w, v.rem_euclid(1.0) * h);
        let cell = (cy as usize).min(self.height - 1) * self.width + (cx as usize).min(self.width - 1);
        let id = self.cells[cell];
        let yarn = &self.yarns[id - 1];
        let wrap = |d: f64, period: f64| d - period * (d / period).round();
        let (du, dv) = (wrap(cx - yarn.center[0], w), wrap(cy - yarn.center[1], h));
        // Which copy of the tile holds the segment's centre (a segment may wrap over an edge).
        let copy = |t: f64, c: f64, d: f64, center: f64, period: f64| {
            t.floor() as i64 + ((c - d - center) / period).round() as i64
        };
        let instance = [copy(u, cx, du, yarn.center[0], w), copy(v, cy, dv, yarn.center[1], h)];
        let (x, y) = match yarn.kind {
            YarnKind::Warp => (du, dv),
            YarnKind::Weft => (-dv, du),
        };
        Located { yarn, id, x, y, instance }
    }
}

/// A point of the tile in its segment: the segment, its 1-based id, the point's coordinates
/// across (`x`) and along (`y`) it in cells, and which copy of the tile the segment is in.
pub(super) struct Located<'a> {
    pub(super) yarn: &'a YarnSegment,
    pub(super) id: usize,
    pub(super) x: f64,
    pub(super) y: f64,
    pub(super) instance: [i64; 2],
}
