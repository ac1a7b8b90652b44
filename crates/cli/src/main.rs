//! `fiberlab`: light scattering by fibers from the command line. One module per verb; each
//! parses its flags into an `Args` struct and runs it (`run(&Args) -> anyhow::Result<()>`).
#![forbid(unsafe_code)]

mod arg_values;
mod bench;
mod check;
mod compare;
mod compare_model;
mod devices;
mod dual_tables;
mod eval;
mod evaluate;
mod explore;
mod files;
mod fit;
mod hair;
mod interrupt;
mod measure;
mod medulla_tables;
mod memory_budget;
mod merge;
mod mesh;
mod model_args;
mod models;
mod montage;
mod plot;
mod render;
mod sample;
mod scene;
mod texture;

use clap::{Parser, Subcommand};

/// `fiberlab --version`: the package version and the commit it was built from (`build.rs`).
const VERSION: &str = concat!(env!("CARGO_PKG_VERSION"), " (", env!("FIBERLAB_COMMIT"), ")");

/// fiberlab: scattering functions for hair, fur and other fibers.
#[derive(Parser)]
#[command(name = "fiberlab", version = VERSION, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Validate every model (furnace, reciprocity, pdf, χ², finiteness); non-zero exit on failure.
    Check(check::Args),
    /// List models with their kind (fiber or surface), parameters, units, defaults and valid ranges.
    Models(models::Args),
    /// Evaluate f_s (fiber) or f_r (surface) and pdf for direction pairs read as CSV.
    Eval(eval::Args),
    /// Draw importance samples of ω_i for a given ω_o.
    Sample(sample::Args),
    /// Plot a scattering function over (φ, θ_r) at fixed θ_i, with polar slices.
    Plot(plot::Args),
    /// Measure eval and sample throughput of the models (ns/call).
    Bench(bench::Args),
    /// Virtual goniophotometer: measure f_s by ray tracing an explicit fiber.
    Measure(measure::Args),
    /// Build the dual-scattering tables (Zinke et al. 2008) of a far-field model: CSV per light inclination and a figure.
    DualTables(dual_tables::Args),
    /// Build the medulla scattering tables of one medium (random walk) and write CSV slices and a figure.
    MedullaTables(medulla_tables::Args),
    /// Path-trace a scene (default: a head with generated hair) to EXR and PNG.
    Render(render::Args),
    /// List the GPU adapters `render --device gpu` can use (name, kind, API, memory limits).
    Devices(devices::Args),
    /// Merge parts rendered with --tile I/N into one image (bit-exact).
    Merge(merge::Args),
    /// Generate or inspect .hair files.
    Hair(hair::Args),
    /// Print the built-in default scene as a template (--default), or write it (--out FILE).
    Scene(scene::Args),
    /// Write procedural textures: `texture wood` (a figured-maple fiber map).
    Texture(texture::Args),
    /// Write procedural meshes: `mesh cloth` (a cloth draped over a sphere, with uvs).
    Mesh(mesh::Args),
    /// Lay PNG images out in a labelled grid (a contact sheet).
    Montage(montage::Args),
    /// Compare a model with a measured table, per lobe (errors, peaks, difference figures).
    CompareModel(compare_model::Args),
    /// Fit model parameters to a measured table or CSV by weighted least squares.
    Fit(fit::Args),
    /// Compare two images (EXR/PNG/JPEG): RMSE, relative MSE, SSIM, FLIP, difference figure.
    Compare(compare::Args),
    /// Render one scene with several models and compare each with a reference.
    Evaluate(evaluate::Args),
    /// Serve the interactive explorer (models, plots, comparisons, fits, render preview) on localhost.
    Explore(explore::Args),
}

impl Command {
    /// `--memory-limit` of the verbs that have it.
    fn memory_limit(&self) -> Option<u64> {
        match self {
            Command::Render(a) => a.memory.bytes(),
            Command::Measure(a) => a.memory.bytes(),
            Command::Evaluate(a) => a.memory.bytes(),
            Command::Hair(a) => a.memory_limit(),
            _ => None,
        }
    }
}

fn main() {
    // `fiberlab … | head` closes the pipe early: leave quietly instead of panicking in println!.
    let default_hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        let message = info.payload().downcast_ref::<String>().map(String::as_str).unwrap_or("");
        if message.contains("Broken pipe") {
            std::process::exit(0);
        }
        default_hook(info);
    }));
    let cli = Cli::parse();
    // Before any work: signals stop or quit cleanly (`interrupt`), and `--memory-limit`
    // bounds every input file as well as the verb's own check.
    interrupt::install();
    fiberlab_io::memory_budget::set_limit(cli.command.memory_limit());
    #[cfg(fiberlab_stats)]
    struct PrintStats;
    #[cfg(fiberlab_stats)]
    impl Drop for PrintStats {
        fn drop(&mut self) {
            fiberlab_geometry::bvh::stats::print();
        }
    }
    #[cfg(fiberlab_stats)]
    let _stats = PrintStats;
    let result = match &cli.command {
        Command::Check(a) => check::run(a),
        Command::Models(a) => models::run(a),
        Command::Eval(a) => eval::run(a),
        Command::Sample(a) => sample::run(a),
        Command::Plot(a) => plot::run(a),
        Command::Bench(a) => bench::run(a),
        Command::Measure(a) => measure::run(a),
        Command::DualTables(a) => dual_tables::run(a),
        Command::MedullaTables(a) => medulla_tables::run(a),
        Command::Render(a) => render::run(a),
        Command::Devices(a) => devices::run(a),
        Command::Merge(a) => merge::run(a),
        Command::Hair(a) => hair::run(a),
        Command::Scene(a) => scene::run(a),
        Command::Texture(a) => texture::run(a),
        Command::Mesh(a) => mesh::run(a),
        Command::Montage(a) => montage::run(a),
        Command::CompareModel(a) => compare_model::run(a),
        Command::Fit(a) => fit::run(a),
        Command::Compare(a) => compare::run(a),
        Command::Evaluate(a) => evaluate::run(a),
        Command::Explore(a) => explore::run(a),
    };
    if let Err(e) = result {
        if let Some(interrupted) = e.downcast_ref::<interrupt::Interrupted>() {
            eprintln!("fiberlab: {interrupted}");
            std::process::exit(interrupt::EXIT_STATUS);
        }
        eprintln!("fiberlab: error: {e:#}");
        std::process::exit(1);
    }
}
