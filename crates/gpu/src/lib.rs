//! fiberlab on the GPU: a wavefront path tracer for fiber scenes in WGSL compute shaders
//! through wgpu (Vulkan, Metal, DX12), rendering the same scenes as the CPU renderer
//! (`fiberlab-render`) into the same progressive state, so that `--resume`, `--time-limit`,
//! Ctrl-C, tiles and `merge` work across devices.
//!
//! * [`device`]: adapters (`fiberlab devices`) and opening one.
//! * [`wavefront`]: the path tracer (kernels in `src/shaders/`), [`wavefront::render_continuing`].
//! * [`scene_buffers`]: a scene flattened for the GPU; what is not supported is refused there.
//! * [`render_device`]: rendering on the CPU, the GPU or whichever there is (`--device`).
//! * [`model_probe`]: the GPU's scattering model and sampler on given inputs (tests).
//!
//! Supported: the `chiang`, `deon`, `huang-2022`, `kajiya-kay`, `marschner` and `yan-fur` fiber models; `lambert` and
//! `mirror` surfaces, the `leaf` and `lambertian` surface models (`lambertian`'s `k_d` textured
//! too); constant and importance-sampled map environments, sun, distant and
//! emitting-sphere lights with the CPU's light picker and MIS; spheres, tube segments (the CPU's
//! BVH as it is, both node kinds) and triangle meshes; path tracing. Refused with an error
//! naming it: other fiber models, other surface models, dual scattering.

pub mod device;
mod kernels;
pub mod model_probe;
pub mod render_device;
pub mod scene_buffers;
pub mod wavefront;

pub use device::{AdapterChoice, AdapterDescription, AdapterKind, DeviceError, Gpu, list_adapters};
pub use render_device::{DeviceChoice, DeviceRender};
pub use wavefront::{GpuOptions, GpuRenderError, render, render_continuing};
