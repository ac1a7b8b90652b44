//! `fiberlab hair`: generate procedural hair as a `.hair` file (or a grass patch as ribbon
//! curves in a `.usda` file), describe a hair file of any format, or convert between formats
//! (chosen by extension: `.hair`, `.pbrt`/`.pbrt.gz` (read only), `.usda`).

use fiberlab_io::{Format, StrandsError, strand_files};
use fiberlab_procedural::generator::{HairParams, Style};
use fiberlab_procedural::grass::GrassParams;
use std::path::PathBuf;

/// Flags of `fiberlab hair`.
#[derive(clap::Args)]
pub struct Args {
    #[command(subcommand)]
    command: HairCommand,
}

#[derive(clap::Subcommand)]
enum HairCommand {
    /// Grow strands over a unit head sphere (or fur over the whole sphere) and write a .hair
    /// file; or grow a grass patch (--style grass) and write its blades as ribbon curves with
    /// normals to a .usda file.
    Generate(Box<GenerateArgs>),
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

/// Defaults of `--style` straight/wavy/curly ([`HairParams::default`]) and fur
/// ([`HairParams::fur`]); a flag given overrides the style's default.
#[derive(clap::Args)]
struct GenerateArgs {
    /// straight, wavy, curly (hair on a head), fur (short, tapered, clumped strands over the
    /// whole unit sphere; the defaults below in parentheses) or grass (blades as ribbons over
    /// a patch of the plane y = 0, written as .usda; the defaults in brackets with "grass").
    #[arg(long, default_value_t = GenerateStyle::Hair(HairParams::default().style))]
    style: GenerateStyle,
    /// Number of strands [default: 20000 (fur: 60000; grass: 4000 blades)].
    #[arg(long)]
    strands: Option<usize>,
    /// Segments per strand [default: 24 (fur: 6; grass: 8)].
    #[arg(long)]
    segments: Option<usize>,
    /// Strand length, head radius = 1 [default: 1.6 (fur: 0.14; grass: 0.25, the longest blade)].
    #[arg(long)]
    length: Option<f64>,
    /// Each strand's length is uniform in [length·(1 − j), length], j in [0, 1) [default: 0 (fur: 0.35; grass: 0.4)].
    #[arg(long)]
    length_jitter: Option<f64>,
    /// Wave/curl amplitude, head radius = 1 [default: 0.03 (fur: no waves)].
    #[arg(long)]
    amplitude: Option<f64>,
    /// Wave/curl length (pitch) [default: 0.35].
    #[arg(long)]
    wavelength: Option<f64>,
    /// Number of clumps (grass: tufts), 0: none [default: 400 (fur: 3000; grass: 200)].
    #[arg(long)]
    clumps: Option<usize>,
    /// Blend toward the clump guide at the tip, [0, 1] [default: 0.35 (fur: 0.6)].
    #[arg(long)]
    clumping: Option<f64>,
    /// Pull toward −y per unit length [default: 3 (fur: 1.5)].
    #[arg(long)]
    gravity: Option<f64>,
    /// Random direction jitter per step [default: 0.04 (fur: 0.08)].
    #[arg(long)]
    noise: Option<f64>,
    /// Root diameter [default: 0.002 (fur: 0.005)].
    #[arg(long)]
    root_diameter: Option<f64>,
    /// Tip diameter as a fraction of the root diameter, 1: constant radius [default: 0.5 (fur: 0.1;
    /// grass: 0, pointed blades)].
    #[arg(long)]
    tip_ratio: Option<f64>,
    /// Grass: largest blade width at the root [default: 0.01].
    #[arg(long)]
    width: Option<f64>,
    /// Grass: the patch's size along x and z, centred on the origin [default: 1,1].
    #[arg(long, value_delimiter = ',', value_name = "SX,SZ")]
    size: Option<Vec<f64>>,
    /// Grass: largest lean of a blade's root from vertical, degrees [default: 20].
    #[arg(long)]
    lean_deg: Option<f64>,
    /// Grass: largest turn of a blade's tangent from root to tip, degrees [default: 50].
    #[arg(long)]
    bend_deg: Option<f64>,
    /// Grass: largest twist of a blade about its centreline, degrees [default: 60].
    #[arg(long)]
    twist_deg: Option<f64>,
    /// Grass: radius of a tuft [default: 0.04].
    #[arg(long)]
    clump_radius: Option<f64>,
    /// Random seed.
    #[arg(long, default_value_t = HairParams::default().seed)]
    seed: u64,
    /// Output file (its directory is checked writable before the hair is grown).
    #[arg(long, value_parser = crate::files::output_file)]
    out: PathBuf,
    #[command(flatten)]
    memory: crate::memory_budget::MemoryLimit,
}

/// `--style`: a hair style of the hair generator, or grass (the grass generator).
#[derive(Clone, Copy, Debug, PartialEq)]
enum GenerateStyle {
    Hair(Style),
    Grass,
}

impl std::fmt::Display for GenerateStyle {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Hair(s) => s.fmt(f),
            Self::Grass => f.write_str("grass"),
        }
    }
}

