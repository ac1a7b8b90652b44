//! The surface goniophotometer: a slab of parallel dielectric cylinders embedded in a clear
//! finish below a flat interface, over a diffuse or absorbing substrate, measured by tracing
//! rays through the explicit geometry (the validation by geometry of the fiber highlight of
//! Marschner, Westin, Arbree and Moon 2005).
//!
//! # Geometry (local frame: `z` = surface normal, the interface is the plane `z = 0`)
//! - Above: air (index 1). Below: the finish of index `η`, which also fills the space between
//!   the fibers.
//! - The fibers are infinite cylinders of radius `radius` and index `fiber_eta`, with
//!   interior absorption `σ_a` (per unit length, same unit as the radius), all parallel to
//!   `u = (cos δ cos α, cos δ sin α, −sin δ)` (α = `fiber_angle` from `+x` toward `+y`,
//!   δ = `fiber_dip` below the surface), clipped to the slab `z_bot ≤ z ≤ z_top`
//!   (`z_top = −depth`, `z_bot = z_top − thickness`). Where a dipped fiber is cut by the slab's
//!   top plane it has a flat face, a dielectric interface like its wall.
//! - Their centres, in the plane across the axis (coordinates along `v = (−sin α, cos α, 0)`
//!   and `w = u × v`), repeat on a square periodic cell holding `fibers_per_cell` random
//!   non-overlapping circles (seeded by `layout_seed`); the cell's side follows from the
//!   packing fraction.
//! - The substrate at `z = z_bot` reflects diffusely (Lambertian, albedo `substrate`, 0 =
//!   absorbing).
//!
//! # Estimator
//! A collimated beam from `ω_i` lands uniformly on one period of the surface. Every
//! interface (air/finish, finish/fiber at the walls and the cut faces) splits a path by
//! stochastic branch selection (reflect with probability `F`, total internal reflection
//! included), so weights change only by absorption and the substrate's albedo; after
//! [`ROULETTE_AFTER`] events Russian roulette ends paths without bias. Each bin's BRDF is
//! `f_r = P_bin / ∫_bin cosθ_o dω_o`, `P_bin` the fraction of the incident power leaving
//! through the bin, θ_o from the normal; the cosine-weighted solid angle of the bin is
//! integrated exactly (it tends to `cosθ_o · Ω_bin` for small bins). A finish reflection is a
//! delta: its whole power `F(θ_i)` lands in the mirror bin.
//!
//! Paths are classified by what they met: `finish` (reflected by the interface at once),
//! `fiber` (exactly one fiber met at its cylindrical wall, no cut face, no substrate: every
//! such path keeps its angle with the axis, so inside the finish it leaves on the fiber's
//! specular cone), `substrate` (the substrate and no fiber) and `multiple` (the rest,
//! including every path through a cut face).

use crate::{BinSums, LobeTable, Setup};
use fiberlab_math::{DVec3, Rgb, fresnel};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use rayon::prelude::*;
use std::f64::consts::{FRAC_PI_2, PI, TAU};
use std::sync::atomic::{AtomicBool, Ordering};
use thiserror::Error;

/// Rays traced per independently seeded chunk.
const CHUNK: usize = 1 << 15;
/// Events after which Russian roulette ends paths with probability 1% per event.
pub const ROULETTE_AFTER: usize = 1000;
/// Events after which a path is dropped (counted; with roulette this is practically never).
pub const MAX_EVENTS: usize = 100_000;
/// Self-intersection guard (length units of the radius).
const EPS: f64 = 1e-9;

/// An invalid slab or measurement; the message names the key and its valid range.
#[non_exhaustive]
#[derive(Clone, Debug, Error, PartialEq)]
pub enum SlabError {
    /// A value outside its range, or not finite.
    #[error("surface parameter `{key}` = {value} is invalid; valid range {range}")]
    OutOfRange {
        /// Key.
        key: &'static str,
        /// Value given (degrees for angles).
        value: f64,
        /// Valid range, with its unit.
        range: &'static str,
    },
    /// Random sequential placement could not fit the fibers into the cell.
    #[error("could not place {fibers} non-overlapping fibers at packing {packing}; lower the packing")]
    Jammed {
        /// Fibers per cell.
        fibers: usize,
        /// Packing fraction.
        packing: f64,
    },
    /// More bins than 32-bit bin indices address.
    #[error("bins: {bins_theta} × {bins_phi} bins per table; at most 4294967295")]
    TooManyBins {
        /// Bins in θ_o.
        bins_theta: usize,
        /// Bins in φ_o.
        bins_phi: usize,
    },
}

