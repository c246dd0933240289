//! The physical ranges a mechanism's numbers must lie in, beyond "finite and positive": each is
//! generous for any real driveline or absorber, and excludes values that only make the solvers
//! loop without end or divide by nothing (issue 25: a gear ratio of 1e-300 passed and a linear
//! response then never finished; an epicycloid order ñ of 1e9, a bifilar length of 1e-300 and a
//! roller count of 1e9 were accepted without a word). Every check that uses one states the range
//! in its error; the user guide's "Limits and errors" (`docs/guide/src/limits.md`) lists them.

use std::ops::RangeInclusive;

/// Magnitude of a gear or fixed-ratio coupling's ratio `q̇_joint / q̇_follows`: a real gear
/// stage lies within 1/100..100; beyond 1e6 the geared inertias differ by more than 1e12, past
/// what the mass matrix's 16 digits can hold.
pub const GEAR_RATIO: RangeInclusive<f64> = 1e-6..=1e6;

/// Lengths of a path's geometry (pivot radius R, path radius L, vertex radius ρ₀), m: a micron to
/// a kilometre.
pub const PATH_LENGTH_M: RangeInclusive<f64> = 1e-6..=1e3;

/// A path's order ñ: tuning orders of absorbers lie near the engine orders (½ to ~20); the upper
/// end is the highest excitation order a study accepts (`study::validate::MAX_ORDER`).
pub const PATH_ORDER: RangeInclusive<f64> = 1e-3..=1e3;

/// Most rollers of one roller set: an absorber runs on one to four; the count only scales the
/// rollers' mass and inertia, so a thousand rollers is a data error, not a design.
pub const MAX_ROLLERS: u32 = 100;

/// The smoothing rate ε of a friction element, rad/s or m/s: `tanh(q̇/ε)` turns a slip of ε into
/// full friction, so ε sets a damping of `T/ε`; below 1e-6 the equations become so stiff that
/// an explicit integrator needs a step per nanosecond.
pub const FRICTION_SMOOTHING: RangeInclusive<f64> = 1e-6..=1e3;

/// Largest jump of a pressure table across its 720° → 0° seam, as a multiple of the steepest
/// step between neighbouring points inside the table (bar per degree, times the seam's angular
/// gap): the periodic spline closes any gap, so a table that does not join would be closed by a
/// made-up swing.
pub const PRESSURE_SEAM_FACTOR: f64 = 2.0;

/// Whether `v` is finite and inside `range`.
pub fn within(v: f64, range: &RangeInclusive<f64>) -> bool {
    v.is_finite() && range.contains(&v)
}

/// A range for a message: `1e-6..=1e6`.
pub fn show(range: &RangeInclusive<f64>) -> String {
    format!("{:e}..={:e}", range.start(), range.end())
}

/// Highest natural frequency `√(k/J)/2π` of one spring, stage, end stop or mesh on the inertia it
/// moves, Hz: the stiffest contacts and meshes of real drivelines and absorbers ring at tens of
/// kHz; a megahertz means a stiffness or an inertia in the wrong units, and would hold an
/// explicit integrator to sub-microsecond steps.
pub const MAX_NATURAL_HZ: f64 = 1e6;

/// Highest decay rate `c/J` of one damper on the inertia it moves, 1/s (a time constant of
/// 10 ns): a shaft damper of 1e9 N·m·s/rad on a flywheel decays in well under a nanosecond, which
/// no driveline does, and made a 2 s transient planned at 0.01 s run for minutes.
pub const MAX_DECAY_RATE: f64 = 1e8;
