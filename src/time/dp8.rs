//! The step of DOP853 (Dormand–Prince 8(5,3); E. Hairer, S. P. Nørsett, G. Wanner, *Solving
//! Ordinary Differential Equations I*, §II.10, the code DOP853) on the `differential-equations`
//! crate's own tableau, with its dense output formed only for the steps that are sampled.
//!
//! Why a step of our own: the crate's `ExplicitRungeKutta::step` evaluates the three extra
//! stages of the dense output and forms its seven coefficients after every accepted step,
//! whether or not the caller interpolates in it. Where stability holds the step below the
//! sample interval (a stiff shaft: 0.26 ms steps against 0.5 ms samples) half the steps carry no
//! sample, and that work was a fifth of the right-hand sides and about a third of the step's
//! arithmetic (BENCHMARKS.md, "Stiff shafts"). This step does the crate's operations in the
//! crate's order (the same stage sums, error norm, step-size rule and stiffness test, and its
//! interpolant, so the same bits: the time-domain tests and the studies' outputs are unchanged)
//! and leaves the dense stages to [`Dp8::dense`], called by the driver when a sample falls in
//! the step. The crate's `init` still chooses the first step.

use super::system::{Slab, System};
use differential_equations::error::Error;
use differential_equations::methods::{DormandPrince, ExplicitRungeKutta, Ordinary};
use differential_equations::ode::{ODE, OrdinaryNumericalMethod};
use differential_equations::tableau::ButcherTableau;
use differential_equations::tolerance::Tolerance;
use differential_equations::utils::constrain_step_size;

/// The crate's DOP853 for state type `Y`: order 8, 12 stages, 16 with the dense-output stages.
pub(crate) type Dop853<Y> = ExplicitRungeKutta<Ordinary, DormandPrince, f64, Y, 8, 12, 16>;

/// Stages of the method, and with the dense output's.
const S: usize = 12;
const I: usize = 16;

/// What a step did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Outcome {
    Accepted,
    Rejected,
}

/// DOP853 stepped by hand (see the module doc).
pub(crate) struct Dp8<Y: Slab> {
    c: [f64; I],
    /// The tableau's non-zero coefficients, `(stage, coefficient)`: the stage sums of row i of
    /// A, the solution's weights, the error estimators' and the dense output's rows.
    ///
    /// NOTE: a term with a zero coefficient adds ±0 to every entry, which changes no value (at
    /// most the sign of a zero): DOP853's tableau is a third zeros (stages 2–5 feed neither the
    /// solution nor most later stages), and skipping them was a quarter of the step's and the
    /// dense output's arithmetic on 32 pendulums (BENCHMARKS.md, "Stiff shafts").
    a: Vec<Vec<(usize, f64)>>,
    b: Vec<(usize, f64)>,
    bh: Vec<(usize, f64)>,
    er: Vec<(usize, f64)>,
    bi: Vec<Vec<(usize, f64)>>,
    rtol: Tolerance<f64>,
    atol: Tolerance<f64>,
    h_min: f64,
    h_max: f64,
    max_steps: usize,
    /// The crate's step-size rule: safety factor and the bounds of one step's change.
    safety: f64,
    min_scale: f64,
    max_scale: f64,
    t: f64,
    h: f64,
    y: Y,
    t_prev: f64,
    h_prev: f64,
    y_prev: Y,
    /// The stages of the last step; `k[0]` the derivative at its start.
    k: [Y; I],
    /// The derivative at the current point (the last accepted step's FSAL evaluation).
    fsal: Y,
    /// The dense output's coefficients of the last accepted step, once formed.
    cont: [Y; 8],
    dense_ready: bool,
    rejected_last: bool,
    steps: usize,
    stiff: usize,
    non_stiff: usize,
}

