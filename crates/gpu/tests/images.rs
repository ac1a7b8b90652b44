//! Images of small scenes on the GPU against the CPU renderer: a white furnace, the per-channel
//! means and the block errors of each light type and material, and the progressive state
//! across devices, stops, tiles and chunks.

mod common;

use fiberlab_geometry::CurveSet;
use fiberlab_geometry::TriangleMesh;
use fiberlab_gpu::{Gpu, GpuOptions};
use fiberlab_io::LinearImage;
use fiberlab_math::{DVec3, Rgb};
use fiberlab_procedural::generator::{HairParams, Style};
use fiberlab_render::accumulation::Accumulation;
use fiberlab_render::camera::Camera;
use fiberlab_render::integrator::{self, Region, RenderSettings, merge};
use fiberlab_render::light::{EnvironmentMap, Light};
use fiberlab_render::scene::{Scene, SceneBuilder, SurfaceMaterial};
use fiberlab_render::surface_material::{ModelMaterial, TextureSource};
use fiberlab_render::texture::Wrap;
use std::sync::atomic::AtomicBool;

const SIDE: u32 = 24;

fn hair(strands: usize) -> CurveSet {
    let hair = HairParams {
        strands,
        segments: 12,
        clumps: 10,
        style: Style::Wavy,
        root_diameter: 0.03,
        ..HairParams::default()
    }
    .generate()
    .unwrap();
    hair.curve_set()
}

fn builder() -> SceneBuilder {
    let camera =
        Camera::look_at(DVec3::new(0.3, 0.6, 4.5), DVec3::new(0.0, -0.2, 0.0), DVec3::Y, 45.0, SIDE, SIDE).unwrap();
    SceneBuilder::new(camera)
}

fn chiang(params: &[(&str, &str)]) -> fiberlab_scatter::Model {
    fiberlab_scatter::build("chiang", params).unwrap()
}

fn settings(spp: u32) -> RenderSettings {
    RenderSettings { spp, max_depth: 16, seed: 3, ..RenderSettings::default() }
}

fn gpu_render(gpu: &Gpu, scene: &Scene, s: &RenderSettings) -> integrator::RenderOutput {
    fiberlab_gpu::render(gpu, scene, s, GpuOptions::default(), &|_| {}, &AtomicBool::new(false)).unwrap()
}

fn cpu_render(scene: &Scene, s: &RenderSettings) -> integrator::RenderOutput {
    integrator::render(scene, s, &|_| {}, &AtomicBool::new(false))
}

fn channel_means(image: &LinearImage) -> [f64; 3] {
    let mut m = [0.0; 3];
    for p in image.pixels() {
        for k in 0..3 {
            m[k] += f64::from(p[k]);
        }
    }
    m.map(|x| x / image.pixels().len() as f64)
}

/// RMS over 4×4 blocks of the difference of two images' block means (luminance-free: all
/// channels), relative to the reference's mean.
fn block_rms(a: &LinearImage, b: &LinearImage) -> f64 {
    let (w, h) = (a.width(), a.height());
    let (mut sum, mut n) = (0.0, 0);
    for by in (0..h).step_by(4) {
        for bx in (0..w).step_by(4) {
            for k in 0..3 {
                let (mut da, mut db) = (0.0, 0.0);
                for y in by..(by + 4).min(h) {
                    for x in bx..(bx + 4).min(w) {
                        da += f64::from(a.get(x, y)[k]);
                        db += f64::from(b.get(x, y)[k]);
                    }
                }
                sum += ((da - db) / 16.0).powi(2);
                n += 1;
            }
        }
    }
    (sum / f64::from(n)).sqrt()
}

/// Hair of `model` under a white sky, rendered on the GPU without a depth limit: every channel's
/// mean within 0.5 % of 1 and every pixel's green within 0.25 of 1.
fn assert_white_furnace(gpu: &Gpu, model: fiberlab_scatter::Model, name: &str) {
    let mut b = builder();
    let m = b.fiber_material(model);
    b.fibers(hair(400), m).light(Light::Constant { radiance: Rgb::ONE });
    let scene = b.build();
    let out = gpu_render(gpu, &scene, &RenderSettings { max_depth: u32::MAX, ..settings(32) });
    assert_eq!(out.stats.nonfinite_samples, 0);
    let means = channel_means(&out.image);
    eprintln!("{name} furnace means {means:?}, {} rays", out.stats.rays);
    for m in means {
        assert!((m - 1.0).abs() < 0.005, "{name}: mean {m}");
    }
    for p in out.image.pixels() {
        assert!((f64::from(p[1]) - 1.0).abs() < 0.25, "{name}: pixel {p:?}");
    }
}

/// A lossless Chiang fiber under a white sky integrates to the sky: every pixel of hair and
/// background is 1 (the sample weight of lossless Chiang is exactly 1 on the camera side).
#[test]
fn white_furnace_of_lossless_chiang_hair_is_one() {
    let Some(gpu) = common::gpu() else { return };
    assert_white_furnace(gpu, chiang(&[("sigma_a", "0")]), "chiang");
    // A lossy fiber is darker: the test can fail.
    let mut b = builder();
    let m = b.fiber_material(chiang(&[("eumelanin", "1")]));
    b.fibers(hair(400), m).light(Light::Constant { radiance: Rgb::ONE });
    let dark = gpu_render(gpu, &b.build(), &settings(8));
    assert!(channel_means(&dark.image)[0] < 0.95);
}

