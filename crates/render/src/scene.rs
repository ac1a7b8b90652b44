//! A renderable scene: camera, fiber assemblies, spheres, meshes, materials and lights,
//! assembled by a [`SceneBuilder`] so that its invariants hold by construction:
//! - fibers take a fiber material ([`FiberMaterialId`], a scattering model) and spheres and
//!   meshes a surface material ([`SurfaceMaterialId`], [`SurfaceMaterial`]): a wrong pairing
//!   does not type-check;
//! - an emitting sphere is one sphere with an emission, never a sphere plus a separate light;
//! - the next-event light picker is built once, with the scene.

use crate::camera::Camera;
use crate::light::{Emitter, Light, LightPicker, LightSample, SphereLight};
use crate::surface_material::ModelMaterial;
use fiberlab_geometry::Ray;
use fiberlab_geometry::curves::{CurveHit, CurveSet};
use fiberlab_geometry::mesh::SurfacePoint;
use fiberlab_geometry::shapes::{TriangleMesh, sphere_hit};
use fiberlab_math::{DVec3, Rgb};
use fiberlab_scatter::Model;

/// What a sphere or mesh does with light.
#[derive(Clone, Debug)]
pub enum SurfaceMaterial {
    /// Lambertian surface: `f = albedo/π`.
    Lambert(Rgb),
    /// Perfect mirror with reflectance.
    Mirror(Rgb),
    /// A registered surface model, possibly textured ([`crate::surface_material`]).
    Model(Box<ModelMaterial>),
}

/// A fiber material of a scene (its scattering model): only fibers take one. Obtained from
/// [`SceneBuilder::fiber_material`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FiberMaterialId(usize);

/// A surface material of a scene: only spheres and meshes take one. Obtained from
/// [`SceneBuilder::surface_material`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SurfaceMaterialId(usize);

/// A sphere surface, possibly emitting.
#[derive(Clone, Debug)]
pub struct Sphere {
    center: DVec3,
    radius: f64,
    material: SurfaceMaterialId,
    emission: Option<Rgb>,
}

impl Sphere {
    /// Centre.
    #[must_use]
    pub fn center(&self) -> DVec3 {
        self.center
    }
    /// Radius.
    #[must_use]
    pub fn radius(&self) -> f64 {
        self.radius
    }
    /// Its material.
    #[must_use]
    pub fn material(&self) -> SurfaceMaterialId {
        self.material
    }
    /// The light it is when it emits.
    #[must_use]
    pub fn light(&self) -> Option<SphereLight> {
        self.emission.map(|radiance| SphereLight { center: self.center, radius: self.radius, radiance })
    }
}

/// Fibers with one material.
#[derive(Clone, Debug)]
pub struct Fibers {
    curves: CurveSet,
    material: FiberMaterialId,
}

impl Fibers {
    /// The tubes.
    #[must_use]
    pub fn curves(&self) -> &CurveSet {
        &self.curves
    }
    /// Their material.
    #[must_use]
    pub fn material(&self) -> FiberMaterialId {
        self.material
    }
}

/// A mesh with one material.
#[derive(Clone, Debug)]
pub struct Mesh {
    mesh: TriangleMesh,
    material: SurfaceMaterialId,
}

impl Mesh {
    /// The triangles.
    #[must_use]
    pub fn mesh(&self) -> &TriangleMesh {
        &self.mesh
    }
    /// Its material.
    #[must_use]
    pub fn material(&self) -> SurfaceMaterialId {
        self.material
    }
}

