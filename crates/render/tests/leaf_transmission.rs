//! Transmission through a two-sided surface model (`leaf`) in the path tracer, against an
//! independent quadrature of the model's BSDF, and grass patches in scene files.
//!
//! A wide horizontal leaf under a unit constant sky, with a black floor below it: seen from
//! below at `ω_o`, its radiance is `∫_{upper} f(ω_i, ω_o)|cosθ_i| dω_i` (light from the sky
//! crossing the leaf; the floor sends nothing), which by reciprocity is the leaf's directional
//! transmittance `T(ω_o)`; seen from above, `R(ω_o)` (what crosses is absorbed by the floor).
//! The reference integrates the model's `eval` over the hemisphere by a midpoint rule in
//! (cos²θ_i, φ_i), independent of the renderer's sampling and of the model's own albedo table.

use fiberlab_geometry::shapes::TriangleMesh;
use fiberlab_math::{DVec3, Rgb};
use fiberlab_render::camera::Camera;
use fiberlab_render::integrator::{RenderSettings, render};
use fiberlab_render::light::Light;
use fiberlab_render::scene::{SceneBuilder, SurfaceMaterial};
use fiberlab_render::surface_material::ModelMaterial;
use fiberlab_scatter::{SurfaceModel, SurfaceScattering, build_surface, find_surface};
use std::f64::consts::TAU;
use std::sync::atomic::AtomicBool;

/// `∫ f(ω_i, ω_o)|cosθ_i| dω_i` over the hemisphere `sign·z > 0` of ω_i (ω_o with z > 0).
fn hemisphere_integral(model: &SurfaceModel, wo: DVec3, sign: f64) -> Rgb {
    // ∫ f μ dμ dφ = ½ ∫ f d(μ²) dφ: midpoints in t = μ² and φ.
    let (nt, nphi) = (400, 400);
    let mut sum = Rgb::ZERO;
    for i in 0..nt {
        let t = (i as f64 + 0.5) / nt as f64;
        let (mu, sin) = (t.sqrt(), (1.0 - t).sqrt());
        for j in 0..nphi {
            let phi = TAU * (j as f64 + 0.5) / nphi as f64;
            let wi = DVec3::new(sin * phi.cos(), sin * phi.sin(), sign * mu);
            sum += model.eval(wi, wo);
        }
    }
    sum * (0.5 * TAU / (nt * nphi) as f64)
}

/// Mean pixel of a render of the leaf plane from `eye` toward `target` (narrow view).
fn leaf_render(eye: DVec3, target: DVec3) -> [f64; 3] {
    let spec = find_surface("leaf").unwrap();
    let model = build_surface::<&str, &str>("leaf", &[]).unwrap();
    let camera = Camera::look_at(eye, target, DVec3::Y, 1.0, 4, 4).unwrap();
    let mut b = SceneBuilder::new(camera);
    let leaf = b.surface_material(SurfaceMaterial::Model(Box::new(
        ModelMaterial::new(spec.name, spec.params, model, &[]).unwrap(),
    )));
    let black = b.surface_material(SurfaceMaterial::Lambert(Rgb::ZERO));
    b.mesh(TriangleMesh::floor(0.0, 1000.0), leaf);
    b.mesh(TriangleMesh::floor(-1.0, 1000.0), black);
    b.light(Light::Constant { radiance: Rgb::ONE });
    let scene = b.build();
    let settings = RenderSettings { spp: 1024, max_depth: 16, seed: 3, ..RenderSettings::default() };
    let out = render(&scene, &settings, &|_| {}, &AtomicBool::new(false));
    assert_eq!(out.stats.nonfinite_samples, 0);
    let px = out.image.pixels();
    std::array::from_fn(|k| px.iter().map(|p| f64::from(p[k])).sum::<f64>() / px.len() as f64)
}

#[test]
fn a_leaf_transmits_and_reflects_in_the_renderer_as_its_bsdf_integrates() {
    let model = build_surface::<&str, &str>("leaf", &[]).unwrap();
    // Viewing direction 50° from the normal (cos 0.643): eye offset from the look-at point.
    let (mu_o, sin_o) = (50f64.to_radians().cos(), 50f64.to_radians().sin());
    let wo = DVec3::new(sin_o, 0.0, mu_o);
    let (t_ref, r_ref) = (hemisphere_integral(&model, wo, -1.0), hemisphere_integral(&model, wo, 1.0));
    // Below: the eye at y = −0.5 looks up at (x, 0, 0); above: at y = +0.5 looks down.
    let reach = 0.5 * sin_o / mu_o;
    let below = leaf_render(DVec3::new(-reach, -0.5, 0.0), DVec3::ZERO);
    let above = leaf_render(DVec3::new(-reach, 0.5, 0.0), DVec3::ZERO);
    eprintln!("T: render {below:?} vs quadrature {t_ref:?}; R: render {above:?} vs quadrature {r_ref:?}");
    // 1.5 % (the render's noise at 16k paths a view is a few tenths of a percent), and 1e-4
    // absolute where the reference is 0: the default leaf's transmitted blue, which is outside
    // the Rec. 709 gamut and clamped at 0 (the grazing sky between the two planes adds ~1e-8).
    let close = |a: f64, b: f64| (a - b).abs() <= 0.015 * b + 1e-4;
    for k in 0..3 {
        assert!(close(below[k], t_ref[k]), "T channel {k}: render {} vs quadrature {}", below[k], t_ref[k]);
        assert!(close(above[k], r_ref[k]), "R channel {k}: render {} vs quadrature {}", above[k], r_ref[k]);
    }
    // The leaf transmits, and its glow is green.
    assert!(t_ref[0] > 0.02 && t_ref[1] > 0.1 && t_ref[1] > t_ref[0] && t_ref[1] > t_ref[2], "{t_ref:?}");
}

/// `scenes/grass.toml` builds: one grass mesh of the generator's triangle count under a
/// transmitting leaf material; bad generator values and a grass entry with a file are errors
/// naming the key.
#[test]
fn the_grass_scene_builds_and_bad_grass_is_an_error_naming_the_key() {
    use fiberlab_render::scene_file::SceneFile;
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/grass.toml");
    let (scene, _) = SceneFile::read(&path).unwrap().build().unwrap();
    let grass = &scene.meshes()[0];
    assert_eq!(grass.mesh().len(), 6000 * 15, "6000 pointed blades of 8 segments");
    let SurfaceMaterial::Model(m) = scene.surface_material(grass.material()) else { panic!("a model material") };
    assert!(m.model_name() == "leaf" && m.model().properties().transmits);

    let text = std::fs::read_to_string(&path).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let write_and_build = |t: &str| {
        let p = dir.path().join("g.toml");
        std::fs::write(&p, t).unwrap();
        SceneFile::read(&p).and_then(|f| f.build()).map(|_| ()).map_err(|e| e.to_string())
    };
    let e = write_and_build(&text.replace("height = 0.3,", "height = -0.3,")).unwrap_err();
    assert!(e.contains("grass: `height` = -0.3 is invalid") && e.contains("g.toml"), "{e}");
    let e = write_and_build(&text.replace("seed = 1 }", "seed = 1, colour = 2 }")).unwrap_err();
    assert!(e.contains("colour"), "{e}");
    let e =
        write_and_build(&text.replace("material = \"blade\"\n", "material = \"blade\"\nfloor = 0.0\n")).unwrap_err();
    assert!(e.contains("grass takes translate only"), "{e}");
}
