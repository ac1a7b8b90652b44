//! GPU adapters: listing them (`fiberlab devices`) and opening one for compute.
//!
//! Backends are Vulkan (Linux and Windows; Mesa's software rasterizer lavapipe, "llvmpipe",
//! runs the same shaders on the CPU), Metal (macOS) and DX12 (Windows). An adapter whose
//! device type is `Cpu` is a software emulation: `--device auto` does not pick it, `--device
//! gpu` does (that is how CI tests the shaders without a GPU).

use std::fmt;

/// What kind of processor an adapter is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AdapterKind {
    /// A discrete GPU.
    Discrete,
    /// A GPU sharing the CPU's memory.
    Integrated,
    /// A virtual GPU (e.g. in a virtual machine).
    Virtual,
    /// A software emulation on the CPU (lavapipe, WARP, SwiftShader).
    Cpu,
    /// Unknown.
    Other,
}

impl AdapterKind {
    fn of(t: wgpu::DeviceType) -> Self {
        match t {
            wgpu::DeviceType::DiscreteGpu => Self::Discrete,
            wgpu::DeviceType::IntegratedGpu => Self::Integrated,
            wgpu::DeviceType::VirtualGpu => Self::Virtual,
            wgpu::DeviceType::Cpu => Self::Cpu,
            wgpu::DeviceType::Other => Self::Other,
        }
    }

    /// A name for people.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Discrete => "discrete GPU",
            Self::Integrated => "integrated GPU",
            Self::Virtual => "virtual GPU",
            Self::Cpu => "CPU emulation",
            Self::Other => "other",
        }
    }
}

/// One adapter as `fiberlab devices` lists it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct AdapterDescription {
    /// Position in the list (what `FIBERLAB_GPU_ADAPTER` selects).
    pub index: usize,
    /// The adapter's name (e.g. "NVIDIA H200", "llvmpipe (LLVM 15.0.6, 256 bits)").
    pub name: String,
    /// Its kind.
    pub kind: AdapterKind,
    /// The API: "Vulkan", "Metal", "Dx12".
    pub backend: String,
    /// Driver name and version.
    pub driver: String,
    /// The largest buffer it allows, bytes.
    pub max_buffer_bytes: u64,
    /// The largest storage buffer a shader may bind, bytes.
    pub max_storage_binding_bytes: u64,
    /// True when it can run the path tracer (compute shaders with enough storage buffers).
    pub usable: bool,
}

impl fmt::Display for AdapterDescription {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let driver = if self.driver.is_empty() { String::new() } else { format!(", driver {}", self.driver) };
        write!(
            f,
            "{}: {} ({}, {}{driver}); largest buffer {:.1} GiB, storage binding {:.1} GiB{}",
            self.index,
            self.name,
            self.kind.name(),
            self.backend,
            self.max_buffer_bytes as f64 / (1u64 << 30) as f64,
            self.max_storage_binding_bytes as f64 / (1u64 << 30) as f64,
            if self.usable { "" } else { " — not usable: too few storage buffers per shader" }
        )
    }
}

/// Why no GPU could be opened.
#[derive(Debug, thiserror::Error)]
pub enum DeviceError {
    /// No adapter was found at all.
    #[error(
        "no GPU adapter found (looked for Vulkan, Metal and DX12 adapters through wgpu; on Linux install a Vulkan driver — for software rendering Mesa's lavapipe: `apt-get install mesa-vulkan-drivers libvulkan1`)"
    )]
    NoAdapter,
    /// Adapters exist but none is a real GPU (for `--device auto`, which then renders on the CPU).
    #[error("only CPU emulations among the GPU adapters ({0})")]
    OnlyEmulation(String),
    /// `FIBERLAB_GPU_ADAPTER` names no adapter.
    #[error("FIBERLAB_GPU_ADAPTER={0}: no such adapter (`fiberlab devices` lists them)")]
    NoSuchAdapter(String),
    /// The adapter cannot run the path tracer.
    #[error("adapter {name} cannot run the path tracer: {why}")]
    Unsuitable {
        /// Adapter name.
        name: String,
        /// What it lacks.
        why: String,
    },
    /// Opening the device failed.
    #[error("opening {name}: {error}")]
    Open {
        /// Adapter name.
        name: String,
        /// The driver's message.
        error: String,
    },
}

/// Storage buffers the path tracer binds in one shader stage.
pub(crate) const STORAGE_BUFFERS: u32 = 13;

fn instance() -> wgpu::Instance {
    let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
    desc.backends = wgpu::Backends::VULKAN | wgpu::Backends::METAL | wgpu::Backends::DX12;
    wgpu::Instance::new(desc)
}

/// Runs a future to completion on this thread. wgpu's native futures are ready after the
/// driver call they wrap (or after `Device::poll`), so a busy wait with a no-op waker suffices.
pub(crate) fn block_on<F: Future>(future: F) -> F::Output {
    let mut future = std::pin::pin!(future);
    let mut cx = std::task::Context::from_waker(std::task::Waker::noop());
    loop {
        if let std::task::Poll::Ready(v) = future.as_mut().poll(&mut cx) {
            return v;
        }
        std::thread::yield_now();
    }
}

