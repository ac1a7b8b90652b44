//! The wavefront path tracer's host side: buffers made once per render, a pass loop that
//! brings every pixel of the region to more samples, and the merge of each pass's per-pixel
//! sums into the same progressive [`Accumulation`] as CPU renders.
//!
//! # Samples, blocks and passes
//! A pixel's samples are taken in blocks of sample indices fixed by the index alone: `[0, 1)`,
//! `[1, 2)`, `[2, 4)`, `[4, 8)`, `[8, 16)`, then every 16 (the last block cut at the target
//! spp). The GPU sums a block in sample order in `f32`; the host adds the block's sum to the
//! pixel's `f64` sum. A pass takes the next block of every pixel below the target; its pixels
//! are split into chunks of at most `max_paths` samples in flight. So on one device the image
//! depends only on the seed, the spp and where blocks were cut — not on the region's size, the
//! tiles, the chunking, or a stop and resume at block boundaries. Ctrl-C and the deadline are
//! checked between bounces: the chunk in flight is then dropped (its pixels keep the samples
//! of earlier passes), so a stop costs at most one chunk's bounces. The state is the CPU's, so
//! a render begun on the GPU continues on the CPU and the other way round (the images agree in
//! distribution, not bit for bit: the GPU computes in `f32`).

use crate::device::Gpu;
use crate::kernels::{Kernels, Pipelines};
use crate::scene_buffers::{SceneBuffers, Unsupported};
use fiberlab_math::Rgb;
use fiberlab_render::accumulation::{Accumulation, ResumeError};
use fiberlab_render::dual_scattering::Integrator;
use fiberlab_render::integrator::{Progress, Region, RenderOutput, RenderSettings, RenderStats};
use fiberlab_render::scene::Scene;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;
use wgpu::util::DeviceExt;

/// Most samples per block (module docs).
pub const BLOCK: u32 = 16;
const WORKGROUP: u32 = 64;
/// Bytes per path in flight: its state (112), two queue entries (8), a shadow ray (64).
const BYTES_PER_PATH: u64 = 112 + 8 + 64;

/// The end of the block that begins at sample `count` (module docs).
#[must_use]
pub fn block_end(count: u32) -> u32 {
    if count == 0 {
        1
    } else if count < BLOCK {
        (count + 1).next_power_of_two()
    } else {
        (count / BLOCK + 1).saturating_mul(BLOCK)
    }
}

/// How the GPU renders (beside the [`RenderSettings`] it shares with the CPU).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GpuOptions {
    /// Most samples in flight at once (the chunk size; at most 65535 × 64).
    pub max_paths: u32,
}

impl Default for GpuOptions {
    fn default() -> Self {
        Self { max_paths: 1 << 21 }
    }
}

/// Why a GPU render failed.
#[derive(Debug, thiserror::Error)]
pub enum GpuRenderError {
    /// The scene uses what the GPU cannot render.
    #[error(transparent)]
    Unsupported(#[from] Unsupported),
    /// The saved state does not fit the scene.
    #[error(transparent)]
    Resume(#[from] ResumeError),
    /// The device reported an error.
    #[error("GPU error: {0}")]
    Device(String),
}

/// `Params` of the shaders' bindings (144 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
struct Params {
    eye: [f32; 3],
    tan_half: f32,
    forward: [f32; 3],
    aspect: f32,
    right: [f32; 3],
    width: f32,
    up: [f32; 3],
    height: f32,
    seed_hash: [u32; 2],
    max_depth: u32,
    rr_depth: u32,
    job_count: u32,
    slot_count: u32,
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
    pad: [u32; 3],
}

const _: () = assert!(std::mem::size_of::<Params>() == 144);

/// The second Sobol dimension of every byte value at each byte position of the index
/// (render/src/sampler.rs builds the same table).
pub(crate) fn sobol_byte_tables() -> Vec<u32> {
    let mut direction = [0u32; 32];
    let mut v = 1u32;
    for d in &mut direction {
        *d = v;
        v ^= v << 1;
    }
    let mut out = Vec::with_capacity(1024);
    for b in 0..4 {
        for x in 0..256u32 {
            let y = (0..8).filter(|bit| x & (1 << bit) != 0).fold(0, |y, bit| y ^ direction[8 * b + bit]);
            out.push(y);
        }
    }
    out
}

fn to_bytes(words: &[u32]) -> &[u8] {
    bytemuck::cast_slice(words)
}

/// The buffers of one render (made once; nothing is allocated per pass).
struct Buffers {
    params: wgpu::Buffer,
    jobs: wgpu::Buffer,
    counters: wgpu::Buffer,
    args: wgpu::Buffer,
    job_sums: wgpu::Buffer,
    readback: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
    paths: wgpu::Buffer,
    shadow: wgpu::Buffer,
}

fn storage(device: &wgpu::Device, label: &str, bytes: u64, extra: wgpu::BufferUsages) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: bytes.max(16).next_multiple_of(16),
        usage: wgpu::BufferUsages::STORAGE | extra,
        mapped_at_creation: false,
    })
}