/// The sample: finish, fibers and substrate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FiberSlab {
    /// Index of the finish (and of the matrix between the fibers), ≥ 1.
    pub eta: f64,
    /// In-plane angle α of the fiber axis from `+x` toward `+y` (radians).
    pub fiber_angle: f64,
    /// Dip δ of the axis below the surface plane (radians, [0, π/2)).
    pub fiber_dip: f64,
    /// Fiber radius (the length unit of `depth`, `thickness` and `sigma_a`'s inverse).
    pub radius: f64,
    /// Area fraction of the fiber cross-sections in the plane across the axis, [0, 0.5].
    pub packing: f64,
    /// Absolute index of the fibers, ≥ 1.
    pub fiber_eta: f64,
    /// Absorption coefficient inside the fibers (per unit length).
    pub sigma_a: Rgb,
    /// Depth of the slab's top below the interface (> 0).
    pub depth: f64,
    /// Slab thickness (≥ 0); the substrate lies at its bottom.
    pub thickness: f64,
    /// Lambertian albedo of the substrate (0 = absorbing).
    pub substrate: Rgb,
    /// Fibers per periodic cell (≥ 1).
    pub fibers_per_cell: usize,
    /// Seed of the fiber positions.
    pub layout_seed: u64,
}

impl Default for FiberSlab {
    fn default() -> Self {
        Self {
            eta: 1.5,
            fiber_angle: 0.0,
            fiber_dip: 0.0,
            radius: 1.0,
            packing: 0.3,
            fiber_eta: 1.55,
            sigma_a: Rgb::ZERO,
            depth: 0.5,
            thickness: 10.0,
            substrate: Rgb::ZERO,
            fibers_per_cell: 24,
            layout_seed: 1,
        }
    }
}

impl FiberSlab {
    /// Unit fiber axis `u` in the local frame.
    #[must_use]
    pub fn axis(&self) -> DVec3 {
        let (sd, cd) = self.fiber_dip.sin_cos();
        let (sa, ca) = self.fiber_angle.sin_cos();
        DVec3::new(cd * ca, cd * sa, -sd)
    }

    /// Checks every parameter against its range.
    pub fn validate(&self) -> Result<(), SlabError> {
        let check = |key, value: f64, ok: bool, range, shown: f64| {
            if value.is_finite() && ok { Ok(()) } else { Err(SlabError::OutOfRange { key, value: shown, range }) }
        };
        check("eta", self.eta, (1.0..=10.0).contains(&self.eta), "[1, 10]", self.eta)?;
        check("fiber_eta", self.fiber_eta, (1.0..=10.0).contains(&self.fiber_eta), "[1, 10]", self.fiber_eta)?;
        check("fiber_angle", self.fiber_angle, true, "finite degrees", self.fiber_angle.to_degrees())?;
        let dip_ok = (0.0..89.0f64.to_radians()).contains(&self.fiber_dip);
        check("fiber_dip", self.fiber_dip, dip_ok, "[0, 89) degrees", self.fiber_dip.to_degrees())?;
        check("radius", self.radius, self.radius > 0.0, "> 0", self.radius)?;
        check("packing", self.packing, (0.0..=0.5).contains(&self.packing), "[0, 0.5]", self.packing)?;
        check("depth", self.depth, self.depth > 0.0, "> 0 (radii)", self.depth)?;
        check("thickness", self.thickness, self.thickness >= 0.0, ">= 0", self.thickness)?;
        for k in 0..3 {
            let s = self.sigma_a[k];
            check("sigma_a", s, s >= 0.0, ">= 0 per unit length", s)?;
            let a = self.substrate[k];
            check("substrate", a, (0.0..=1.0).contains(&a), "[0, 1]", a)?;
        }
        let n = self.fibers_per_cell as f64;
        check("fibers_per_cell", n, (1.0..=10_000.0).contains(&n), "[1, 10000]", n)?;
        Ok(())
    }
}

/// Fiber centres on the periodic cell across the axis, with a uniform grid for ray walks.
#[derive(Clone, Debug)]
struct Layout {
    /// Cell side.
    period: f64,
    /// Grid subcells per cell side.
    grid: usize,
    /// Circles overlapping each subcell: centres in cell coordinates (copies from the
    /// neighbouring cells may lie outside [0, period)).
    cells: Vec<Vec<(f64, f64)>>,
    radius: f64,
}

