// Buffers of the wavefront path tracer (`wavefront.rs` creates them in this order).

/// Per-render constants (`Params` in `wavefront.rs`).
struct Params {
    eye: vec3<f32>,
    tan_half: f32,
    forward: vec3<f32>,
    aspect: f32,
    right: vec3<f32>,
    width: f32,
    up: vec3<f32>,
    height: f32,
    seed_hash: vec2<u32>,
    max_depth: u32,
    rr_depth: u32,
    job_count: u32,
    slot_count: u32,
    /// Capacity of one half of the ray queue.
    queue_capacity: u32,
    oriented_base: u32,
    sphere_base: u32,
    sphere_count: u32,
    object_base: u32,
    object_count: u32,
    material_base: u32,
    light_base: u32,
    light_count: u32,
    emitter_base: u32,
    emitter_count: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

/// One camera sample in flight: its ray, throughput and radiance, what the last vertex left
/// for MIS, its sampler state and the hit of its ray.
struct PathState {
    o: vec3<f32>,
    t_min: f32,
    d: vec3<f32>,
    prev_pdf: f32,
    beta: vec3<f32>,
    depth: u32,
    l: vec3<f32>,
    /// Bit 0: the last scattering was a delta lobe (or the camera).
    flags: u32,
    prev_p: vec3<f32>,
    /// x | y << 16.
    pixel: u32,
    key: vec2<u32>,
    index: u32,
    /// The primitive the ray leaves.
    skip: u32,
    hit_t: f32,
    hit_prim: u32,
    hit_h: f32,
    _pad: u32,
}

/// A shadow ray with the contribution it brings to its path when unoccluded.
struct ShadowRay {
    o: vec3<f32>,
    t_max: f32,
    d: vec3<f32>,
    path: u32,
    contribution: vec3<f32>,
    skip: u32,
    aim: u32,
    t_min: f32,
    _pad0: u32,
    _pad1: u32,
}

@group(0) @binding(0) var<uniform> params: Params;
/// BVH nodes of every tree: axis-aligned (32 words each), then oriented (80 words each, from
/// `params.oriented_base`).
@group(0) @binding(1) var<storage, read> nodes: array<u32>;
@group(0) @binding(2) var<storage, read> prims: array<u32>;
/// Tube segments, 4 × vec4 each (geometry's `CurveSet::segment_words`; the last word holds the
/// material instead of the strand).
@group(0) @binding(3) var<storage, read> segments: array<vec4<f32>>;
/// Triangles, 3 × vec4 each (corners; the first corner's w is the material).
@group(0) @binding(4) var<storage, read> triangles: array<vec4<f32>>;
/// Spheres, objects, materials, lights and emitters as words (`scene_buffers.rs`).
@group(0) @binding(5) var<storage, read> scene_words: array<u32>;
/// The second Sobol dimension per index byte (render/src/sampler.rs).
@group(0) @binding(6) var<storage, read> sobol_bytes: array<u32>;
/// Pixel jobs: (x | y << 16, first sample index, first slot, samples).
@group(0) @binding(7) var<storage, read> jobs: array<vec4<u32>>;
@group(0) @binding(8) var<storage, read_write> paths: array<PathState>;
/// Two halves of `params.queue_capacity` path indices: the rays of this bounce and the next.
@group(0) @binding(9) var<storage, read_write> ray_queue: array<u32>;
@group(0) @binding(10) var<storage, read_write> shadow_queue: array<ShadowRay>;
/// Queue counters (`COUNT_*`).
@group(0) @binding(11) var<storage, read_write> counters: array<atomic<u32>>;
/// Per job: the sum of its samples' radiance and the number of non-finite samples (bits).
@group(0) @binding(12) var<storage, read_write> job_sums: array<vec4<f32>>;

/// counters[0], [1]: rays in queue half 0, 1; [2]: shadow rays; [3]: the current half;
/// [4], [5]: rays traced (low, high word).
const COUNT_SHADOW: u32 = 2u;
const COUNT_CURRENT: u32 = 3u;
const COUNT_RAYS_LO: u32 = 4u;
const COUNT_RAYS_HI: u32 = 5u;
const WORKGROUP: u32 = 64u;
