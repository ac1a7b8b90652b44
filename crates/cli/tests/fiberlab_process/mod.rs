//! Running the `fiberlab` binary from the integration tests: one way to start it and to read what
//! it printed, shared by the test files (`mod fiberlab_process;`). Not every file uses every item.
#![allow(dead_code)]

use assert_cmd::Command;
use std::path::Path;

/// The `fiberlab` binary that this test run built.
pub fn fiberlab() -> Command {
    Command::cargo_bin("fiberlab").expect("binary builds")
}

/// The binary, started in `dir`.
pub fn fiberlab_in(dir: &Path) -> Command {
    let mut c = fiberlab();
    c.current_dir(dir);
    c
}

/// Runs `cmd`, asserts that it succeeded and returns its standard output.
pub fn stdout_of(cmd: &mut Command) -> String {
    let out = cmd.output().expect("runs");
    assert!(out.status.success(), "failed: {}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8(out.stdout).expect("utf-8")
}

/// Runs `cmd`, asserts that it succeeded and returns its standard error (progress and summaries).
pub fn stderr_of(cmd: &mut Command) -> String {
    let out = cmd.output().expect("runs");
    assert!(out.status.success(), "failed: {}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// Runs `cmd`, asserts that it was refused as bad input (exit code 1, no panic) and returns the
/// message.
pub fn refused(cmd: &mut Command) -> String {
    let out = cmd.output().expect("runs");
    assert_eq!(out.status.code(), Some(1), "{}", String::from_utf8_lossy(&out.stderr));
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(!err.contains("panicked"), "{err}");
    err
}
