//! Counting the fibers a shadow ray crosses, for dual scattering
//! ([`crate::dual_scattering`]; Zinke, Yuksel, Weber and Keyser 2008, §5):
//!
//! * **exact**: a counting walk of the ray through every assembly's BVH
//!   ([`fiberlab_geometry::curves::CurveSet::each_entry`]) — every tube the ray enters, each with the sine of
//!   the light's inclination to that fiber (`ω_d·u`), so each crossing is looked up at its own θ;
//! * **grid**: a voxel density grid ([`DensityGrid`]) built once per scene. Each cell holds the
//!   projected fiber "area density" `W = Σ 2r ℓ / V` (sum over the pieces of segments whose
//!   midpoint falls in the cell: diameter × length, per cell volume) and the second moment of
//!   the tangents `T = Σ 2r ℓ t tᵀ / V` (6 numbers). A ray of direction `d` crosses, per unit
//!   length, `W·⟨sin γ⟩` fibers (γ the angle between ray and fiber), estimated as
//!   `W·√(1 − dᵀTd/W)` (exact for parallel fibers); the light's inclination to the cell's fibers
//!   is `sin²θ = dᵀTd/W`. The walk marches half-cell steps. Memory: 7 `f32` per cell, 28 bytes
//!   (64³ cells: 7.3 MB). Dual scattering walks the first cells of each ray exactly and uses
//!   the grid only beyond ([`crate::dual_scattering::DualScatteringSettings::grid_near_cells`]):
//!   a cell's average is wrong right at the shading point, where it holds the shading fiber and,
//!   at the edge of a hair layer, the fibers on the far side of the start.

use crate::scene::{FiberMaterialId, Scene};
use fiberlab_geometry::Ray;
use fiberlab_math::DVec3;

/// How dual scattering counts the fibers toward the light.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum FiberCount {
    /// A counting walk of the shadow ray through the BVH.
    #[default]
    Exact,
    /// A precomputed voxel density grid.
    Grid,
}

impl FiberCount {
    /// `exact` or `grid`.
    pub fn parse(name: &str) -> Result<Self, String> {
        match name {
            "exact" => Ok(Self::Exact),
            "grid" => Ok(Self::Grid),
            other => Err(format!("unknown fiber count `{other}` (known: exact, grid)")),
        }
    }
}

/// One crossing (exact) or one step's share of crossings (grid) along a shadow ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Crossing {
    /// Number of fibers (1 for an exact crossing, fractional for a grid step).
    pub count: f64,
    /// `|sin|` of the light direction's inclination to the crossed fiber(s).
    pub sin_theta: f64,
    /// The crossed fibers' material.
    pub material: FiberMaterialId,
}

/// Every fiber the ray enters within `(t_min, t_max)`, except entries into strand `skip`
/// (assembly index, strand) closer than `skip_distance` (the shading fiber itself).
pub fn exact_crossings(
    scene: &Scene,
    ray: &Ray,
    skip: Option<(usize, u32)>,
    skip_distance: f64,
    each: &mut dyn FnMut(Crossing),
) {
    for (k, f) in scene.fibers().iter().enumerate() {
        f.curves().each_entry(ray, |hit| {
            if skip == Some((k, hit.strand)) && hit.t < skip_distance {
                return;
            }
            each(Crossing { count: 1.0, sin_theta: ray.d.dot(hit.tangent).abs().min(1.0), material: f.material() });
        });
    }
}

/// [`exact_crossings`] that stops when `each` returns true (true then), in no particular
/// order of the crossings ([`fiberlab_geometry::curves::CurveSet::each_entry_until`]).
pub fn exact_crossings_until(
    scene: &Scene,
    ray: &Ray,
    skip: Option<(usize, u32)>,
    skip_distance: f64,
    each: &mut dyn FnMut(Crossing) -> bool,
) -> bool {
    scene.fibers().iter().enumerate().any(|(k, f)| {
        f.curves().each_entry_until(ray, |hit| {
            if skip == Some((k, hit.strand)) && hit.t < skip_distance {
                return false;
            }
            each(Crossing { count: 1.0, sin_theta: ray.d.dot(hit.tangent).abs().min(1.0), material: f.material() })
        })
    })
}

/// Fiber density per cell (module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct DensityGrid {
    min: DVec3,
    cell: f64,
    dims: [usize; 3],
    /// Per cell: `W, T_xx, T_yy, T_zz, T_xy, T_xz, T_yz`.
    cells: Vec<[f32; 7]>,
    material: FiberMaterialId,
}

