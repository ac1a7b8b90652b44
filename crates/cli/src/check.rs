//! `fiberlab check`: run the validation harness and print the table.
//!
//! A signal (Ctrl-C, SIGTERM, SIGHUP) starts no further configuration: those in flight
//! finish, the rows of every finished one are printed (the partial table, its last line
//! saying how many were checked) and the exit status is 130 (`crate::interrupt`).

use fiberlab_check::{CheckCase, Effort, Row, check_cases_until, default_cases};
use indicatif::{ProgressBar, ProgressStyle};

/// Flags of `fiberlab check`.
#[derive(clap::Args)]
pub struct Args {
    /// Check only the configurations of this model.
    #[arg(long)]
    model: Option<String>,
    /// Check one configuration of a surface model (needs --model): KEY=VALUE, repeatable,
    /// e.g. `--param pattern=scenes/weaves/satin.weave` for `irawan-2012`.
    #[arg(long = "param", value_name = "KEY=VALUE")]
    params: Vec<String>,
    /// Print the rows as one JSON array instead of a table.
    #[arg(long)]
    json: bool,
    /// No progress bar (it is drawn on stderr, and only on a terminal, so stdout is the same
    /// either way).
    #[arg(long, short)]
    quiet: bool,
}

/// Runs the harness; fails (non-zero exit) when any row fails.
pub fn run(args: &Args) -> anyhow::Result<()> {
    if let Some(name) = &args.model {
        fiberlab_scatter::lookup(name)?;
    }
    if !args.params.is_empty() {
        return run_one(args);
    }
    let cases: Vec<CheckCase> =
        default_cases().into_iter().filter(|c| args.model.as_deref().is_none_or(|m| m == c.model)).collect();
    // On stderr, drawn only on a terminal (indicatif's default target); ticking on its own so
    // that the elapsed time moves while a slow configuration runs.
    let bar = if args.quiet { ProgressBar::hidden() } else { ProgressBar::new(cases.len() as u64) };
    bar.set_style(
        ProgressStyle::with_template("{spinner} checking {pos}/{len} model configurations {wide_bar} {elapsed}")
            .expect("valid template"),
    );
    bar.enable_steady_tick(std::time::Duration::from_millis(250));
    let stop = crate::interrupt::listen(&format!("checking {} model configurations", cases.len()), "the rows done");
    let mut rows = check_cases_until(&cases, &Effort::default(), || bar.inc(1), stop);
    bar.finish_and_clear();
    crate::interrupt::finishing();
    // Keep the table in registry order, whatever order the threads finished in.
    let order = |r: &Row| cases.iter().position(|c| c.label() == r.model).unwrap_or(usize::MAX);
    rows.sort_by_key(order);
    if crate::interrupt::stopped() {
        let checked = cases.iter().filter(|c| rows.iter().any(|r| r.model == c.label())).count();
        let result = finish(&rows, args.json);
        let verdict = match result {
            Ok(()) => "all passed".to_string(),
            Err(e) => e.to_string(),
        };
        return Err(crate::interrupt::Interrupted(format!(
            "checked {checked} of {} configurations ({verdict}); the table above is partial",
            cases.len()
        ))
        .into());
    }
    finish(&rows, args.json)
}

/// Prints the rows; an error when any failed.
fn finish(rows: &[Row], json: bool) -> anyhow::Result<()> {
    let failed = rows.iter().filter(|r| !r.pass).count();
    if json {
        println!("{}", serde_json::to_string_pretty(rows)?);
    } else {
        print_table(rows);
        let tests = rows.iter().filter(|r| !r.report).count();
        println!("\n{} passed, {} failed", tests - failed, failed);
    }
    anyhow::ensure!(failed == 0, "{failed} check(s) failed");
    Ok(())
}

/// `--model NAME --param …`: the one configuration, built through the model loader.
fn run_one(args: &Args) -> anyhow::Result<()> {
    let Some(model) = &args.model else { anyhow::bail!("--param needs --model (a surface model)") };
    let model_args =
        crate::model_args::ModelArgs { model: model.clone(), params: args.params.clone(), params_file: None };
    anyhow::ensure!(
        model_args.kind()? == fiberlab_scatter::ModelKind::Surface,
        "--param is for surface models; `{model}` is a fiber model (its configurations are fixed)"
    );
    let built = model_args.build_surface()?;
    let bar = if args.quiet { ProgressBar::hidden() } else { ProgressBar::new_spinner() };
    bar.set_message(format!("checking {}", model_args.label()));
    bar.enable_steady_tick(std::time::Duration::from_millis(250));
    let rows = fiberlab_check::surface::check_surface_model(&model_args.label(), &built, &Effort::default());
    bar.finish_and_clear();
    finish(&rows, args.json)
}

fn fmt(x: f64) -> String {
    if x.is_nan() {
        "-".into()
    } else if x == 0.0 || (1e-3..1e5).contains(&x.abs()) {
        format!("{x:.6}")
    } else {
        format!("{x:.3e}")
    }
}

fn print_table(rows: &[Row]) {
    let w = rows.iter().map(|r| r.model.chars().count()).max().unwrap_or(5).max(5);
    let t = rows.iter().map(|r| r.test.chars().count()).max().unwrap_or(4).max(4);
    println!("{:<w$}  {:<t$}  {:>12}  {:>12}  {:>10}  pass", "model", "test", "value", "expected", "tolerance");
    for r in rows {
        let pass = if r.report {
            "report"
        } else if r.pass {
            "yes"
        } else {
            "NO"
        };
        println!(
            "{:<w$}  {:<t$}  {:>12}  {:>12}  {:>10}  {pass}",
            r.model,
            r.test,
            fmt(r.value),
            fmt(r.expected),
            fmt(r.tolerance)
        );
    }
}