/// The same for a lossless d'Eon fiber (`theta_n = camera`): its sample weight is the sum of its
/// tabulated lobe masses at the camera's inclination, 1 to the table's 2·10⁻³ between rows.
#[test]
fn white_furnace_of_lossless_deon_hair_is_one() {
    let Some(gpu) = common::gpu() else { return };
    assert_white_furnace(gpu, fiberlab_scatter::build("deon", &[("sigma_a", "0")]).unwrap(), "deon");
}

/// What a case adds to the scene: its lights (and a mirror).
type AddLights = Box<dyn Fn(&mut SceneBuilder)>;

/// GPU against CPU at the same seed, 32 spp: per-channel means within 1 %, and the 4×4-block
/// RMS difference below the noise (the RMS difference of two CPU renders with different seeds).
fn assert_matches_the_cpu(gpu: &Gpu, scene: &Scene, name: &str) {
    let s = settings(32);
    let g = gpu_render(gpu, scene, &s);
    let c = cpu_render(scene, &s);
    let c2 = cpu_render(scene, &RenderSettings { seed: 11, ..s.clone() });
    let (gm, cm) = (channel_means(&g.image), channel_means(&c.image));
    let (err, noise) = (block_rms(&g.image, &c.image), block_rms(&c2.image, &c.image));
    eprintln!(
        "{name}: GPU means {gm:.4?}, CPU {cm:.4?}; block RMS GPU−CPU {err:.5}, CPU−CPU {noise:.5}; rays GPU {} CPU {}",
        g.stats.rays, c.stats.rays
    );
    assert_eq!(g.stats.nonfinite_samples, 0, "{name}");
    for k in 0..3 {
        assert!((gm[k] / cm[k] - 1.0).abs() < 0.01, "{name}: channel {k}: GPU {} CPU {}", gm[k], cm[k]);
    }
    assert!(err < noise, "{name}: block RMS {err} above the noise {noise}");
}

/// Each light type (and the surface materials), GPU against CPU at the same seed: per-channel
/// means within 1 %, and the 4×4-block RMS difference below the noise (the RMS difference of
/// two CPU renders with different seeds).
#[test]
fn images_match_the_cpu_for_each_light_and_material() {
    let Some(gpu) = common::gpu() else { return };
    let sun = Light::sun(DVec3::new(1.0, 1.3, 0.5), 0.05, Rgb::new(3.0, 2.8, 2.5));
    let cases: Vec<(&str, AddLights)> = vec![
        (
            "sky",
            Box::new(|b: &mut SceneBuilder| {
                b.light(Light::Constant { radiance: Rgb::new(0.5, 0.6, 0.8) });
            }),
        ),
        (
            "sun and sky",
            Box::new(move |b: &mut SceneBuilder| {
                b.light(sun.clone()).light(Light::Constant { radiance: Rgb::new(0.2, 0.25, 0.3) });
            }),
        ),
        (
            "distant",
            Box::new(|b: &mut SceneBuilder| {
                b.light(Light::Distant {
                    direction: DVec3::new(-0.5, 1.0, 0.8).normalize(),
                    irradiance: Rgb::splat(2.0),
                });
            }),
        ),
        (
            "sphere light",
            Box::new(|b: &mut SceneBuilder| {
                let white = b.surface_material(SurfaceMaterial::Lambert(Rgb::ONE));
                b.sphere(DVec3::new(1.5, 1.5, 1.5), 0.4, white, Some(Rgb::splat(6.0)));
            }),
        ),
        (
            "mirror and sky",
            Box::new(|b: &mut SceneBuilder| {
                let mirror = b.surface_material(SurfaceMaterial::Mirror(Rgb::splat(0.9)));
                b.sphere(DVec3::new(-1.1, -0.3, -0.8), 0.5, mirror, None);
                b.light(Light::Constant { radiance: Rgb::new(0.5, 0.6, 0.8) });
            }),
        ),
    ];
    for (name, lights) in &cases {
        let make = || {
            let mut b = builder();
            let hair_m = b.fiber_material(chiang(&[("eumelanin", "0.3"), ("beta_m", "0.25")]));
            let skin = b.surface_material(SurfaceMaterial::Lambert(Rgb::new(0.6, 0.45, 0.35)));
            let floor = b.surface_material(SurfaceMaterial::Lambert(Rgb::splat(0.4)));
            b.fibers(hair(200), hair_m);
            b.sphere(DVec3::new(0.0, -0.4, -0.3), 0.6, skin, None);
            b.mesh(TriangleMesh::floor(-1.0, 10.0), floor);
            lights(&mut b);
            b.build()
        };
        assert_matches_the_cpu(gpu, &make(), name);
    }
}

