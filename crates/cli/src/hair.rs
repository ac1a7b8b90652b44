//! `fiberlab hair`: generate procedural hair as a `.hair` file, or describe one.

use fiberlab_io::HairFile;
use fiberlab_render::generator::{HairParams, Style};
use std::path::PathBuf;

/// Flags of `fiberlab hair`.
#[derive(clap::Args)]
pub struct Args {
    #[command(subcommand)]
    command: HairCommand,
}

#[derive(clap::Subcommand)]
enum HairCommand {
    /// Grow strands over a unit head sphere and write a .hair file.
    Generate(GenerateArgs),
    /// Print counts, bounds and thickness of a .hair file (validates it).
    Info {
        /// The file.
        file: PathBuf,
    },
}

#[derive(clap::Args)]
struct GenerateArgs {
    /// straight, wavy or curly.
    #[arg(long, default_value_t = HairParams::default().style)]
    style: Style,
    /// Number of strands.
    #[arg(long, default_value_t = HairParams::default().strands)]
    strands: usize,
    /// Segments per strand.
    #[arg(long, default_value_t = HairParams::default().segments)]
    segments: usize,
    /// Strand length (head radius = 1).
    #[arg(long, default_value_t = HairParams::default().length)]
    length: f64,
    /// Wave/curl amplitude (head radius = 1).
    #[arg(long, default_value_t = HairParams::default().amplitude)]
    amplitude: f64,
    /// Wave/curl length (pitch).
    #[arg(long, default_value_t = HairParams::default().wavelength)]
    wavelength: f64,
    /// Number of clumps (0: none).
    #[arg(long, default_value_t = HairParams::default().clumps)]
    clumps: usize,
    /// Blend toward the clump guide at the tip, [0, 1].
    #[arg(long, default_value_t = HairParams::default().clumping)]
    clumping: f64,
    /// Pull toward −y per unit length.
    #[arg(long, default_value_t = HairParams::default().gravity)]
    gravity: f64,
    /// Random direction jitter per step.
    #[arg(long, default_value_t = HairParams::default().noise)]
    noise: f64,
    /// Root diameter.
    #[arg(long, default_value_t = HairParams::default().root_diameter)]
    root_diameter: f64,
    /// Tip diameter as a fraction of the root diameter (1: constant radius).
    #[arg(long, default_value_t = HairParams::default().tip_ratio)]
    tip_ratio: f64,
    /// Random seed.
    #[arg(long, default_value_t = HairParams::default().seed)]
    seed: u64,
    /// Output file (its directory is checked writable before the hair is grown).
    #[arg(long, value_parser = crate::files::output_file)]
    out: PathBuf,
    #[command(flatten)]
    memory: crate::memory_budget::MemoryLimit,
}

/// Runs `fiberlab hair`.
pub fn run(args: &Args) -> anyhow::Result<()> {
    match &args.command {
        HairCommand::Generate(g) => {
            let params = HairParams {
                style: g.style,
                strands: g.strands,
                segments: g.segments,
                length: g.length,
                amplitude: g.amplitude,
                wavelength: g.wavelength,
                clumps: g.clumps,
                clumping: g.clumping,
                gravity: g.gravity,
                noise: g.noise,
                root_diameter: g.root_diameter,
                tip_ratio: g.tip_ratio,
                seed: g.seed,
                ..HairParams::default()
            };
            g.memory.check(&crate::memory_budget::hair_generate_needs(&params))?;
            let hair = params.generate()?;
            hair.write(&g.out)?;
            eprintln!("{} strands, {} points → {}", hair.strand_count(), hair.points.len(), g.out.display());
        }
        HairCommand::Info { file } => {
            // The reader's errors name the file already.
            let hair = HairFile::read(file)?;
            let mut lo = [f32::INFINITY; 3];
            let mut hi = [f32::NEG_INFINITY; 3];
            for p in &hair.points {
                for k in 0..3 {
                    lo[k] = lo[k].min(p[k]);
                    hi[k] = hi[k].max(p[k]);
                }
            }
            let (tmin, tmax) = (0..hair.points.len())
                .map(|i| hair.thickness_at(i))
                .fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), t| (a.min(t), b.max(t)));
            println!("strands     {}", hair.strand_count());
            println!("points      {}", hair.points.len());
            println!("flags       {:#x}", hair.flags());
            println!("bounds      {lo:?} – {hi:?}");
            println!("thickness   {tmin} – {tmax}");
        }
    }
    Ok(())
}
