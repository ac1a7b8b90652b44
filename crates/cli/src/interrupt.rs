//! Signals: SIGINT (Ctrl-C), SIGTERM and SIGHUP, one handler for the whole process,
//! installed by `main` before any verb runs.
//!
//! * A long verb that can stop cleanly — `render`, `measure`, `fit`, `check`, `sample`,
//!   `dual-tables` — [`listen`]s: the first signal asks it to stop; it finishes the step in
//!   flight, writes what is done under a `.partial` name (`PREFIX.partial.exr`,
//!   `out.partial.csv`, …; never over a finished output) and exits with status
//!   [`EXIT_STATUS`]. While it writes ([`finishing`]) further signals wait; otherwise a second
//!   signal quits at once, writing nothing.
//! * `explore` [`listen_quietly`]s: the first signal shuts the server down gracefully (the
//!   work in flight cancelled, connections closed; exit status 0), the second quits at once.
//! * Every other verb quits at the first signal.
//! * Quitting removes every temporary file still being written
//!   ([`fiberlab_io::output_file::remove_temporaries`]), so no hidden `.NAME.XXXX.tmp` is left
//!   behind; the outputs are as they were before the command.
//!
//! The exit status is 130 (128 + SIGINT) for all three signals: the handler cannot tell them
//! apart, and a script sees one status for "stopped by a signal, partial output written".

use std::sync::OnceLock;
use std::sync::atomic::{AtomicBool, AtomicU8, Ordering};

/// The exit status of a command stopped by a signal.
pub const EXIT_STATUS: i32 = 130;

/// Set by the first signal while a verb listens.
static STOP: AtomicBool = AtomicBool::new(false);

/// What a signal does now: [`QUIT`], [`STOP_FIRST`] or [`WAIT`].
static MODE: AtomicU8 = AtomicU8::new(QUIT);

/// No verb listens: quit.
const QUIT: u8 = 0;
/// A verb listens: the first signal sets [`STOP`], the second quits.
const STOP_FIRST: u8 = 1;
/// A verb writes what it has: signals wait.
const WAIT: u8 = 2;

/// What the first signal prints when the verb listens (set by [`listen_quietly`]; else
/// [`STOPPING`]).
static STOPPING_MESSAGE: OnceLock<String> = OnceLock::new();

/// What the first signal prints while a verb that writes its work listens.
const STOPPING: &str = "fiberlab: stopping: finishing the step in flight and writing what is done (again to quit)";

/// Installs the handler (once; `main` calls it before the verb runs).
pub fn install() {
    // Only one handler per process; if one is already set, the signals keep their defaults.
    let _ = ctrlc::set_handler(|| match MODE.load(Ordering::SeqCst) {
        STOP_FIRST if !STOP.swap(true, Ordering::SeqCst) => {
            eprintln!("\n{}", STOPPING_MESSAGE.get().map_or(STOPPING, String::as_str));
        }
        WAIT => {}
        _ => quit(),
    });
}

/// Quits at once: removes the temporary files being written, exits with [`EXIT_STATUS`].
fn quit() -> ! {
    fiberlab_io::output_file::remove_temporaries();
    eprintln!("\nfiberlab: interrupted: quitting without writing");
    std::process::exit(EXIT_STATUS);
}

/// The verb stops cleanly: from now on the first signal sets the returned flag (polled by
/// the verb's loops and the library functions it calls) instead of quitting. Says so on
/// standard error: `{doing} (Ctrl-C stops and keeps {kept})`.
pub fn listen(doing: &str, kept: &str) -> &'static AtomicBool {
    MODE.store(STOP_FIRST, Ordering::SeqCst);
    eprintln!("{doing} ({LISTENING} {kept})");
    &STOP
}

/// As [`listen`] for a verb that says for itself how to stop it (a server): the first signal
/// prints `stopping` and sets the returned flag.
pub fn listen_quietly(stopping: &str) -> &'static AtomicBool {
    let _ = STOPPING_MESSAGE.set(stopping.to_string());
    MODE.store(STOP_FIRST, Ordering::SeqCst);
    &STOP
}

/// What every verb that [`listen`]s says when it starts (a test can wait for it).
pub const LISTENING: &str = "Ctrl-C stops and keeps";

/// The verb writes its outputs: signals wait until it is done.
pub fn finishing() {
    MODE.store(WAIT, Ordering::SeqCst);
}

/// Whether a signal asked the verb to stop.
pub fn stopped() -> bool {
    STOP.load(Ordering::SeqCst)
}

/// Whether a signal asked the verb to stop while it was still working (before
/// [`finishing`]): a streamed output then keeps its rows under the partial name itself.
pub fn stopped_in_flight() -> bool {
    stopped() && MODE.load(Ordering::SeqCst) == STOP_FIRST
}

/// A command stopped by a signal after writing what was done; `main` prints it and exits
/// with [`EXIT_STATUS`].
#[derive(Debug)]
pub struct Interrupted(pub String);

impl std::fmt::Display for Interrupted {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "interrupted: {}", self.0)
    }
}

impl std::error::Error for Interrupted {}