impl DensityGrid {
    /// The grid over every assembly's bounds, `resolution` cells along the longest side
    /// (`Ok(None)` without fibers). Segments are cut into pieces of at most a quarter cell,
    /// each deposited in the cell of its midpoint. The crossings report the first
    /// assembly's material. The cells are checked against the memory budget
    /// ([`fiberlab_io::memory_budget`]) before they are allocated.
    pub fn build(scene: &Scene, resolution: usize) -> Result<Option<Self>, fiberlab_io::memory_budget::MemoryError> {
        let Some(first) = scene.fibers().first() else { return Ok(None) };
        let bounds =
            scene.fibers().iter().fold(fiberlab_geometry::bvh::Aabb::EMPTY, |b, f| b.union(f.curves().bounds()));
        let extent = bounds.max - bounds.min;
        if !(extent.max_element() > 0.0 && extent.max_element().is_finite()) {
            return Ok(None);
        }
        let resolution = resolution.max(1);
        let cell = extent.max_element() / resolution as f64;
        // Counted in u64 (a float-to-integer conversion saturates), checked before allocating.
        let dims64 = [0, 1, 2].map(|a| ((extent[a] / cell).ceil() as u64).max(1));
        let count = dims64[0].checked_mul(dims64[1]).and_then(|n| n.checked_mul(dims64[2]));
        fiberlab_io::memory_budget::check_needs(&[fiberlab_io::memory_budget::Need::new(
            format!("fiber density grid {}×{}×{} (--dual grid={resolution})", dims64[0], dims64[1], dims64[2]),
            count.and_then(|n| n.checked_mul(std::mem::size_of::<[f32; 7]>() as u64)),
        )])?;
        let dims = dims64.map(|d| d as usize);
        let mut cells = vec![[0f32; 7]; dims[0] * dims[1] * dims[2]];
        let volume = cell * cell * cell;
        let index = |p: DVec3| -> usize {
            let q = (p - bounds.min) / cell;
            let c = [0, 1, 2].map(|a| (q[a].max(0.0) as usize).min(dims[a] - 1));
            (c[2] * dims[1] + c[1]) * dims[0] + c[0]
        };
        for f in scene.fibers() {
            f.curves().each_segment(|p0, p1, radius| {
                let axis = p1 - p0;
                let length = axis.length();
                if length <= 0.0 {
                    return;
                }
                let t = axis / length;
                let pieces = ((length / (0.25 * cell)).ceil() as usize).max(1);
                let w = 2.0 * radius * length / pieces as f64 / volume;
                for k in 0..pieces {
                    let p = p0 + axis * ((k as f64 + 0.5) / pieces as f64);
                    let c = &mut cells[index(p)];
                    for (slot, v) in
                        c.iter_mut().zip([1.0, t.x * t.x, t.y * t.y, t.z * t.z, t.x * t.y, t.x * t.z, t.y * t.z])
                    {
                        *slot += (w * v) as f32;
                    }
                }
            });
        }
        Ok(Some(Self { min: bounds.min, cell, dims, cells, material: first.material() }))
    }

    /// Memory of the cells, bytes.
    #[must_use]
    pub fn bytes(&self) -> usize {
        self.cells.len() * std::mem::size_of::<[f32; 7]>()
    }

    /// Edge length of a cell, scene units.
    #[must_use]
    pub fn cell(&self) -> f64 {
        self.cell
    }

    /// Cells along each axis.
    #[must_use]
    pub fn dims(&self) -> [usize; 3] {
        self.dims
    }

    /// Marches the ray from `t_min` to `min(t_max, grid exit)` in half-cell steps, reporting
    /// each step's crossings (skipped where the cell is empty).
    pub fn crossings(&self, ray: &Ray, each: &mut dyn FnMut(Crossing)) {
        let max = self.min + DVec3::new(self.dims[0] as f64, self.dims[1] as f64, self.dims[2] as f64) * self.cell;
        let (mut t0, mut t1) = (ray.t_min, ray.t_max);
        for a in 0..3 {
            let inv = 1.0 / ray.d[a];
            let (mut near, mut far) = ((self.min[a] - ray.o[a]) * inv, (max[a] - ray.o[a]) * inv);
            if near > far {
                std::mem::swap(&mut near, &mut far);
            }
            if near.is_nan() || far.is_nan() {
                // Parallel to this slab: inside or never.
                if ray.o[a] < self.min[a] || ray.o[a] > max[a] {
                    return;
                }
                continue;
            }
            t0 = t0.max(near);
            t1 = t1.min(far);
        }
        if t1.partial_cmp(&t0) != Some(std::cmp::Ordering::Greater) {
            return;
        }
        let step = 0.5 * self.cell;
        let steps = ((t1 - t0) / step).ceil() as usize;
        let d = ray.d;
        for k in 0..steps {
            let (a, b) = (t0 + k as f64 * step, (t0 + (k + 1) as f64 * step).min(t1));
            let p = ray.at(0.5 * (a + b));
            let q = (p - self.min) / self.cell;
            if q.min_element() < 0.0 {
                continue;
            }
            let c = [q.x as usize, q.y as usize, q.z as usize];
            if c[0] >= self.dims[0] || c[1] >= self.dims[1] || c[2] >= self.dims[2] {
                continue;
            }
            let v = &self.cells[(c[2] * self.dims[1] + c[1]) * self.dims[0] + c[0]];
            let w = f64::from(v[0]);
            if w <= 0.0 {
                continue;
            }
            let [xx, yy, zz, xy, xz, yz] = [v[1], v[2], v[3], v[4], v[5], v[6]].map(f64::from);
            let along = d.x * d.x * xx
                + d.y * d.y * yy
                + d.z * d.z * zz
                + 2.0 * (d.x * d.y * xy + d.x * d.z * xz + d.y * d.z * yz);
            let sin2 = (along / w).clamp(0.0, 1.0);
            each(Crossing {
                count: w * (1.0 - sin2).sqrt() * (b - a),
                sin_theta: sin2.sqrt(),
                material: self.material,
            });
        }
    }
}