fn storage_with(device: &wgpu::Device, label: &str, words: &[u32]) -> wgpu::Buffer {
    let padded;
    let words = if words.is_empty() {
        padded = vec![0u32; 4];
        &padded
    } else {
        words
    };
    device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some(label),
        contents: to_bytes(words),
        usage: wgpu::BufferUsages::STORAGE,
    })
}

/// Waits for the GPU and returns the first `bytes` of the read-back buffer as words.
pub(crate) fn read_back(gpu: &Gpu, buffer: &wgpu::Buffer, bytes: u64) -> Result<Vec<u32>, GpuRenderError> {
    let slice = buffer.slice(..bytes);
    let (tx, rx) = std::sync::mpsc::channel();
    slice.map_async(wgpu::MapMode::Read, move |r| {
        let _ = tx.send(r);
    });
    gpu.device.poll(wgpu::PollType::wait_indefinitely()).map_err(|e| GpuRenderError::Device(e.to_string()))?;
    rx.recv().map_err(|e| GpuRenderError::Device(e.to_string()))?.map_err(|e| GpuRenderError::Device(e.to_string()))?;
    let words = {
        let view = slice.get_mapped_range().map_err(|e| GpuRenderError::Device(e.to_string()))?;
        bytemuck::cast_slice::<u8, u32>(&view).to_vec()
    };
    buffer.unmap();
    Ok(words)
}

/// Kernels and buffers for one scene, made once.
struct Prepared<'g> {
    kernels: &'g Kernels,
    buffers: Buffers,
    params: Params,
    max_paths: u32,
    max_jobs: u64,
}

impl<'g> Prepared<'g> {
    fn new(
        gpu: &'g Gpu,
        scene: &Scene,
        settings: &RenderSettings,
        options: GpuOptions,
        pixels: u64,
    ) -> Result<Self, GpuRenderError> {
        let camera = scene.camera();
        let sb = SceneBuffers::new(scene)?;
        let limit = gpu.limits.max_storage_buffer_binding_size.min(gpu.limits.max_buffer_size);
        for (what, words) in [
            ("BVH nodes", sb.nodes.len()),
            ("BVH leaves", sb.prims.len()),
            ("segments", sb.segments.len()),
            ("triangles", sb.triangles.len()),
            ("materials, lights and their tables", sb.words.len()),
        ] {
            let bytes = 4 * words as u64;
            if bytes > limit {
                return Err(Unsupported::TooLarge { what, bytes, limit }.into());
            }
        }
        let max_paths = u64::from(options.max_paths.clamp(1, 65_535 * WORKGROUP))
            .min(limit / BYTES_PER_PATH)
            .min(pixels.max(1) * u64::from(BLOCK)) as u32;
        let device = &gpu.device;
        // Validation and out-of-memory errors become this function's error, not a panic.
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let memory = device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let made = Self::make(gpu, camera, settings, &sb, max_paths, pixels);
        let failed = [crate::device::block_on(memory.pop()), crate::device::block_on(scope.pop())];
        if let Some(e) = failed.into_iter().flatten().next() {
            return Err(GpuRenderError::Device(e.to_string()));
        }
        Ok(made)
    }

