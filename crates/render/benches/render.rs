//! Criterion benchmarks: BVH build, closest-hit rays (camera and incoherent) and path-traced
#![allow(missing_docs)] // criterion macros generate undocumented items
//! samples on a reduced default scene. Run with `cargo bench -p fiberlab-render`.
use criterion::{Criterion, criterion_group, criterion_main};
use fiberlab_procedural::generator::HairParams;
use fiberlab_render::bench::{bvh_build, ray_throughput, samples_per_second};
use fiberlab_render::scene_file::SceneFile;

fn benches(c: &mut Criterion) {
    let hair = HairParams { strands: 5000, ..HairParams::default() }.generate().unwrap();
    let mut g = c.benchmark_group("render");
    g.sample_size(10);
    g.bench_function("bvh_build_5k_strands", |b| b.iter(|| bvh_build(&hair)));
    let (set, stats) = bvh_build(&hair);
    eprintln!("{} segments, {} pieces, {:.1} bytes/segment", stats.segments, stats.pieces, stats.bytes_per_segment());
    let (scene, settings) = SceneFile::default_scene().build().unwrap();
    g.bench_function("rays_10k", |b| b.iter(|| ray_throughput(&set, scene.camera(), 10_000, 1)));
    g.bench_function("samples_32x32x1", |b| b.iter(|| samples_per_second(&scene, &settings, 32, 1, 1)));
    g.finish();
}

criterion_group!(render_benches, benches);
criterion_main!(render_benches);
