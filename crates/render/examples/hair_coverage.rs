//! Writes the fiber coverage of a scene's camera view ([`fiberlab_render::fiber_coverage`]) as
//! an EXR: the fraction of each pixel the fibers cover, for `exr_stats --mask`.
//! Usage: `cargo run --release -p fiberlab-render --example hair_coverage -- SCENE.toml OUT.exr [RAYS_PER_AXIS]`.
use fiberlab_render::fiber_coverage::fiber_coverage;
use fiberlab_render::scene_file::SceneFile;
use std::path::Path;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [scene, out, ..] = args.as_slice() else {
        eprintln!("usage: hair_coverage SCENE.toml OUT.exr [RAYS_PER_AXIS]");
        std::process::exit(2);
    };
    let n = args.get(2).map_or(4, |s| s.parse().expect("RAYS_PER_AXIS: a whole number"));
    let file = SceneFile::read(Path::new(scene)).unwrap_or_else(|e| panic!("{e}"));
    let (scene, _) = file.build().unwrap_or_else(|e| panic!("{e}"));
    fiber_coverage(&scene, n).write_exr(Path::new(out)).unwrap_or_else(|e| panic!("{out}: {e}"));
}
