//! Renders the built-in default scene to `preview.exr` / `preview.png` and prints timings and
//! performance figures. Usage: `cargo run --release -p fiberlab-render --example preview [SPP] [THREADS]`.
use fiberlab_io::ToneMap;
use fiberlab_procedural::generator::HairParams;
use fiberlab_render::bench::{bvh_build, ray_throughput, samples_per_second};
use fiberlab_render::scene_file::SceneFile;
use std::sync::atomic::AtomicBool;
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let t0 = Instant::now();
    let file = SceneFile::default_scene();
    let (scene, mut settings) = file.build().expect("default scene");
    println!("scene build (generate 20k strands + BVH): {:.2} s", t0.elapsed().as_secs_f64());
    let hair = HairParams::default().generate().unwrap();
    let (set, stats) = bvh_build(&hair);
    println!(
        "BVH: {} segments, {} pieces, {:.3} s, {:.1} bytes/segment",
        stats.segments,
        stats.pieces,
        stats.seconds,
        stats.bytes_per_segment()
    );
    let (cam, inc, hit) = ray_throughput(&set, scene.camera(), 200_000, 1);
    println!("rays (1 thread): camera {cam:.2} Mrays/s ({:.0}% hit), incoherent {inc:.2} Mrays/s", hit * 100.0);
    println!("samples/s (1 thread, 64×64 centre, 2 spp): {:.0}", samples_per_second(&scene, &settings, 64, 2, 1));
    if let Some(spp) = args.get(1).and_then(|s| s.parse().ok()) {
        settings.spp = spp;
    }
    settings.threads = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(0);
    let out = fiberlab_render::integrator::render(&scene, &settings, &|_| {}, &AtomicBool::new(false));
    println!("render: {:.2} s, {:?}", out.stats.seconds, out.stats);
    out.image.write_exr("preview.exr".as_ref()).unwrap();
    out.image.write_png("preview.png".as_ref(), file.render_settings().exposure, ToneMap::Filmic).unwrap();
}
