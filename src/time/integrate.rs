//! Nonlinear time integration: DOP853 (Dormand–Prince 8(5,3), from the `differential-equations`
//! crate) over any right-hand side `ẋ = f(t, x)`, with its order-7 dense output streamed through
//! a fixed-rate sampler.
//!
//! The paper integrates eq. (7) with SciPy's `odeint` (section 3.2); kanedyn uses an explicit
//! 8th-order method instead: the CPVA is not stiff, and the 240 s order sweeps of section 4.1
//! need some 10⁵ steps, where a high order pays off.
//!
//! Memory stays O(1) in the length of the run: no step is stored. After every accepted step the
//! sampler evaluates the step's interpolant at each sample time `t_k = t0 + k/fs` that the step
//! covered and hands `(t_k, x(t_k))` to the caller, who keeps what it needs (see
//! [`crate::time::probe::simulate`] for a recorder of named signals).
//!
//! ```no_run
//! use kanedyn::time::integrate::{integrate, IntegrateOptions};
//! # fn demo(kane: &mut kanedyn::kane::Kane, x0: &[f64]) {
//! let mut u1 = Vec::new();
//! let run = integrate(|t, x, dx| kane.rhs(t, x, dx), x0, 0.0, 10.0, &IntegrateOptions::default(), |s| {
//!     u1.push(s.x[2])
//! });
//! # }
//! ```
//!
//! Why a driver loop of our own around the crate's `init`/`step`/`interpolate` instead of its
//! `IVP::solve`: `solve` keeps a `Solution` and drops the step statistics when it fails, its ODE
//! trait cannot report an error from the right-hand side, and it clones the state twice per step.
//! The loop (private module `dop853`) is the crate's `solve_ode` minus those three things; its
//! steps (private module `dp8`) are the crate's, with the dense output formed only for the steps
//! a sample falls in.

pub use crate::time::run::{
    IntegrateError, IntegrateOptions, IntegrateStats, Integrated, IntegratorChoice, Method, Sample,
};

use crate::error::EngineError;
use crate::time::dop853::run;
use crate::time::system::DynRhs;