impl std::str::FromStr for GenerateStyle {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        if s == "grass" {
            return Ok(Self::Grass);
        }
        s.parse::<Style>()
            .map(Self::Hair)
            .map_err(|_| format!("unknown style `{s}`; expected straight, wavy, curly, fur or grass"))
    }
}

impl GenerateArgs {
    /// The grass generator's parameters: its defaults, overridden by the flags given; a flag of
    /// the hair generator only is an error naming it.
    fn grass(&self) -> anyhow::Result<GrassParams> {
        let hair_only = [
            ("--amplitude", self.amplitude.is_some()),
            ("--wavelength", self.wavelength.is_some()),
            ("--clumping", self.clumping.is_some()),
            ("--gravity", self.gravity.is_some()),
            ("--noise", self.noise.is_some()),
            ("--root-diameter", self.root_diameter.is_some()),
        ];
        if let Some((flag, _)) = hair_only.iter().find(|(_, given)| *given) {
            anyhow::bail!(
                "{flag} is a hair flag; --style grass takes --width, --size, --lean-deg, --bend-deg, --twist-deg, --clump-radius"
            );
        }
        let d = GrassParams::default();
        let size = match self.size.as_deref() {
            None => d.size,
            Some(&[sx, sz]) => [sx, sz],
            Some(v) => anyhow::bail!("--size takes two numbers SX,SZ; got {}", v.len()),
        };
        Ok(GrassParams {
            blades: self.strands.unwrap_or(d.blades),
            segments: self.segments.unwrap_or(d.segments),
            size,
            height: self.length.unwrap_or(d.height),
            height_jitter: self.length_jitter.unwrap_or(d.height_jitter),
            width: self.width.unwrap_or(d.width),
            tip_ratio: self.tip_ratio.unwrap_or(d.tip_ratio),
            lean_deg: self.lean_deg.unwrap_or(d.lean_deg),
            bend_deg: self.bend_deg.unwrap_or(d.bend_deg),
            twist_deg: self.twist_deg.unwrap_or(d.twist_deg),
            clumps: self.clumps.unwrap_or(d.clumps),
            clump_radius: self.clump_radius.unwrap_or(d.clump_radius),
            seed: self.seed,
        })
    }

    /// A grass flag given with a hair style, by name.
    fn grass_flag(&self) -> Option<&'static str> {
        [
            ("--width", self.width.is_some()),
            ("--size", self.size.is_some()),
            ("--lean-deg", self.lean_deg.is_some()),
            ("--bend-deg", self.bend_deg.is_some()),
            ("--twist-deg", self.twist_deg.is_some()),
            ("--clump-radius", self.clump_radius.is_some()),
        ]
        .into_iter()
        .find_map(|(flag, given)| given.then_some(flag))
    }
}

impl Args {
    /// `--memory-limit` of `hair generate`.
    pub fn memory_limit(&self) -> Option<u64> {
        match &self.command {
            HairCommand::Generate(g) => g.memory.bytes(),
            _ => None,
        }
    }
}

/// Runs `fiberlab hair`.
pub fn run(args: &Args) -> anyhow::Result<()> {
    match &args.command {
        HairCommand::Generate(g) => {
            let style = match g.style {
                GenerateStyle::Grass => {
                    if Format::of(&g.out)? != Format::Usda {
                        anyhow::bail!(
                            "{}: grass blades are ribbon curves with normals, which only .usda holds; name the output .usda",
                            g.out.display()
                        );
                    }
                    let params = g.grass()?;
                    params.validate()?;
                    g.memory.check(&crate::memory_budget::grass_generate_needs(&params))?;
                    let strands = params.strands()?;
                    strand_files::write(&g.out, &strands, 1)?;
                    eprintln!(
                        "{} blades, {} points (ribbon curves with normals) → {}",
                        strands.strand_count(),
                        strands.points.len(),
                        g.out.display()
                    );
                    return Ok(());
                }
                GenerateStyle::Hair(style) => style,
            };
            if let Some(flag) = g.grass_flag() {
                anyhow::bail!("{flag} is a grass flag; use it with --style grass");
            }
            let base = if style == Style::Fur { HairParams::fur() } else { HairParams::default() };
            let params = HairParams {
                style,
                strands: g.strands.unwrap_or(base.strands),
                segments: g.segments.unwrap_or(base.segments),
                length: g.length.unwrap_or(base.length),
                length_jitter: g.length_jitter.unwrap_or(base.length_jitter),
                amplitude: g.amplitude.unwrap_or(base.amplitude),
                wavelength: g.wavelength.unwrap_or(base.wavelength),
                clumps: g.clumps.unwrap_or(base.clumps),
                clumping: g.clumping.unwrap_or(base.clumping),
                gravity: g.gravity.unwrap_or(base.gravity),
                noise: g.noise.unwrap_or(base.noise),
                root_diameter: g.root_diameter.unwrap_or(base.root_diameter),
                tip_ratio: g.tip_ratio.unwrap_or(base.tip_ratio),
                seed: g.seed,
                ..base
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
