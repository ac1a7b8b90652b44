//! The GPU's scattering code and sampler run on given inputs, for comparing them with the
//! CPU's (the tests in `tests/`): each case is evaluated, and sampled, by one GPU thread.

use crate::device::Gpu;
use crate::scene_buffers::{
    chiang_words, deon_words, hollow_fiber_words, huang_words, irawan_words, kajiya_kay_words, lambertian_words,
    leaf_words, marschner_words, reference_fiber_words, sadeghi_words, wood_words, yan_fur_words,
};
use crate::wavefront::GpuRenderError;
use fiberlab_scatter::chiang_2016::Chiang;
use fiberlab_scatter::deon_2011::Deon;
use fiberlab_scatter::hollow_fiber::HollowFiber;
use fiberlab_scatter::huang_2022::Huang;
use fiberlab_scatter::irawan_2012::Irawan2012;
use fiberlab_scatter::kajiya_kay_1989::KajiyaKay;
use fiberlab_scatter::lambert_1760::Lambertian;
use fiberlab_scatter::leaf::Leaf;
use fiberlab_scatter::marschner_2003::Marschner;
use fiberlab_scatter::marschner_2005::Wood;
use fiberlab_scatter::sadeghi_2013::Sadeghi2013;
use fiberlab_scatter::yan_2017::YanFur;
use glam::Vec3;
use wgpu::util::DeviceExt;

/// The probe's WGSL: the models' (`kernels::MODEL_SHADERS`) and its test kernels.
fn probe_source() -> String {
    let mut source = crate::kernels::MODEL_SHADERS.concat();
    source.push_str(include_str!("shaders/probe.wgsl"));
    source
}

/// One evaluation and one sample at a vertex (of any fiber model; `h` is ignored by the
/// far-field ones).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ChiangCase {
    /// Camera direction, local fiber frame.
    pub wo: Vec3,
    /// Offset across the fiber.
    pub h: f32,
    /// Light direction to evaluate, local.
    pub wi: Vec3,
    /// Uniforms for the sample.
    pub u: [f32; 4],
}

/// What the GPU computed for a [`ChiangCase`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ChiangResult {
    /// `f_s(ω_i, ω_o; h)`.
    pub f: [f32; 3],
    /// The sampling density of `ω_i`.
    pub pdf: f32,
    /// The sampled direction (when `sample_pdf > 0`).
    pub sample_wi: Vec3,
    /// Its density (≤ 0: no sample).
    pub sample_pdf: f32,
    /// Its weight `f_s cosθ_i/pdf`.
    pub sample_weight: [f32; 3],
}

/// The probe's pipeline for `entry`, compiled once per device.
fn probe_pipeline(gpu: &Gpu, entry: &'static str) -> wgpu::ComputePipeline {
    let mut cache = gpu.probe_pipelines.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    cache
        .entry(entry)
        .or_insert_with(|| {
            let module = gpu.device.create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some("fiberlab probe"),
                source: wgpu::ShaderSource::Wgsl(probe_source().into()),
            });
            gpu.device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry),
                layout: None,
                module: &module,
                entry_point: Some(entry),
                compilation_options: wgpu::PipelineCompilationOptions::default(),
                cache: None,
            })
        })
        .clone()
}