impl Layout {
    fn new(slab: &FiberSlab) -> Result<Self, SlabError> {
        let r = slab.radius;
        if slab.packing == 0.0 || slab.thickness == 0.0 {
            return Ok(Self { period: 1.0, grid: 1, cells: vec![Vec::new()], radius: r });
        }
        let n = slab.fibers_per_cell;
        let period = (n as f64 * PI * r * r / slab.packing).sqrt();
        let mut rng = Pcg64::seed_from_u64(slab.layout_seed);
        let mut centres: Vec<(f64, f64)> = Vec::with_capacity(n);
        let min2 = (2.0 * r * (1.0 + 1e-6)).powi(2);
        let mut attempts = 0usize;
        while centres.len() < n {
            attempts += 1;
            if attempts > 2_000_000 {
                return Err(SlabError::Jammed { fibers: n, packing: slab.packing });
            }
            let c = (rng.random::<f64>() * period, rng.random::<f64>() * period);
            let clear = centres.iter().all(|&(x, y)| {
                let dx = (c.0 - x) - period * ((c.0 - x) / period).round();
                let dy = (c.1 - y) - period * ((c.1 - y) / period).round();
                dx * dx + dy * dy >= min2
            });
            if clear {
                centres.push(c);
            }
        }
        let grid = ((period / (2.0 * r)).floor() as usize).clamp(1, 64);
        let side = period / grid as f64;
        let mut cells = vec![Vec::new(); grid * grid];
        for &(x, y) in &centres {
            for ox in -1..=1 {
                for oy in -1..=1 {
                    let (cx, cy) = (x + ox as f64 * period, y + oy as f64 * period);
                    let lo = |c: f64| ((c - r) / side).floor().max(0.0) as usize;
                    let hi = |c: f64| (((c + r) / side).floor() as i64).min(grid as i64 - 1);
                    if cx + r < 0.0 || cy + r < 0.0 || cx - r >= period || cy - r >= period {
                        continue;
                    }
                    for i in lo(cx)..=hi(cx).max(0) as usize {
                        for j in lo(cy)..=hi(cy).max(0) as usize {
                            cells[i * grid + j].push((cx, cy));
                        }
                    }
                }
            }
        }
        Ok(Self { period, grid, cells, radius: r })
    }

    fn subcell(&self, ia: i64, ib: i64) -> (&[(f64, f64)], f64, f64) {
        let g = self.grid as i64;
        let (ca, cb) = (ia.div_euclid(g), ib.div_euclid(g));
        let list = &self.cells[(ia.rem_euclid(g) * g + ib.rem_euclid(g)) as usize];
        (list, ca as f64 * self.period, cb as f64 * self.period)
    }

    /// The fiber (absolute centre across the axis) containing the point `(a, b)`, if any.
    fn containing(&self, a: f64, b: f64) -> Option<(f64, f64)> {
        let side = self.period / self.grid as f64;
        let (list, oa, ob) = self.subcell((a / side).floor() as i64, (b / side).floor() as i64);
        list.iter()
            .map(|&(x, y)| (x + oa, y + ob))
            .find(|&(x, y)| (a - x).powi(2) + (b - y).powi(2) < self.radius * self.radius)
    }

    /// First entry into a fiber along `(a, b) + t (da, db)` for `EPS < t ≤ t_max`: `(t, centre)`.
    fn first_hit(&self, a: f64, b: f64, da: f64, db: f64, t_max: f64) -> Option<(f64, (f64, f64))> {
        let qa = da * da + db * db;
        if qa < 1e-24 || self.cells.iter().all(Vec::is_empty) {
            return None;
        }
        let r2 = self.radius * self.radius;
        let side = self.period / self.grid as f64;
        let (mut ia, mut ib) = ((a / side).floor() as i64, (b / side).floor() as i64);
        let step = |d: f64| if d > 0.0 { 1 } else { -1 };
        let (sa, sb) = (step(da), step(db));
        let next = |i: i64, p: f64, d: f64| {
            if d.abs() < 1e-300 {
                f64::INFINITY
            } else {
                let boundary = if d > 0.0 { (i + 1) as f64 * side } else { i as f64 * side };
                (boundary - p) / d
            }
        };
        let (mut ta, mut tb) = (next(ia, a, da), next(ib, b, db));
        let (dta, dtb) = (side / da.abs(), side / db.abs());
        loop {
            let t_exit = ta.min(tb);
            let (list, oa, ob) = self.subcell(ia, ib);
            let mut best: Option<(f64, (f64, f64))> = None;
            for &(x, y) in list {
                let (cx, cy) = (x + oa, y + ob);
                let (pa, pb) = (a - cx, b - cy);
                let hb = pa * da + pb * db;
                let c = pa * pa + pb * pb - r2;
                let disc = hb * hb - qa * c;
                if disc < 0.0 {
                    continue;
                }
                let t0 = (-hb - disc.sqrt()) / qa;
                if t0 > EPS && t0 <= t_max && best.is_none_or(|(bt, _)| t0 < bt) {
                    best = Some((t0, (cx, cy)));
                }
            }
            if let Some((t, c)) = best
                && t <= t_exit + 1e-12
            {
                return Some((t, c));
            }
            if t_exit > t_max {
                return None;
            }
            if ta < tb {
                ia += sa;
                ta += dta;
            } else {
                ib += sb;
                tb += dtb;
            }
        }
    }
}

/// A measured surface BRDF.
#[derive(Clone, Debug)]
pub struct SurfaceMeasurement {
    /// The setup.
    pub setup: Setup,
    /// Tables in the order of [`SurfaceMeasurement::LOBE_NAMES`]; `f` is `f_r` (sr⁻¹) and the
    /// albedo is the fraction of the incident power leaving in that class.
    pub lobes: Vec<LobeTable>,
    /// Paths dropped after [`MAX_EVENTS`].
    pub dropped: usize,
    /// Rays traced.
    pub traced: usize,
}