/// Kajiya–Kay hair (its tabulated specular lobe copied to the GPU) under sun and sky, GPU
/// against CPU at the same seed, as above.
#[test]
fn kajiya_kay_images_match_the_cpu() {
    let Some(gpu) = common::gpu() else { return };
    let mut b = builder();
    let kk = fiberlab_scatter::build("kajiya-kay", &[("k_d", "0.04,0.03,0.02"), ("k_s", "0.3"), ("p", "60")]).unwrap();
    let hair_m = b.fiber_material(kk);
    let skin = b.surface_material(SurfaceMaterial::Lambert(Rgb::new(0.6, 0.45, 0.35)));
    b.fibers(hair(200), hair_m);
    b.sphere(DVec3::new(0.0, -0.4, -0.3), 0.6, skin, None);
    b.light(Light::sun(DVec3::new(1.0, 1.3, 0.5), 0.05, Rgb::new(3.0, 2.8, 2.5)));
    b.light(Light::Constant { radiance: Rgb::new(0.2, 0.25, 0.3) });
    assert_matches_the_cpu(gpu, &b.build(), "kajiya-kay");
}

/// Marschner hair (exact roots, glints) under sun and sky, GPU against CPU at the same seed, as
/// above.
#[test]
fn marschner_images_match_the_cpu() {
    let Some(gpu) = common::gpu() else { return };
    let mut b = builder();
    let hair_m = b.fiber_material(fiberlab_scatter::build("marschner", &[("sigma_a", "0.4,0.6,1.0")]).unwrap());
    let skin = b.surface_material(SurfaceMaterial::Lambert(Rgb::new(0.6, 0.45, 0.35)));
    b.fibers(hair(200), hair_m);
    b.sphere(DVec3::new(0.0, -0.4, -0.3), 0.6, skin, None);
    b.light(Light::sun(DVec3::new(1.0, 1.3, 0.5), 0.05, Rgb::new(3.0, 2.8, 2.5)));
    b.light(Light::Constant { radiance: Rgb::new(0.2, 0.25, 0.3) });
    assert_matches_the_cpu(gpu, &b.build(), "marschner");
}

/// Each reference fiber (diffuse, Lambertian cylinder, Goldman, and the specular fiber's delta
/// lobe with a mirror cross-section and Fresnel) under sun and sky, GPU against CPU at the same
/// seed, as above.
#[test]
fn reference_fiber_images_match_the_cpu() {
    let Some(gpu) = common::gpu() else { return };
    let fibers: [(&str, &[(&str, &str)]); 4] = [
        ("diffuse", &[("albedo", "0.7,0.5,0.3")]),
        ("lambertian-cylinder", &[("albedo", "0.7,0.5,0.3")]),
        ("goldman", &[("k_d", "0.05,0.04,0.03"), ("k_s", "0.3"), ("p", "40"), ("rho_transmit", "0.3,0.2,0.1")]),
        ("specular", &[("azimuth", "mirror"), ("fresnel", "on"), ("eta", "1.55")]),
    ];
    for (name, params) in fibers {
        let mut b = builder();
        let hair_m = b.fiber_material(fiberlab_scatter::build(name, params).unwrap());
        let skin = b.surface_material(SurfaceMaterial::Lambert(Rgb::new(0.6, 0.45, 0.35)));
        b.fibers(hair(200), hair_m);
        b.sphere(DVec3::new(0.0, -0.4, -0.3), 0.6, skin, None);
        b.light(Light::sun(DVec3::new(1.0, 1.3, 0.5), 0.05, Rgb::new(3.0, 2.8, 2.5)));
        b.light(Light::Constant { radiance: Rgb::new(0.2, 0.25, 0.3) });
        assert_matches_the_cpu(gpu, &b.build(), name);
    }
}

/// d'Eon hair (its azimuthal table copied to the GPU) under sun and sky, GPU against CPU at the
/// same seed, as above.
#[test]
fn deon_images_match_the_cpu() {
    let Some(gpu) = common::gpu() else { return };
    let mut b = builder();
    let hair_m =
        b.fiber_material(fiberlab_scatter::build("deon", &[("eumelanin", "0.3"), ("beta_m", "0.25")]).unwrap());
    let skin = b.surface_material(SurfaceMaterial::Lambert(Rgb::new(0.6, 0.45, 0.35)));
    b.fibers(hair(200), hair_m);
    b.sphere(DVec3::new(0.0, -0.4, -0.3), 0.6, skin, None);
    b.light(Light::sun(DVec3::new(1.0, 1.3, 0.5), 0.05, Rgb::new(3.0, 2.8, 2.5)));
    b.light(Light::Constant { radiance: Rgb::new(0.2, 0.25, 0.3) });
    assert_matches_the_cpu(gpu, &b.build(), "deon");
}

