//! The DOP853 driver loop behind [`crate::time::integrate::integrate`]: the crate's `init`,
//! then the steps of [`super::dp8`] (the crate's step with the dense output formed only where a
//! sample falls), with the right-hand side's errors and non-finite values caught between steps,
//! the step counters kept on failure, and the fixed-rate sampler over the step's dense output
//! (with the interpolant correction of [`dense_sample`]). Why a loop of our own: see the module
//! doc of `integrate`.

use crate::error::EngineError;
use crate::time::dp8::{Dop853, Dp8, Outcome};
use crate::time::run::{IntegrateError, IntegrateOptions, IntegrateStats, Integrated, Sample};
use crate::time::system::{Clock, DynRhs, Fault, Sampler, Slab, System};
use differential_equations::ode::OrdinaryNumericalMethod;

/// Consecutive step cuts (by 4) after trial stages beyond a path's travel before the crossing
/// counts as the motion's own (see the loop in [`run`]).
const MAX_TRAVEL_RETRIES: usize = 30;

/// The solution at `tk` inside the last accepted step `[t_prev, t]`, from the crate's interpolant.
///
/// NOTE: differential-equations 0.7 evaluates DOP853's dense output with s and 1 − s swapped in
/// its high-order part: it returns `c0 + s(c1 + s1(c2 + s(c3 + s1·W(1−s))))` where Hairer's
/// CONTD8 has `W(s) = c4 + s(c5 + s1(c6 + s·c7))`, s1 = 1 − s. That leaves the step's ends exact
/// but puts the samples inside a step far outside the tolerance (measured on x'' = −49x, figures
/// in BENCHMARKS.md, "Measured reasons behind code choices"; the unit tests of `integrate` guard it). Since `A(σ) = c0 + σc1 + σ(1−σ)c2 + σ²(1−σ)c3` is the low-order part and
/// `s²s1²` multiplies W in both, the correct value follows from the crate's value at the mirrored
/// point: `P(s) = P_crate(1 − s) + A(s) − A(1 − s) = P_crate(1 − s) + (2s − 1)(c1 + s·s1·c3)`, with
/// `c1 = y − y_prev` and `c3 = 2c1 − h(f_prev + f)` from the derivatives at the step's two ends.
pub(crate) fn dense_sample<Y: Slab>(
    solver: &Dp8<Y>,
    f_prev: &[f64],
    f: &[f64],
    tk: f64,
    out: &mut [f64],
) -> Result<(), String> {
    let (t0, t1) = (solver.t_prev(), solver.t());
    let h = t1 - t0;
    let s = ((tk - t0) / h).clamp(0.0, 1.0);
    let s1 = 1.0 - s;
    let mirror = (t0 + s1 * h).clamp(t0, t1);
    let crate_value = solver.interpolate(mirror)?;
    let (y0, y1, p) = (solver.y_prev().slice(), solver.y().slice(), crate_value.slice());
    for i in 0..out.len() {
        let c1 = y1[i] - y0[i];
        let c3 = 2.0 * c1 - h * (f_prev[i] + f[i]);
        out[i] = p[i] + (2.0 * s - 1.0) * (c1 + s * s1 * c3);
    }
    Ok(())
}

