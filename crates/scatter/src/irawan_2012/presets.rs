//! The six example fabrics of [`super::Irawan2012`] (tile, α, β, smoothing, areas and yarn
//! parameters of the Mitsuba 0.6 example set; grids and colours ours).

use fiberlab_math::Rgb;

use super::pattern::{WeavePattern, YarnKind, YarnSegment};

/// The preset names, from the example patterns of Mitsuba 0.6 as ported by LuxCore.
pub const IRAWAN_PRESETS: [&str; 6] =
    ["cotton-denim", "silk-shantung", "silk-charmeuse", "cotton-twill", "wool-gabardine", "polyester-lining"];

/// Yarn parameters of a preset: ψ, u_max (degrees), κ, w, l.
type YarnRow = (f64, f64, f64, f64, f64);

fn segment(kind: YarnKind, row: YarnRow, center: [f64; 2], k_d: Rgb, k_s: Rgb) -> YarnSegment {
    let (psi, u_max, kappa, width, length) = row;
    YarnSegment { kind, psi: psi.to_radians(), u_max: u_max.to_radians(), kappa, width, length, center, k_d, k_s }
}

/// A twill/satin-like tile: `columns` warp columns of width `wc` cells; in column `c` the weft
/// (`weft_rows` rows, one segment of length `wc`) starts at row `c·shift` and the warp fills
/// the remaining rows.
struct Tile {
    width: usize,
    height: usize,
    cells: Vec<usize>,
    yarns: Vec<YarnSegment>,
}

impl Tile {
    fn new(width: usize, height: usize) -> Self {
        Self { width, height, cells: vec![0; width * height], yarns: Vec::new() }
    }
    /// Adds a segment covering columns `c0..c0+nc` and rows `r0..r0+nr` (wrapping).
    fn add(&mut self, c0: usize, nc: usize, r0: usize, nr: usize, make: impl Fn([f64; 2]) -> YarnSegment) {
        let center = [
            (c0 as f64 + nc as f64 / 2.0).rem_euclid(self.width as f64),
            (r0 as f64 + nr as f64 / 2.0).rem_euclid(self.height as f64),
        ];
        self.yarns.push(make(center));
        let id = self.yarns.len();
        for c in c0..c0 + nc {
            for r in r0..r0 + nr {
                self.cells[(r % self.height) * self.width + c % self.width] = id;
            }
        }
    }
}

#[allow(clippy::too_many_arguments)] // one argument per column of the preset table
/// `columns` column groups of `wc` cells, each with a weft block of `weft_rows` rows shifted
/// by `shift` rows per group and the warp over the other rows.
fn twill(
    width: usize,
    height: usize,
    wc: usize,
    weft_rows: usize,
    shift: usize,
    warp: YarnRow,
    weft: YarnRow,
    colours: (Rgb, Rgb),
) -> Tile {
    let mut t = Tile::new(width, height);
    let (k_d, k_s) = colours;
    for g in 0..width / wc {
        let r0 = g * shift;
        t.add(g * wc, wc, r0, weft_rows, |c| segment(YarnKind::Weft, weft, c, k_d, k_s));
        t.add(g * wc, wc, r0 + weft_rows, height - weft_rows, |c| segment(YarnKind::Warp, warp, c, k_d, k_s));
    }
    t
}
impl WeavePattern {
    /// One of [`IRAWAN_PRESETS`] (tile, α, β, ss, h_width, areas and yarn parameters from the
    /// example set; the grids are ours, built from the tile sizes and the segment lengths, and
    /// so are the colours — the table gives neither; `k_s` see the module docs).
    #[must_use]
    pub fn preset(name: &str) -> Option<Self> {
        let (tile, alpha, beta, ss, h_width, warp_area, weft_area) = match name {
            "cotton-denim" => {
                let c = (Rgb::new(0.05, 0.1, 0.3), Rgb::splat(0.06));
                (
                    twill(3, 6, 1, 1, 2, (-30.0, 12.0, 0.0, 1.0, 5.0), (-30.0, 38.0, 0.0, 1.0, 1.0), c),
                    0.01,
                    4.0,
                    0.0,
                    0.5,
                    5.0,
                    1.0,
                )
            }
            "silk-shantung" => {
                let (k_d, k_s) = (Rgb::new(0.35, 0.1, 0.05), Rgb::splat(0.12));
                let (warp, weft) = ((0.0, 50.0, -0.5, 2.0, 4.0), (0.0, 23.0, -0.3, 4.0, 4.0));
                let mut t = Tile::new(6, 8);
                t.add(0, 2, 0, 4, |c| segment(YarnKind::Warp, warp, c, k_d, k_s));
                t.add(2, 4, 0, 4, |c| segment(YarnKind::Weft, weft, c, k_d, k_s));
                t.add(2, 2, 4, 4, |c| segment(YarnKind::Warp, warp, c, k_d, k_s));
                t.add(4, 4, 4, 4, |c| segment(YarnKind::Weft, weft, c, k_d, k_s));
                (t, 0.02, 1.5, 0.5, 0.5, 8.0, 16.0)
            }
            "silk-charmeuse" => {
                let c = (Rgb::new(0.3, 0.05, 0.1), Rgb::splat(0.07));
                (
                    twill(5, 10, 1, 1, 2, (0.0, 40.0, 2.0, 1.0, 9.0), (0.0, 60.0, 0.0, 1.0, 1.0), c),
                    0.02,
                    7.3,
                    0.5,
                    0.5,
                    9.0,
                    1.0,
                )
            }
            "cotton-twill" => {
                let c = (Rgb::new(0.3, 0.25, 0.15), Rgb::splat(0.045));
                (
                    twill(4, 8, 1, 2, 2, (-30.0, 24.0, 0.0, 1.0, 6.0), (-30.0, 36.0, 0.0, 2.0, 1.0), c),
                    0.01,
                    4.0,
                    0.0,
                    0.5,
                    6.0,
                    2.0,
                )
            }
            "wool-gabardine" => {
                let c = (Rgb::new(0.2, 0.15, 0.1), Rgb::splat(0.065));
                (
                    twill(6, 9, 2, 3, 3, (30.0, 30.0, 0.0, 2.0, 6.0), (30.0, 30.0, 0.0, 3.0, 2.0), c),
                    0.01,
                    4.0,
                    0.0,
                    0.5,
                    12.0,
                    6.0,
                )
            }
            "polyester-lining" => {
                let (k_d, k_s) = (Rgb::new(0.25, 0.25, 0.3), Rgb::splat(0.075));
                let (warp, weft) = ((0.0, 22.0, -0.7, 1.0, 1.0), (0.0, 16.0, -0.7, 1.0, 1.0));
                let mut t = Tile::new(2, 2);
                t.add(0, 1, 0, 1, |c| segment(YarnKind::Warp, warp, c, k_d, k_s));
                t.add(1, 1, 0, 1, |c| segment(YarnKind::Weft, weft, c, k_d, k_s));
                t.add(0, 1, 1, 1, |c| segment(YarnKind::Weft, weft, c, k_d, k_s));
                t.add(1, 1, 1, 1, |c| segment(YarnKind::Warp, warp, c, k_d, k_s));
                (t, 0.015, 4.0, 0.5, 0.5, 1.0, 1.0)
            }
            _ => return None,
        };
        Some(Self {
            width: tile.width,
            height: tile.height,
            cells: tile.cells,
            yarns: tile.yarns,
            alpha,
            beta,
            ss,
            h_width,
            warp_area,
            weft_area,
        })
    }
}