/// Yan fur (its medulla tables copied to the GPU; a thick medulla, so the scattered lobes carry
/// much of the light) under sun and sky, GPU against CPU at the same seed, as above.
#[test]
fn yan_fur_images_match_the_cpu() {
    let Some(gpu) = common::gpu() else { return };
    let mut b = builder();
    let fur = fiberlab_scatter::build("yan-fur", &[("kappa", "0.7"), ("sigma_m_s", "3"), ("g", "0.4")]).unwrap();
    let hair_m = b.fiber_material(fur);
    let skin = b.surface_material(SurfaceMaterial::Lambert(Rgb::new(0.6, 0.45, 0.35)));
    b.fibers(hair(200), hair_m);
    b.sphere(DVec3::new(0.0, -0.4, -0.3), 0.6, skin, None);
    b.light(Light::sun(DVec3::new(1.0, 1.3, 0.5), 0.05, Rgb::new(3.0, 2.8, 2.5)));
    b.light(Light::Constant { radiance: Rgb::new(0.2, 0.25, 0.3) });
    assert_matches_the_cpu(gpu, &b.build(), "yan-fur");
}

/// Hollow fibers (an air lumen of half the radius in an absorbing wall) under sun and sky, GPU
/// against CPU at the same seed, as above.
#[test]
fn hollow_fiber_images_match_the_cpu() {
    let Some(gpu) = common::gpu() else { return };
    let mut b = builder();
    let fiber = fiberlab_scatter::build("hollow-fiber", &[("kappa", "0.5"), ("sigma_a", "0.4,0.6,1.0")]).unwrap();
    let hair_m = b.fiber_material(fiber);
    let skin = b.surface_material(SurfaceMaterial::Lambert(Rgb::new(0.6, 0.45, 0.35)));
    b.fibers(hair(200), hair_m);
    b.sphere(DVec3::new(0.0, -0.4, -0.3), 0.6, skin, None);
    b.light(Light::sun(DVec3::new(1.0, 1.3, 0.5), 0.05, Rgb::new(3.0, 2.8, 2.5)));
    b.light(Light::Constant { radiance: Rgb::new(0.2, 0.25, 0.3) });
    assert_matches_the_cpu(gpu, &b.build(), "hollow-fiber");
}

/// Huang 2022 (elliptical fibers of random orientation, a rough surface, its TRRT+ residual)
/// under sun and sky, GPU against CPU at the same seed, as above.
#[test]
fn huang_images_match_the_cpu() {
    let Some(gpu) = common::gpu() else { return };
    let mut b = builder();
    let params = [("roughness", "0.2"), ("aspect", "0.6"), ("orientation", "average"), ("eumelanin", "0.4")];
    let hair_m = b.fiber_material(fiberlab_scatter::build("huang-2022", &params).unwrap());
    let skin = b.surface_material(SurfaceMaterial::Lambert(Rgb::new(0.6, 0.45, 0.35)));
    b.fibers(hair(200), hair_m);
    b.sphere(DVec3::new(0.0, -0.4, -0.3), 0.6, skin, None);
    b.light(Light::sun(DVec3::new(1.0, 1.3, 0.5), 0.05, Rgb::new(3.0, 2.8, 2.5)));
    b.light(Light::Constant { radiance: Rgb::new(0.2, 0.25, 0.3) });
    assert_matches_the_cpu(gpu, &b.build(), "huang-2022");
}

/// A surface model as the scene file makes it.
fn surface_model(name: &str, params: &[(&str, &str)]) -> SurfaceMaterial {
    let spec = fiberlab_scatter::find_surface(name).unwrap();
    let model = fiberlab_scatter::build_surface(name, params).unwrap();
    SurfaceMaterial::Model(Box::new(ModelMaterial::new(spec.name, spec.params, model, &[]).unwrap()))
}

/// Leaves (the two-sided `leaf` model: cuticle, body reflection and transmission) on a bent
/// quad with corner normals and texture coordinates (so interpolated normals and uv tangents)
/// and on a sphere, with hair and a floor, under a low sun and sky: GPU against CPU at the
/// same seed, as above.
#[test]
fn leaf_images_match_the_cpu() {
    let Some(gpu) = common::gpu() else { return };
    let mut b = builder();
    let leaf = b.surface_material(surface_model("leaf", &[("roughness", "0.2")]));
    let dry = b.surface_material(surface_model("leaf", &[("cab", "5"), ("cbrown", "1.5"), ("roughness", "0.6")]));
    let floor = b.surface_material(SurfaceMaterial::Lambert(Rgb::splat(0.4)));
    let hair_m = b.fiber_material(chiang(&[("eumelanin", "0.3"), ("beta_m", "0.25")]));
    let (p, n) = (
        [
            DVec3::new(-1.4, -0.9, -0.4),
            DVec3::new(0.4, -0.9, -0.9),
            DVec3::new(0.6, 0.7, -0.5),
            DVec3::new(-1.2, 0.6, 0.1),
        ],
        [DVec3::new(-0.3, 0.2, 1.0), DVec3::new(0.2, 0.1, 1.0), DVec3::new(0.3, -0.2, 1.0), DVec3::new(-0.2, 0.1, 1.0)],
    );
    let uv = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
    let quad = TriangleMesh::with_attributes(
        vec![[p[0], p[1], p[2]], [p[0], p[2], p[3]]],
        vec![[uv[0], uv[1], uv[2]], [uv[0], uv[2], uv[3]]],
        [[n[0], n[1], n[2]], [n[0], n[2], n[3]]].map(|t| t.map(DVec3::normalize)).to_vec(),
    );
    b.mesh(quad, leaf);
    b.sphere(DVec3::new(0.9, -0.5, 0.3), 0.45, dry, None);
    b.fibers(hair(100), hair_m);
    b.mesh(TriangleMesh::floor(-1.0, 10.0), floor);
    b.light(Light::sun(DVec3::new(-0.6, 0.5, -1.0), 0.05, Rgb::new(3.0, 2.8, 2.5)));
    b.light(Light::Constant { radiance: Rgb::new(0.2, 0.25, 0.3) });
    assert_matches_the_cpu(gpu, &b.build(), "leaf");
}

