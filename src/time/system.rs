//! The state and right-hand-side plumbing that both time-stepping loops share (the DOP853 loop
//! of `dop853.rs`, its step in `dp8.rs`, and the Radau IIA loop of `radau.rs`): the state types
//! the `differential-equations` crate steps ([`Slab`], [`Stages`]), the adapter from our fallible
//! right-hand side to the crate's infallible `ODE::diff` ([`System`], with its fault slot), the
//! forward-difference Jacobian the implicit method asks of it, and the fixed-rate sample clock
//! and sampler. It sits below the three loops so that none of them imports another's internals.

use crate::error::EngineError;
use crate::time::run::{IntegrateError, IntegrateStats, Sample};
use differential_equations::linalg::Matrix;
use differential_equations::ode::ODE;
use differential_equations::tolerance::Tolerance;
use differential_equations::traits::State;
use std::cell::{Cell, RefCell};

/// A type-erased right-hand side `(t, x, ẋ)`; an engine error stops the run.
pub(crate) type DynRhs<'a> = dyn FnMut(f64, &[f64], &mut [f64]) -> Result<(), EngineError> + 'a;

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

impl Fault {
    /// The fault as the run's error, with the counters `stats` at time `t_reached`.
    pub(super) fn error(self, t_reached: f64, stats: IntegrateStats) -> IntegrateError {
        match self {
            Fault::Engine { t, err } => IntegrateError::Engine { source: err, t_eval: t, t_reached, stats },
            Fault::NonFinite { t } => IntegrateError::NonFinite { what: "derivative", t_eval: t, t_reached, stats },
        }
    }
}

/// Adapter from the caller's `FnMut` with errors to the crate's `ODE::diff(&self)` without:
/// interior mutability for the closure, a counter, and a fault slot the driver checks after every
/// step (the crate cannot stop mid-step, so after a fault the remaining stages get NaN and the
/// step's result is discarded).
pub(super) struct System<'a> {
    pub(super) f: RefCell<&'a mut DynRhs<'a>>,
    pub(super) evals: Cell<usize>,
    pub(super) fault: RefCell<Option<Fault>>,
    pub(super) recent: RefCell<Recent>,
    /// Whether evaluations are kept in `recent`: only during the crate's `init` (the DOP853 steps
    /// hand their end derivative over themselves, [`Dp8::fsal`]; the implicit route reads none).
    pub(super) keep: Cell<bool>,
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

    /// `stats` with the right-hand-side evaluations counted so far.
    pub(super) fn counted(&self, mut stats: IntegrateStats) -> IntegrateStats {
        stats.rhs_evals = self.evals.get();
        stats
    }
}

/// The last derivative evaluation kept `(t, ẋ)` (`System::keep`): f(t0, x0), which the crate's
/// `init` evaluates last.
pub(super) struct Recent {
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
    pub(super) fn at(&self, t: f64) -> Option<&[f64]> {
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

    // Only the implicit method asks (DOP853 never does): see `fd_jacobian`.
    fn jacobian(&self, t: f64, y: &Y, j: &mut Matrix<f64>) {
        fd_jacobian(self, t, y, j);
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

/// The Jacobian by forward differences (Hairer's increment, see the `radau` module docs), counted in the right-hand-side
/// evaluations; a fault inside leaves NaN in the matrix and the fault in its slot.
fn fd_jacobian<Y: Slab>(sys: &System<'_>, t: f64, y: &Y, j: &mut Matrix<f64>) {
    let n = y.slice().len();
    let mut f0 = Y::from_slice(y.slice());
    let mut f1 = Y::from_slice(y.slice());
    let mut yp = Y::from_slice(y.slice());
    ODE::<f64, Y>::diff(sys, t, y, &mut f0);
    for c in 0..n {
        let x = y.slice()[c];
        let delta = (f64::EPSILON * x.abs().max(1e-5)).sqrt();
        yp.slice_mut()[c] = x + delta;
        // Divide by the increment actually taken (x + δ rounds).
        let d = yp.slice()[c] - x;
        ODE::<f64, Y>::diff(sys, t, &yp, &mut f1);
        for r in 0..n {
            j[(r, c)] = (f1.slice()[r] - f0.slice()[r]) / d;
        }
        yp.slice_mut()[c] = x;
    }
}
