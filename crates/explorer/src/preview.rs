//! The render preview's scenes, built from the chosen model and a light direction: for a
//! fiber model a single fiber, a tress or a fur ball; for a surface model a lit sphere or a
//! flat sample (a floor tile seen at 50°). Geometry comes from the geometry and procedural
//! crates ([`CurveSet`], [`HairParams::fur`], [`TriangleMesh::floor`]), the light is a distant light
//! (parallel rays from the direction the page drags) plus a dim sky.
//!
//! Scene units: the single fiber has radius 0.03 across a 2.4-unit view; the tress is 400
//! wavy strands of diameter 0.006 hanging 2 units; the fur ball is the `fur` generator's
//! preset thinned to 15,000 strands on a unit sphere.

use crate::error::{ApiError, ApiResult};
use crate::limits::{self, Limits};
use crate::request::{Built, ModelChoice};
use fiberlab_geometry::{CurveSet, TriangleMesh};
use fiberlab_math::split_mix::SplitMix64;
use fiberlab_math::{DVec3, Rgb};
use fiberlab_procedural::generator::HairParams;
use fiberlab_render::camera::Camera;
use fiberlab_render::light::Light;
use fiberlab_render::scene::{Scene, SceneBuilder, SurfaceMaterial};
use fiberlab_render::surface_material::ModelMaterial;
use serde::Deserialize;
use std::f64::consts::TAU;

/// Which scene.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum Kind {
    /// One gently curved fiber (fiber models).
    Fiber,
    /// 400 hanging wavy strands (fiber models).
    Tress,
    /// A fur ball (fiber models).
    Fur,
    /// A lit sphere (surface models).
    Sphere,
    /// A flat sample seen at 50° (surface models).
    Sample,
}

impl Kind {
    /// Whether the scene shows a fiber model (else a surface model).
    #[must_use]
    pub fn for_fibers(self) -> bool {
        matches!(self, Kind::Fiber | Kind::Tress | Kind::Fur)
    }
}

/// Strands of the preview's fur ball.
pub const FUR_STRANDS: usize = 15_000;

/// The light: distant, from azimuth `azimuth` (degrees about the vertical, 0 toward the camera)
/// and elevation `elevation` (degrees above the horizon).
#[must_use]
pub fn light_direction(azimuth: f64, elevation: f64) -> DVec3 {
    let (a, e) = (azimuth.to_radians(), elevation.to_radians());
    DVec3::new(e.cos() * a.sin(), e.sin(), e.cos() * a.cos())
}

fn fur_params() -> HairParams {
    HairParams { strands: FUR_STRANDS, ..HairParams::fur() }
}

/// Bytes the scene of `kind` holds at `size × size` pixels (estimates of the generator, the
/// tubes and BVH, and the image state), checked against the limits.
pub fn check(kind: Kind, size: u32, limits: &Limits) -> ApiResult<()> {
    limits::at_most("pixels (size²)", u64::from(size) * u64::from(size), u64::from(limits.max_pixels))?;
    let pixels = u64::from(size) * u64::from(size);
    let image = pixels.checked_mul(fiberlab_render::accumulation::BYTES_PER_PIXEL + 12);
    let geometry = match kind {
        Kind::Fur => {
            let p = fur_params();
            let segments = p.segment_count();
            p.estimated_bytes().zip(segments.and_then(CurveSet::estimated_bytes)).map(|(a, b)| a + b)
        }
        Kind::Tress => CurveSet::estimated_bytes(TRESS_STRANDS as u64 * TRESS_SEGMENTS as u64),
        _ => Some(1 << 20),
    };
    limits::memory("the preview scene", image.zip(geometry).map(|(a, b)| a + b), limits)
}

const TRESS_STRANDS: usize = 400;
const TRESS_SEGMENTS: usize = 60;

fn single_fiber() -> CurveSet {
    let points: Vec<DVec3> = (0..=48)
        .map(|k| {
            let s = -1.3 + 2.6 * k as f64 / 48.0;
            DVec3::new(s, 0.12 * (1.2 * s).sin(), -0.25 * s * s)
        })
        .collect();
    let radii = vec![0.03; points.len()];
    CurveSet::from_polylines([(points.as_slice(), radii.as_slice())])
}

