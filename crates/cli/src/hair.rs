//! `fiberlab hair`: generate procedural hair as a `.hair` file, describe a hair file of any
//! format, or convert between formats (chosen by extension: `.hair`, `.pbrt`/`.pbrt.gz`
//! (read only), `.usda`).

use fiberlab_io::{Format, StrandsError, strand_files};
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
    /// Print counts, bounds, widths and basis of a hair file (.hair, .pbrt, .pbrt.gz, .usda;
    /// reading it validates it).
    Info {
        /// The file.
        file: PathBuf,
    },
    /// Convert a hair file to .hair or .usda (formats by extension). Cubic curves written as
    /// .hair become polylines: each span evaluated at --segments-per-curve uniform steps.
    Convert {
        /// Input: .hair, .pbrt, .pbrt.gz or .usda.
        input: PathBuf,
        /// Output: .hair or .usda (its directory is checked writable first).
        #[arg(value_parser = crate::files::output_file)]
        output: PathBuf,
        /// Polyline segments per span of a cubic curve, when writing .hair.
        #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u32).range(1..=1024))]
        segments_per_curve: u32,
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
            // The readers' errors name the file already.
            let s = strand_files::read(file)?;
            println!("strands     {}", s.strand_count());
            println!("points      {}", s.points.len());
            println!("segments    {}", s.span_count());
            println!("basis       {}", s.basis);
            println!("type        {}", s.kind);
            if Format::of(file)? == Format::Hair {
                println!("flags       {:#x}", fiberlab_io::HairHeader::read(file)?.flags);
            }
            match (s.bounds(), s.width_range()) {
                (Some((lo, hi)), Some((wmin, wmax))) => {
                    println!("bounds      {lo:?} – {hi:?}");
                    println!("widths      {wmin} – {wmax}");
                }
                _ => {
                    println!("bounds      none (no points)");
                    println!("widths      none");
                }
            }
        }
        HairCommand::Convert { input, output, segments_per_curve } => {
            let out_format = Format::of(output)?;
            if out_format == Format::Pbrt {
                anyhow::bail!("{}: writing pbrt files is not supported; write .hair or .usda", output.display());
            }
            let s = strand_files::read(input)?;
            strand_files::write(output, &s, *segments_per_curve as usize).map_err(|e| match e {
                // Only these lack the file's name.
                StrandsError::Inconsistent(m) => anyhow::anyhow!("{}: {m}", output.display()),
                e => e.into(),
            })?;
            eprintln!("{} strands, {} points ({}) → {}", s.strand_count(), s.points.len(), s.basis, output.display());
        }
    }
    Ok(())
}
