//! `fiberlab models`: every registered model (fiber and surface) with its kind and parameters.

/// Flags of `fiberlab models`.
#[derive(clap::Args)]
pub struct Args {
    /// Show only this model.
    #[arg(long)]
    model: Option<String>,
    /// Print each model's registry entry as the Markdown of the book's model pages (the
    /// text between their `registry table` comments).
    #[arg(long)]
    markdown: bool,
}

/// Prints both registries: each model's title line, then `kind: fiber` or `kind: surface`.
pub fn run(args: &Args) -> anyhow::Result<()> {
    if let Some(name) = &args.model {
        fiberlab_scatter::lookup(name)?;
    }
    let mut first = true;
    for entry in fiberlab_scatter::registry().filter(|e| args.model.as_deref().is_none_or(|n| n == e.info().name)) {
        let spec = entry.info();
        if args.markdown {
            if !first {
                println!();
            }
            first = false;
            print!("{}", spec.markdown(entry.kind()));
            continue;
        }
        println!("{} — {}", spec.name, spec.summary);
        println!("  kind: {}", entry.kind());
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
