//! Surface-model materials in the path tracer, against closed forms.

use fiberlab_geometry::shapes::TriangleMesh;
use fiberlab_io::LinearImage;
use fiberlab_math::{DVec3, Rgb};
use fiberlab_render::camera::Camera;
use fiberlab_render::integrator::{RenderSettings, render};
use fiberlab_render::light::Light;
use fiberlab_render::scene::{SceneBuilder, SurfaceMaterial};
use fiberlab_render::surface_material::{ModelMaterial, TextureSource};
use fiberlab_render::texture::Wrap;
use fiberlab_scatter::{build_surface, find_surface};
use std::f64::consts::PI;
use std::sync::atomic::AtomicBool;

fn lambertian(k_d: &str, textures: &[(String, TextureSource)]) -> SurfaceMaterial {
    let spec = find_surface("lambertian").unwrap();
    let model = build_surface("lambertian", &[("k_d", k_d)]).unwrap();
    SurfaceMaterial::Model(Box::new(ModelMaterial::new(spec.name, spec.params, model, textures).unwrap()))
}

fn settings(spp: u32) -> RenderSettings {
    RenderSettings { spp, max_depth: 1, seed: 3, ..RenderSettings::default() }
}

/// A floor of the `lambertian` surface model (k_d) under a delta distant light of irradiance E
/// at angle θ from the normal has radiance `k_d E cosθ/π` in every pixel, exactly (one light
/// sample, no MIS with a delta light); the same floor under a constant sky L has radiance
/// `k_d L` (light and BSDF sampling with MIS).
#[test]
fn lambertian_model_floor_matches_the_closed_forms() {
    let (e, theta) = (3.0, 0.7_f64);
    let k_d = [0.25, 0.5, 0.75];
    let camera = Camera::look_at(DVec3::new(0.0, 2.0, 0.0), DVec3::ZERO, DVec3::Z, 20.0, 6, 6).unwrap();
    let mut b = SceneBuilder::new(camera.clone());
    let m = b.surface_material(lambertian("0.25,0.5,0.75", &[]));
    b.mesh(TriangleMesh::floor(0.0, 50.0), m);
    b.light(Light::Distant { direction: DVec3::new(theta.sin(), theta.cos(), 0.0), irradiance: Rgb::splat(e) });
    let out = render(&b.build(), &settings(2), &|_| {}, &AtomicBool::new(false));
    for p in out.image.pixels() {
        for k in 0..3 {
            let expected = k_d[k] * e * theta.cos() / PI;
            assert!((f64::from(p[k]) / expected - 1.0).abs() < 1e-5, "{p:?} vs {expected}");
        }
    }
    let mut b = SceneBuilder::new(camera);
    let m = b.surface_material(lambertian("0.25,0.5,0.75", &[]));
    b.mesh(TriangleMesh::floor(0.0, 1e4), m);
    b.light(Light::Constant { radiance: Rgb::splat(0.6) });
    let out = render(&b.build(), &settings(512), &|_| {}, &AtomicBool::new(false));
    let px = out.image.pixels();
    for k in 0..3 {
        let mean: f64 = px.iter().map(|p| f64::from(p[k])).sum::<f64>() / px.len() as f64;
        let expected = k_d[k] * 0.6;
        assert!((mean / expected - 1.0).abs() < 0.01, "channel {k}: {mean} vs {expected}");
    }
}

/// A textured k_d (two texels, 0.2 and 0.8, side by side along u) is affine in u between the
/// texel centres, so a pixel's mean over its footprint (an affine image of the pixel on a
/// floor parallel to the image plane) is the bilinear value at the pixel centre's uv:
/// `k_d(x) = 0.2 + 0.6 (x − 1)/2` for floor uv `u = x/4` (uv scale ¼), under E = π from straight
/// above (radiance = k_d).
#[test]
fn textured_floor_follows_its_bilinear_texture() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("ramp.exr");
    LinearImage::from_pixels(2, 1, vec![[0.2; 3], [0.8; 3]]).unwrap().write_exr(&path).unwrap();
    let source = TextureSource { wrap: Wrap::Clamp, scale: [0.25, 0.25], ..TextureSource::file(path) };
    let half_fov = (0.8_f64 / 10.0).atan();
    let camera = Camera::look_at(
        DVec3::new(2.0, 10.0, 2.0),
        DVec3::new(2.0, 0.0, 2.0),
        DVec3::Z,
        2.0 * half_fov.to_degrees(),
        8,
        8,
    )
    .unwrap();
    let mut b = SceneBuilder::new(camera.clone());
    let m = b.surface_material(lambertian("0.5", &[("k_d".into(), source)]));
    b.mesh(TriangleMesh::floor(0.0, 50.0), m);
    b.light(Light::Distant { direction: DVec3::Y, irradiance: Rgb::splat(PI) });
    let out = render(&b.build(), &settings(1024), &|_| {}, &AtomicBool::new(false));
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for y in 0..8 {
        for x in 0..8 {
            let ray = camera.ray(x as f64 + 0.5, y as f64 + 0.5);
            let floor_x = ray.o.x + ray.d.x * (-ray.o.y / ray.d.y);
            let expected = 0.2 + 0.6 * (floor_x - 1.0) / 2.0;
            let got = f64::from(out.image.get(x, y)[0]);
            assert!((got / expected - 1.0).abs() < 0.005, "pixel ({x}, {y}): {got} vs {expected}");
            (lo, hi) = (lo.min(got), hi.max(got));
        }
    }
    assert!(hi - lo > 0.3, "the ramp is visible: {lo}..{hi}");
}