fn run_probe(
    gpu: &Gpu,
    entry: &'static str,
    material: &[u32],
    input: &[[f32; 4]],
) -> Result<Vec<[f32; 4]>, GpuRenderError> {
    let device = &gpu.device;
    let pipeline = probe_pipeline(gpu, entry);
    let init = |label: &str, bytes: &[u8], usage: wgpu::BufferUsages| {
        device.create_buffer_init(&wgpu::util::BufferInitDescriptor { label: Some(label), contents: bytes, usage })
    };
    let storage = wgpu::BufferUsages::STORAGE;
    let material = init("material", bytemuck::cast_slice(material), storage);
    let inputs = init("in", bytemuck::cast_slice(input), storage);
    let bytes = std::mem::size_of_val(input) as u64;
    let output = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("out"),
        size: bytes,
        usage: storage | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let sobol = init("sobol", bytemuck::cast_slice(&crate::wavefront::sobol_byte_tables()), storage);
    let readback = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("read back"),
        size: bytes,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let layout = pipeline.get_bind_group_layout(0);
    let buffers = [&material, &inputs, &output, &sobol];
    // Entry points bind what they use: the layout of `probe_sampler_cases` has no material,
    // the models' have no sampler tables.
    let sampler = entry == "probe_sampler_cases";
    let entries: Vec<wgpu::BindGroupEntry> = buffers
        .iter()
        .enumerate()
        .filter(|(i, _)| if sampler { *i != 0 } else { *i != 3 })
        .map(|(i, b)| wgpu::BindGroupEntry { binding: i as u32, resource: b.as_entire_binding() })
        .collect();
    let bind_group =
        device.create_bind_group(&wgpu::BindGroupDescriptor { label: None, layout: &layout, entries: &entries });
    let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor::default());
    {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor::default());
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &bind_group, &[]);
        pass.dispatch_workgroups((input.len() as u32 / 3).div_ceil(64), 1, 1);
    }
    encoder.copy_buffer_to_buffer(&output, 0, &readback, 0, bytes);
    gpu.queue.submit([encoder.finish()]);
    let words = crate::wavefront::read_back(gpu, &readback, bytes)?;
    Ok(words.chunks_exact(4).map(|c| [0, 1, 2, 3].map(|k| f32::from_bits(c[k]))).collect())
}

/// The GPU's Chiang model on each case.
pub fn chiang(gpu: &Gpu, model: &Chiang, cases: &[ChiangCase]) -> Result<Vec<ChiangResult>, GpuRenderError> {
    let input: Vec<[f32; 4]> =
        cases.iter().flat_map(|c| [c.wo.extend(c.h).to_array(), c.wi.extend(0.0).to_array(), c.u]).collect();
    let out = run_probe(gpu, "probe_chiang_cases", &chiang_words(model), &input)?;
    Ok(results(&out))
}

/// The GPU's Kajiya–Kay model on each case.
pub fn kajiya_kay(gpu: &Gpu, model: &KajiyaKay, cases: &[ChiangCase]) -> Result<Vec<ChiangResult>, GpuRenderError> {
    let input: Vec<[f32; 4]> =
        cases.iter().flat_map(|c| [c.wo.extend(c.h).to_array(), c.wi.extend(0.0).to_array(), c.u]).collect();
    let (words, table) = kajiya_kay_words(model, 32);
    let material: Vec<u32> = words.iter().chain(&table).copied().collect();
    let out = run_probe(gpu, "probe_kajiya_kay_cases", &material, &input)?;
    Ok(results(&out))
}

/// The GPU's Marschner model on each case.
pub fn marschner(gpu: &Gpu, model: &Marschner, cases: &[ChiangCase]) -> Result<Vec<ChiangResult>, GpuRenderError> {
    let input: Vec<[f32; 4]> =
        cases.iter().flat_map(|c| [c.wo.extend(c.h).to_array(), c.wi.extend(0.0).to_array(), c.u]).collect();
    let (words, table) = marschner_words(model, 32);
    let material: Vec<u32> = words.iter().chain(&table).copied().collect();
    let out = run_probe(gpu, "probe_marschner_cases", &material, &input)?;
    Ok(results(&out))
}

/// The GPU's d'Eon model on each case.
pub fn deon(gpu: &Gpu, model: &Deon, cases: &[ChiangCase]) -> Result<Vec<ChiangResult>, GpuRenderError> {
    let input: Vec<[f32; 4]> =
        cases.iter().flat_map(|c| [c.wo.extend(c.h).to_array(), c.wi.extend(0.0).to_array(), c.u]).collect();
    let (words, table) = deon_words(model, 32);
    let material: Vec<u32> = words.iter().chain(&table).copied().collect();
    let out = run_probe(gpu, "probe_deon_cases", &material, &input)?;
    Ok(results(&out))
}

