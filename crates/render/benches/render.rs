//! Criterion benchmarks for the renderer (see fiberlab_render::bench).
fn main() {}