fn adapters(instance: &wgpu::Instance) -> Vec<wgpu::Adapter> {
    block_on(instance.enumerate_adapters(wgpu::Backends::VULKAN | wgpu::Backends::METAL | wgpu::Backends::DX12))
}

fn describe(index: usize, a: &wgpu::Adapter) -> AdapterDescription {
    let info = a.get_info();
    let limits = a.limits();
    let driver = [info.driver.as_str(), info.driver_info.as_str()]
        .iter()
        .filter(|s| !s.is_empty())
        .copied()
        .collect::<Vec<_>>()
        .join(" ");
    AdapterDescription {
        index,
        name: info.name,
        kind: AdapterKind::of(info.device_type),
        backend: format!("{:?}", info.backend),
        driver,
        max_buffer_bytes: limits.max_buffer_size,
        max_storage_binding_bytes: limits.max_storage_buffer_binding_size,
        usable: limits.max_storage_buffers_per_shader_stage >= STORAGE_BUFFERS,
    }
}

/// Every adapter wgpu finds on this machine (empty when there is none).
#[must_use]
pub fn list_adapters() -> Vec<AdapterDescription> {
    adapters(&instance()).iter().enumerate().map(|(i, a)| describe(i, a)).collect()
}

/// Which adapter to open.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AdapterChoice {
    /// The best usable adapter, software emulations included (`--device gpu`).
    Any,
    /// The best usable hardware GPU; an error when only emulations exist (`--device auto`).
    Hardware,
}

/// An open device and queue with what the path tracer needs to know about them.
pub struct Gpu {
    pub(crate) device: wgpu::Device,
    pub(crate) queue: wgpu::Queue,
    description: AdapterDescription,
    pub(crate) limits: wgpu::Limits,
    /// The path tracer's compiled kernels, made on first use.
    pub(crate) pipelines: std::sync::OnceLock<crate::kernels::Pipelines>,
    /// The model probe's compiled entry points ([`crate::model_probe`]), made on first use
    /// (each costs lavapipe a second or two to compile).
    pub(crate) probe_pipelines: std::sync::Mutex<std::collections::HashMap<&'static str, wgpu::ComputePipeline>>,
}

impl fmt::Debug for Gpu {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Gpu").field("adapter", &self.description).finish()
    }
}

fn preference(kind: AdapterKind) -> u32 {
    match kind {
        AdapterKind::Discrete => 0,
        AdapterKind::Integrated => 1,
        AdapterKind::Virtual => 2,
        AdapterKind::Other => 3,
        AdapterKind::Cpu => 4,
    }
}

impl Gpu {
    /// Opens an adapter: the one `FIBERLAB_GPU_ADAPTER` names (its index in `fiberlab devices`)
    /// or the first usable one of the most capable kind (discrete, integrated, virtual, other,
    /// CPU emulation).
    pub fn open(choice: AdapterChoice) -> Result<Self, DeviceError> {
        let instance = instance();
        let all = adapters(&instance);
        if all.is_empty() {
            return Err(DeviceError::NoAdapter);
        }
        let described: Vec<AdapterDescription> = all.iter().enumerate().map(|(i, a)| describe(i, a)).collect();
        let index = match std::env::var("FIBERLAB_GPU_ADAPTER") {
            Ok(v) => v
                .trim()
                .parse::<usize>()
                .ok()
                .filter(|&i| i < all.len())
                .ok_or(DeviceError::NoSuchAdapter(v.clone()))?,
            Err(_) => {
                let mut order: Vec<&AdapterDescription> = described.iter().filter(|d| d.usable).collect();
                order.sort_by_key(|d| (preference(d.kind), d.index));
                let best = order.first().ok_or_else(|| DeviceError::Unsuitable {
                    name: described.iter().map(|d| d.name.clone()).collect::<Vec<_>>().join(", "),
                    why: format!("fewer than {STORAGE_BUFFERS} storage buffers per shader stage"),
                })?;
                if choice == AdapterChoice::Hardware && best.kind == AdapterKind::Cpu {
                    let names = described.iter().map(|d| d.name.clone()).collect::<Vec<_>>().join(", ");
                    return Err(DeviceError::OnlyEmulation(names));
                }
                best.index
            }
        };
        let adapter = &all[index];
        let description = described[index].clone();
        if !description.usable {
            return Err(DeviceError::Unsuitable {
                name: description.name,
                why: format!("fewer than {STORAGE_BUFFERS} storage buffers per shader stage"),
            });
        }
        let limits = adapter.limits();
        let desc = wgpu::DeviceDescriptor {
            label: Some("fiberlab"),
            required_features: wgpu::Features::empty(),
            required_limits: limits.clone(),
            experimental_features: wgpu::ExperimentalFeatures::disabled(),
            memory_hints: wgpu::MemoryHints::Performance,
            trace: wgpu::Trace::Off,
        };
        let (device, queue) = block_on(adapter.request_device(&desc))
            .map_err(|e| DeviceError::Open { name: description.name.clone(), error: e.to_string() })?;
        Ok(Self {
            device,
            queue,
            description,
            limits,
            pipelines: std::sync::OnceLock::new(),
            probe_pipelines: std::sync::Mutex::default(),
        })
    }

    /// The adapter this device runs on.
    #[must_use]
    pub fn adapter(&self) -> &AdapterDescription {
        &self.description
    }
}
