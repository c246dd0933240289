//! The DOP853 driver loop behind [`crate::time::integrate::integrate`]: the crate's `init`,
//! then the steps of [`super::dp8`] (the crate's step with the dense output formed only where a
//! sample falls), with the right-hand side's errors and non-finite values caught between steps,
//! the step counters kept on failure, and the fixed-rate sampler over the step's dense output
//! (with the interpolant correction of [`dense_sample`]). Why a loop of our own: see the module
//! doc of `integrate`.

use crate::error::EngineError;
use crate::time::dp8::{Dp8, Outcome};
use crate::time::run::{IntegrateError, IntegrateOptions, IntegrateStats, Integrated, Sample};
use differential_equations::methods::{DormandPrince, ExplicitRungeKutta, Ordinary};
use differential_equations::ode::{ODE, OrdinaryNumericalMethod};
use differential_equations::tolerance::Tolerance;
use differential_equations::traits::State;
use std::cell::{Cell, RefCell};

/// A type-erased right-hand side `(t, x, ẋ)`.
/// Consecutive step cuts (by 4) after trial stages beyond a path's travel before the crossing
/// counts as the motion's own (see the loop in [`run`]).
const MAX_TRAVEL_RETRIES: usize = 30;

pub(crate) type DynRhs<'a> = dyn FnMut(f64, &[f64], &mut [f64]) -> Result<(), EngineError> + 'a;

/// The crate's DOP853 for state type `Y`: order 8, 12 stages, 16 with the dense-output stages.
pub(crate) type Dop853<Y> = ExplicitRungeKutta<Ordinary, DormandPrince, f64, Y, 8, 12, 16>;

/// A state type the crate can step and we can view as a slice.
pub(crate) trait Slab: State<f64> {
    fn from_slice(x: &[f64]) -> Self;
    fn slice(&self) -> &[f64];
    fn slice_mut(&mut self) -> &mut [f64];
}

impl<const N: usize> Slab for [f64; N] {
    fn from_slice(x: &[f64]) -> Self {
        let mut a = [0.0; N];
        a.copy_from_slice(x);
        a
    }
    fn slice(&self) -> &[f64] {
        self
    }
    fn slice_mut(&mut self) -> &mut [f64] {
        self
    }
}

/// A fixed-size state whose vector operations the crate's DOP853 step inlines.
///
/// NOTE: the crate's `[f64; N]` state forms every stage term by an out-of-line `add_scaled`
/// (assert, loop, return): about 200 calls per step, 31 % of the 16-disk shaft's 60 s sweep
/// (34 states; BENCHMARKS.md, "Stiff shafts"). The same element-wise operations written here
/// `#[inline(always)]` give the same bits (the error norm's sum runs in the same order) without
/// the calls. Used for the longer states only, so the small mechanisms' runs are as before.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Stages<const N: usize>([f64; N]);