    fn make(
        gpu: &'g Gpu,
        camera: &fiberlab_render::camera::Camera,
        settings: &RenderSettings,
        sb: &SceneBuffers,
        max_paths: u32,
        pixels: u64,
    ) -> Self {
        let (w, h) = (camera.width, camera.height);
        let device = &gpu.device;
        let Pipelines { layout, kernels } = gpu.pipelines.get_or_init(|| Pipelines::new(&gpu.device));
        let (eye, forward, right, up, tan_half) = camera.basis();
        let v3 = |v: fiberlab_math::DVec3| [v.x as f32, v.y as f32, v.z as f32];
        let seed_hash = fiberlab_math::split_mix::mix64(settings.seed ^ 0xA076_1D64_78BD_642F);
        let params = Params {
            eye: v3(eye),
            tan_half: tan_half as f32,
            forward: v3(forward),
            aspect: (f64::from(w) / f64::from(h)) as f32,
            right: v3(right),
            width: w as f32,
            up: v3(up),
            height: h as f32,
            seed_hash: [seed_hash as u32, (seed_hash >> 32) as u32],
            max_depth: settings.max_depth,
            rr_depth: settings.rr_depth,
            queue_capacity: max_paths,
            oriented_base: sb.oriented_base,
            sphere_base: sb.sphere_base,
            sphere_count: sb.sphere_count,
            object_base: sb.object_base,
            object_count: sb.object_count,
            material_base: sb.material_base,
            light_base: sb.light_base,
            light_count: sb.light_count,
            emitter_base: sb.emitter_base,
            emitter_count: sb.emitter_count,
            ..Params::default()
        };
        let max_jobs = u64::from(max_paths).min(pixels.max(1));
        let params_buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("params"),
            size: std::mem::size_of::<Params>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let copy_dst = wgpu::BufferUsages::COPY_DST;
        let copy_src = wgpu::BufferUsages::COPY_SRC;
        let nodes = storage_with(device, "nodes", &sb.nodes);
        let prims = storage_with(device, "prims", &sb.prims);
        let segments = storage_with(device, "segments", &sb.segments);
        let triangles = storage_with(device, "triangles", &sb.triangles);
        let words = storage_with(device, "scene", &sb.words);
        let sobol = storage_with(device, "sobol", &sobol_byte_tables());
        let jobs = storage(device, "jobs", 16 * max_jobs, copy_dst);
        let paths = storage(device, "paths", 112 * u64::from(max_paths), copy_src);
        let queue = storage(device, "ray queue", 8 * u64::from(max_paths), wgpu::BufferUsages::empty());
        let shadow = storage(device, "shadow queue", 64 * u64::from(max_paths), copy_dst);
        let counters = storage(device, "counters", 64, copy_dst | copy_src);
        let job_sums = storage(device, "job sums", 16 * max_jobs, copy_src);
        let args = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("dispatch args"),
            size: 32,
            usage: wgpu::BufferUsages::INDIRECT | copy_dst,
            mapped_at_creation: false,
        });
        let readback = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("read back"),
            size: (16 * max_jobs).max(112 * u64::from(max_paths)).next_multiple_of(16) + 64,
            usage: wgpu::BufferUsages::MAP_READ | copy_dst,
            mapped_at_creation: false,
        });
        let all = [
            &params_buffer,
            &nodes,
            &prims,
            &segments,
            &triangles,
            &words,
            &sobol,
            &jobs,
            &paths,
            &queue,
            &shadow,
            &counters,
            &job_sums,
        ];
        let entries: Vec<wgpu::BindGroupEntry> = all
            .iter()
            .enumerate()
            .map(|(i, b)| wgpu::BindGroupEntry { binding: i as u32, resource: b.as_entire_binding() })
            .collect();
        let bind_group =
            device.create_bind_group(&wgpu::BindGroupDescriptor { label: Some("fiberlab"), layout, entries: &entries });
        let buffers =
            Buffers { params: params_buffer, jobs, counters, args, job_sums, readback, bind_group, paths, shadow };
        Self { kernels, buffers, params, max_paths, max_jobs }
    }
}

/// A ray for [`query_rays`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct QueryRay {
    /// Origin.
    pub o: glam::Vec3,
    /// Unit direction.
    pub d: glam::Vec3,
    /// Distances considered: (t_min, t_max).
    pub t_min: f32,
    /// See `t_min`.
    pub t_max: f32,
}

