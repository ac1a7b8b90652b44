//! The steps of the examples' own path tracer (`dual_terms`, `dual_forward`): written here, not
//! taken from the renderer's integrator, so that comparing the two checks the integrator. They
//! share with the renderer only the scene's intersection, light sampling and models.

use fiberlab_geometry::curves::CurveHit;
use fiberlab_math::split_mix::SplitMix64;
use fiberlab_math::{DVec3, Rgb};
use fiberlab_render::scene::{Hit, Scene, SurfaceMaterial};
use fiberlab_scatter::ScatteringFunction;
use std::f64::consts::PI;

/// Whether light arriving from `wi` and leaving along `−ray_d` scatters backward at the fiber
/// (both on the same side of it: the dual-scattering tables' backward half-circle).
pub fn backward_event(hit: &CurveHit, ray_d: DVec3, wi: DVec3) -> bool {
    let frame = hit.frame(ray_d);
    let (a, b) = (frame.to_local(wi), frame.to_local(-ray_d));
    a.y * b.y + a.z * b.z > 0.0
}

/// The next direction at `hit` (reached along `ray_d`) and its weight: the fiber model's own
/// sampler, or a cosine-distributed bounce off a Lambert surface. Sets `backward` when a fiber
/// after the first (`depth > 0`) scatters backward. `None` ends the path (no sample, or a
/// surface material these examples do not trace).
pub fn scatter(
    scene: &Scene,
    hit: &Hit,
    ray_d: DVec3,
    depth: usize,
    u: [f64; 4],
    backward: &mut bool,
) -> Option<(DVec3, Rgb)> {
    match hit {
        Hit::Fiber { hit, material } => {
            let frame = hit.frame(ray_d);
            let s = scene.fiber_model(*material).sample(frame.to_local(-ray_d), hit.h, u)?;
            let wi = frame.to_world(s.wi).normalize();
            if depth > 0 && backward_event(hit, ray_d, wi) {
                *backward = true;
            }
            Some((wi, s.weight))
        }
        Hit::Surface { n, material, .. } => {
            let facing = if n.dot(ray_d) < 0.0 { *n } else { -*n };
            let SurfaceMaterial::Lambert(albedo) = scene.surface_material(*material) else { return None };
            let t = facing.any_orthonormal_vector();
            let b = facing.cross(t);
            let (r, a) = (u[0].sqrt(), 2.0 * PI * u[1]);
            let wi = (t * (r * a.cos()) + b * (r * a.sin()) + facing * (1.0 - u[0]).max(0.0).sqrt()).normalize();
            Some((wi, *albedo))
        }
    }
}

/// `f_s·cosθ_i` at the vertex `hit` (reached along `ray_d`) for light arriving from `wi`:
/// the fiber model, or a Lambert surface.
pub fn f_cos(scene: &Scene, hit: &Hit, ray_d: DVec3, wi: DVec3) -> Rgb {
    match hit {
        Hit::Fiber { hit, material } => {
            let frame = hit.frame(ray_d);
            let (wi_l, wo_l) = (frame.to_local(wi), frame.to_local(-ray_d));
            scene.fiber_model(*material).eval(wi_l, wo_l, hit.h) * (1.0 - wi_l.x * wi_l.x).max(0.0).sqrt()
        }
        Hit::Surface { n, material, .. } => {
            let facing = if n.dot(ray_d) < 0.0 { *n } else { -*n };
            match scene.surface_material(*material) {
                SurfaceMaterial::Lambert(albedo) => *albedo * (facing.dot(wi).max(0.0) / PI),
                _ => panic!("the examples' path tracer traces only Lambertian surfaces"),
            }
        }
    }
}

/// Next-event estimation at the vertex `hit` at `p` (no MIS: escaped rays after the camera
/// ray are not counted): one light picked and sampled, and `(ω_i, f·cosθ·L/(P(light)·pdf))`
/// when its light arrives unoccluded and is not black. The caller multiplies by the throughput.
pub fn light_sample(scene: &Scene, hit: &Hit, ray_d: DVec3, p: DVec3, rng: &mut SplitMix64) -> Option<(DVec3, Rgb)> {
    let (emitter, select) = scene.light_picker().pick(rng.next_f64())?;
    let ls = scene.sample_emitter(emitter, p, [rng.next_f64(), rng.next_f64()])?;
    let f = f_cos(scene, hit, ray_d, ls.wi);
    if f.is_black() || ls.radiance.is_black() {
        return None;
    }
    let eps = 1e-9 * (1.0 + p.abs().max_element());
    let t_max = if ls.distance.is_finite() { ls.distance * (1.0 - 1e-9) - eps } else { f64::INFINITY };
    let shadow = fiberlab_geometry::Ray { o: p, d: ls.wi, t_min: eps, t_max };
    scene.unoccluded(&shadow).then(|| (ls.wi, f * ls.radiance / (select * ls.pdf)))
}

/// Multiplies the throughput by `weight` and, from depth 3, plays Russian roulette on its
/// largest channel; `false` ends the path.
pub fn carry_on(beta: &mut Rgb, weight: Rgb, depth: usize, rng: &mut SplitMix64) -> bool {
    *beta *= weight;
    if beta.is_black() || !beta.is_finite() {
        return false;
    }
    if depth >= 3 {
        let survive = beta.max_component().min(1.0);
        if rng.next_f64() >= survive {
            return false;
        }
        *beta = *beta / survive;
    }
    true
}
