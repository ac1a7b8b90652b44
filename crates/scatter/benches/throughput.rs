//! Eval and sample throughput of every registered model with default parameters (ns/call).
#![allow(missing_docs)] // criterion macros generate undocumented items
//! Run: `cargo bench -p fiberlab-scatter --bench throughput`.

use criterion::{Criterion, criterion_group, criterion_main};
use fiberlab_math::frame::direction;
use fiberlab_scatter::{MODELS, ScatteringFunction, build};
use std::hint::black_box;

fn throughput(c: &mut Criterion) {
    // A fixed set of direction pairs and offsets, cycled through.
    let pairs: Vec<_> = (0..256)
        .map(|k| {
            let t = k as f64;
            (direction((t * 0.37).sin() * 1.4, t * 0.91), direction((t * 0.53).cos() * 1.4, t * 1.7), (t * 0.29).sin())
        })
        .collect();
    for spec in MODELS {
        let model = build::<&str, &str>(spec.name, &[]).expect("defaults build");
        let mut k = 0usize;
        c.bench_function(&format!("{}/eval", spec.name), |b| {
            b.iter(|| {
                k = (k + 1) & 255;
                let (wi, wo, h) = pairs[k];
                black_box(model.eval(black_box(wi), black_box(wo), h))
            })
        });
        let mut k = 0usize;
        c.bench_function(&format!("{}/sample", spec.name), |b| {
            b.iter(|| {
                k = (k + 1) & 255;
                let (_, wo, h) = pairs[k];
                let u = [
                    (k as f64 * 0.618) % 1.0,
                    (k as f64 * 0.414) % 1.0,
                    (k as f64 * 0.732) % 1.0,
                    (k as f64 * 0.236) % 1.0,
                ];
                black_box(model.sample(black_box(wo), h, u))
            })
        });
    }
}

criterion_group!(benches, throughput);
criterion_main!(benches);