/// Integrates `ẋ = rhs(t, x)` from `x(t0) = x0` to `t1 > t0` with DOP853 and calls `on_sample` at
/// every sample time (see [`IntegrateOptions::sample_rate_hz`]), in increasing time.
///
/// `rhs(t, x, xdot)` writes ẋ into `xdot` (same length as x) or returns an [`EngineError`], which
/// ends the run. A NaN or infinite derivative or state also ends it. On failure the samples
/// already delivered stay delivered and the error names the time reached.
///
/// State lengths 1 to 16 run on fixed-size arrays (no heap allocation per step); longer states on
/// `Vec<f64>` (a few allocations per step, small next to such a right-hand side).
pub fn integrate<R, S>(
    mut rhs: R,
    x0: &[f64],
    t0: f64,
    t1: f64,
    opts: &IntegrateOptions,
    mut on_sample: S,
) -> Result<Integrated, IntegrateError>
where
    R: FnMut(f64, &[f64], &mut [f64]) -> Result<(), EngineError>,
    S: FnMut(&Sample<'_>),
{
    check_input(x0, t0, t1, opts)?;
    // NOTE: the solver is monomorphised per state length only, not per closure type: one compiled
    // DOP853 per length serves every caller, and the indirect call this costs is small next to one
    // right-hand side (figures: BENCHMARKS.md, "Measured reasons behind code choices").
    let rhs: &mut DynRhs = &mut rhs;
    let on_sample: &mut dyn FnMut(&Sample<'_>) = &mut on_sample;
    macro_rules! dispatch {
        ($($n:literal)*; $($e:literal)*) => {
            match x0.len() {
                $($n => match opts.method {
                    Method::Dop853 => run::<[f64; $n]>(rhs, x0, t0, t1, opts, on_sample),
                    Method::Radau5 => crate::time::radau::run::<[f64; $n]>(rhs, x0, t0, t1, opts, on_sample),
                },)*
                // NOTE: a mechanism's state is [q; u], of even length: DOP853 on fixed-size states
                // up to 33 coordinates too (a 16-disk shaft with a pendulum, 32 pendulums), where
                // the crate's per-stage clones of a `Vec` state were 16 % of a sweep's time and its
                // out-of-line stage sums another 31 % (BENCHMARKS.md, "Stiff shafts"); the
                // implicit method keeps its dynamic state there (its step is dominated by its
                // linear algebra).
                $($e if opts.method == Method::Dop853 => run::<crate::time::system::Stages<$e>>(rhs, x0, t0, t1, opts, on_sample),)*
                _ => match opts.method {
                    Method::Dop853 => run::<Vec<f64>>(rhs, x0, t0, t1, opts, on_sample),
                    Method::Radau5 => crate::time::radau::run::<crate::time::radau::DynState>(rhs, x0, t0, t1, opts, on_sample),
                },
            }
        };
    }
    dispatch!(1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16; 18 20 22 24 26 28 30 32 34 36 38 40 42 44 46 48 50 52 54 56 58 60 62 64 66)
}

fn check_input(x0: &[f64], t0: f64, t1: f64, opts: &IntegrateOptions) -> Result<(), IntegrateError> {
    let bad = |message: String| Err(IntegrateError::InvalidInput { message });
    if x0.is_empty() {
        return bad("the initial state is empty".into());
    }
    if let Some(i) = x0.iter().position(|v| !v.is_finite()) {
        return bad(format!("initial state x0[{i}] = {} is not finite", x0[i]));
    }
    if !(t0.is_finite() && t1.is_finite() && t1 > t0) {
        return bad(format!("need finite t0 < t1, got t0 = {t0} s, t1 = {t1} s"));
    }
    if !(opts.rtol > 0.0 && opts.atol > 0.0 && opts.rtol.is_finite() && opts.atol.is_finite()) {
        return bad(format!("rtol and atol must be positive, got rtol = {:e}, atol = {:e}", opts.rtol, opts.atol));
    }
    if let Some(fs) = opts.sample_rate_hz
        && !(fs.is_finite() && fs > 0.0)
    {
        return bad(format!("sample rate must be positive, got {fs} Hz"));
    }
    for (name, h) in [("h0", opts.h0), ("h_max", opts.h_max)] {
        if let Some(h) = h
            && !(h.is_finite() && h > 0.0)
        {
            return bad(format!("{name} must be a positive step in s, got {h}"));
        }
    }
    if opts.max_steps == 0 {
        return bad("max_steps must be at least 1".into());
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_abs_diff_eq;

    /// Harmonic oscillator x'' = −ω² x: the samples must follow cos(ωt) to the tolerance, land
    /// on the grid t0 + k/fs and include both ends.
    #[test]
    fn samples_on_the_grid_follow_the_exact_solution() {
        let w = 7.0;
        let opts = IntegrateOptions { rtol: 1e-12, atol: 1e-12, sample_rate_hz: Some(100.0), ..Default::default() };
        let mut worst: f64 = 0.0;
        let mut ts = Vec::new();
        let out = integrate(
            |_, x, dx| {
                dx[0] = x[1];
                dx[1] = -w * w * x[0];
                Ok(())
            },
            &[1.0, 0.0],
            0.5,
            2.5,
            &opts,
            |s| {
                worst = worst.max((s.x[0] - (w * (s.t - 0.5)).cos()).abs());
                ts.push(s.t);
            },
        )
        .unwrap();
        assert_eq!(ts.len(), 201);
        assert_eq!(ts[0], 0.5);
        assert_eq!(*ts.last().unwrap(), 2.5);
        assert!(ts.iter().enumerate().all(|(k, &t)| t == 0.5 + k as f64 / 100.0));
        // 2.2 periods at rtol 1e-12: the end point is off by 1.6e-12 and the samples inside steps
        // by 3.4e-12. With the crate's own interpolant (s and 1 − s swapped, see dense_sample)
        // they were off by 3.5e-8: this bound guards the correction.
        assert!(worst < 1e-10, "worst sample error {worst:e}");
        assert_eq!(out.stats.samples, 201);
        assert!(out.stats.accepted > 10 && out.stats.rhs_evals >= 15 * out.stats.accepted);
        assert_eq!(out.t_end, 2.5);
    }

    #[test]
    fn long_states_take_the_vec_path() {
        // 20 uncoupled decays x_i' = −i x_i against exp(−i t).
        let n = 20;
        let x0 = vec![1.0; n];
        let opts = IntegrateOptions { rtol: 1e-11, atol: 1e-13, sample_rate_hz: None, ..Default::default() };
        let out = integrate(
            |_, x, dx| {
                for i in 0..x.len() {
                    dx[i] = -(i as f64) * x[i];
                }
                Ok(())
            },
            &x0,
            0.0,
            1.0,
            &opts,
            |_| {},
        )
        .unwrap();
        for i in 0..n {
            assert_abs_diff_eq!(out.x_end[i], (-(i as f64)).exp(), epsilon = 1e-10);
        }
        assert_eq!(out.stats.samples, 0);
    }

    #[test]
    fn bad_input_is_refused() {
        let f = |_: f64, _: &[f64], _: &mut [f64]| Ok(());
        let o = IntegrateOptions::default();
        assert!(matches!(integrate(f, &[1.0], 1.0, 1.0, &o, |_| {}), Err(IntegrateError::InvalidInput { .. })));
        assert!(matches!(integrate(f, &[f64::NAN], 0.0, 1.0, &o, |_| {}), Err(IntegrateError::InvalidInput { .. })));
        let o2 = IntegrateOptions { rtol: 0.0, ..o };
        assert!(matches!(integrate(f, &[1.0], 0.0, 1.0, &o2, |_| {}), Err(IntegrateError::InvalidInput { .. })));
    }
}

#[cfg(test)]
mod radau_tests {
    use super::*;

    /// x'' = −ω² x by Radau IIA, on the fixed-size (n = 2) and the any-length (n = 20, ten copies)
    /// paths: samples against cos(ωt).
    #[test]
    fn radau_follows_the_oscillator() {
        let w = 7.0;
        for copies in [1usize, 10] {
            let opts = IntegrateOptions {
                rtol: 1e-9,
                atol: 1e-9,
                sample_rate_hz: Some(100.0),
                method: Method::Radau5,
                ..Default::default()
            };
            let mut worst: f64 = 0.0;
            let mut x0 = vec![0.0; 2 * copies];
            for c in 0..copies {
                x0[2 * c] = 1.0;
            }
            let out = integrate(
                |_, x, dx| {
                    for c in 0..copies {
                        dx[2 * c] = x[2 * c + 1];
                        dx[2 * c + 1] = -w * w * x[2 * c];
                    }
                    Ok(())
                },
                &x0,
                0.0,
                2.0,
                &opts,
                |s| worst = worst.max((s.x[0] - (w * s.t).cos()).abs()),
            )
            .unwrap();
            eprintln!(
                "copies {copies}: worst {worst:e}, end {:e}, {}",
                (out.x_end[0] - (w * 2.0).cos()).abs(),
                out.stats
            );
            assert!(worst < 1e-6, "worst {worst:e}");
        }
    }
}