impl<Y: Slab> Dp8<Y> {
    /// The stepper continuing from the crate's solver just after its `init` (its point, first
    /// step, tolerances, bounds and step-size rule), with `f0` the derivative at that point.
    pub(crate) fn after_init(solver: &Dop853<Y>, f0: Y) -> Self {
        let tab = ButcherTableau::<f64, S, I>::dop853();
        let zero = solver.y().zeros_like();
        let nz = |row: &[f64]| row.iter().copied().enumerate().filter(|&(_, v)| v != 0.0).collect::<Vec<_>>();
        let bi = tab.bi.expect("DOP853 has a dense output");
        Self {
            c: tab.c,
            a: (0..I).map(|i| nz(&tab.a[i][..i])).collect(),
            b: nz(&tab.b),
            bh: nz(&tab.bh.expect("DOP853 has a lower-order solution")),
            er: nz(&tab.er.expect("DOP853 has an error estimator")),
            bi: bi.iter().map(|row| nz(row)).collect(),
            rtol: solver.rtol.clone(),
            atol: solver.atol.clone(),
            h_min: solver.h_min,
            h_max: solver.h_max,
            max_steps: solver.max_steps,
            safety: solver.safety_factor,
            min_scale: solver.min_scale,
            max_scale: solver.max_scale,
            t: solver.t(),
            h: solver.h(),
            y: solver.y().clone(),
            t_prev: solver.t(),
            h_prev: 0.0,
            y_prev: solver.y().clone(),
            k: std::array::from_fn(|i| if i == 0 { f0.clone() } else { zero.clone() }),
            fsal: f0,
            cont: std::array::from_fn(|_| zero.clone()),
            dense_ready: false,
            rejected_last: false,
            steps: 0,
            stiff: 0,
            non_stiff: 0,
        }
    }

    pub(crate) fn t(&self) -> f64 {
        self.t
    }
    pub(crate) fn h(&self) -> f64 {
        self.h
    }
    pub(crate) fn set_h(&mut self, h: f64) {
        self.h = h;
    }
    pub(crate) fn y(&self) -> &Y {
        &self.y
    }
    pub(crate) fn t_prev(&self) -> f64 {
        self.t_prev
    }
    pub(crate) fn y_prev(&self) -> &Y {
        &self.y_prev
    }
    /// The derivative at the current point.
    pub(crate) fn fsal(&self) -> &Y {
        &self.fsal
    }
    /// Marks the next step as a retry after a rejection (its growth is then capped at 1).
    pub(crate) fn set_rejected(&mut self) {
        self.rejected_last = true;
    }

    /// One step of length `h()` from the current point: the crate's `step` without the dense
    /// output (its checks, stage sums, error estimate, step-size rule and stiffness test).
    pub(crate) fn step(&mut self, ode: &System<'_>) -> Result<Outcome, Error<f64, Y>> {
        if self.h.abs() < self.h_prev.abs() * 1e-14 {
            return Err(Error::StepSize { t: self.t, y: self.y.clone() });
        }
        if self.steps >= self.max_steps {
            return Err(Error::MaxSteps { t: self.t, y: self.y.clone() });
        }
        self.steps += 1;
        // Stage 0 is the derivative at the step's start (the dense output of the last step,
        // formed or not, is given up here).
        self.k[0] = self.fsal.clone();
        self.dense_ready = false;
        let (t, h) = (self.t, self.h);
        let mut y_stage = self.y.zeros_like();
        for i in 1..S {
            y_stage = self.y.clone();
            for &(j, a) in &self.a[i] {
                y_stage.add_scaled(a * h, &self.k[j]);
            }
            ode.diff(t + self.c[i] * h, &y_stage, &mut self.k[i]);
        }
        let ysti = y_stage;
        let mut yseg = self.y.zeros_like();
        for &(i, b) in &self.b {
            yseg.add_scaled(b, &self.k[i]);
        }
        let y_new = self.y.plus_scaled(h, &yseg);
        let t_new = t + h;
        let n = self.y.len();
        let mut err_state = self.y.zeros_like();
        for &(j, e) in &self.er {
            err_state.add_scaled(e, &self.k[j]);
        }
        let mut err = self.y.error_norm(&y_new, &err_state, &self.atol, &self.rtol);
        let mut err2_state = yseg.clone();
        for &(j, e) in &self.bh {
            err2_state.add_scaled(-e, &self.k[j]);
        }
        let err2 = self.y.error_norm(&y_new, &err2_state, &self.atol, &self.rtol);
        let mut deno = err + 0.01 * err2;
        if deno <= 0.0 {
            deno = 1.0;
        }
        err = h.abs() * err * (1.0 / (deno * n as f64)).sqrt();
        let mut scale = self.safety * err.powf(-(1.0 / 8.0));
        scale = scale.max(self.min_scale).min(self.max_scale);
        let outcome = if err <= 1.0 {
            let mut dydt = self.y.zeros_like();
            ode.diff(t_new, &y_new, &mut dydt);
            // Hairer's stiffness test, every 100 steps: h|λ| estimated from the last two stages.
            if self.steps.is_multiple_of(100) {
                let num = yseg.diff_norm_squared(&self.k[S - 1]);
                let den = dydt.diff_norm_squared(&ysti);
                if den > 0.0 {
                    if h * (num / den).sqrt() > 6.1 {
                        self.non_stiff = 0;
                        self.stiff += 1;
                        if self.stiff == 15 {
                            return Err(Error::Stiffness { t: self.t, y: self.y.clone() });
                        }
                    }
                } else {
                    self.non_stiff += 1;
                    if self.non_stiff == 6 {
                        self.stiff = 0;
                    }
                }
            }
            self.t_prev = t;
            self.h_prev = h;
            self.y_prev = std::mem::replace(&mut self.y, y_new);
            self.t = t_new;
            self.fsal = dydt;
            if self.rejected_last {
                self.rejected_last = false;
                scale = scale.min(1.0);
            }
            Outcome::Accepted
        } else {
            self.rejected_last = true;
            Outcome::Rejected
        };
        self.h = constrain_step_size(h * scale, self.h_min, self.h_max);
        Ok(outcome)
    }