/// Integrates `ẋ = rhs(t, x)` from `(t0, x0)` to `t1` with DOP853 (see the module doc),
/// delivering the fixed-rate samples to `on_sample`.
pub(crate) fn run<Y: Slab>(
    rhs: &mut DynRhs,
    x0: &[f64],
    t0: f64,
    t1: f64,
    opts: &IntegrateOptions,
    on_sample: &mut dyn FnMut(&Sample<'_>),
) -> Result<Integrated, IntegrateError> {
    let n = x0.len();
    let sys = System::new(rhs, n);
    let mut solver = Dop853::<Y>::dop853().rtol(opts.rtol).atol(opts.atol).max_steps(opts.max_steps);
    if let Some(h) = opts.h0 {
        solver = solver.h0(h.min(t1 - t0));
    }
    if let Some(h) = opts.h_max {
        solver = solver.h_max(h);
    }
    let mut stats = IntegrateStats::default();
    let mut clock = Clock::new(t0, t1, opts.sample_rate_hz);
    let mut sampler = Sampler { on_sample, xdot: opts.sample_derivatives.then(|| vec![0.0; n]) };
    // Derivatives at the start and the end of the current step, and one sample state.
    let (mut f_prev, mut f_end, mut xk) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);

    let mut solver = start(solver, &sys, (t0, t1), x0, &mut f_prev, stats)?;
    if clock.due(t0).is_some() {
        sampler.deliver(&sys, &mut stats, 0, t0, x0).map_err(|f| f.error(t0, sys.counted(stats)))?;
        clock.next = 1;
    }

    // The run is complete once t is within rounding of t1.
    let t_done = t1 - 4.0 * f64::EPSILON * t1.abs().max(t0.abs());
    let (mut travel_retries, mut travel_fault): (usize, Option<Fault>) = (0, None);
    loop {
        let t = solver.t();
        if t >= t_done {
            break;
        }
        let mut h = solver.h();
        if t + h > t1 {
            h = t1 - t;
            solver.set_h(h);
        }
        // Hairer's test: a step below the resolution of t cannot advance the solution. Cut down
        // there by trial stages beyond a path's travel, the motion does leave it.
        if 0.1 * h.abs() <= t.abs() * f64::EPSILON || h == 0.0 {
            if let Some(fault) = travel_fault.take() {
                return Err(fault.error(t, sys.counted(stats)));
            }
            return Err(IntegrateError::StepSizeUnderflow { t_reached: t, h, stats: sys.counted(stats) });
        }
        // The watchdog's deadline, read every 64 attempts (a clock read costs about as much as
        // a tenth of one right-hand side).
        if (stats.accepted + stats.rejected) % 64 == 0
            && let Some(budget_s) = past_deadline(opts)
        {
            return Err(IntegrateError::Deadline { budget_s, t_reached: t, stats: sys.counted(stats) });
        }
        let res = solver.step(&sys);
        let fault = sys.fault.borrow_mut().take();
        if let Some(fault) = fault {
            stats.rejected += 1; // the faulty attempt is discarded
            // A trial stage beyond a path's end (or its travel limit) says the step was too
            // long, not that the motion leaves the path: an absorber driven into its end stop
            // turns back within a step that its stages overshoot. The solver rejected the step
            // (its error estimate is NaN, and t and x are kept), so it is retried 4 times
            // shorter; only a crossing that survives `MAX_TRAVEL_RETRIES` such cuts (the step
            // then ~1e-18 of the first) is the motion's own and ends the run at that time.
            if matches!(fault, Fault::Engine { err: EngineError::OutOfTravel { .. }, .. })
                && travel_retries < MAX_TRAVEL_RETRIES
            {
                travel_retries += 1;
                travel_fault = Some(fault);
                solver.set_rejected();
                solver.set_h(0.25 * h);
                continue;
            }
            return Err(fault.error(t, sys.counted(stats)));
        }
        (travel_retries, travel_fault) = (0, None);
        let outcome = match res {
            Ok(o) => o,
            Err(e) => return Err(solver_error(e, opts.max_steps, (t, h), sys.counted(stats))),
        };
        if outcome == Outcome::Rejected {
            stats.rejected += 1;
            continue;
        }
        stats.accepted += 1;
        let t_new = solver.t();
        if !solver.y().slice().iter().all(|v| v.is_finite()) {
            return Err(IntegrateError::NonFinite {
                what: "state",
                t_eval: t_new,
                t_reached: t,
                stats: sys.counted(stats),
            });
        }
        if clock.due(t_new).is_some() {
            f_end.copy_from_slice(solver.fsal().slice());
            let ends = (f_prev.as_slice(), f_end.as_slice());
            step_samples(&mut solver, &sys, ends, (&mut clock, &mut sampler), &mut xk, &mut stats)?;
            std::mem::swap(&mut f_prev, &mut f_end);
        } else {
            f_prev.copy_from_slice(solver.fsal().slice());
        }
    }
    // Samples at t1 that rounding put a hair beyond the last step take the final state.
    let t_end = solver.t();
    while let Some(tk) = clock.due(t1) {
        sampler
            .deliver(&sys, &mut stats, clock.next, tk, solver.y().slice())
            .map_err(|f| f.error(t_end, sys.counted(stats)))?;
        clock.next += 1;
    }
    Ok(Integrated { t_end, x_end: solver.y().slice().to_vec(), stats: sys.counted(stats) })
}

