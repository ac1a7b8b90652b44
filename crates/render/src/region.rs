//! Pixel rectangles of an image: what a render, a part or a crop covers.

/// A half-open pixel rectangle `[x0, x1) × [y0, y1)`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Region {
    /// First column.
    pub x0: u32,
    /// First row.
    pub y0: u32,
    /// One past the last column.
    pub x1: u32,
    /// One past the last row.
    pub y1: u32,
}

impl Region {
    /// The whole image.
    #[must_use]
    pub fn full(width: u32, height: u32) -> Self {
        Self { x0: 0, y0: 0, x1: width, y1: height }
    }

    /// Part `i` of `n` (0-based): a band of whole rows; the `n` parts tile the image.
    #[must_use]
    pub fn part(i: u32, n: u32, width: u32, height: u32) -> Self {
        let row = |k: u32| (u64::from(height) * u64::from(k) / u64::from(n.max(1))) as u32;
        Self { x0: 0, y0: row(i), x1: width, y1: row(i + 1) }
    }

    /// Number of pixels.
    #[must_use]
    pub fn area(&self) -> u64 {
        u64::from(self.x1.saturating_sub(self.x0)) * u64::from(self.y1.saturating_sub(self.y0))
    }
}
