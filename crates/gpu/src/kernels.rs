//! The path tracer's compute kernels: the WGSL source (`src/shaders/`), the one bind group
//! layout every kernel shares (the buffers of `shaders/bindings.wgsl`) and the compiled
//! pipelines, made once per device.

/// The scattering models' WGSL and what they share (`src/shaders/`), which the path tracer and
/// the model probe (`model_probe.rs`) both compile.
pub(crate) const MODEL_SHADERS: [&str; 17] = [
    include_str!("shaders/sampler.wgsl"),
    include_str!("shaders/chiang.wgsl"),
    include_str!("shaders/pole_taper.wgsl"),
    include_str!("shaders/kajiya_kay.wgsl"),
    include_str!("shaders/marschner.wgsl"),
    include_str!("shaders/deon.wgsl"),
    include_str!("shaders/yan_fur.wgsl"),
    include_str!("shaders/reference_fibers.wgsl"),
    include_str!("shaders/hollow_fiber.wgsl"),
    include_str!("shaders/huang_2022.wgsl"),
    include_str!("shaders/ggx.wgsl"),
    include_str!("shaders/leaf.wgsl"),
    include_str!("shaders/wood.wgsl"),
    include_str!("shaders/sadeghi.wgsl"),
    include_str!("shaders/lambertian.wgsl"),
    include_str!("shaders/irawan_2012.wgsl"),
    include_str!("shaders/textures.wgsl"),
];

/// The WGSL source of the path tracer: its buffers, the models, then the geometry, lights and
/// kernels.
fn shader_source() -> String {
    let mut source = String::from(include_str!("shaders/bindings.wgsl"));
    source.extend(MODEL_SHADERS);
    source.extend([
        include_str!("shaders/geometry.wgsl"),
        include_str!("shaders/lights.wgsl"),
        include_str!("shaders/wavefront.wgsl"),
    ]);
    source
}

/// The compiled kernels.
pub(crate) struct Kernels {
    pub(crate) generate: wgpu::ComputePipeline,
    pub(crate) extend: wgpu::ComputePipeline,
    pub(crate) shade: wgpu::ComputePipeline,
    pub(crate) count_shadow_rays: wgpu::ComputePipeline,
    pub(crate) shadow: wgpu::ComputePipeline,
    pub(crate) next_bounce: wgpu::ComputePipeline,
    pub(crate) sum_jobs: wgpu::ComputePipeline,
    pub(crate) query_rays: wgpu::ComputePipeline,
}

fn bind_group_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    let entry = |binding: u32, ty: wgpu::BufferBindingType| wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer { ty, has_dynamic_offset: false, min_binding_size: None },
        count: None,
    };
    let mut entries = vec![entry(0, wgpu::BufferBindingType::Uniform)];
    for b in 1..=7 {
        entries.push(entry(b, wgpu::BufferBindingType::Storage { read_only: true }));
    }
    for b in 8..=12 {
        entries.push(entry(b, wgpu::BufferBindingType::Storage { read_only: false }));
    }
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor { label: Some("fiberlab"), entries: &entries })
}

impl Kernels {
    fn new(device: &wgpu::Device, layout: &wgpu::BindGroupLayout) -> Self {
        let source = shader_source();
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("fiberlab wavefront"),
            source: wgpu::ShaderSource::Wgsl(source.into()),
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("fiberlab"),
            bind_group_layouts: &[Some(layout)],
            immediate_size: 0,
        });
        let make = |entry: &str| {
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry),
                layout: Some(&pipeline_layout),
                module: &module,
                entry_point: Some(entry),
                compilation_options: wgpu::PipelineCompilationOptions::default(),
                cache: None,
            })
        };
        Self {
            generate: make("generate"),
            extend: make("extend"),
            shade: make("shade"),
            count_shadow_rays: make("count_shadow_rays"),
            shadow: make("shadow"),
            next_bounce: make("next_bounce"),
            sum_jobs: make("sum_jobs"),
            query_rays: make("query_rays"),
        }
    }
}

/// The bind group layout and the kernels, compiled once per device.
pub(crate) struct Pipelines {
    pub(crate) layout: wgpu::BindGroupLayout,
    pub(crate) kernels: Kernels,
}

impl Pipelines {
    /// Compiles the kernels for `device` (seconds on lavapipe: each pipeline is compiled by LLVM).
    pub(crate) fn new(device: &wgpu::Device) -> Self {
        let layout = bind_group_layout(device);
        let kernels = Kernels::new(device, &layout);
        Self { layout, kernels }
    }
}