/// Woven cloth (`irawan-2012`): staple-yarn denim on a bent quad with corner normals and texture
/// coordinates, the pattern repeated 3 × 3 times (`uv_scale`), and filament-yarn charmeuse on a
/// sphere (its spherical coordinates, 8 × 4 repeats), with hair and a floor, under a low sun and
/// sky: GPU against CPU at the same seed, as above.
#[test]
fn irawan_images_match_the_cpu() {
    let Some(gpu) = common::gpu() else { return };
    let cloth = |preset: &str, scale: [f64; 2]| {
        let spec = fiberlab_scatter::find_surface("irawan-2012").unwrap();
        let model = fiberlab_scatter::build_surface("irawan-2012", &[("preset", preset)]).unwrap();
        let m = ModelMaterial::new(spec.name, spec.params, model, &[]).unwrap();
        SurfaceMaterial::Model(Box::new(m.with_uv_scale(scale).unwrap()))
    };
    let mut b = builder();
    let denim = b.surface_material(cloth("cotton-denim", [3.0, 3.0]));
    let silk = b.surface_material(cloth("silk-charmeuse", [8.0, 4.0]));
    let floor = b.surface_material(SurfaceMaterial::Lambert(Rgb::splat(0.4)));
    let hair_m = b.fiber_material(chiang(&[("eumelanin", "0.3"), ("beta_m", "0.25")]));
    let (p, n) = (
        [
            DVec3::new(-1.4, -0.9, -0.4),
            DVec3::new(0.4, -0.9, -0.9),
            DVec3::new(0.6, 0.7, -0.5),
            DVec3::new(-1.2, 0.6, 0.1),
        ],
        [DVec3::new(-0.3, 0.2, 1.0), DVec3::new(0.2, 0.1, 1.0), DVec3::new(0.3, -0.2, 1.0), DVec3::new(-0.2, 0.1, 1.0)],
    );
    let uv = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
    let quad = TriangleMesh::with_attributes(
        vec![[p[0], p[1], p[2]], [p[0], p[2], p[3]]],
        vec![[uv[0], uv[1], uv[2]], [uv[0], uv[2], uv[3]]],
        [[n[0], n[1], n[2]], [n[0], n[2], n[3]]].map(|t| t.map(DVec3::normalize)).to_vec(),
    );
    b.mesh(quad, denim);
    b.sphere(DVec3::new(0.9, -0.5, 0.3), 0.45, silk, None);
    b.fibers(hair(100), hair_m);
    b.mesh(TriangleMesh::floor(-1.0, 10.0), floor);
    b.light(Light::sun(DVec3::new(-0.6, 0.5, 1.0), 0.05, Rgb::new(3.0, 2.8, 2.5)));
    b.light(Light::Constant { radiance: Rgb::new(0.2, 0.25, 0.3) });
    assert_matches_the_cpu(gpu, &b.build(), "irawan-2012");
}