/// The GPU's Yan fur model (its medulla tables and far-field nodes copied) on each case.
pub fn yan_fur(gpu: &Gpu, model: &YanFur, cases: &[ChiangCase]) -> Result<Vec<ChiangResult>, GpuRenderError> {
    let input: Vec<[f32; 4]> =
        cases.iter().flat_map(|c| [c.wo.extend(c.h).to_array(), c.wi.extend(0.0).to_array(), c.u]).collect();
    let (words, table) = yan_fur_words(model, 32);
    let material: Vec<u32> = words.iter().chain(&table).copied().collect();
    let out = run_probe(gpu, "probe_yan_fur_cases", &material, &input)?;
    Ok(results(&out))
}

/// The GPU's hollow fiber (near field) on each case.
pub fn hollow_fiber(gpu: &Gpu, model: &HollowFiber, cases: &[ChiangCase]) -> Result<Vec<ChiangResult>, GpuRenderError> {
    let input: Vec<[f32; 4]> =
        cases.iter().flat_map(|c| [c.wo.extend(c.h).to_array(), c.wi.extend(0.0).to_array(), c.u]).collect();
    let out = run_probe(gpu, "probe_hollow_fiber_cases", &hollow_fiber_words(model), &input)?;
    Ok(results(&out))
}

/// The GPU's Huang 2022 model (its shift constants and interface tables copied) on each case.
pub fn huang(gpu: &Gpu, model: &Huang, cases: &[ChiangCase]) -> Result<Vec<ChiangResult>, GpuRenderError> {
    let input: Vec<[f32; 4]> =
        cases.iter().flat_map(|c| [c.wo.extend(c.h).to_array(), c.wi.extend(0.0).to_array(), c.u]).collect();
    let (words, table) = huang_words(model, 32);
    let material: Vec<u32> = words.iter().chain(&table).copied().collect();
    let out = run_probe(gpu, "probe_huang_cases", &material, &input)?;
    Ok(results(&out))
}

/// The GPU's leaf surface model (its cuticle albedo table copied) on each case, in the surface's
/// local frame (z the normal; `h` is ignored).
pub fn leaf(gpu: &Gpu, model: &Leaf, cases: &[ChiangCase]) -> Result<Vec<ChiangResult>, GpuRenderError> {
    let input: Vec<[f32; 4]> =
        cases.iter().flat_map(|c| [c.wo.extend(c.h).to_array(), c.wi.extend(0.0).to_array(), c.u]).collect();
    let (words, table) = leaf_words(model, 32);
    let material: Vec<u32> = words.iter().chain(&table).copied().collect();
    let out = run_probe(gpu, "probe_leaf_cases", &material, &input)?;
    Ok(results(&out))
}

/// The GPU's `lambertian` surface model (untextured) on each case, in the surface's local frame.
pub fn lambertian(gpu: &Gpu, model: &Lambertian, cases: &[ChiangCase]) -> Result<Vec<ChiangResult>, GpuRenderError> {
    let input: Vec<[f32; 4]> =
        cases.iter().flat_map(|c| [c.wo.extend(c.h).to_array(), c.wi.extend(0.0).to_array(), c.u]).collect();
    let (words, _) = lambertian_words(model, None, 32);
    let out = run_probe(gpu, "probe_lambertian_cases", &words, &input)?;
    Ok(results(&out))
}

/// The GPU's reference fiber (`diffuse`, `lambertian-cylinder`, `specular` or `goldman`) on each
/// case; `None` for any other model. The specular fiber's eval is zero and its sample's pdf 1
/// (a delta lobe).
pub fn reference_fiber(
    gpu: &Gpu,
    model: &fiberlab_scatter::Model,
    cases: &[ChiangCase],
) -> Option<Result<Vec<ChiangResult>, GpuRenderError>> {
    let input: Vec<[f32; 4]> =
        cases.iter().flat_map(|c| [c.wo.extend(c.h).to_array(), c.wi.extend(0.0).to_array(), c.u]).collect();
    let (words, table) = reference_fiber_words(model, 32)?;
    let material: Vec<u32> = words.iter().chain(&table).copied().collect();
    Some(run_probe(gpu, "probe_reference_fiber_cases", &material, &input).map(|out| results(&out)))
}