/// What the GPU found along a [`QueryRay`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct QueryHit {
    /// The closest hit: distance, primitive (kind in the top two bits: 1 segment, 2 sphere,
    /// 3 triangle; the index below) and offset across a fiber; `None` for a miss.
    pub closest: Option<(f32, u32, f32)>,
    /// True when the any-hit query found a blocker.
    pub blocked: bool,
}

/// The closest-hit and any-hit queries of the GPU's walk for each ray (for tests against the
/// CPU's brute force, and tools).
pub fn query_rays(gpu: &Gpu, scene: &Scene, rays: &[QueryRay]) -> Result<Vec<QueryHit>, GpuRenderError> {
    let settings = RenderSettings::default();
    let options = GpuOptions { max_paths: rays.len().max(1) as u32 };
    let p = Prepared::new(gpu, scene, &settings, options, (rays.len() as u64).div_ceil(u64::from(BLOCK)))?;
    let n = rays.len().min(p.max_paths as usize);
    if n < rays.len() {
        return Err(GpuRenderError::Device(format!("{} rays: at most {} per query", rays.len(), p.max_paths)));
    }
    let mut params = p.params;
    params.slot_count = n as u32;
    let b = &p.buffers;
    gpu.queue.write_buffer(&b.params, 0, bytemuck::bytes_of(&params));
    let mut words = Vec::with_capacity(16 * n);
    for r in rays {
        let f = |x: f32| x.to_bits();
        words.extend([f(r.o.x), f(r.o.y), f(r.o.z), f(r.t_max), f(r.d.x), f(r.d.y), f(r.d.z), 0]);
        words.extend([0, 0, 0, u32::MAX, u32::MAX, f(r.t_min), 0, 0]);
    }
    gpu.queue.write_buffer(&b.shadow, 0, to_bytes(&words));
    let mut encoder = gpu.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("query") });
    {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor::default());
        pass.set_bind_group(0, &b.bind_group, &[]);
        pass.set_pipeline(&p.kernels.query_rays);
        pass.dispatch_workgroups(groups(n as u32), 1, 1);
    }
    let bytes = 112 * n as u64;
    encoder.copy_buffer_to_buffer(&b.paths, 0, &b.readback, 0, bytes);
    gpu.queue.submit([encoder.finish()]);
    let out = read_back(gpu, &b.readback, bytes)?;
    Ok(out
        .chunks_exact(28)
        .map(|s| {
            let prim = s[25];
            QueryHit {
                closest: (prim != u32::MAX).then(|| (f32::from_bits(s[24]), prim, f32::from_bits(s[26]))),
                blocked: s[15] != 0,
            }
        })
        .collect())
}

/// One pixel's block in a chunk: (x | y << 16, first sample, first slot, samples).
type Job = [u32; 4];

/// Renders the scene from scratch on the GPU; see [`render_continuing`].
pub fn render(
    gpu: &Gpu,
    scene: &Scene,
    settings: &RenderSettings,
    options: GpuOptions,
    progress: &(dyn Fn(&Progress) + Sync),
    stop: &AtomicBool,
) -> Result<RenderOutput, GpuRenderError> {
    let (w, h) = (scene.camera().width, scene.camera().height);
    render_continuing(gpu, scene, settings, options, Accumulation::new(w, h), progress, stop)
}

