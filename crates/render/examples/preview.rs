//! Renders the built-in default scene to `preview.exr` / `preview.png` and prints timings.
//! Usage: `cargo run --release -p fiberlab-render --example preview [SPP] [THREADS]`.
use fiberlab_io::ToneMap;
use fiberlab_render::scene_file::SceneFile;
use std::sync::atomic::AtomicBool;
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let t0 = Instant::now();
    let file = SceneFile::default_scene();
    let (scene, mut settings) = file.build().expect("default scene");
    println!("build: {:.2} s", t0.elapsed().as_secs_f64());
    if let Some(spp) = args.get(1).and_then(|s| s.parse().ok()) {
        settings.spp = spp;
    }
    settings.threads = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(0);
    let out = fiberlab_render::integrator::render(&scene, &settings, &|_, _| {}, &AtomicBool::new(false));
    println!("render: {:.2} s, {:?}", out.stats.seconds, out.stats);
    out.image.write_exr("preview.exr".as_ref()).unwrap();
    out.image.write_png("preview.png".as_ref(), file.render_settings().exposure, ToneMap::Filmic).unwrap();
}
