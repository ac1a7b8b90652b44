//! `fiberlab explore`: serves the interactive explorer (`fiberlab_explorer`) and prints its
//! address; `--open` also asks the desktop to open it in a browser.

use std::process::{Command, Stdio};

/// Flags of `fiberlab explore`.
#[derive(clap::Args)]
pub struct Args {
    /// Port to listen on (0: any free port).
    #[arg(long, default_value_t = 8765)]
    port: u16,
    /// Address to listen on; the default serves this machine only. Anyone who can reach the
    /// address can use the server's CPU (within its limits).
    #[arg(long, default_value = "127.0.0.1")]
    host: String,
    /// Open the page in the desktop's browser.
    #[arg(long)]
    open: bool,
}

/// Serves until interrupted: the first Ctrl-C (or SIGTERM, SIGHUP) shuts the server down
/// gracefully, a second quits at once.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let config = fiberlab_explorer::Config { host: args.host.clone(), port: args.port, ..Default::default() };
    let stop = crate::interrupt::listen_quietly(
        "fiberlab explore: stopping: cancelling the work in flight and closing connections (again to quit)",
    );
    let ended = fiberlab_explorer::serve_until(
        &config,
        |url| {
            println!("fiberlab explore: serving {url} (Ctrl-C stops it)");
            if args.open {
                open_browser(url);
            }
        },
        stop,
    )?;
    let connections = if ended.closed_connections { "connections closed" } else { "connections dropped" };
    eprintln!("fiberlab explore: stopped ({} requests cancelled, {connections})", ended.cancelled);
    Ok(())
}

/// Asks the desktop to open `url` (a failure is reported, not fatal: the address is printed).
fn open_browser(url: &str) {
    let opener = if cfg!(target_os = "macos") {
        Command::new("open").arg(url).stdout(Stdio::null()).stderr(Stdio::null()).spawn()
    } else if cfg!(target_os = "windows") {
        Command::new("cmd").args(["/C", "start", "", url]).stdout(Stdio::null()).stderr(Stdio::null()).spawn()
    } else {
        Command::new("xdg-open").arg(url).stdout(Stdio::null()).stderr(Stdio::null()).spawn()
    };
    if let Err(e) = opener {
        eprintln!("fiberlab explore: could not open a browser ({e}); open {url} yourself");
    }
}
