//! `fiberlab models`: every registered model with its parameters.

use fiberlab_scatter::MODELS;

/// Flags of `fiberlab models`.
#[derive(clap::Args)]
pub struct Args {
    /// Show only this model.
    #[arg(long)]
    model: Option<String>,
}

/// Prints the registry.
pub fn run(args: &Args) -> anyhow::Result<()> {
    if let Some(name) = &args.model {
        fiberlab_scatter::find(name)?;
    }
    for spec in MODELS.iter().filter(|m| args.model.as_deref().is_none_or(|n| n == m.name)) {
        println!("{} — {}", spec.name, spec.summary);
        println!("  source: {}", spec.citation);
        println!("  {:<14} {:<28} {:<10} {:<10} description", "parameter", "valid", "unit", "default");
        for p in spec.params {
            let default = if p.default.is_empty() { "(unset)" } else { p.default };
            let unit = if p.unit.is_empty() { "-" } else { p.unit };
            println!("  {:<14} {:<28} {:<10} {:<10} {}", p.key, p.valid(), unit, default, p.doc);
        }
        println!();
    }
    Ok(())
}
