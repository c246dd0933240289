//! Fixtures shared by the stories: the branched drivetrain with its closed form, the CLI runner,
//! the paper's harmonic-balance problem, copies of the examples, a shooting solver for periodic
//! orbits, a swept test signal, a wound shaft-CPVA, and the scratch folder every test writing
//! files works in.

#![allow(dead_code)] // each story uses some of them

pub mod branched;
pub mod cli;
pub mod cpva_hbm;
pub mod examples;
pub mod shooting;
pub mod swept_signal;
pub mod two_pendulums;
pub mod wound_shaft;

/// A fresh, empty folder `kanedyn-<tag>-…` in the system temp dir (TMPDIR honoured), removed
/// with all it holds when the guard drops, even when the test panics: so that a run leaves
/// nothing behind in /tmp, and its random suffix keeps tests, and runs of the suite side by side,
/// out of each other's files. Bind the guard to a named variable that lives to the test's end
/// (`let _ = scratch(..)` would remove the folder at once).
pub fn scratch(tag: &str) -> tempfile::TempDir {
    tempfile::Builder::new().prefix(&format!("kanedyn-{tag}-")).tempdir().unwrap()
}
