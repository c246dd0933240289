//! kanedyn: planar multibody dynamics by Kane's method, for torsional-vibration engineering.
//!
//! A mechanism (bodies joined in a tree, read from RON) becomes the equations of motion
//! `M(q) u̇ = F(q, u, t)`, `q̇ = W⁻¹ u`, evaluated numerically from Kane's partial velocities
//! without heap allocation. The rotor with centrifugal pendulum vibration absorbers (CPVA) is the
//! flagship example; see the README, the user guide (`docs/guide/`) and `docs/design/index.md`.
//!
//! The crate is a pipeline; each module is one stage and imports only the stages before it:
//!
//! ```text
//!  RON file ─► load ─► model::Mechanism ─► kane (M, F, ẋ) ─┬─► time   (integrate, probes)  ─┐
//!   (io, error)                                          ├─► linear (modes, FRF, Campbell) ├─► signal ─► study ─► bin
//!                                                        └─► hbm    (periodic branches)   ─┘   (plot)
//! ```
//!
//! - [`io`], [`error`]: reading text under a policy, and errors located at file:line:col;
//!   [`deadline`]: the watchdog's stop time that every long loop checks.
//! - [`model`]: what the user describes (bodies, joints, loads, excitations, speeds), as data.
//! - [`load`]: file → spec → [`model::mechanism::Mechanism`], with catalog parts and the
//!   engine's positive-definiteness check, every error located at the offending field.
//! - [`kane`]: the engine: Kane's method as the textbook writes it, and the fast forms.
//! - [`time`], [`linear`], [`hbm`]: the three analyses of a mechanism (time integration, linear
//!   analysis about a steady spin, harmonic balance with continuation and stability).
//! - [`signal`]: order tracking of sampled responses (STFT and angle domain).
//! - [`study`]: one RON study file in, every trace, table and figure out; [`plot`] draws them.
//! - [`cpva`]: the paper's rotor with pendulums, as a builder and in closed form.
//! - [`opentorsion`]: OpenTorsion models (TORS JSON, or an assembly from Python) written as
//!   mechanism RON (`kanedyn import`).

// Index loops mirror the formulas (M_rs, paths r..s) and keep parallel arrays in step.
#![warn(missing_docs)]
#![allow(clippy::needless_range_loop)]

pub mod deadline;
pub mod error;
pub mod io;

pub mod model;

pub mod load;

pub mod opentorsion;

pub mod kane;

pub mod hbm;
pub mod linear;
pub mod time;

pub mod signal;

pub mod combustion;
pub mod cpva;
pub mod plot;
pub mod study;
pub mod synthesis;

/// The user guide's Rust chapter, whose examples run as doc tests (`cargo test --doc`).
#[cfg(doctest)]
#[doc = include_str!("../docs/guide/src/library.md")]
pub struct GuideLibraryChapter;