fn tress() -> CurveSet {
    let mut rng = SplitMix64::new(7);
    let strands: Vec<(Vec<DVec3>, Vec<f64>)> = (0..TRESS_STRANDS)
        .map(|_| {
            let x0 = 0.5 * (rng.next_f64() - 0.5);
            let z0 = 0.12 * (rng.next_f64() - 0.5);
            let phase = TAU * rng.next_f64();
            let amplitude = 0.025 + 0.015 * rng.next_f64();
            let points = (0..=TRESS_SEGMENTS)
                .map(|k| {
                    let s = k as f64 / TRESS_SEGMENTS as f64;
                    // Spread a little toward the tips, wave across the tress.
                    let spread = 1.0 + 0.6 * s;
                    let wave = amplitude * (TAU * s * 4.0 + phase).sin() * s.min(0.1) * 10.0;
                    DVec3::new(x0 * spread + wave, 1.05 - 2.1 * s, z0 * spread + 0.3 * wave)
                })
                .collect();
            (points, vec![0.003; TRESS_SEGMENTS + 1])
        })
        .collect();
    CurveSet::from_polylines(strands.iter().map(|(p, r)| (p.as_slice(), r.as_slice())))
}

fn camera(eye: [f64; 3], target: [f64; 3], fov: f64, size: u32) -> ApiResult<Camera> {
    Camera::look_at(DVec3::from(eye), DVec3::from(target), DVec3::Y, fov, size, size)
        .ok_or_else(|| ApiError::internal("degenerate preview camera"))
}

/// Builds the preview scene of `kind` for `choice`, lit from `light` (unit, toward the
/// light); the scene's maximum path depth comes with it.
pub fn build(kind: Kind, choice: &ModelChoice, light: DVec3, size: u32) -> ApiResult<(Scene, u32)> {
    let model = choice.build()?;
    let sun = Light::Distant { direction: light, irradiance: Rgb::splat(3.0) };
    let sky = Light::Constant { radiance: Rgb::new(0.035, 0.04, 0.05) };
    match (kind, model) {
        (Kind::Fiber | Kind::Tress | Kind::Fur, Built::Fiber(model)) => {
            let cam = match kind {
                Kind::Fur => camera([0.0, 1.0, 4.2], [0.0, 0.0, 0.0], 33.0, size)?,
                Kind::Tress => camera([0.0, 0.0, 3.4], [0.0, 0.0, 0.0], 40.0, size)?,
                _ => camera([0.0, 0.0, 3.0], [0.0, -0.15, 0.0], 48.0, size)?,
            };
            let mut b = SceneBuilder::new(cam);
            let fibers = b.fiber_material(model);
            let curves = match kind {
                Kind::Fur => {
                    let hair = fur_params().generate().map_err(|e| ApiError::internal(e.to_string()))?;
                    let skin = b.surface_material(SurfaceMaterial::Lambert(Rgb::new(0.3, 0.22, 0.16)));
                    b.sphere(DVec3::ZERO, 1.0, skin, None);
                    hair.curve_set()
                }
                Kind::Tress => tress(),
                _ => single_fiber(),
            };
            b.fibers(curves, fibers);
            b.light(sun).light(sky);
            Ok((b.build(), if kind == Kind::Fiber { 64 } else { 24 }))
        }
        (Kind::Sphere | Kind::Sample, Built::Surface(model)) => {
            let spec = fiberlab_scatter::find_surface(&choice.model).map_err(|e| ApiError::bad(e.to_string()))?;
            let mut material = ModelMaterial::new(spec.name, spec.params, model, &[])
                .map_err(|e| ApiError::bad(format!("model `{}`: {e}", choice.model)))?;
            if material.uv_scale().is_some() {
                // Threads a few pixels wide: the sphere's u runs once around, the tile's u
                // over 2 units.
                let scale = if kind == Kind::Sphere { [60.0, 30.0] } else { [30.0, 30.0] };
                material = material.with_uv_scale(scale).map_err(|e| ApiError::internal(e.to_string()))?;
            }
            let cam = match kind {
                Kind::Sphere => camera([0.0, 0.6, 3.4], [0.0, 0.0, 0.0], 38.0, size)?,
                _ => camera([0.0, 1.45, 1.75], [0.0, 0.0, 0.0], 38.0, size)?,
            };
            let mut b = SceneBuilder::new(cam);
            let surface = b.surface_material(SurfaceMaterial::Model(Box::new(material)));
            match kind {
                Kind::Sphere => {
                    let floor = b.surface_material(SurfaceMaterial::Lambert(Rgb::splat(0.25)));
                    b.sphere(DVec3::ZERO, 1.0, surface, None);
                    b.mesh(TriangleMesh::floor(-1.0, 20.0), floor);
                }
                _ => {
                    b.mesh(TriangleMesh::floor(0.0, 1.0), surface);
                }
            }
            b.light(sun).light(sky);
            Ok((b.build(), 8))
        }
        (k, Built::Fiber(_)) => Err(ApiError::bad(format!(
            "scene `{k:?}` shows a surface model; `{}` is a fiber model (scenes: fiber, tress, fur)",
            choice.model
        ))),
        (k, Built::Surface(_)) => Err(ApiError::bad(format!(
            "scene `{k:?}` shows a fiber model; `{}` is a surface model (scenes: sphere, sample)",
            choice.model
        ))),
    }
}