    /// Forms the last accepted step's dense output (the crate's coefficients, with its three
    /// extra stages), once per step.
    pub(crate) fn dense(&mut self, ode: &System<'_>) {
        if self.dense_ready {
            return;
        }
        let (t, h) = (self.t_prev, self.h_prev);
        let ydiff = self.y.minus(&self.y_prev);
        let mut bspl = ydiff.zeros_like();
        bspl.add_scaled(h, &self.k[0]);
        bspl.add_scaled(-1.0, &ydiff);
        let mut cont3 = ydiff.clone();
        cont3.add_scaled(-h, &self.fsal);
        cont3.add_scaled(-1.0, &bspl);
        self.cont[0] = self.y_prev.clone();
        self.cont[1] = ydiff;
        self.cont[2] = bspl;
        self.cont[3] = cont3;
        self.k[S] = self.fsal.clone();
        for i in S + 1..I {
            let mut y_stage = self.y_prev.clone();
            for &(j, a) in &self.a[i] {
                y_stage.add_scaled(a * h, &self.k[j]);
            }
            ode.diff(t + self.c[i] * h, &y_stage, &mut self.k[i]);
        }
        for i in 4..8 {
            self.cont[i].fill(0.0);
            for &(j, b) in &self.bi[i] {
                self.cont[i].add_scaled(b, &self.k[j]);
            }
            self.cont[i].scale_by(h);
        }
        self.dense_ready = true;
    }

    /// The crate's interpolant of the last accepted step at `t_interp` (with its s and 1 − s
    /// swapped in the high-order part, which [`super::dop853::dense_sample`] corrects); needs
    /// [`Dp8::dense`] first.
    pub(crate) fn interpolate(&self, t_interp: f64) -> Result<Y, String> {
        if !self.dense_ready || t_interp < self.t_prev || t_interp > self.t {
            return Err(format!("interpolation at {t_interp} outside the step [{}, {}]", self.t_prev, self.t));
        }
        let s = (t_interp - self.t_prev) / self.h_prev;
        let s1 = 1.0 - s;
        let last = self.cont.len() - 1;
        let mut acc = self.cont[last].clone();
        for i in (1..last).rev() {
            let factor = if i >= 4 {
                if (last - i) % 2 == 1 { s1 } else { s }
            } else if i % 2 == 1 {
                s1
            } else {
                s
            };
            acc.scale_by(factor);
            acc.add_scaled(1.0, &self.cont[i]);
        }
        Ok(self.cont[0].plus_scaled(s, &acc))
    }
}
