//! Splits the error of hair images by how the sun reaches the fiber each pixel sees: the
//! camera ray through the pixel centre, if its first hit is a fiber, a ray from there toward
//! the sun: hidden by a surface (the head, the floor), or crossing `n` fibers (exact count,
//! the shading strand skipped within four radii as in dual scattering). Per class: pixels,
//! the reference's mean luminance, and each image's relative error of its mean luminance.
//! Usage: `cargo run --release -p fiberlab-render --example dual_regions -- SCENE.toml
//! REFERENCE.exr IMAGE.exr…` (images of that scene's camera; the scene needs a sun).
use fiberlab_geometry::Ray;
use fiberlab_geometry::shapes::sphere_hit;
use fiberlab_io::LinearImage;
use fiberlab_math::Rgb;
use fiberlab_render::dual_scattering::{DualScattering, DualScatteringSettings, RENDER_TABLE_RESOLUTION};
use fiberlab_render::light::Light;
use fiberlab_render::scene::Hit;
use fiberlab_render::scene_file::SceneFile;
use std::path::Path;

const CLASSES: [&str; 6] = ["sun hidden by a surface", "0 fibers", "1-3 fibers", "4-15 fibers", "16-63 fibers", "64+"];

fn class_of(n: f64) -> usize {
    match n as u64 {
        0 => 1,
        1..=3 => 2,
        4..=15 => 3,
        16..=63 => 4,
        _ => 5,
    }
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.len() < 3 {
        eprintln!("usage: dual_regions SCENE.toml REFERENCE.exr IMAGE.exr…");
        std::process::exit(2);
    }
    let file = SceneFile::read(Path::new(&args[0])).unwrap_or_else(|e| panic!("{e}"));
    let (scene, _) = file.build().unwrap_or_else(|e| panic!("{e}"));
    let sun = scene
        .lights()
        .iter()
        .find_map(|l| match l {
            Light::Sun { direction, .. } | Light::Distant { direction, .. } => Some(*direction),
            _ => None,
        })
        .expect("the scene has no sun");
    let read = |p: &String| LinearImage::read_exr(Path::new(p)).unwrap_or_else(|e| panic!("{p}: {e}"));
    let reference = read(&args[1]);
    let images: Vec<LinearImage> = args[2..].iter().map(read).collect();
    let counter = DualScattering::new(
        &scene,
        DualScatteringSettings { count_cutoff: 0.0, ..Default::default() },
        &RENDER_TABLE_RESOLUTION,
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let camera = scene.camera();
    let (w, h) = (camera.width as usize, camera.height as usize);
    assert_eq!((reference.width(), reference.height()), (w, h), "the reference is not of this camera");
    let mut pixels = [0usize; CLASSES.len()];
    let mut sums = vec![[0.0f64; CLASSES.len()]; images.len() + 1];
    let lum = |p: [f32; 3]| Rgb::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2])).luminance();
    for y in 0..h {
        for x in 0..w {
            let ray = camera.ray(x as f64 + 0.5, y as f64 + 0.5);
            let Some(Hit::Fiber { hit, .. }) = scene.intersect(&ray) else { continue };
            let eps = 1e-9 * (1.0 + hit.p.abs().max_element());
            let shadow = Ray { o: hit.p, d: sun, t_min: eps, t_max: f64::INFINITY };
            let hidden =
                scene.spheres().iter().any(|s| {
                    sphere_hit(shadow.o, shadow.d, s.center(), s.radius(), shadow.t_min, shadow.t_max).is_some()
                }) || scene.meshes().iter().any(|m| m.mesh().occluded(&shadow));
            let class = if hidden {
                0
            } else {
                let skip = scene.fibers().iter().position(|f| f.curves().segment_count() > 0).map(|a| (a, hit.strand));
                class_of(counter.count(&scene, &shadow, skip, 4.0 * hit.radius).0)
            };
            pixels[class] += 1;
            sums[0][class] += lum(reference.get(x, y));
            for (s, img) in sums[1..].iter_mut().zip(&images) {
                s[class] += lum(img.get(x, y));
            }
        }
    }
    let total: usize = pixels.iter().sum();
    let ref_total: f64 = sums[0].iter().sum();
    println!("| class | pixels | reference share | {} |", args[2..].join(" | "));
    println!("|---|---|---|{}", "---|".repeat(images.len()));
    for (c, name) in CLASSES.iter().enumerate() {
        if pixels[c] == 0 {
            continue;
        }
        let errors: Vec<String> = sums[1..].iter().map(|s| format!("{:+.3}", s[c] / sums[0][c] - 1.0)).collect();
        println!("| {name} | {} | {:.3} | {} |", pixels[c], sums[0][c] / ref_total, errors.join(" | "));
    }
    let errors: Vec<String> =
        sums[1..].iter().map(|s| format!("{:+.3}", s.iter().sum::<f64>() / ref_total - 1.0)).collect();
    println!("| all fiber pixels | {total} | 1.000 | {} |", errors.join(" | "));
}
