//! `fiberlab devices`: the GPU adapters wgpu finds (Vulkan, Metal, DX12), one a line.

/// Flags of `fiberlab devices` (none).
#[derive(clap::Args)]
pub struct Args {}

/// Runs `fiberlab devices`.
pub fn run(_args: &Args) -> anyhow::Result<()> {
    let adapters = fiberlab_gpu::list_adapters();
    if adapters.is_empty() {
        println!("{}", fiberlab_gpu::DeviceError::NoAdapter);
        return Ok(());
    }
    for a in &adapters {
        println!("{a}");
    }
    println!(
        "`render --device gpu` uses the first usable one of the most capable kind (FIBERLAB_GPU_ADAPTER=N picks one); `--device auto` skips CPU emulations"
    );
    Ok(())
}
