//! Names the commit in `fiberlab --version`: `git rev-parse --short=9 HEAD` of the checkout the
//! binary is built from, or `FIBERLAB_COMMIT` when set (a packager's choice), or "unknown
//! commit" when neither git nor a `.git` directory is there (a packaged source tree).

use std::path::Path;
use std::process::Command;

/// What `git ARGS` prints in the crate's directory, trimmed; `None` when git is missing or fails.
fn git(args: &[&str]) -> Option<String> {
    let out = Command::new("git").args(args).current_dir(env!("CARGO_MANIFEST_DIR")).output().ok()?;
    let text = String::from_utf8(out.stdout).ok()?.trim().to_string();
    (out.status.success() && !text.is_empty()).then_some(text)
}

fn main() {
    println!("cargo:rerun-if-env-changed=FIBERLAB_COMMIT");
    let commit = match std::env::var("FIBERLAB_COMMIT") {
        Ok(c) if !c.trim().is_empty() => c.trim().to_string(),
        _ => git(&["rev-parse", "--short=9", "HEAD"]).unwrap_or_else(|| "unknown commit".into()),
    };
    println!("cargo:rustc-env=FIBERLAB_COMMIT={commit}");
    // Build again when HEAD moves: HEAD itself (a checkout), the branch it names (a commit),
    // and the packed refs (a branch packed by git gc).
    let mut watched = vec!["HEAD".to_string(), "packed-refs".to_string()];
    if let Some(branch) = git(&["symbolic-ref", "-q", "HEAD"]) {
        watched.push(branch);
    }
    for name in watched {
        if let Some(path) = git(&["rev-parse", "--git-path", &name]) {
            let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(path);
            if path.exists() {
                println!("cargo:rerun-if-changed={}", path.display());
            }
        }
    }
    // Without git state to watch, run again only when the build script changes.
    println!("cargo:rerun-if-changed=build.rs");
}