/// The `lambertian` surface model with a uv-mapped albedo texture (8 × 4 texels, linear EXR): on
/// a bent quad with texture coordinates (repeated twice along u) and on a sphere (its spherical
/// coordinates, clamped), and untextured on the floor, with hair, under sun and sky: GPU against
/// CPU at the same seed, as above.
#[test]
fn textured_lambertian_images_match_the_cpu() {
    let Some(gpu) = common::gpu() else { return };
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("albedo.exr");
    let texels = (0..32)
        .map(|k| {
            let (x, y) = (k % 8, k / 8);
            let c = if (x + y) % 2 == 0 { 0.85 } else { 0.15 };
            [c, 0.2 + 0.1 * y as f32, 0.9 - 0.1 * x as f32]
        })
        .collect();
    LinearImage::from_pixels(8, 4, texels).unwrap().write_exr(&path).unwrap();
    let textured = |source: TextureSource| {
        let spec = fiberlab_scatter::find_surface("lambertian").unwrap();
        let model = fiberlab_scatter::build_surface::<&str, &str>("lambertian", &[]).unwrap();
        let textures = [("k_d".to_string(), source)];
        SurfaceMaterial::Model(Box::new(ModelMaterial::new(spec.name, spec.params, model, &textures).unwrap()))
    };
    let mut b = builder();
    let tiled = b.surface_material(textured(TextureSource { scale: [2.0, 1.0], ..TextureSource::file(path.clone()) }));
    let clamped = b.surface_material(textured(TextureSource { wrap: Wrap::Clamp, ..TextureSource::file(path) }));
    let floor = b.surface_material(surface_model("lambertian", &[("k_d", "0.3,0.35,0.4")]));
    let hair_m = b.fiber_material(chiang(&[("eumelanin", "0.3"), ("beta_m", "0.25")]));
    let p = [
        DVec3::new(-1.4, -0.9, -0.4),
        DVec3::new(0.4, -0.9, -0.9),
        DVec3::new(0.6, 0.7, -0.5),
        DVec3::new(-1.2, 0.6, 0.1),
    ];
    let uv = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
    let quad = TriangleMesh::with_attributes(
        vec![[p[0], p[1], p[2]], [p[0], p[2], p[3]]],
        vec![[uv[0], uv[1], uv[2]], [uv[0], uv[2], uv[3]]],
        Vec::new(),
    );
    b.mesh(quad, tiled);
    b.sphere(DVec3::new(0.9, -0.5, 0.3), 0.45, clamped, None);
    b.fibers(hair(100), hair_m);
    b.mesh(TriangleMesh::floor(-1.0, 10.0), floor);
    b.light(Light::sun(DVec3::new(1.0, 1.3, 0.5), 0.05, Rgb::new(3.0, 2.8, 2.5)));
    b.light(Light::Constant { radiance: Rgb::new(0.2, 0.25, 0.3) });
    assert_matches_the_cpu(gpu, &b.build(), "textured lambertian");
}

/// The `wood` surface model: a plank (a bent quad with texture coordinates) of rough-finished
/// wood whose k_d (colour), fiber angle and dip (degrees) are uv-mapped textures (linear EXRs,
/// the angle's repeated twice along u, the dip's clamped), and a tiger's-eye sphere (smooth
/// finish: a delta mirror lobe), with hair and a floor, under sun and sky: GPU against CPU at the
/// same seed, as above.
#[test]
fn wood_images_match_the_cpu() {
    let Some(gpu) = common::gpu() else { return };
    let dir = tempfile::tempdir().unwrap();
    let texture = |name: &str, w: usize, h: usize, texel: &dyn Fn(usize, usize) -> [f32; 3]| {
        let path = dir.path().join(name);
        let texels = (0..w * h).map(|k| texel(k % w, k / w)).collect();
        LinearImage::from_pixels(w, h, texels).unwrap().write_exr(&path).unwrap();
        path
    };
    let k_d = texture("k_d.exr", 8, 4, &|x, y| [0.3 + 0.05 * x as f32, 0.2 + 0.03 * y as f32, 0.1]);
    let angle = texture("angle.exr", 6, 3, &|x, y| [(30 * x) as f32 - 60.0 + (10 * y) as f32; 3]);
    let dip = texture("dip.exr", 4, 4, &|x, y| [if (x + y) % 2 == 0 { 35.0 } else { -20.0 }; 3]);
    let spec = fiberlab_scatter::find_surface("wood").unwrap();
    let model =
        fiberlab_scatter::build_surface("wood", &[("roughness", "0.1"), ("beta", "8"), ("k_f", "0.08,0.06,0.04")])
            .unwrap();
    let textures = [
        ("k_d".to_string(), TextureSource::file(k_d)),
        ("fiber_angle".to_string(), TextureSource { scale: [2.0, 1.0], ..TextureSource::file(angle) }),
        ("fiber_dip".to_string(), TextureSource { wrap: Wrap::Clamp, ..TextureSource::file(dip) }),
    ];
    let mut b = builder();
    let plank = b.surface_material(SurfaceMaterial::Model(Box::new(
        ModelMaterial::new(spec.name, spec.params, model, &textures).unwrap(),
    )));
    let stone = b.surface_material(surface_model("wood", &[("preset", "tigers-eye")]));
    let floor = b.surface_material(SurfaceMaterial::Lambert(Rgb::splat(0.4)));
    let hair_m = b.fiber_material(chiang(&[("eumelanin", "0.3"), ("beta_m", "0.25")]));
    let p = [
        DVec3::new(-1.4, -0.9, -0.4),
        DVec3::new(0.4, -0.9, -0.9),
        DVec3::new(0.6, 0.7, -0.5),
        DVec3::new(-1.2, 0.6, 0.1),
    ];
    let uv = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
    let quad = TriangleMesh::with_attributes(
        vec![[p[0], p[1], p[2]], [p[0], p[2], p[3]]],
        vec![[uv[0], uv[1], uv[2]], [uv[0], uv[2], uv[3]]],
        Vec::new(),
    );
    b.mesh(quad, plank);
    b.sphere(DVec3::new(0.9, -0.5, 0.3), 0.45, stone, None);
    b.fibers(hair(100), hair_m);
    b.mesh(TriangleMesh::floor(-1.0, 10.0), floor);
    b.light(Light::sun(DVec3::new(0.8, 1.3, 0.9), 0.05, Rgb::new(3.0, 2.8, 2.5)));
    b.light(Light::Constant { radiance: Rgb::new(0.2, 0.25, 0.3) });
    assert_matches_the_cpu(gpu, &b.build(), "wood");
}