/// The crate's `init` at `(t0, x0)` (it chooses the first step and ends with f(t0, x0), which
/// goes into `f_prev`), then our own stepper from there (`dp8`: the crate's steps, with the
/// dense output formed only where a sample falls; they hand over their end derivative
/// themselves).
fn start<Y: Slab>(
    mut solver: Dop853<Y>,
    sys: &System<'_>,
    (t0, t1): (f64, f64),
    x0: &[f64],
    f_prev: &mut [f64],
    stats: IntegrateStats,
) -> Result<Dp8<Y>, IntegrateError> {
    let y0 = Y::from_slice(x0);
    sys.keep.set(true);
    let init = solver.init(sys, t0, t1, &y0);
    sys.keep.set(false);
    if let Some(fault) = sys.fault.borrow_mut().take() {
        return Err(fault.error(t0, sys.counted(stats)));
    }
    if let Err(e) = init {
        return Err(IntegrateError::Solver { message: format!("{e:?}"), t_reached: t0, stats: sys.counted(stats) });
    }
    end_derivative(sys, t0, x0, f_prev).map_err(|f| f.error(t0, sys.counted(stats)))?;
    Ok(Dp8::after_init(&solver, Y::from_slice(f_prev)))
}

/// The watchdog's budget (s) when its deadline has passed.
fn past_deadline(opts: &IntegrateOptions) -> Option<f64> {
    let d = opts.deadline?;
    d.passed().then_some(d.budget_s)
}

/// The samples that fall inside the step just accepted (`ends`: the derivatives at its two
/// ends), from the corrected dense output, delivered by `sampler` in the order of `clock`.
fn step_samples<Y: Slab>(
    solver: &mut Dp8<Y>,
    sys: &System<'_>,
    ends: (&[f64], &[f64]),
    (clock, sampler): (&mut Clock, &mut Sampler<'_>),
    xk: &mut [f64],
    stats: &mut IntegrateStats,
) -> Result<(), IntegrateError> {
    let t_new = solver.t();
    // The three dense-output stages, for this step's samples.
    solver.dense(sys);
    if let Some(fault) = sys.fault.borrow_mut().take() {
        return Err(fault.error(t_new, sys.counted(*stats)));
    }
    while let Some(tk) = clock.due(t_new) {
        dense_sample(solver, ends.0, ends.1, tk, xk).map_err(|message| IntegrateError::Solver {
            message,
            t_reached: t_new,
            stats: sys.counted(*stats),
        })?;
        sampler.deliver(sys, stats, clock.next, tk, xk).map_err(|f| f.error(t_new, sys.counted(*stats)))?;
        clock.next += 1;
    }
    Ok(())
}

/// The crate's step error as ours, at time `t` with step `h` (`at`).
fn solver_error<Y: Slab>(
    e: differential_equations::error::Error<f64, Y>,
    max_steps: usize,
    (t, h): (f64, f64),
    stats: IntegrateStats,
) -> IntegrateError {
    use differential_equations::error::Error as E;
    match e {
        E::MaxSteps { .. } => IntegrateError::MaxSteps { max_steps, t_reached: t, stats },
        E::StepSize { .. } => IntegrateError::StepSizeUnderflow { t_reached: t, h, stats },
        E::Stiffness { .. } => IntegrateError::Stiff { t_reached: t, stats },
        other => IntegrateError::Solver { message: format!("{other:?}"), t_reached: t, stats },
    }
}

/// Copies ẋ at `(t, x)` (the solver's start) into `out`: the kept evaluation when it was made at
/// t (always, by the structure of the crate's `init`), else one extra call.
fn end_derivative(sys: &System<'_>, t: f64, x: &[f64], out: &mut [f64]) -> Result<(), Fault> {
    if let Some(d) = sys.recent.borrow().at(t) {
        out.copy_from_slice(d);
        return Ok(());
    }
    sys.evals.set(sys.evals.get() + 1);
    (sys.f.borrow_mut())(t, x, out).map_err(|err| Fault::Engine { t, err })?;
    if out.iter().all(|v| v.is_finite()) { Ok(()) } else { Err(Fault::NonFinite { t }) }
}