impl<const N: usize> State<f64> for Stages<N> {
    #[inline(always)]
    fn len(&self) -> usize {
        N
    }
    #[inline(always)]
    fn get_component(&self, index: usize) -> f64 {
        self.0[index]
    }
    #[inline(always)]
    fn set_component(&mut self, index: usize, value: f64) {
        self.0[index] = value;
    }
    #[inline(always)]
    fn map_components_mut<F: FnMut(usize, &mut f64)>(&mut self, mut f: F) {
        for (i, v) in self.0.iter_mut().enumerate() {
            f(i, v);
        }
    }
    #[inline(always)]
    fn zeros_like(&self) -> Self {
        Self([0.0; N])
    }
    #[inline(always)]
    fn zeros() -> Self {
        Self([0.0; N])
    }
    #[inline(always)]
    fn mul_add_assign(&mut self, alpha: f64, other: &Self) {
        for (s, o) in self.0.iter_mut().zip(&other.0) {
            *s += alpha * *o;
        }
    }
    #[inline(always)]
    fn scale_mut(&mut self, alpha: f64) {
        for s in &mut self.0 {
            *s *= alpha;
        }
    }
    #[inline(always)]
    fn add_scaled(&mut self, alpha: f64, other: &Self) -> &mut Self {
        self.mul_add_assign(alpha, other);
        self
    }
    #[inline(always)]
    fn scale_by(&mut self, alpha: f64) -> &mut Self {
        self.scale_mut(alpha);
        self
    }
    #[inline(always)]
    fn fill(&mut self, value: f64) {
        self.0 = [value; N];
    }
    #[inline(always)]
    fn copy_from_state(&mut self, other: &Self) {
        self.0 = other.0;
    }
    #[inline(always)]
    fn plus_scaled(&self, alpha: f64, other: &Self) -> Self {
        let mut out = *self;
        out.mul_add_assign(alpha, other);
        out
    }
    #[inline(always)]
    fn minus(&self, other: &Self) -> Self {
        self.plus_scaled(-1.0, other)
    }
    #[inline(always)]
    fn diff_norm_squared(&self, other: &Self) -> f64 {
        self.0.iter().zip(&other.0).fold(0.0, |sum, (a, b)| {
            let d = *a - *b;
            sum + d * d
        })
    }
    #[inline(always)]
    fn error_norm(&self, y_new: &Self, err: &Self, atol: &Tolerance<f64>, rtol: &Tolerance<f64>) -> f64 {
        // Hairer's weighted sum of squares, `Σ (err_i / (atol_i + rtol_i max(|y_i|, |y_new,i|)))²`,
        // summed in index order.
        let mut sum = 0.0;
        for i in 0..N {
            let sk = atol[i] + rtol[i] * self.0[i].abs().max(y_new.0[i].abs());
            let e = err.0[i] / sk;
            sum += e * e;
        }
        sum
    }
}

impl<const N: usize> Slab for Stages<N> {
    fn from_slice(x: &[f64]) -> Self {
        let mut a = [0.0; N];
        a.copy_from_slice(x);
        Self(a)
    }
    fn slice(&self) -> &[f64] {
        &self.0
    }
    fn slice_mut(&mut self) -> &mut [f64] {
        &mut self.0
    }
}

impl Slab for Vec<f64> {
    fn from_slice(x: &[f64]) -> Self {
        x.to_vec()
    }
    fn slice(&self) -> &[f64] {
        self
    }
    fn slice_mut(&mut self) -> &mut [f64] {
        self
    }
}

/// The first failure seen inside the right-hand side, kept until the driver looks.
pub(super) enum Fault {
    Engine { t: f64, err: EngineError },
    NonFinite { t: f64 },
}

/// Adapter from the caller's `FnMut` with errors to the crate's `ODE::diff(&self)` without:
/// interior mutability for the closure, a counter, and a fault slot the driver checks after every
/// step (the crate cannot stop mid-step, so after a fault the remaining stages get NaN and the
/// step's result is discarded).
pub(super) struct System<'a> {
    pub(super) f: RefCell<&'a mut DynRhs<'a>>,
    pub(super) evals: Cell<usize>,
    pub(super) fault: RefCell<Option<Fault>>,
    recent: RefCell<Recent>,
    /// Whether evaluations are kept in `recent`: only during the crate's `init` (the DOP853 steps
    /// hand their end derivative over themselves, [`Dp8::fsal`]; the implicit route reads none).
    keep: Cell<bool>,
}

impl<'a> System<'a> {
    pub(super) fn new(rhs: &'a mut DynRhs<'a>, n: usize) -> Self {
        Self {
            f: RefCell::new(rhs),
            evals: Cell::new(0),
            fault: RefCell::new(None),
            recent: RefCell::new(Recent::new(n)),
            keep: Cell::new(false),
        }
    }
}

/// The last derivative evaluation kept `(t, ẋ)` (`System::keep`): f(t0, x0), which the crate's
/// `init` evaluates last.
struct Recent {
    t: f64,
    xdot: Vec<f64>,
}

impl Recent {
    fn new(n: usize) -> Self {
        Self { t: f64::NAN, xdot: vec![0.0; n] }
    }

