//! kanedyn: planar multibody dynamics by Kane's method, for torsional-vibration engineering.
//!
//! A mechanism (bodies joined by revolute joints in a tree, read from RON) becomes the equations
//! of motion `M(q) u̇ = F(q, u, t)`, `q̇ = W⁻¹ u`, evaluated numerically from Kane's partial
//! velocities without heap allocation. The rotor with centrifugal pendulum vibration absorbers
//! (CPVA) is the flagship example; see the README.

// Index loops mirror the formulas (M_rs, paths r..s) and keep parallel arrays in step.
#![allow(clippy::needless_range_loop)]

pub mod body;
pub mod cpva;
pub mod error;
pub mod excitation;
pub mod hbm;
pub mod inertia;
pub mod integrate;
pub mod io;
pub mod joint;
pub mod kane;
pub mod kinematics;
pub mod linear;
pub mod loads;
pub mod math;
pub mod mechanism;
pub mod plot;
pub mod probe;
pub mod shape;
pub mod signal;
pub mod speeds;
pub mod study;