/// The GPU's `irawan-2012` surface model on each case at the tile position `positions[k]`
/// (`u`, `v` as the model's parameters), in the surface's local frame (`h` is ignored).
pub fn irawan(
    gpu: &Gpu,
    model: &Irawan2012,
    cases: &[ChiangCase],
    positions: &[[f32; 2]],
) -> Result<Vec<ChiangResult>, GpuRenderError> {
    let input: Vec<[f32; 4]> = cases
        .iter()
        .zip(positions)
        .flat_map(|(c, p)| [c.wo.extend(p[0]).to_array(), c.wi.extend(p[1]).to_array(), c.u])
        .collect();
    let (words, table) = irawan_words(model, [1.0, 1.0], 32);
    let material: Vec<u32> = words.iter().chain(&table).copied().collect();
    let out = run_probe(gpu, "probe_irawan_cases", &material, &input)?;
    Ok(results(&out))
}

/// The GPU's `wood` surface model (untextured) on each case, in the surface's local frame; a
/// sample of the smooth finish's mirror lobe has `sample_pdf` −1.
pub fn wood(gpu: &Gpu, model: &Wood, cases: &[ChiangCase]) -> Result<Vec<ChiangResult>, GpuRenderError> {
    let input: Vec<[f32; 4]> =
        cases.iter().flat_map(|c| [c.wo.extend(c.h).to_array(), c.wi.extend(0.0).to_array(), c.u]).collect();
    let (words, _) = wood_words(model, None, 32);
    let out = run_probe(gpu, "probe_wood_cases", &words, &input)?;
    Ok(results(&out))
}

/// The GPU's `sadeghi-2013` cloth (untextured; its thread families copied) on each case, in the surface's
/// local frame.
pub fn sadeghi(gpu: &Gpu, model: &Sadeghi2013, cases: &[ChiangCase]) -> Result<Vec<ChiangResult>, GpuRenderError> {
    let input: Vec<[f32; 4]> =
        cases.iter().flat_map(|c| [c.wo.extend(c.h).to_array(), c.wi.extend(0.0).to_array(), c.u]).collect();
    let (words, table) = sadeghi_words(model, None, 32);
    let material: Vec<u32> = words.iter().chain(&table).copied().collect();
    let out = run_probe(gpu, "probe_sadeghi_cases", &material, &input)?;
    Ok(results(&out))
}

fn results(out: &[[f32; 4]]) -> Vec<ChiangResult> {
    out.chunks_exact(3)
        .map(|o| ChiangResult {
            f: [o[0][0], o[0][1], o[0][2]],
            pdf: o[0][3],
            sample_wi: Vec3::new(o[1][0], o[1][1], o[1][2]),
            sample_pdf: o[1][3],
            sample_weight: [o[2][0], o[2][1], o[2][2]],
        })
        .collect()
}

/// The GPU sampler's dimension pair `pair` of sample `index` of pixel (x, y) for `seed`, per
/// case (the CPU's `PixelSampler` to 24 bits).
pub fn sampler(gpu: &Gpu, seed: u64, cases: &[(u32, u32, u32, u32)]) -> Result<Vec<[f32; 2]>, GpuRenderError> {
    let hash = fiberlab_math::split_mix::mix64(seed ^ 0xA076_1D64_78BD_642F);
    let bits = |v: [u32; 4]| v.map(f32::from_bits);
    let input: Vec<[f32; 4]> = cases
        .iter()
        .flat_map(|&(x, y, i, p)| [bits([x, y, i, p]), bits([hash as u32, (hash >> 32) as u32, 0, 0]), [0.0; 4]])
        .collect();
    let out = run_probe(gpu, "probe_sampler_cases", &[0; 4], &input)?;
    Ok(out.chunks_exact(3).map(|o| [o[0][0], o[0][1]]).collect())
}