/// Rows of `fiberlab measure`'s table ([`fiberlab_io::table::write`]).
impl fiberlab_io::table::Tabulated for SurfaceMeasurement {
    fn incidence(&self) -> (f64, f64) {
        (self.setup.theta_i, self.setup.phi_i)
    }

    fn bins(&self) -> (usize, usize) {
        (self.setup.bins_theta, self.setup.bins_phi)
    }

    fn bin_centre(&self, i: usize, j: usize) -> (f64, f64) {
        SurfaceMeasurement::bin_centre(self, i, j)
    }

    fn lobe_tables(&self) -> Vec<(&'static str, &[Rgb], &[Rgb])> {
        Self::LOBE_NAMES.iter().zip(&self.lobes).map(|(name, l)| (*name, &l.f[..], &l.std[..])).collect()
    }
}

impl SurfaceMeasurement {
    /// Path classes in table order.
    pub const LOBE_NAMES: [&'static str; 5] = ["finish", "fiber", "substrate", "multiple", "all"];

    /// Centre (θ_o, φ_o) in radians of bin `(i, j)`.
    #[must_use]
    pub fn bin_centre(&self, i: usize, j: usize) -> (f64, f64) {
        let s = &self.setup;
        ((i as f64 + 0.5) * FRAC_PI_2 / s.bins_theta as f64, -PI + (j as f64 + 0.5) * TAU / s.bins_phi as f64)
    }

    /// Table of class `name`.
    #[must_use]
    pub fn lobe(&self, name: &str) -> Option<&LobeTable> {
        Self::LOBE_NAMES.iter().position(|n| *n == name).map(|k| &self.lobes[k])
    }
}

/// `∫_bin cosθ dω` of a bin in row `i` (θ from the normal).
#[must_use]
pub fn bin_cos_solid_angle(i: usize, bins_theta: usize, bins_phi: usize) -> f64 {
    let (a, b) = (i as f64 * FRAC_PI_2 / bins_theta as f64, (i + 1) as f64 * FRAC_PI_2 / bins_theta as f64);
    0.5 * (b.sin().powi(2) - a.sin().powi(2)) * TAU / bins_phi as f64
}

/// Reflection of `d` about the plane of unit normal `n`.
fn reflect(d: DVec3, n: DVec3) -> DVec3 {
    (d - n * (2.0 * d.dot(n))).normalize()
}

/// Splits a path at a smooth interface: `n` the unit normal on the incident side
/// (`d·n < 0`), `ratio` = n_transmitted / n_incident. Returns the new direction and whether
/// it was transmitted.
fn dielectric_split(d: DVec3, n: DVec3, ratio: f64, rng: &mut impl Rng) -> (DVec3, bool) {
    let cos_i = (-d.dot(n)).clamp(0.0, 1.0);
    if rng.random::<f64>() < fresnel::dielectric(cos_i, ratio) {
        return (reflect(d, n), false);
    }
    let e = 1.0 / ratio;
    let sin2_t = e * e * (1.0 - cos_i * cos_i);
    if sin2_t >= 1.0 {
        return (reflect(d, n), false);
    }
    ((d * e + n * (e * cos_i - (1.0 - sin2_t).sqrt())).normalize(), true)
}

/// Cosine-weighted direction about `+z` (upward).
fn cosine_up(rng: &mut impl Rng) -> DVec3 {
    let (u0, u1): (f64, f64) = (rng.random(), rng.random());
    let r = u0.sqrt();
    let (s, c) = (TAU * u1).sin_cos();
    DVec3::new(r * c, r * s, (1.0 - u0).max(0.0).sqrt())
}

/// How a traced path ended.
enum Ending {
    /// Left through the interface: direction, weight, class index.
    Exit(DVec3, Rgb, u8),
    /// Absorbed (by the substrate or by roulette).
    Absorbed,
    /// Dropped after [`MAX_EVENTS`].
    Dropped,
}

/// Where a path is.
#[derive(Clone, Copy)]
enum Place {
    /// In the finish between the interface and the slab.
    Above,
    /// In the finish between the fibers of the slab.
    Matrix,
    /// Inside the fiber with this centre across the axis.
    Fiber((f64, f64)),
}

struct Tracer<'a> {
    slab: &'a FiberSlab,
    layout: &'a Layout,
    v: DVec3,
    w: DVec3,
    z_top: f64,
    z_bot: f64,
}

