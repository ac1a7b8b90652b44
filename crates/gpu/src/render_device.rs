//! Rendering on the device the user chose: `cpu` (the CPU path tracer, the default), `gpu` (the
//! GPU path tracer on the best adapter, software emulations included) or `auto` (a hardware GPU
//! when there is one, else the CPU with a note saying why). One function for the command line
//! and Python.

use crate::device::{AdapterChoice, DeviceError, Gpu};
use crate::wavefront::{GpuOptions, GpuRenderError};
use fiberlab_render::accumulation::Accumulation;
use fiberlab_render::integrator::{Progress, RenderOutput, RenderSettings};
use fiberlab_render::scene::Scene;
use std::sync::atomic::AtomicBool;

/// Where to render.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum DeviceChoice {
    /// The CPU path tracer.
    #[default]
    Cpu,
    /// The GPU path tracer (an error when no adapter can run it).
    Gpu,
    /// A hardware GPU when there is one, else the CPU.
    Auto,
}

impl DeviceChoice {
    /// `cpu`, `gpu` or `auto`.
    pub fn named(name: &str) -> Result<Self, String> {
        match name {
            "cpu" => Ok(Self::Cpu),
            "gpu" => Ok(Self::Gpu),
            "auto" => Ok(Self::Auto),
            other => Err(format!("device `{other}`: expected cpu, gpu or auto")),
        }
    }
}

/// Why a render on a device failed.
#[derive(Debug, thiserror::Error)]
pub enum DeviceRenderError {
    /// No GPU could be opened.
    #[error("--device gpu: {0}")]
    Device(#[from] DeviceError),
    /// The GPU render failed.
    #[error(transparent)]
    Render(#[from] GpuRenderError),
}

/// A render and the device that made it.
#[derive(Debug)]
pub struct DeviceRender {
    /// The image, state and statistics.
    pub output: RenderOutput,
    /// The device: "CPU" or the adapter's name and API.
    pub device: String,
    /// Why `auto` rendered on the CPU.
    pub note: Option<String>,
}

/// Opens the device `choice` asks for: `Ok(None)` means the CPU, with the reason when `auto`
/// fell back to it.
pub fn open(choice: DeviceChoice) -> Result<(Option<Gpu>, Option<String>), DeviceError> {
    match choice {
        DeviceChoice::Cpu => Ok((None, None)),
        DeviceChoice::Gpu => Ok((Some(Gpu::open(AdapterChoice::Any)?), None)),
        DeviceChoice::Auto => match Gpu::open(AdapterChoice::Hardware) {
            Ok(g) => Ok((Some(g), None)),
            Err(e) => Ok((None, Some(format!("--device auto: {e}; rendering on the CPU")))),
        },
    }
}

/// Renders `scene` on `gpu` (opened by [`open`]) or on the CPU when `None`, continuing `start`
/// ([`fiberlab_render::integrator::render_continuing`], [`crate::wavefront::render_continuing`]).
pub fn render_continuing(
    gpu: Option<&Gpu>,
    scene: &Scene,
    settings: &RenderSettings,
    start: Accumulation,
    progress: &(dyn Fn(&Progress) + Sync),
    stop: &AtomicBool,
) -> Result<DeviceRender, DeviceRenderError> {
    Ok(match gpu {
        None => DeviceRender {
            output: fiberlab_render::integrator::render_continuing(scene, settings, start, progress, stop)
                .map_err(GpuRenderError::from)?,
            device: "CPU".into(),
            note: None,
        },
        Some(g) => DeviceRender {
            output: crate::wavefront::render_continuing(
                g,
                scene,
                settings,
                GpuOptions::default(),
                start,
                progress,
                stop,
            )?,
            device: format!("{} ({})", g.adapter().name, g.adapter().backend),
            note: None,
        },
    })
}
