//! Running the `kanedyn` binary from an integration test (tests/it/cli.rs, tests/it/input_hardening.rs,
//! tests/it/study_reliability.rs, included there with `#[path]`).

#![allow(dead_code)]

use std::process::{Command, Output};

/// Runs `kanedyn args…` in the repository root and returns its whole output.
pub fn run(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_kanedyn")).args(args).current_dir(env!("CARGO_MANIFEST_DIR")).output().unwrap()
}

/// Runs `kanedyn args…` in the repository root: (success, stdout, stderr).
pub fn kanedyn(args: &[&str]) -> (bool, String, String) {
    let out = run(args);
    (out.status.success(), String::from_utf8_lossy(&out.stdout).into(), String::from_utf8_lossy(&out.stderr).into())
}