/// The `sadeghi-2013` cloth (linen with overridden thread parameters and uv-mapped textures of
/// thread 1's albedo and thread 2's γ_s (degrees) on a bent quad whose uv tangents turn the
/// weave, satin on a sphere), with hair and a floor, under sun and sky: GPU against CPU at the
/// same seed, as above.
#[test]
fn sadeghi_images_match_the_cpu() {
    let Some(gpu) = common::gpu() else { return };
    let dir = tempfile::tempdir().unwrap();
    let texture = |name: &str, texel: &dyn Fn(usize, usize) -> [f32; 3]| {
        let path = dir.path().join(name);
        let texels = (0..12).map(|k| texel(k % 4, k / 4)).collect();
        LinearImage::from_pixels(4, 3, texels).unwrap().write_exr(&path).unwrap();
        path
    };
    let albedo = texture("albedo.exr", &|x, y| [0.1 + 0.2 * x as f32, 0.5 - 0.1 * y as f32, 0.3]);
    let gamma = texture("gamma.exr", &|x, y| [(4 + 6 * ((x + y) % 3)) as f32; 3]);
    let spec = fiberlab_scatter::find_surface("sadeghi-2013").unwrap();
    let model = fiberlab_scatter::build_surface(
        "sadeghi-2013",
        &[("preset", "linen-plain"), ("gamma_s_1", "15"), ("k_d_2", "0.05")],
    )
    .unwrap();
    let textures = [
        ("albedo_1".to_string(), TextureSource::file(albedo)),
        ("gamma_s_2".to_string(), TextureSource { scale: [2.0, 1.0], ..TextureSource::file(gamma) }),
    ];
    let mut b = builder();
    let linen = b.surface_material(SurfaceMaterial::Model(Box::new(
        ModelMaterial::new(spec.name, spec.params, model, &textures).unwrap(),
    )));
    let satin = b.surface_material(surface_model("sadeghi-2013", &[("preset", "polyester-satin-charmeuse")]));
    let floor = b.surface_material(SurfaceMaterial::Lambert(Rgb::splat(0.4)));
    let hair_m = b.fiber_material(chiang(&[("eumelanin", "0.3"), ("beta_m", "0.25")]));
    let p = [
        DVec3::new(-1.4, -0.9, -0.4),
        DVec3::new(0.4, -0.9, -0.9),
        DVec3::new(0.6, 0.7, -0.5),
        DVec3::new(-1.2, 0.6, 0.1),
    ];
    let uv = [[0.0, 0.0], [1.0, 0.2], [0.8, 1.0], [-0.2, 0.8]];
    let quad = TriangleMesh::with_attributes(
        vec![[p[0], p[1], p[2]], [p[0], p[2], p[3]]],
        vec![[uv[0], uv[1], uv[2]], [uv[0], uv[2], uv[3]]],
        Vec::new(),
    );
    b.mesh(quad, linen);
    b.sphere(DVec3::new(0.9, -0.5, 0.3), 0.45, satin, None);
    b.fibers(hair(100), hair_m);
    b.mesh(TriangleMesh::floor(-1.0, 10.0), floor);
    b.light(Light::sun(DVec3::new(0.8, 1.3, 0.9), 0.05, Rgb::new(3.0, 2.8, 2.5)));
    b.light(Light::Constant { radiance: Rgb::new(0.2, 0.25, 0.3) });
    assert_matches_the_cpu(gpu, &b.build(), "sadeghi-2013");
}

/// An importance-sampled environment map (a blue-white sky gradient with a small warm bright
/// patch, 64 × 32 cells), GPU against CPU at the same seed, as above: the map's cells, row and
/// column CDFs are copied to the GPU and sampled there as on the CPU.
#[test]
fn environment_map_images_match_the_cpu() {
    let Some(gpu) = common::gpu() else { return };
    let (w, h) = (64, 32);
    let mut px = Vec::with_capacity(w * h);
    for y in 0..h {
        for x in 0..w {
            let t = y as f32 / h as f32;
            let patch = (x as i32 - 40).abs() <= 1 && (y as i32 - 9).abs() <= 1;
            px.push(if patch { [40.0, 30.0, 18.0] } else { [0.3 + 0.5 * t, 0.4 + 0.4 * t, 0.9 - 0.2 * t] });
        }
    }
    let map = EnvironmentMap::new(LinearImage::from_pixels(w, h, px).unwrap(), Rgb::ONE);
    let mut b = builder();
    let hair_m = b.fiber_material(chiang(&[("eumelanin", "0.3"), ("beta_m", "0.25")]));
    let skin = b.surface_material(SurfaceMaterial::Lambert(Rgb::new(0.6, 0.45, 0.35)));
    b.fibers(hair(200), hair_m);
    b.sphere(DVec3::new(0.0, -0.4, -0.3), 0.6, skin, None);
    b.light(Light::Map(Box::new(map)));
    assert_matches_the_cpu(gpu, &b.build(), "environment map");
}