/// Renders progressively on the GPU, continuing `start`, until every pixel of the region has
/// `settings.spp` samples (module docs); `settings.threads` and `tile_size` do not apply.
/// Stops (`stop`, the deadline) keep every finished chunk's samples.
pub fn render_continuing(
    gpu: &Gpu,
    scene: &Scene,
    settings: &RenderSettings,
    options: GpuOptions,
    start: Accumulation,
    progress: &(dyn Fn(&Progress) + Sync),
    stop: &AtomicBool,
) -> Result<RenderOutput, GpuRenderError> {
    let t0 = Instant::now();
    let camera = scene.camera();
    let (w, h) = (camera.width, camera.height);
    if (start.width(), start.height()) != (w, h) {
        return Err(
            ResumeError::Size { found_w: start.width() as usize, found_h: start.height() as usize, w, h }.into()
        );
    }
    if w > 1 << 16 || h > 1 << 16 {
        return Err(GpuRenderError::Device(format!("{w}×{h}: the GPU renders at most 65536 pixels a side")));
    }
    if !matches!(settings.integrator, Integrator::Path) {
        return Err(Unsupported::Integrator.into());
    }
    let full = Region::full(w, h);
    let region =
        settings.region.map_or(full, |r| Region { x0: r.x0.min(w), y0: r.y0.min(h), x1: r.x1.min(w), y1: r.y1.min(h) });
    let pixels = region.area();
    let p = Prepared::new(gpu, scene, settings, options, pixels)?;
    let (kernels, buffers, mut params, max_paths, max_jobs) =
        (p.kernels, &p.buffers, p.params, p.max_paths, p.max_jobs);
    let mut state = start;
    let target = settings.spp;
    let samples_total = state.samples_missing(region, target);
    let stopped = || {
        if stop.load(Ordering::Relaxed) {
            return true;
        }
        let late = settings.deadline.is_some_and(|d| Instant::now() >= d);
        if late {
            stop.store(true, Ordering::Relaxed);
        }
        late
    };
    let mut stats = RenderStats::default();
    let mut samples_done = 0u64;
    let mut jobs: Vec<Job> = Vec::new();
    'passes: while !stopped() {
        // The next block of every pixel below the target.
        jobs.clear();
        let mut pass_spp = 0;
        for y in region.y0..region.y1 {
            for x in region.x0..region.x1 {
                let (_, count) = state.pixel(x, y);
                if count < target {
                    let end = block_end(count).min(target);
                    pass_spp = pass_spp.max(end);
                    jobs.push([x | (y << 16), count, 0, end - count]);
                }
            }
        }
        if jobs.is_empty() {
            break;
        }
        stats.passes += 1;
        let mut first = 0;
        while first < jobs.len() {
            if stopped() {
                break 'passes;
            }
            // A chunk: jobs while their samples fit.
            let mut slots = 0u32;
            let mut end = first;
            while end < jobs.len() && (end - first) < max_jobs as usize && slots + jobs[end][3] <= max_paths {
                jobs[end][2] = slots;
                slots += jobs[end][3];
                end += 1;
            }
            let chunk = &jobs[first..end];
            let Some(result) = run_chunk(gpu, kernels, buffers, &mut params, chunk, slots, &stopped)? else {
                break 'passes;
            };
            for (job, sum) in chunk.iter().zip(result.sums.chunks_exact(4)) {
                let (x, y) = (job[0] & 0xffff, job[0] >> 16);
                let (s, c) = state.pixel(x, y);
                let add = Rgb::new(
                    f32::from_bits(sum[0]).into(),
                    f32::from_bits(sum[1]).into(),
                    f32::from_bits(sum[2]).into(),
                );
                state.set_pixel(x, y, s + add, c + job[3]);
                stats.nonfinite_samples += u64::from(sum[3]);
            }
            stats.samples += u64::from(slots);
            stats.rays += result.rays;
            samples_done += u64::from(slots);
            progress(&Progress { samples_done, samples_total, pass: stats.passes, pass_spp });
            first = end;
        }
    }
    (stats.spp_min, stats.spp_max) = state.count_range(region);
    stats.interrupted = stats.spp_min < target;
    stats.seconds = t0.elapsed().as_secs_f64();
    Ok(RenderOutput { image: state.image(region), accumulation: state, stats })
}

/// What a chunk brought: per job the sum (3 × `f32` bits) and the non-finite samples, and the
/// rays traced.
struct ChunkResult {
    sums: Vec<u32>,
    rays: u64,
}

fn groups(n: u32) -> u32 {
    n.div_ceil(WORKGROUP)
}

