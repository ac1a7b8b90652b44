//! A renderable scene: camera, fiber assemblies, spheres, meshes, materials and lights.

use crate::bvh::Ray;
use crate::camera::Camera;
use crate::curves::{CurveHit, CurveSet};
use crate::light::Light;
use crate::shapes::{TriangleMesh, sphere_hit};
use fiberlab_math::{DVec3, Rgb};
use fiberlab_scatter::Model;

/// What a surface or fiber does with light.
#[derive(Clone, Debug)]
pub enum Material {
    /// A fiber scattering function (any registered model), for curves.
    Fiber(Box<Model>),
    /// Lambertian surface: `f = albedo/π`.
    Lambert(Rgb),
    /// Perfect mirror with reflectance.
    Mirror(Rgb),
}

/// A sphere surface, possibly emitting (then also listed as a [`Light::Sphere`]).
#[derive(Clone, Debug)]
pub struct Sphere {
    /// Centre.
    pub center: DVec3,
    /// Radius.
    pub radius: f64,
    /// Index into [`Scene::materials`].
    pub material: usize,
    /// Index into [`Scene::lights`] when emitting.
    pub light: Option<usize>,
}

/// Fibers with one material.
#[derive(Clone, Debug)]
pub struct Fibers {
    /// The tubes.
    pub curves: CurveSet,
    /// Index into [`Scene::materials`].
    pub material: usize,
}

/// A mesh with one material.
#[derive(Clone, Debug)]
pub struct Mesh {
    /// The triangles.
    pub mesh: TriangleMesh,
    /// Index into [`Scene::materials`].
    pub material: usize,
}

/// The nearest intersection.
#[derive(Clone, Copy, Debug)]
pub enum Hit {
    /// A fiber.
    Fiber {
        /// Geometry of the hit.
        hit: CurveHit,
        /// Material index.
        material: usize,
    },
    /// A sphere or triangle.
    Surface {
        /// Ray distance.
        t: f64,
        /// Point.
        p: DVec3,
        /// Geometric unit normal (not flipped).
        n: DVec3,
        /// Material index.
        material: usize,
        /// Emitting light index, if any.
        light: Option<usize>,
    },
}

impl Hit {
    /// Ray distance.
    #[must_use]
    pub fn t(&self) -> f64 {
        match self {
            Hit::Fiber { hit, .. } => hit.t,
            Hit::Surface { t, .. } => *t,
        }
    }
}

/// Everything the integrator needs.
#[derive(Clone, Debug)]
pub struct Scene {
    /// The camera.
    pub camera: Camera,
    /// Materials, referenced by index.
    pub materials: Vec<Material>,
    /// Fiber assemblies.
    pub fibers: Vec<Fibers>,
    /// Spheres.
    pub spheres: Vec<Sphere>,
    /// Meshes.
    pub meshes: Vec<Mesh>,
    /// Lights.
    pub lights: Vec<Light>,
}

impl Scene {
    /// Nearest hit along the ray.
    #[must_use]
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        let mut best: Option<Hit> = None;
        let mut r = *ray;
        // Cheap solid shapes first: a head in front shortens the ray before the hair's tree.
        for s in &self.spheres {
            if let Some(t) = sphere_hit(r.o, r.d, s.center, s.radius, r.t_min, r.t_max) {
                r.t_max = t;
                let p = r.at(t);
                best = Some(Hit::Surface { t, p, n: (p - s.center) / s.radius, material: s.material, light: s.light });
            }
        }
        for m in &self.meshes {
            if let Some((t, n)) = m.mesh.intersect(&r) {
                r.t_max = t;
                best = Some(Hit::Surface { t, p: r.at(t), n, material: m.material, light: None });
            }
        }
        for f in &self.fibers {
            if let Some(hit) = f.curves.intersect(&r) {
                r.t_max = hit.t;
                best = Some(Hit::Fiber { hit, material: f.material });
            }
        }
        best
    }

    /// True when nothing blocks the ray before `ray.t_max` (emitting spheres count as blockers
    /// except the one at the end, which the caller excludes by shortening `t_max`).
    #[must_use]
    pub fn unoccluded(&self, ray: &Ray) -> bool {
        !(self.spheres.iter().any(|s| sphere_hit(ray.o, ray.d, s.center, s.radius, ray.t_min, ray.t_max).is_some())
            || self.meshes.iter().any(|m| m.mesh.occluded(ray))
            || self.fibers.iter().any(|f| f.curves.occluded(ray)))
    }
}
