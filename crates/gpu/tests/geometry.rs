//! The GPU's BVH walk (both node kinds, as the CPU stores them) and its tube, sphere and
//! triangle tests against the CPU: closest hits and any-hit queries on hair-like and
//! adversarial segment sets against testing every segment, and a mixed scene against the CPU
//! scene's queries.

mod common;

use fiberlab_check::rng::TestRng;
use fiberlab_geometry::CurveSet;
use fiberlab_geometry::Ray;
use fiberlab_geometry::TriangleMesh;
use fiberlab_gpu::wavefront::{QueryRay, query_rays};
use fiberlab_math::{DVec3, Rgb};
use fiberlab_procedural::generator::{HairParams, Style};
use fiberlab_render::camera::Camera;
use fiberlab_render::scene::{Scene, SceneBuilder, SurfaceMaterial};

fn vec(rng: &mut TestRng) -> DVec3 {
    let u = rng.u4();
    DVec3::new(u[0], u[1], u[2])
}

fn scene_of(curves: CurveSet, surfaces: bool) -> Scene {
    let camera = Camera::look_at(DVec3::new(0.0, 0.0, 5.0), DVec3::ZERO, DVec3::Y, 40.0, 8, 8).unwrap();
    let mut b = SceneBuilder::new(camera);
    let fiber = b.fiber_material(fiberlab_scatter::build::<&str, &str>("chiang", &[]).unwrap());
    b.fibers(curves, fiber);
    if surfaces {
        let grey = b.surface_material(SurfaceMaterial::Lambert(Rgb::splat(0.5)));
        b.sphere(DVec3::new(0.2, -0.1, 0.0), 0.45, grey, None);
        b.sphere(DVec3::new(-0.7, 0.5, 0.3), 0.2, grey, Some(Rgb::ONE));
        b.mesh(TriangleMesh::floor(-0.8, 3.0), grey);
    }
    b.build()
}

fn strands(points: &[Vec<DVec3>], radii: &[Vec<f64>]) -> CurveSet {
    CurveSet::from_polylines(points.iter().zip(radii).map(|(p, r)| (p.as_slice(), r.as_slice())))
}

/// Rays from a box around the set toward points near its middle, some with short t_max.
fn rays(rng: &mut TestRng, n: usize, reach: f64) -> Vec<Ray> {
    (0..n)
        .map(|k| {
            let o = (vec(rng) - 0.5) * 2.0 * reach;
            let target = (vec(rng) - 0.5) * reach;
            let mut r = Ray::new(o, (target - o).normalize());
            if k.is_multiple_of(5) {
                r.t_max = (target - o).length() * rng.u4()[0];
            }
            r
        })
        .collect()
}

fn query(r: &Ray) -> QueryRay {
    QueryRay { o: r.o.as_vec3(), d: r.d.as_vec3(), t_min: r.t_min as f32, t_max: r.t_max.min(3e38) as f32 }
}

/// Compares the GPU's answers with the CPU's (`closest`: its distance and h, `blocked`) for
/// each ray; a disagreement is allowed only for a grazing hit (|h| > 0.995, where f32 and f64
/// may fall on either side of the tube's edge), at most 0.5 % of the rays. Returns the hits.
fn compare(
    what: &str,
    rays: &[Ray],
    cpu: &[(Option<(f64, f64)>, bool)],
    gpu: &[fiberlab_gpu::wavefront::QueryHit],
) -> usize {
    let (mut hits, mut grazing) = (0, 0);
    for ((ray, (c, blocked)), g) in rays.iter().zip(cpu).zip(gpu) {
        let gh = g.closest.map(|(t, _, h)| (f64::from(t), f64::from(h)));
        let agree = match (c, gh) {
            (Some((ct, _)), Some((gt, _))) => (ct - gt).abs() <= 1e-4 * (1.0 + ct.abs()),
            (None, None) => true,
            _ => false,
        };
        if !agree || *blocked != g.blocked {
            let edge = c.is_some_and(|(_, h)| h.abs() > 0.995) || gh.is_some_and(|(_, h)| h.abs() > 0.995);
            assert!(edge, "{what}: ray {ray:?}: CPU {c:?} blocked {blocked}, GPU {gh:?} blocked {}", g.blocked);
            grazing += 1;
        }
        hits += usize::from(c.is_some());
    }
    eprintln!("{what}: {} rays, {hits} hits, {grazing} grazing disagreements", rays.len());
    assert!(grazing * 200 <= rays.len(), "{what}: {grazing} disagreements");
    hits
}