    fn push(&mut self, t: f64, xdot: &[f64]) {
        self.t = t;
        self.xdot.copy_from_slice(xdot);
    }

    /// The kept evaluation, if it was at time `t`.
    fn at(&self, t: f64) -> Option<&[f64]> {
        (self.t == t).then_some(self.xdot.as_slice())
    }
}

impl<Y: Slab> ODE<f64, Y> for System<'_> {
    fn diff(&self, t: f64, y: &Y, dydt: &mut Y) {
        let out = dydt.slice_mut();
        if self.fault.borrow().is_some() {
            out.fill(f64::NAN);
            return;
        }
        self.evals.set(self.evals.get() + 1);
        let res = (self.f.borrow_mut())(t, y.slice(), out);
        let fault = match res {
            Err(err) => Some(Fault::Engine { t, err }),
            Ok(()) if !out.iter().all(|v| v.is_finite()) => Some(Fault::NonFinite { t }),
            Ok(()) => None,
        };
        // NOTE: the DOP853 stages are not copied (3 % of the 16-disk shaft's sweep).
        if fault.is_some() {
            out.fill(f64::NAN);
            *self.fault.borrow_mut() = fault;
        } else if self.keep.get() {
            self.recent.borrow_mut().push(t, out);
        }
    }

    // Only the implicit method asks (DOP853 never does): see `radau::jacobian`.
    fn jacobian(&self, t: f64, y: &Y, j: &mut differential_equations::linalg::Matrix<f64>) {
        crate::time::radau::jacobian(self, t, y, j);
    }
}

/// Sample clock: `t_k = t0 + k/fs` for `k = 0..count` (computed, not accumulated, so t_k has no
/// drift over 480,000 samples).
pub(super) struct Clock {
    t0: f64,
    fs: f64,
    t1: f64,
    pub(super) next: usize,
    count: usize,
}

impl Clock {
    pub(super) fn new(t0: f64, t1: f64, fs: Option<f64>) -> Self {
        let Some(fs) = fs else { return Self { t0, fs: 1.0, t1, next: 0, count: 0 } };
        // A few ulps of slack so that t1 on the grid (240 s at 2 kHz) counts despite rounding.
        let count = ((t1 - t0) * fs * (1.0 + 4.0 * f64::EPSILON)).floor() as usize + 1;
        Self { t0, fs, t1, next: 0, count }
    }

    /// The next sample time if it is not later than `t`.
    pub(super) fn due(&self, t: f64) -> Option<f64> {
        if self.next >= self.count {
            return None;
        }
        let tk = (self.t0 + self.next as f64 / self.fs).min(self.t1);
        (tk <= t).then_some(tk)
    }
}

/// Delivers sample `k` at `(t, x)`, first evaluating ẋ there when asked.
pub(super) struct Sampler<'a> {
    pub(super) on_sample: &'a mut dyn FnMut(&Sample<'_>),
    pub(super) xdot: Option<Vec<f64>>,
}