impl Tracer<'_> {
    fn trace(&self, origin: DVec3, wi: DVec3, rng: &mut impl Rng) -> Ending {
        let slab = self.slab;
        let (mut d, entered) = dielectric_split(-wi, DVec3::Z, slab.eta, rng);
        if !entered {
            return Ending::Exit(d, Rgb::ONE, 0);
        }
        let mut p = origin;
        let mut weight = Rgb::ONE;
        let mut place = Place::Above;
        let (mut encounters, mut substrate, mut cut_face) = (0u32, false, false);
        let class = |encounters: u32, substrate: bool, cut_face: bool| match (encounters, substrate, cut_face) {
            (1, false, false) => 1,
            (0, true, _) => 2,
            _ => 3,
        };
        for event in 0..MAX_EVENTS {
            // Russian roulette (`crate::roulette`).
            if !crate::roulette::survives(&mut weight, event, ROULETTE_AFTER, || rng.random::<f64>()) {
                return Ending::Absorbed;
            }
            match place {
                Place::Above => {
                    if d.z > 0.0 {
                        p += d * (-p.z / d.z);
                        p.z = 0.0;
                        let (nd, out) = dielectric_split(d, -DVec3::Z, 1.0 / slab.eta, rng);
                        if out {
                            return Ending::Exit(nd, weight, class(encounters, substrate, cut_face));
                        }
                        d = nd;
                    } else {
                        p += d * ((self.z_top - p.z) / d.z);
                        p.z = self.z_top;
                        if self.z_top <= self.z_bot {
                            // No slab: the substrate lies right here.
                            match self.substrate(&mut weight, &mut substrate, rng) {
                                Some(nd) => d = nd,
                                None => return Ending::Absorbed,
                            }
                            continue;
                        }
                        match self.layout.containing(p.dot(self.v), p.dot(self.w)) {
                            Some(c) => {
                                encounters += 1;
                                cut_face = true;
                                let (nd, inside) = dielectric_split(d, DVec3::Z, slab.fiber_eta / slab.eta, rng);
                                d = nd;
                                if inside {
                                    place = Place::Fiber(c);
                                }
                            }
                            None => place = Place::Matrix,
                        }
                    }
                }
                Place::Matrix => {
                    let t_plane = if d.z > 0.0 {
                        (self.z_top - p.z) / d.z
                    } else if d.z < 0.0 {
                        (self.z_bot - p.z) / d.z
                    } else {
                        f64::INFINITY
                    };
                    let (a, b) = (p.dot(self.v), p.dot(self.w));
                    let hit = self.layout.first_hit(a, b, d.dot(self.v), d.dot(self.w), t_plane.max(0.0));
                    if let Some((t, c)) = hit {
                        p += d * t;
                        encounters += 1;
                        let n = self.normal(p, c);
                        let (nd, inside) = dielectric_split(d, n, slab.fiber_eta / slab.eta, rng);
                        d = nd;
                        if inside {
                            place = Place::Fiber(c);
                        }
                    } else if d.z > 0.0 {
                        p += d * t_plane;
                        p.z = self.z_top;
                        place = Place::Above;
                    } else {
                        p += d * t_plane;
                        p.z = self.z_bot;
                        match self.substrate(&mut weight, &mut substrate, rng) {
                            Some(nd) => d = nd,
                            None => return Ending::Absorbed,
                        }
                    }
                }
                Place::Fiber(c) => {
                    let (a, b) = (p.dot(self.v) - c.0, p.dot(self.w) - c.1);
                    let (da, db) = (d.dot(self.v), d.dot(self.w));
                    let qa = da * da + db * db;
                    let t_wall = if qa < 1e-24 {
                        f64::INFINITY
                    } else {
                        let hb = a * da + b * db;
                        let cc = a * a + b * b - slab.radius * slab.radius;
                        (-hb + (hb * hb - qa * cc).max(0.0).sqrt()) / qa
                    };
                    let t_plane = if d.z > 0.0 {
                        (self.z_top - p.z) / d.z
                    } else if d.z < 0.0 {
                        (self.z_bot - p.z) / d.z
                    } else {
                        f64::INFINITY
                    };
                    let t = t_wall.min(t_plane).max(0.0);
                    if !t.is_finite() {
                        return Ending::Dropped;
                    }
                    if slab.sigma_a != Rgb::ZERO {
                        weight *= (slab.sigma_a * -t).exp();
                    }
                    p += d * t;
                    if t_wall <= t_plane {
                        let n = -self.normal(p, c);
                        let (nd, out) = dielectric_split(d, n, slab.eta / slab.fiber_eta, rng);
                        d = nd;
                        if out {
                            place = Place::Matrix;
                        }
                    } else if d.z > 0.0 {
                        p.z = self.z_top;
                        cut_face = true;
                        let (nd, out) = dielectric_split(d, -DVec3::Z, slab.eta / slab.fiber_eta, rng);
                        d = nd;
                        if out {
                            place = Place::Above;
                        }
                    } else {
                        p.z = self.z_bot;
                        match self.substrate(&mut weight, &mut substrate, rng) {
                            Some(nd) => d = nd,
                            None => return Ending::Absorbed,
                        }
                    }
                }
            }
        }
        Ending::Dropped
    }

    /// Outward unit normal of the fiber with centre `c` at the wall point `p`.
    fn normal(&self, p: DVec3, c: (f64, f64)) -> DVec3 {
        let (a, b) = (p.dot(self.v) - c.0, p.dot(self.w) - c.1);
        (self.v * a + self.w * b).normalize()
    }

    /// A diffuse bounce on the substrate (`None`: absorbed).
    fn substrate(&self, weight: &mut Rgb, touched: &mut bool, rng: &mut impl Rng) -> Option<DVec3> {
        *touched = true;
        if self.slab.substrate.is_black() {
            return None;
        }
        *weight *= self.slab.substrate;
        Some(cosine_up(rng))
    }
}