/// The progressive state on the GPU: a render stopped at 4 spp and continued to 8 equals one
/// render to 8 bit for bit; so do two tiles merged and a render in small chunks; a render begun
/// on the GPU continues on the CPU to the requested spp; a stop before anything keeps nothing.
#[test]
fn progressive_state_resumes_across_stops_tiles_chunks_and_devices() {
    let Some(gpu) = common::gpu() else { return };
    let mut b = builder();
    let m = b.fiber_material(chiang(&[]));
    let skin = b.surface_material(SurfaceMaterial::Lambert(Rgb::splat(0.5)));
    b.fibers(hair(200), m).sphere(DVec3::new(0.0, -0.4, -0.3), 0.6, skin, None);
    b.light(Light::sun(DVec3::new(1.0, 1.0, 1.0), 0.05, Rgb::splat(2.0)));
    let scene = b.build();
    let s8 = settings(8);
    let whole = gpu_render(gpu, &scene, &s8);
    assert_eq!((whole.stats.spp_min, whole.stats.spp_max), (8, 8));
    let none = AtomicBool::new(false);
    let four = gpu_render(gpu, &scene, &settings(4));
    let resumed = fiberlab_gpu::render_continuing(
        gpu,
        &scene,
        &s8,
        GpuOptions::default(),
        four.accumulation.clone(),
        &|_| {},
        &none,
    )
    .unwrap();
    assert_eq!(resumed.image, whole.image);
    let chunked = fiberlab_gpu::render(gpu, &scene, &s8, GpuOptions { max_paths: 100 }, &|_| {}, &none).unwrap();
    assert_eq!(chunked.image, whole.image);
    let parts: Vec<LinearImage> = (0..2)
        .map(|i| {
            gpu_render(gpu, &scene, &RenderSettings { region: Some(Region::part(i, 2, SIDE, SIDE)), ..s8.clone() })
                .image
        })
        .collect();
    assert_eq!(merge(&parts).unwrap(), whole.image);
    // GPU to 4 spp, then the CPU to 8: every pixel has 8 samples, the first 4 the GPU's.
    let state = Accumulation::from_image(&four.image, SIDE, SIDE).unwrap();
    let cpu = integrator::render_continuing(&scene, &s8, state, &|_| {}, &none).unwrap();
    assert_eq!((cpu.stats.spp_min, cpu.stats.spp_max), (8, 8));
    assert_eq!(cpu.stats.samples, u64::from(SIDE * SIDE * 4));
    let (a, b) = (channel_means(&cpu.image), channel_means(&whole.image));
    assert!((a[1] / b[1] - 1.0).abs() < 0.05, "{a:?} vs {b:?}");
    let stopped =
        fiberlab_gpu::render(gpu, &scene, &s8, GpuOptions::default(), &|_| {}, &AtomicBool::new(true)).unwrap();
    assert!(stopped.stats.interrupted && stopped.stats.samples == 0);
}

/// What the GPU does not render is refused with the reason.
#[test]
fn unsupported_models_are_refused_by_name() {
    let Some(gpu) = common::gpu() else { return };
    let mut b = builder();
    let m = b.fiber_material(fiberlab_scatter::build::<&str, &str>("sadeghi-thread", &[]).unwrap());
    b.fibers(hair(10), m).light(Light::Constant { radiance: Rgb::ONE });
    let err =
        fiberlab_gpu::render(gpu, &b.build(), &settings(1), GpuOptions::default(), &|_| {}, &AtomicBool::new(false))
            .unwrap_err()
            .to_string();
    assert!(
        err.contains("`sadeghi-thread`")
            && err.contains("huang-2022")
            && err.contains("goldman")
            && err.contains("--device cpu"),
        "{err}"
    );
    let mut b = builder();
    let model = fiberlab_scatter::build_surface("irawan-2012", &[("spine", "conic")]).unwrap();
    let spec = fiberlab_scatter::find_surface("irawan-2012").unwrap();
    let conic = b.surface_material(SurfaceMaterial::Model(Box::new(
        ModelMaterial::new(spec.name, spec.params, model, &[]).unwrap(),
    )));
    b.mesh(TriangleMesh::floor(-1.0, 10.0), conic).light(Light::Constant { radiance: Rgb::ONE });
    let err =
        fiberlab_gpu::render(gpu, &b.build(), &settings(1), GpuOptions::default(), &|_| {}, &AtomicBool::new(false))
            .unwrap_err()
            .to_string();
    assert!(err.contains("`irawan-2012` with spine") && err.contains("--device cpu"), "{err}");
    let mut b = builder();
    let far = fiberlab_scatter::build("hollow-fiber", &[("field", "far")]).unwrap();
    let m = b.fiber_material(far);
    b.fibers(hair(10), m).light(Light::Constant { radiance: Rgb::ONE });
    let err =
        fiberlab_gpu::render(gpu, &b.build(), &settings(1), GpuOptions::default(), &|_| {}, &AtomicBool::new(false))
            .unwrap_err()
            .to_string();
    assert!(err.contains("`hollow-fiber`") && err.contains("field = near"), "{err}");
}