impl Sampler<'_> {
    pub(super) fn deliver(
        &mut self,
        sys: &System<'_>,
        stats: &mut IntegrateStats,
        k: usize,
        t: f64,
        x: &[f64],
    ) -> Result<(), Fault> {
        let xdot = match self.xdot.as_mut() {
            Some(buf) => {
                stats.sample_rhs_evals += 1;
                (sys.f.borrow_mut())(t, x, buf).map_err(|err| Fault::Engine { t, err })?;
                if !buf.iter().all(|v| v.is_finite()) {
                    return Err(Fault::NonFinite { t });
                }
                Some(buf.as_slice())
            }
            None => None,
        };
        (self.on_sample)(&Sample { k, t, x, xdot });
        stats.samples += 1;
        Ok(())
    }
}

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

    // Turns a fault into our error, with the counters at this point.
    let fail = |fault: Fault, t_reached: f64, stats: IntegrateStats| match fault {
        Fault::Engine { t, err } => IntegrateError::Engine { source: err, t_eval: t, t_reached, stats },
        Fault::NonFinite { t } => IntegrateError::NonFinite { what: "derivative", t_eval: t, t_reached, stats },
    };
    let with_evals = |mut s: IntegrateStats| {
        s.rhs_evals = sys.evals.get();
        s
    };

    let y0 = Y::from_slice(x0);
    sys.keep.set(true);
    let init = solver.init(&sys, t0, t1, &y0);
    sys.keep.set(false);
    if let Some(fault) = sys.fault.borrow_mut().take() {
        return Err(fail(fault, t0, with_evals(stats)));
    }
    if let Err(e) = init {
        return Err(IntegrateError::Solver { message: format!("{e:?}"), t_reached: t0, stats: with_evals(stats) });
    }
    // init ends with f(t0, x0).
    end_derivative(&sys, t0, x0, &mut f_prev).map_err(|f| fail(f, t0, with_evals(stats)))?;
    // The steps from here are our own (`dp8`): the crate's, with the dense output formed only
    // where a sample falls; they hand over their end derivative themselves.
    let mut solver = Dp8::after_init(&solver, Y::from_slice(&f_prev));
    if clock.due(t0).is_some() {
        sampler.deliver(&sys, &mut stats, 0, t0, x0).map_err(|f| fail(f, t0, with_evals(stats)))?;
        clock.next = 1;
    }

    // The run is complete once t is within rounding of t1.
    let t_done = t1 - 4.0 * f64::EPSILON * t1.abs().max(t0.abs());
    let (mut travel_retries, mut travel_fault) = (0, None);
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
                return Err(fail(fault, t, with_evals(stats)));
            }
            return Err(IntegrateError::StepSizeUnderflow { t_reached: t, h, stats: with_evals(stats) });
        }
        // The watchdog's deadline, read every 64 attempts (a clock read costs about as much as
        // a tenth of one right-hand side).
        if let Some((at, budget_s)) = opts.deadline
            && (stats.accepted + stats.rejected) % 64 == 0
            && std::time::Instant::now() >= at
        {
            return Err(IntegrateError::Deadline { budget_s, t_reached: t, stats: with_evals(stats) });
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
            return Err(fail(fault, t, with_evals(stats)));
        }
        (travel_retries, travel_fault) = (0, None);
        let outcome = match res {
            Ok(o) => o,
            Err(e) => {
                let stats = with_evals(stats);
                use differential_equations::error::Error as E;
                return Err(match e {
                    E::MaxSteps { .. } => IntegrateError::MaxSteps { max_steps: opts.max_steps, t_reached: t, stats },
                    E::StepSize { .. } => IntegrateError::StepSizeUnderflow { t_reached: t, h, stats },
                    E::Stiffness { .. } => IntegrateError::Stiff { t_reached: t, stats },
                    other => IntegrateError::Solver { message: format!("{other:?}"), t_reached: t, stats },
                });
            }
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
                stats: with_evals(stats),
            });
        }
        if clock.due(t_new).is_some() {
            f_end.copy_from_slice(solver.fsal().slice());
            // The three dense-output stages, for this step's samples.
            solver.dense(&sys);
            if let Some(fault) = sys.fault.borrow_mut().take() {
                return Err(fail(fault, t_new, with_evals(stats)));
            }
            while let Some(tk) = clock.due(t_new) {
                dense_sample(&solver, &f_prev, &f_end, tk, &mut xk).map_err(|message| IntegrateError::Solver {
                    message,
                    t_reached: t_new,
                    stats: with_evals(stats),
                })?;
                sampler
                    .deliver(&sys, &mut stats, clock.next, tk, &xk)
                    .map_err(|f| fail(f, t_new, with_evals(stats)))?;
                clock.next += 1;
            }
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
            .map_err(|f| fail(f, t_end, with_evals(stats)))?;
        clock.next += 1;
    }
    Ok(Integrated { t_end, x_end: solver.y().slice().to_vec(), stats: with_evals(stats) })
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
