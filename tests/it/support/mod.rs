//! Fixtures shared by the stories: the branched drivetrain with its closed form, the CLI runner,
//! the paper's harmonic-balance problem, copies of the examples, a shooting solver for periodic
//! orbits, a swept test signal, a wound shaft-CPVA.

#![allow(dead_code)] // each story uses some of them

pub mod branched;
pub mod cli;
pub mod cpva_hbm;
pub mod examples;
pub mod shooting;
pub mod swept_signal;
pub mod two_pendulums;
pub mod wound_shaft;