/// One exit: bin, class and weight.
struct Record {
    bin: u32,
    class: u8,
    w: Rgb,
}

/// Measures the BRDF of `slab` for `setup`; `progress(rays)` after each chunk, `stop` ends
/// early (what was traced is kept and normalized by the rays traced).
pub fn measure_surface(
    slab: &FiberSlab,
    setup: &Setup,
    stop: &AtomicBool,
    progress: impl Fn(usize) + Sync,
) -> Result<SurfaceMeasurement, SlabError> {
    slab.validate()?;
    if !(0.0..89.9f64.to_radians()).contains(&setup.theta_i) {
        let value = setup.theta_i.to_degrees();
        return Err(SlabError::OutOfRange { key: "theta_i", value, range: "[0, 89.9) degrees from the normal" });
    }
    if !setup.phi_i.is_finite() {
        return Err(SlabError::OutOfRange { key: "phi_i", value: setup.phi_i, range: "finite degrees" });
    }
    let (nt, np) = (setup.bins_theta.max(1), setup.bins_phi.max(1));
    if (nt as u128) * (np as u128) > u128::from(u32::MAX) {
        return Err(SlabError::TooManyBins { bins_theta: nt, bins_phi: np });
    }
    let layout = Layout::new(slab)?;
    let u = slab.axis();
    let v = DVec3::new(-slab.fiber_angle.sin(), slab.fiber_angle.cos(), 0.0);
    let w = u.cross(v);
    let tracer = Tracer { slab, layout: &layout, v, w, z_top: -slab.depth, z_bot: -slab.depth - slab.thickness };
    // One horizontal period: `period` along v, and along the axis's horizontal direction the
    // distance over which the dipped pattern advances one period in w.
    let h = DVec3::new(slab.fiber_angle.cos(), slab.fiber_angle.sin(), 0.0);
    let sin_dip = slab.fiber_dip.sin();
    let along = if sin_dip > 1e-9 { layout.period / sin_dip } else { 0.0 };
    let (st, ct) = setup.theta_i.sin_cos();
    let wi = DVec3::new(st * setup.phi_i.cos(), st * setup.phi_i.sin(), ct);
    let chunks = setup.rays.div_ceil(CHUNK);
    let mut sums = BinSums::new(4, nt * np);
    let (mut dropped, mut traced) = (0usize, 0usize);
    let batch = 2 * rayon::current_num_threads().max(1);
    let mut next = 0;
    while next < chunks && !stop.load(Ordering::Relaxed) {
        let end = (next + batch).min(chunks);
        let results: Vec<(Vec<Record>, usize, usize)> = (next..end)
            .into_par_iter()
            .map(|c| {
                let n = CHUNK.min(setup.rays - c * CHUNK);
                let mut rng = Pcg64::seed_from_u64(setup.seed ^ (c as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15));
                let mut records = Vec::with_capacity(n);
                let mut drop = 0;
                for _ in 0..n {
                    let origin = v * (rng.random::<f64>() * layout.period) + h * (rng.random::<f64>() * along);
                    match tracer.trace(origin, wi, &mut rng) {
                        Ending::Exit(dir, weight, class) => {
                            let t = dir.z.clamp(-1.0, 1.0).acos();
                            let f = dir.y.atan2(dir.x);
                            let i = ((t / FRAC_PI_2 * nt as f64) as usize).min(nt - 1);
                            let j = (((f + PI) / TAU * np as f64) as usize).min(np - 1);
                            records.push(Record { bin: (i * np + j) as u32, class, w: weight });
                        }
                        Ending::Absorbed => {}
                        Ending::Dropped => drop += 1,
                    }
                }
                progress(n);
                (records, drop, n)
            })
            .collect();
        for (records, drop, n) in results {
            for r in records {
                sums.add(r.class as usize, r.bin as usize, r.w);
            }
            dropped += drop;
            traced += n;
        }
        next = end;
    }
    let lobes = sums.tables(traced, nt, np, |i| bin_cos_solid_angle(i, nt, np));
    Ok(SurfaceMeasurement { setup: *setup, lobes, dropped, traced })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(
        slab: &FiberSlab,
        theta_i: f64,
        phi_i: f64,
        rays: usize,
        bins: (usize, usize),
        seed: u64,
    ) -> SurfaceMeasurement {
        let setup = Setup { theta_i, phi_i, rays, bins_theta: bins.0, bins_phi: bins.1, seed };
        measure_surface(slab, &setup, &AtomicBool::new(false), |_| {}).unwrap()
    }

    /// Bin index of direction (θ, φ).
    fn bin_of(m: &SurfaceMeasurement, theta: f64, phi: f64) -> usize {
        let (nt, np) = (m.setup.bins_theta, m.setup.bins_phi);
        let i = ((theta / FRAC_PI_2 * nt as f64) as usize).min(nt - 1);
        let j = (((phi + PI) / TAU * np as f64) as usize).min(np - 1);
        i * np + j
    }

    /// Conservative standard error of a class's albedo: the square root of the sum of the
    /// bins' variances (the bins' covariances, −m_i m_j/n, are negative).
    fn albedo_se(m: &SurfaceMeasurement, class: &str) -> f64 {
        let t = m.lobe(class).unwrap();
        let (nt, np) = (m.setup.bins_theta, m.setup.bins_phi);
        (0..nt * np).map(|k| (t.std[k][0] * bin_cos_solid_angle(k / np, nt, np)).powi(2)).sum::<f64>().sqrt()
    }

    #[test]
    fn bare_interface_over_black_reflects_fresnel_into_the_mirror_bin() {
        let slab = FiberSlab { packing: 0.0, ..FiberSlab::default() };
        for theta_i in [0.2f64, 1.1] {
            let rays = 200_000;
            let m = run(&slab, theta_i, 0.7, rays, (18, 36), 3);
            let expected = fresnel::dielectric(theta_i.cos(), 1.5);
            let finish = m.lobe("finish").unwrap();
            let se = (expected * (1.0 - expected) / rays as f64).sqrt();
            assert!((finish.albedo[0] - expected).abs() < 5.0 * se, "{} vs {expected} ± {se}", finish.albedo[0]);
            // All of it in the mirror bin (θ_i, φ_i + π), nothing in any other class.
            let k = bin_of(&m, theta_i, 0.7 - PI);
            let omega = bin_cos_solid_angle(k / 36, 18, 36);
            assert!((finish.f[k][0] * omega - finish.albedo[0]).abs() < 1e-12);
            assert_eq!(m.lobe("all").unwrap().albedo[0], finish.albedo[0]);
        }
    }

    #[test]
    fn lossless_fibers_over_a_white_substrate_conserve_energy() {
        let slab = FiberSlab {
            fiber_dip: 25f64.to_radians(),
            fiber_angle: 0.4,
            packing: 0.4,
            substrate: Rgb::ONE,
            thickness: 6.0,
            ..FiberSlab::default()
        };
        let m = run(&slab, 0.5, 0.0, 200_000, (9, 18), 5);
        let all = m.lobe("all").unwrap().albedo[0];
        let se = albedo_se(&m, "all");
        assert_eq!(m.dropped, 0);

        assert!((all - 1.0).abs() < 5.0 * se, "albedo {all} ± {se}");
        assert!(se < 0.005, "{se}");
        // The classes partition the total, and the fibers were met.
        let parts: f64 = (0..4).map(|k| m.lobes[k].albedo[0]).sum();
        assert!((parts - all).abs() < 1e-12);
        assert!(m.lobe("fiber").unwrap().albedo[0] > 0.0);
        assert!(m.lobe("multiple").unwrap().albedo[0] > 0.5);
    }

    /// Cosine-weighted hemispherical average of the Fresnel reflectance met from inside a
    /// medium of index `eta` (total internal reflection included), by the midpoint rule.
    fn internal_diffuse_reflectance(eta: f64) -> f64 {
        let k = 200_000;
        (0..k)
            .map(|s| {
                let t = (s as f64 + 0.5) * FRAC_PI_2 / k as f64;
                fresnel::dielectric(t.cos(), 1.0 / eta) * 2.0 * t.sin() * t.cos() * FRAC_PI_2 / k as f64
            })
            .sum()
    }

    #[test]
    fn lambertian_under_a_dielectric_matches_the_multiple_reflection_closed_form() {
        // Radiance leaving a Lambertian substrate of albedo ρ is uniform inside the finish;
        // a fraction F̄ of its exitance returns to the substrate, so the exitance is
        // M = T_i ρ / (1 − ρ F̄) and f_r = T_i T_o ρ / (π η² (1 − ρ F̄)), with T = 1 − F and
        // L_out = T_o L_in / η² (radiance across an interface).
        let (eta, rho, theta_i) = (1.5, 0.8, 0.5);
        let slab = FiberSlab { eta, packing: 0.0, substrate: Rgb::splat(rho), ..FiberSlab::default() };
        let (nt, np) = (9, 4);
        let m = run(&slab, theta_i, 0.0, 400_000, (nt, np), 11);
        let fbar = internal_diffuse_reflectance(eta);
        let t_i = 1.0 - fresnel::dielectric(theta_i.cos(), eta);
        let f = |t: f64| t_i * (1.0 - fresnel::dielectric(t.cos(), eta)) * rho / (PI * eta * eta * (1.0 - rho * fbar));
        let sub = m.lobe("substrate").unwrap();
        for i in 0..nt {
            // Bin average of the closed form, weighted by cosθ sinθ.
            let (a, k) = (i as f64 * FRAC_PI_2 / nt as f64, 1000);
            let h = FRAC_PI_2 / nt as f64 / k as f64;
            let (mut num, mut den) = (0.0, 0.0);
            for s in 0..k {
                let t = a + (s as f64 + 0.5) * h;
                num += f(t) * t.sin() * t.cos();
                den += t.sin() * t.cos();
            }
            let expected = num / den;
            let got: f64 = (0..np).map(|j| sub.f[i * np + j][0]).sum::<f64>() / np as f64;
            let se = (0..np).map(|j| sub.std[i * np + j][0].powi(2)).sum::<f64>().sqrt() / np as f64;
            assert!((got - expected).abs() < 5.0 * se, "row {i}: {got} vs {expected} ± {se}");
            assert!(se < 0.02 * expected, "row {i}: se {se}");
        }
        let total = t_i * rho * (1.0 - fbar) / (1.0 - rho * fbar);
        let se = albedo_se(&m, "substrate");
        assert!((sub.albedo[0] - total).abs() < 5.0 * se, "{} vs {total} ± {se}", sub.albedo[0]);
    }

    #[test]
    fn single_fiber_paths_leave_on_the_refracted_cone_of_the_axis() {
        // Every exit of the `fiber` class has ψ_i′ + ψ_o′ = 0 for the directions refracted
        // into the finish (D = dip): the bins it fills straddle that locus.
        let slab = FiberSlab {
            fiber_dip: 20f64.to_radians(),
            fiber_angle: 0.3,
            fiber_eta: 2.3,
            sigma_a: Rgb::splat(5.0),
            packing: 0.3,
            ..FiberSlab::default()
        };
        let (nt, np) = (90, 180);
        let m = run(&slab, 0.5, 0.2, 300_000, (nt, np), 31);
        let u = slab.axis();
        let inside = |t: f64, p: f64| {
            let s = t.sin() / slab.eta;
            DVec3::new(s * p.cos(), s * p.sin(), (1.0 - s * s).sqrt())
        };
        let psi_i = inside(0.5, 0.2).dot(u).asin();
        let fib = m.lobe("fiber").unwrap();
        assert!(fib.albedo[0] > 0.005, "{}", fib.albedo[0]);
        let half_bin = 0.5 * FRAC_PI_2 / nt as f64 + 0.5 * TAU / np as f64;
        let mut filled = 0;
        for i in 0..nt {
            for j in 0..np {
                if fib.f[i * np + j][0] > 0.0 {
                    let (t, p) = m.bin_centre(i, j);
                    let psi_h = psi_i + inside(t, p).dot(u).asin();
                    assert!(psi_h.abs() < 1.5 * half_bin, "bin ({t}, {p}): ψ_h = {psi_h}");
                    filled += 1;
                }
            }
        }
        assert!(filled > 100, "{filled}");
    }

    #[test]
    fn tabulated_brdf_is_reciprocal_between_swapped_directions() {
        let slab = FiberSlab {
            fiber_dip: 30f64.to_radians(),
            fiber_angle: 0.35,
            packing: 0.3,
            sigma_a: Rgb::splat(0.2),
            substrate: Rgb::splat(0.6),
            thickness: 6.0,
            ..FiberSlab::default()
        };
        let (nt, np) = (9, 18);
        // Bin centres: θ = 5°, 15°, …; φ = −170°, −150°, …
        for ((ta, pa), (tb, pb)) in [((25.0f64, 10.0f64), (55.0f64, -130.0f64)), ((45.0, -90.0), (15.0, 50.0))] {
            let (ta, pa, tb, pb) = (ta.to_radians(), pa.to_radians(), tb.to_radians(), pb.to_radians());
            let m_ab = run(&slab, ta, pa, 400_000, (nt, np), 21);
            let m_ba = run(&slab, tb, pb, 400_000, (nt, np), 22);
            let (kb, ka) = (bin_of(&m_ab, tb, pb), bin_of(&m_ba, ta, pa));
            let (all_ab, all_ba) = (m_ab.lobe("all").unwrap(), m_ba.lobe("all").unwrap());
            let (f1, s1) = (all_ab.f[kb][0], all_ab.std[kb][0]);
            let (f2, s2) = (all_ba.f[ka][0], all_ba.std[ka][0]);
            let se = (s1 * s1 + s2 * s2).sqrt();
            assert!(f1 > 20.0 * se, "{f1} ± {s1}");
            assert!((f1 - f2).abs() < 4.0 * se, "{f1} ± {s1} vs {f2} ± {s2}");
        }
    }
}