/// The nearest intersection.
#[derive(Clone, Copy, Debug)]
pub enum Hit {
    /// A fiber.
    Fiber {
        /// Geometry of the hit.
        hit: CurveHit,
        /// Its material.
        material: FiberMaterialId,
    },
    /// A sphere or triangle.
    Surface {
        /// Ray distance.
        t: f64,
        /// Point.
        p: DVec3,
        /// Geometric unit normal (not flipped).
        n: DVec3,
        /// Texture coordinates, shading normal and tangent ([`fiberlab_geometry::mesh`]).
        shading: SurfacePoint,
        /// Its material.
        material: SurfaceMaterialId,
        /// The sphere hit (index into [`Scene::spheres`]) when it emits.
        emitter: Option<usize>,
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

/// Assembles a [`Scene`]: materials first (each call returns the id that geometry refers
/// to), then geometry and lights.
#[derive(Clone, Debug)]
pub struct SceneBuilder {
    scene: Scene,
}

impl SceneBuilder {
    /// An empty scene seen by `camera`.
    #[must_use]
    pub fn new(camera: Camera) -> Self {
        Self {
            scene: Scene {
                camera,
                fiber_materials: Vec::new(),
                surface_materials: Vec::new(),
                fibers: Vec::new(),
                spheres: Vec::new(),
                meshes: Vec::new(),
                lights: Vec::new(),
                picker: LightPicker::new(&[], 0, 0),
            },
        }
    }

    /// Adds a fiber material: the scattering model of the fibers that use it.
    pub fn fiber_material(&mut self, model: Model) -> FiberMaterialId {
        self.scene.fiber_materials.push(model);
        FiberMaterialId(self.scene.fiber_materials.len() - 1)
    }

    /// Adds a surface material.
    pub fn surface_material(&mut self, material: SurfaceMaterial) -> SurfaceMaterialId {
        self.scene.surface_materials.push(material);
        SurfaceMaterialId(self.scene.surface_materials.len() - 1)
    }

    /// Adds an assembly of fibers.
    pub fn fibers(&mut self, curves: CurveSet, material: FiberMaterialId) -> &mut Self {
        self.scene.fibers.push(Fibers { curves, material });
        self
    }

    /// Adds a sphere; with `emission`, it is also a light of that radiance.
    pub fn sphere(
        &mut self,
        center: DVec3,
        radius: f64,
        material: SurfaceMaterialId,
        emission: Option<Rgb>,
    ) -> &mut Self {
        self.scene.spheres.push(Sphere { center, radius, material, emission });
        self
    }

    /// Adds a triangle mesh.
    pub fn mesh(&mut self, mesh: TriangleMesh, material: SurfaceMaterialId) -> &mut Self {
        self.scene.meshes.push(Mesh { mesh, material });
        self
    }

    /// Adds a light at infinity.
    pub fn light(&mut self, light: Light) -> &mut Self {
        self.scene.lights.push(light);
        self
    }

    /// The scene, with its light picker: the lights at infinity in the order added, then
    /// the emitting spheres in the order added.
    #[must_use]
    pub fn build(mut self) -> Scene {
        let s = &self.scene;
        let weighted: Vec<(Emitter, f64)> = s
            .lights
            .iter()
            .enumerate()
            .map(|(i, l)| (Emitter::Light(i), l.selection_weight()))
            .chain(
                s.spheres
                    .iter()
                    .enumerate()
                    .filter_map(|(i, sp)| Some((Emitter::Sphere(i), sp.light()?.selection_weight()))),
            )
            .collect();
        self.scene.picker = LightPicker::new(&weighted, s.lights.len(), s.spheres.len());
        self.scene
    }
}

/// Everything the integrator needs; built with a [`SceneBuilder`].
#[derive(Clone, Debug)]
pub struct Scene {
    camera: Camera,
    fiber_materials: Vec<Model>,
    surface_materials: Vec<SurfaceMaterial>,
    fibers: Vec<Fibers>,
    spheres: Vec<Sphere>,
    meshes: Vec<Mesh>,
    lights: Vec<Light>,
    picker: LightPicker,
}

impl Scene {
    /// The camera.
    #[must_use]
    pub fn camera(&self) -> &Camera {
        &self.camera
    }

    /// Fiber assemblies.
    #[must_use]
    pub fn fibers(&self) -> &[Fibers] {
        &self.fibers
    }

    /// Spheres.
    #[must_use]
    pub fn spheres(&self) -> &[Sphere] {
        &self.spheres
    }

    /// Meshes.
    #[must_use]
    pub fn meshes(&self) -> &[Mesh] {
        &self.meshes
    }

    /// Lights at infinity (emitting spheres are among [`Scene::spheres`]).
    #[must_use]
    pub fn lights(&self) -> &[Light] {
        &self.lights
    }

    /// The next-event light picker over the lights and the emitting spheres.
    #[must_use]
    pub fn light_picker(&self) -> &LightPicker {
        &self.picker
    }

    /// The scattering model of a fiber material.
    #[must_use]
    pub fn fiber_model(&self, id: FiberMaterialId) -> &Model {
        &self.fiber_materials[id.0]
    }

    /// A surface material.
    #[must_use]
    pub fn surface_material(&self, id: SurfaceMaterialId) -> &SurfaceMaterial {
        &self.surface_materials[id.0]
    }

    /// Every fiber material's model, to replace (e.g. to render one scene with several
    /// models); the picker does not depend on them.
    pub fn fiber_models_mut(&mut self) -> impl Iterator<Item = &mut Model> {
        self.fiber_materials.iter_mut()
    }

    /// A sample of `emitter` seen from `p`.
    #[must_use]
    pub fn sample_emitter(&self, emitter: Emitter, p: DVec3, u: [f64; 2]) -> Option<LightSample> {
        match emitter {
            Emitter::Light(i) => self.lights[i].sample(u),
            Emitter::Sphere(i) => self.spheres[i].light()?.sample(p, u),
        }
    }

    /// Nearest hit along the ray.
    #[must_use]
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        let mut best = self.intersect_surfaces(ray);
        let mut r = *ray;
        if let Some(Hit::Surface { t, .. }) = best {
            r.t_max = t;
        }
        for f in &self.fibers {
            if let Some(hit) = f.curves.intersect(&r) {
                r.t_max = hit.t;
                best = Some(Hit::Fiber { hit, material: f.material });
            }
        }
        best
    }

    /// Nearest sphere or mesh hit along the ray, fibers ignored (dual scattering's bounce
    /// toward a surface counts the fibers in between instead).
    #[must_use]
    pub fn intersect_surfaces(&self, ray: &Ray) -> Option<Hit> {
        let mut best: Option<Hit> = None;
        let mut r = *ray;
        // Cheap solid shapes first: a head in front shortens the ray before the hair's tree.
        for (i, s) in self.spheres.iter().enumerate() {
            if let Some(t) = sphere_hit(r.o, r.d, s.center, s.radius, r.t_min, r.t_max) {
                r.t_max = t;
                let p = r.at(t);
                let emitter = s.emission.map(|_| i);
                let shading = SurfacePoint::on_sphere(p, s.center, s.radius);
                let n = (p - s.center) / s.radius;
                best = Some(Hit::Surface { t, p, n, shading, material: s.material, emitter });
            }
        }
        for m in &self.meshes {
            if let Some((t, n, shading)) = m.mesh.intersect_point(&r) {
                r.t_max = t;
                best = Some(Hit::Surface { t, p: r.at(t), n, shading, material: m.material, emitter: None });
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

#[cfg(test)]
mod tests {
    use super::*;

    /// An emitting sphere is one object: a ray hitting it reports it as the emitter, the picker
    /// offers it with weight π L beside the lights at infinity (added before or after it), and
    /// its light is made from its own centre and radius; a sphere without emission is no light.
    #[test]
    fn an_emitting_sphere_is_one_object_and_the_picker_sees_it() {
        let camera = Camera::look_at(DVec3::new(0.0, 0.0, 5.0), DVec3::ZERO, DVec3::Y, 30.0, 4, 4).unwrap();
        let mut b = SceneBuilder::new(camera);
        let white = b.surface_material(SurfaceMaterial::Lambert(Rgb::ONE));
        b.sphere(DVec3::ZERO, 1.0, white, Some(Rgb::splat(2.0)));
        b.sphere(DVec3::new(0.0, 3.0, 0.0), 0.5, white, None);
        b.light(Light::Constant { radiance: Rgb::splat(1.0) });
        let scene = b.build();
        let ray = Ray { o: DVec3::new(0.0, 0.0, 5.0), d: -DVec3::Z, t_min: 0.0, t_max: f64::INFINITY };
        let Some(Hit::Surface { t, emitter, .. }) = scene.intersect(&ray) else { panic!("the sphere is hit") };
        assert_eq!((t, emitter), (4.0, Some(0)));
        let up = Ray { o: DVec3::ZERO + DVec3::new(0.0, 1.5, 0.0), d: DVec3::Y, ..ray };
        assert!(matches!(scene.intersect(&up), Some(Hit::Surface { emitter: None, .. })));
        let p = scene.light_picker();
        // Weights π·2 (sphere) and π·1 (sky): 2/3 and 1/3.
        assert!(
            (p.sphere_probability(0) - 2.0 / 3.0).abs() < 1e-12 && (p.light_probability(0) - 1.0 / 3.0).abs() < 1e-12
        );
        assert_eq!(p.sphere_probability(1), 0.0);
        assert_eq!(p.pick(0.0).map(|(e, _)| e), Some(Emitter::Light(0)), "lights at infinity come first");
        let s = scene.sample_emitter(Emitter::Sphere(0), DVec3::new(0.0, 0.0, 5.0), [0.5, 0.5]).unwrap();
        // The sample ends on the sphere's surface, and carries its radiance.
        let end = DVec3::new(0.0, 0.0, 5.0) + s.wi * s.distance;
        assert!((end.length() - 1.0).abs() < 1e-9 && s.radiance == Rgb::splat(2.0), "{end:?}");
    }
}