fn check_curves(what: &str, curves: CurveSet, rays: &[Ray]) {
    let Some(gpu) = common::gpu() else { return };
    let cpu: Vec<(Option<(f64, f64)>, bool)> = rays
        .iter()
        .map(|r| {
            let hit = curves.intersect_brute_force(r);
            (hit.map(|h| (h.t, h.h)), hit.is_some())
        })
        .collect();
    let oriented = curves.bvh().oriented_node_count();
    let scene = scene_of(curves, false);
    let queries: Vec<QueryRay> = rays.iter().map(query).collect();
    let got = query_rays(gpu, &scene, &queries).unwrap();
    let hits = compare(what, rays, &cpu, &got);
    eprintln!("{what}: {oriented} oriented nodes");
    assert!(hits > rays.len() / 20, "{what}: only {hits} hits");
}

#[test]
fn hair_like_strands_closest_and_any_hit_match_brute_force() {
    let hair = HairParams {
        strands: 600,
        segments: 12,
        clumps: 12,
        style: Style::Curly,
        root_diameter: 0.02,
        ..HairParams::default()
    }
    .generate()
    .unwrap();
    let curves = hair.curve_set();
    assert!(curves.bvh().oriented_node_count() > 0, "the test must cover oriented nodes");
    let mut rng = TestRng::new(1);
    check_curves("hair", curves, &rays(&mut rng, 6000, 2.5));
}

#[test]
fn adversarial_strands_match_brute_force() {
    let mut rng = TestRng::new(2);
    // Parallel strands side by side, 2.5 radii apart.
    let (mut pts, mut rad) = (Vec::new(), Vec::new());
    for i in 0..300 {
        let x = -0.75 + 0.005 * f64::from(i);
        pts.push((0..6).map(|k| DVec3::new(x, -1.0 + 0.4 * f64::from(k), 0.01 * f64::from(k % 2))).collect());
        rad.push(vec![0.002; 6]);
    }
    check_curves("parallel", strands(&pts, &rad), &rays(&mut rng, 4000, 1.5));
    // Strands crossing at one point, with sharp reversals and zero-length segments.
    let (mut pts, mut rad) = (Vec::new(), Vec::new());
    for i in 0..150 {
        let d = (vec(&mut rng) - 0.5).normalize();
        pts.push(vec![-d, -d * 1e-9, DVec3::ZERO, DVec3::ZERO, d, d * 0.5]);
        rad.push(vec![0.01 + 0.001 * f64::from(i % 7); 6]);
    }
    check_curves("crossing", strands(&pts, &rad), &rays(&mut rng, 4000, 1.5));
    // Radii from 1e-4 to 0.3 in one set.
    let (mut pts, mut rad) = (Vec::new(), Vec::new());
    for i in 0..200u32 {
        let p = (vec(&mut rng) - 0.5) * 2.0;
        let d = (vec(&mut rng) - 0.5) * 0.6;
        pts.push(vec![p, p + d, p + d * 2.0 + DVec3::Y * 0.1]);
        let r = if i.is_multiple_of(2) { 1e-4 } else { 0.3 * rng.u4()[0] + 1e-3 };
        rad.push(vec![r; 3]);
    }
    check_curves("radii", strands(&pts, &rad), &rays(&mut rng, 4000, 2.0));
}

/// Spheres (one emitting), a floor and hair in one scene: the GPU's nearest hit and shadow
/// query against the CPU scene's.
#[test]
fn mixed_scene_matches_the_cpu_scene_queries() {
    let Some(gpu) = common::gpu() else { return };
    let hair = HairParams {
        strands: 300,
        segments: 10,
        clumps: 8,
        style: Style::Wavy,
        root_diameter: 0.02,
        ..HairParams::default()
    }
    .generate()
    .unwrap();
    let scene = scene_of(hair.curve_set(), true);
    let mut rng = TestRng::new(4);
    let rays = rays(&mut rng, 5000, 2.5);
    let cpu: Vec<(Option<(f64, f64)>, bool)> = rays
        .iter()
        .map(|r| {
            let hit = scene.intersect(r).map(|h| match h {
                fiberlab_render::scene::Hit::Fiber { hit, .. } => (hit.t, hit.h),
                fiberlab_render::scene::Hit::Surface { t, .. } => (t, 0.0),
            });
            (hit, !scene.unoccluded(r))
        })
        .collect();
    let got = query_rays(gpu, &scene, &rays.iter().map(query).collect::<Vec<_>>()).unwrap();
    let kinds: std::collections::BTreeSet<u32> =
        got.iter().filter_map(|g| g.closest.map(|(_, p, _)| p >> 30)).collect();
    assert_eq!(kinds.len(), 3, "rays hit segments, spheres and triangles: {kinds:?}");
    compare("mixed", &rays, &cpu, &got);
}