/// Runs one chunk of jobs to the end of its paths; `None` when stopped first.
fn run_chunk(
    gpu: &Gpu,
    k: &Kernels,
    b: &Buffers,
    params: &mut Params,
    jobs: &[Job],
    slots: u32,
    stopped: &dyn Fn() -> bool,
) -> Result<Option<ChunkResult>, GpuRenderError> {
    let queue = &gpu.queue;
    params.job_count = jobs.len() as u32;
    params.slot_count = slots;
    queue.write_buffer(&b.params, 0, bytemuck::bytes_of(params));
    queue.write_buffer(&b.jobs, 0, bytemuck::cast_slice(jobs));
    let mut counters = [0u32; 16];
    counters[0] = slots;
    counters[4] = slots;
    queue.write_buffer(&b.counters, 0, to_bytes(&counters));
    queue.write_buffer(&b.args, 0, to_bytes(&[groups(slots), 1, 1, 0, 0, 1, 1, 0]));
    let device = &gpu.device;
    let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("generate") });
    {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor::default());
        pass.set_bind_group(0, &b.bind_group, &[]);
        pass.set_pipeline(&k.generate);
        pass.dispatch_workgroups(groups(slots), 1, 1);
    }
    let mut batch = 2;
    let mut bounces = 0u32;
    loop {
        for _ in 0..batch {
            {
                let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor::default());
                pass.set_bind_group(0, &b.bind_group, &[]);
                pass.set_pipeline(&k.extend);
                pass.dispatch_workgroups_indirect(&b.args, 0);
                pass.set_pipeline(&k.shade);
                pass.dispatch_workgroups_indirect(&b.args, 0);
                pass.set_pipeline(&k.count_shadow_rays);
                pass.dispatch_workgroups(1, 1, 1);
            }
            encoder.copy_buffer_to_buffer(&b.counters, 32, &b.args, 0, 32);
            {
                let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor::default());
                pass.set_bind_group(0, &b.bind_group, &[]);
                pass.set_pipeline(&k.shadow);
                pass.dispatch_workgroups_indirect(&b.args, 16);
                pass.set_pipeline(&k.next_bounce);
                pass.dispatch_workgroups(1, 1, 1);
            }
            encoder.copy_buffer_to_buffer(&b.counters, 32, &b.args, 0, 32);
        }
        bounces += batch;
        encoder.copy_buffer_to_buffer(&b.counters, 0, &b.readback, 0, 64);
        queue.submit([encoder.finish()]);
        let c = read_back(gpu, &b.readback, 64)?;
        let alive = c[c[3] as usize];
        if alive == 0 {
            break;
        }
        if stopped() {
            return Ok(None);
        }
        if bounces > 1 << 16 {
            return Err(GpuRenderError::Device(format!("{alive} paths still alive after {bounces} bounces")));
        }
        batch = (batch * 2).min(8);
        encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("bounces") });
    }
    let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("sums") });
    {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor::default());
        pass.set_bind_group(0, &b.bind_group, &[]);
        pass.set_pipeline(&k.sum_jobs);
        pass.dispatch_workgroups(groups(jobs.len() as u32), 1, 1);
    }
    let sum_bytes = 16 * jobs.len() as u64;
    encoder.copy_buffer_to_buffer(&b.job_sums, 0, &b.readback, 0, sum_bytes);
    encoder.copy_buffer_to_buffer(&b.counters, 0, &b.readback, sum_bytes.next_multiple_of(16), 64);
    queue.submit([encoder.finish()]);
    let words = read_back(gpu, &b.readback, sum_bytes.next_multiple_of(16) + 64)?;
    let at = (sum_bytes.next_multiple_of(16) / 4) as usize;
    let rays = u64::from(words[at + 4]) | (u64::from(words[at + 5]) << 32);
    let mut sums = words;
    sums.truncate(4 * jobs.len());
    Ok(Some(ChunkResult { sums, rays }))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Blocks end at 1, 2, 4, 8, 16 and then every 16, wherever they begin.
    #[test]
    fn blocks_are_fixed_by_the_sample_index() {
        let ends: Vec<u32> = [0, 1, 2, 3, 4, 7, 8, 15, 16, 17, 31, 32].iter().map(|&c| block_end(c)).collect();
        assert_eq!(ends, [1, 2, 4, 4, 8, 8, 16, 16, 32, 32, 32, 48]);
        assert_eq!(block_end(u32::MAX - 3), u32::MAX, "saturates instead of wrapping");
    }
}
