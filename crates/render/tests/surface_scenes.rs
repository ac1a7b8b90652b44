//! Scene files with surface-model materials, textures and cabochons.

use fiberlab_geometry::Ray;
use fiberlab_io::LinearImage;
use fiberlab_math::DVec3;
use fiberlab_render::scene::{Hit, SurfaceMaterial};
use fiberlab_render::scene_file::SceneFile;
use std::path::Path;

const CAMERA: &str = "[camera]\neye = [0, 3, 0.01]\ntarget = [0, 0, 0]\nfov = 30\nwidth = 4\nheight = 4\n";

fn build(dir: &Path, text: &str) -> Result<fiberlab_render::scene::Scene, String> {
    let path = dir.join("s.toml");
    std::fs::write(&path, text).unwrap();
    SceneFile::read(&path).and_then(|f| f.build()).map(|(s, _)| s).map_err(|e| e.to_string())
}

#[test]
fn a_textured_surface_model_material_on_a_cabochon() {
    let dir = tempfile::tempdir().unwrap();
    LinearImage::from_pixels(2, 1, vec![[0.2; 3], [0.6; 3]]).unwrap().write_exr(&dir.path().join("kd.exr")).unwrap();
    let text = format!(
        "{CAMERA}[materials.stone]\nmodel = \"lambertian\"\nparams = {{ k_d = {{ file = \"kd.exr\", wrap = \"clamp\" }} }}\n\
         [[mesh]]\ncabochon = {{ radius = 1.0, height = 0.5 }}\ntranslate = [0, 0.1, 0]\nmaterial = \"stone\"\n"
    );
    let scene = build(dir.path(), &text).unwrap();
    let ray = Ray::new(DVec3::new(0.0, 3.0, 0.0), -DVec3::Y);
    let Some(Hit::Surface { t, shading, material, .. }) = scene.intersect(&ray) else { panic!("the dome is hit") };
    assert!((3.0 - t - 0.6).abs() < 1e-3, "apex at 0.1 + 0.5: {}", 3.0 - t);
    let SurfaceMaterial::Model(m) = scene.surface_material(material) else { panic!("a model material") };
    assert_eq!((m.model_name(), m.textures().len()), ("lambertian", 1));
    let [u, v] = shading.uv.unwrap();
    assert!((u - 0.5).abs() < 1e-9 && (v - 0.5).abs() < 1e-9);
    // Untextured plain values pass through the registry, with its errors.
    let e = build(dir.path(), &format!("{CAMERA}[materials.s]\nmodel = \"lambertian\"\nparams = {{ k_d = 2 }}\n"))
        .unwrap_err();
    assert!(e.contains("material `s`") && e.contains("k_d"), "{e}");
    let e = build(
        dir.path(),
        &format!("{CAMERA}[materials.s]\nmodel = \"lambertian\"\nparams = {{ k_d = \"none.png\" }}\n"),
    )
    .unwrap_err();
    assert!(e.contains("material `s`: k_d: texture ") && e.contains("none.png"), "{e}");
}

#[test]
fn an_obj_without_uvs_under_a_textured_material_is_an_error_naming_the_mesh() {
    let dir = tempfile::tempdir().unwrap();
    LinearImage::from_pixels(1, 1, vec![[0.5; 3]]).unwrap().write_exr(&dir.path().join("kd.exr")).unwrap();
    std::fs::write(dir.path().join("bare.obj"), "v 0 0 0\nv 1 0 0\nv 1 0 1\nf 1 2 3\n").unwrap();
    let text = format!(
        "{CAMERA}[materials.t]\nmodel = \"lambertian\"\nparams = {{ k_d = \"kd.exr\" }}\n\
         [[mesh]]\nfile = \"bare.obj\"\nmaterial = \"t\"\n"
    );
    let e = build(dir.path(), &text).unwrap_err();
    assert!(e.contains("bare.obj: material `t` is textured but the mesh has no texture coordinates"), "{e}");
    // The same mesh under an untextured model material is fine.
    let ok = text.replace("params = { k_d = \"kd.exr\" }", "params = { k_d = 0.5 }");
    assert!(build(dir.path(), &ok).is_ok());
}

/// `params = { pattern = "weaves/….weave" }`: the weave file is read relative to the scene
/// file, and the material's model is the fabric of that file (its values at a highlight
/// equal those of the model built from the same file by hand); a bad file is an error naming
/// the scene file and line and the weave file, line and field.
#[test]
fn a_scene_material_reads_its_weave_pattern_relative_to_the_scene() {
    use fiberlab_scatter::SurfaceScattering;
    let dir = tempfile::tempdir().unwrap();
    let weaves = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/weaves");
    let text = std::fs::read_to_string(weaves.join("satin.weave")).unwrap();
    std::fs::create_dir(dir.path().join("weaves")).unwrap();
    std::fs::write(dir.path().join("weaves/satin.weave"), &text).unwrap();
    let scene_text = |file: &str| {
        format!(
            "{CAMERA}[materials.cloth]\nmodel = \"irawan-2012\"\nparams = {{ pattern = \"{file}\" }}\n\
             [[mesh]]\ncabochon = {{ radius = 1.0, height = 0.5 }}\nmaterial = \"cloth\"\n"
        )
    };
    let scene = build(dir.path(), &scene_text("weaves/satin.weave")).unwrap();
    let ray = Ray::new(DVec3::new(0.0, 3.0, 0.0), -DVec3::Y);
    let Some(Hit::Surface { material, .. }) = scene.intersect(&ray) else { panic!("the dome is hit") };
    let SurfaceMaterial::Model(m) = scene.surface_material(material) else { panic!("a model material") };
    let pattern = fiberlab_io::weave_pattern::parse_weave_pattern(&text, "satin.weave").unwrap();
    let mut by_hand = fiberlab_scatter::irawan_2012::Irawan2012::new(pattern).unwrap();
    let mut from_scene = m.model().clone();
    let (wi, wo) = (DVec3::new(0.0, -0.4, 0.9).normalize(), DVec3::new(0.0, 0.3, 0.95).normalize());
    let mut lit = 0;
    for k in 0..100 {
        let (u, v) = (0.1 + 0.008 * f64::from(k % 10), 0.01 * f64::from(k));
        by_hand.set_position(u, v);
        from_scene.set_parameter("u", fiberlab_math::Rgb::splat(u)).unwrap();
        from_scene.set_parameter("v", fiberlab_math::Rgb::splat(v)).unwrap();
        let (a, b) = (by_hand.eval(wi, wo), from_scene.eval(wi, wo));
        assert_eq!(a, b, "({u}, {v})");
        lit += usize::from(a[0] > 0.3 / std::f64::consts::PI * 1.01);
    }
    assert!(lit > 0, "a highlight among the points");
    std::fs::write(dir.path().join("weaves/bad.weave"), text.replace("umax=35", "umax=95")).unwrap();
    let e = build(dir.path(), &scene_text("weaves/bad.weave")).unwrap_err();
    assert!(e.contains("s.toml:") && e.contains("material `cloth`"), "{e}");
    assert!(e.contains("bad.weave:12:") && e.contains("umax"), "{e}");
    let e = build(dir.path(), &scene_text("weaves/missing.weave")).unwrap_err();
    assert!(e.contains("s.toml:") && e.contains("missing.weave"), "{e}");
}
