//! The optimisation: SLSQP (the `slsqp` crate, a sequential quadratic programme with the
//! constraints' and objective's exact gradients) on the epigraph form of the min–max problem,
//!
//! minimise t over (u, t) subject to a_k(x)/a_ref − t ≤ 0 (every operating point k),
//! peak_k(x)/travel − 1 ≤ 0, 1 − T_jump,s(x)/(margin·T_max) ≤ 0 (every speed s),
//!
//! with x = lower + u·(upper − lower), u ∈ [0, 1]ⁿ: the largest rotor response is smooth in each
//! point's own term, so the non-smooth max becomes smooth constraints, and SLSQP's active set
//! finds which points bind. Several starts (a Halton sequence over the box, the first its centre)
//! run on threads; their optima are compared and the distinct ones reported.

use super::kkt::{Kkt, kkt};
use super::problem::{Evaluation, Problem, SynthesisError, search_scale};
use rayon::prelude::*;

/// A scaled constraint value at most this counts as met (the rows are O(1)).
const FEASIBLE: f64 = 1e-9;
use std::cell::RefCell;

/// How the optimiser runs.
#[derive(Debug, Clone)]
pub struct OptimiseOptions {
    /// Number of starts (≥ 1): the box centre, then a Halton sequence.
    pub starts: usize,
    /// Largest number of design evaluations per start.
    pub max_evaluations: usize,
    /// SLSQP's relative tolerance on the objective and the variables.
    pub tolerance: f64,
}

impl Default for OptimiseOptions {
    fn default() -> Self {
        Self { starts: 1, max_evaluations: 200, tolerance: 1e-10 }
    }
}

/// One design evaluated by the optimiser (the convergence history).
#[derive(Debug, Clone, PartialEq, serde::Serialize, schemars::JsonSchema)]
pub struct Iterate {
    /// The design, in the variables' units.
    pub x: Vec<f64>,
    /// The largest rotor response over the set, rad/s² (NaN where the design failed).
    pub worst_response: f64,
    /// The largest scaled constraint value (≤ 0: feasible).
    pub violation: f64,
}

/// A constraint at the reported design, in the scaled form `g ≤ 0`.
#[derive(Debug, Clone, PartialEq, serde::Serialize, schemars::JsonSchema)]
pub struct ConstraintValue {
    /// What it bounds, with its operating point.
    pub name: String,
    /// Its scaled value g (≤ 0 when met; 0 when active).
    pub value: f64,
    /// Its Lagrange multiplier (0 unless active).
    pub multiplier: f64,
}

/// The outcome of one start.
#[derive(Debug, Clone, PartialEq, serde::Serialize, schemars::JsonSchema)]
pub struct Optimum {
    /// The start, in the variables' units.
    pub start: Vec<f64>,
    /// The design reached, in the variables' units.
    pub x: Vec<f64>,
    /// Its evaluation.
    pub evaluation: Evaluation,
    /// Every constraint there (the epigraph's rows name the operating point they bound).
    pub constraints: Vec<ConstraintValue>,
    /// The first-order optimality check.
    pub kkt: Kkt,
    /// Why SLSQP stopped.
    pub status: String,
    /// Every design the start evaluated, in order.
    pub history: Vec<Iterate>,
    /// Harmonic-balance solves spent by the start.
    pub solves: usize,
}

impl Optimum {
    /// Whether every constraint is met to `tol` (scaled).
    pub fn feasible(&self, tol: f64) -> bool {
        // The response rows come first, one per operating point; they bound t, not the design.
        self.constraints.iter().skip(self.evaluation.points.len()).all(|c| c.value <= tol)
    }
}

/// The result of a synthesis: every start's optimum, the best and the distinct ones.
#[derive(Debug, Clone, PartialEq, serde::Serialize, schemars::JsonSchema)]
pub struct Synthesis {
    /// The response scale a_ref, rad/s²: the largest response at the box centre.
    pub response_scale: f64,
    /// Per start.
    pub optima: Vec<Optimum>,
    /// Index of the best feasible optimum (the lowest response), or of the least violated.
    pub best: usize,
    /// Indices of the distinct optima (variables apart by more than 1e-4 of their range), the
    /// best first.
    pub distinct: Vec<usize>,
}

/// The scaled constraint rows of an evaluation at epigraph level t, with their gradients in
/// (u, t): the response rows, the travel rows, the jump rows, in that order.
pub(super) fn rows(problem: &Problem, ev: &Evaluation, a_ref: f64, t: f64) -> Vec<(String, f64, Vec<f64>)> {
    let n = problem.variables.len();
    let range: Vec<f64> = problem.variables.iter().map(|v| v.upper - v.lower).collect();
    let scaled = |g: &[f64], by: f64, last: f64| -> Vec<f64> {
        let mut out: Vec<f64> = (0..n).map(|i| g[i] * range[i] / by).collect();
        out.push(last);
        out
    };
    let at = |p: &super::problem::OperatingValue| {
        format!("{} rpm, {} N·m", crate::plot::num(p.rpm, 6), crate::plot::num(p.torque_nm, 6))
    };
    let mut out = Vec::new();
    for p in &ev.points {
        let at = at(p);
        out.push((
            format!("response at {at}"),
            p.rotor_accel / a_ref - t,
            scaled(&p.rotor_accel_gradient, a_ref, -1.0),
        ));
    }
    if let Some(travel) = problem.travel {
        for p in &ev.points {
            let at = at(p);
            out.push((
                format!("travel at {at}"),
                p.absorber_peak / travel - 1.0,
                scaled(&p.absorber_peak_gradient, travel, 0.0),
            ));
        }
    }
    let t_max = problem.torques.iter().copied().fold(0.0, f64::max);
    let need = problem.jump_margin.unwrap_or(1.0) * t_max;
    for j in &ev.jumps {
        let name = format!("jump margin at {} rpm", crate::plot::num(j.rpm, 6));
        let (value, grad) = match j.torque_nm {
            Some(tj) => (1.0 - tj / need, j.gradient.iter().map(|g| -g).collect::<Vec<f64>>()),
            // No fold up to the searched torque: the margin holds with at least that to spare.
            None => (1.0 - search_scale(problem.jump_margin) / problem.jump_margin.unwrap_or(1.0), vec![0.0; n]),
        };
        out.push((name, value, scaled(&grad, need, 0.0)));
    }
    out
}

/// The variables of u ∈ [0, 1]ⁿ.
fn design(problem: &Problem, u: &[f64]) -> Vec<f64> {
    problem.variables.iter().zip(u).map(|(v, &s)| v.lower + s * (v.upper - v.lower)).collect()
}

/// The k-th point (k ≥ 1) of the Halton sequence in `dim` dimensions (bases the first primes);
/// k = 0 is the box centre.
fn halton(k: usize, dim: usize) -> Vec<f64> {
    const PRIMES: [usize; 12] = [2, 3, 5, 7, 11, 13, 17, 19, 23, 29, 31, 37];
    if k == 0 {
        return vec![0.5; dim];
    }
    (0..dim)
        .map(|d| {
            let b = PRIMES[d % PRIMES.len()];
            let (mut f, mut r, mut i) = (1.0, 0.0, k);
            while i > 0 {
                f /= b as f64;
                r += f * (i % b) as f64;
                i /= b;
            }
            r
        })
        .collect()
}

impl Problem {
    /// Minimises the largest rotor response over the operating set under the travel and jump
    /// constraints from `opts.starts` starts on threads.
    ///
    /// # Errors
    /// An ill-posed problem ([`Problem::check`]), or a box centre that cannot be evaluated (no
    /// response scale).
    pub fn optimise(&self, opts: &OptimiseOptions) -> Result<Synthesis, SynthesisError> {
        self.check()?;
        let n = self.variables.len();
        let centre = self.evaluate(&design(self, &vec![0.5; n]))?;
        let a_ref = centre.worst_response();
        if !(a_ref.is_finite() && a_ref > 0.0) {
            return Err(SynthesisError::Invalid(format!(
                "the response at the box centre is {a_ref} rad/s²: nothing to reduce"
            )));
        }
        let optima: Vec<Optimum> =
            (0..opts.starts.max(1)).into_par_iter().map(|k| self.run_start(&halton(k, n), a_ref, opts)).collect();
        let score = |o: &Optimum| (!o.feasible(1e-6), o.evaluation.worst_response());
        let mut order: Vec<usize> = (0..optima.len()).collect();
        order.sort_by(|&a, &b| {
            let (fa, ra) = score(&optima[a]);
            let (fb, rb) = score(&optima[b]);
            fa.cmp(&fb).then(ra.total_cmp(&rb))
        });
        let mut distinct: Vec<usize> = Vec::new();
        for &k in &order {
            let apart = |d: &usize| {
                optima[*d]
                    .x
                    .iter()
                    .zip(&optima[k].x)
                    .zip(&self.variables)
                    .any(|((a, b), v)| (a - b).abs() > 1e-4 * (v.upper - v.lower))
            };
            if distinct.iter().all(apart) {
                distinct.push(k);
            }
        }
        Ok(Synthesis { response_scale: a_ref, best: order[0], distinct, optima })
    }

    /// One start: SLSQP from u0, restarted from its result (a fresh quasi-Newton matrix) while
    /// that result fails the KKT check, up to [`RESTARTS`] times; then the optimum's check.
    fn run_start(&self, u0: &[f64], a_ref: f64, opts: &OptimiseOptions) -> Optimum {
        let mut trail = Trail::default();
        let mut u = u0.to_vec();
        let mut status = String::new();
        let mut reached = None;
        for pass in 0..=RESTARTS {
            let stopped = self.slsqp_pass(&u, a_ref, opts, &mut trail);
            status = if pass == 0 { stopped } else { format!("{stopped} (after {pass} restarts)") };
            u = self.best_of(&trail, &u);
            let ev = self.evaluate(&design(self, &u));
            let residual = ev.as_ref().ok().map(|ev| {
                trail.solves += ev.solves;
                kkt(&rows(self, ev, a_ref, ev.worst_response() / a_ref), &u, u.len()).residual
            });
            reached = Some(ev);
            if residual.is_some_and(|r| r <= KKT_TOL) || trail.history.len() >= opts.max_evaluations {
                break;
            }
        }
        let x = design(self, &u);
        let (history, solves) = (trail.history, trail.solves);
        let (evaluation, status) = match reached.expect("at least one pass") {
            Ok(ev) => (ev, status),
            Err(e) => {
                let empty = Evaluation { x: x.clone(), points: Vec::new(), jumps: Vec::new(), solves: 0 };
                (empty, format!("{status}; the design it stopped at failed: {e}"))
            }
        };
        let t = evaluation.worst_response() / a_ref;
        let all = rows(self, &evaluation, a_ref, t);
        let kkt = kkt(&all, &u, u.len());
        let constraints = all
            .iter()
            .zip(&kkt.multipliers)
            .map(|((name, value, _), &multiplier)| ConstraintValue { name: name.clone(), value: *value, multiplier })
            .collect();
        Optimum { start: design(self, u0), x, evaluation, constraints, kkt, status, history, solves }
    }
}

/// How many times a start is restarted from its own result.
const RESTARTS: usize = 3;

/// The KKT residual (scaled variables) under which a start's result is an optimum.
const KKT_TOL: f64 = 1e-7;

/// What a start has evaluated so far.
#[derive(Default)]
struct Trail {
    /// Every design evaluated, in order.
    history: Vec<Iterate>,
    /// Harmonic-balance solves spent.
    solves: usize,
}

impl Problem {
    /// One SLSQP run from u0 (the epigraph level starting at the start's own response),
    /// every evaluation appended to `trail`; returns why it stopped.
    fn slsqp_pass(&self, u0: &[f64], a_ref: f64, opts: &OptimiseOptions, trail: &mut Trail) -> String {
        let n = self.variables.len();
        let trail = RefCell::new(trail);
        let last: RefCell<Option<(Vec<f64>, Option<Evaluation>)>> = RefCell::new(None);
        // The evaluation at u (the last one kept: SLSQP asks the objective and each constraint
        // at the same point in turn).
        let evaluated = |u: &[f64]| -> Option<Evaluation> {
            if let Some((at, ev)) = last.borrow().as_ref()
                && at.as_slice() == u
            {
                return ev.clone();
            }
            let x = design(self, u);
            let ev = self.evaluate(&x).ok();
            let worst = ev.as_ref().map_or(f64::NAN, Evaluation::worst_response);
            let violation = ev.as_ref().map_or(f64::INFINITY, |e| {
                rows(self, e, a_ref, f64::INFINITY)
                    .iter()
                    .skip(e.points.len())
                    .map(|r| r.1)
                    .fold(f64::NEG_INFINITY, f64::max)
            });
            let mut t = trail.borrow_mut();
            t.solves += ev.as_ref().map_or(0, |e| e.solves);
            t.history.push(Iterate { x, worst_response: worst, violation });
            *last.borrow_mut() = Some((u.to_vec(), ev.clone()));
            ev
        };
        let Some(start) = evaluated(u0) else { return "the start cannot be evaluated".into() };
        let t0 = start.worst_response() / a_ref;
        let count = rows(self, &start, a_ref, t0).len();
        let objective = |z: &[f64], g: Option<&mut [f64]>, _: &mut ()| -> f64 {
            if let Some(g) = g {
                g.fill(0.0);
                g[n] = 1.0;
            }
            z[n]
        };
        let constraint = |k: usize| {
            let evaluated = &evaluated;
            move |z: &[f64], g: Option<&mut [f64]>, _: &mut ()| -> f64 {
                match evaluated(&z[..n]) {
                    Some(ev) => {
                        let (_, value, grad) = rows(self, &ev, a_ref, z[n]).swap_remove(k);
                        if let Some(g) = g {
                            g.copy_from_slice(&grad);
                        }
                        value
                    }
                    None => {
                        // A design that cannot be evaluated counts as violating every
                        // constraint, with no direction: the line search steps back.
                        if let Some(g) = g {
                            g.fill(0.0);
                        }
                        1.0
                    }
                }
            }
        };
        let cons: Vec<_> = (0..count).map(constraint).collect();
        let mut z0 = u0.to_vec();
        z0.push(t0);
        let mut bounds = vec![(0.0, 1.0); n];
        bounds.push((0.0, 1e3));
        let tols = slsqp::StopTols { ftol_rel: opts.tolerance, xtol_rel: opts.tolerance, ..Default::default() };
        let left = opts.max_evaluations.saturating_sub(trail.borrow().history.len()).max(1);
        match slsqp::minimize(objective, &z0, &bounds, &cons, (), left, Some(tols)) {
            Ok((s, ..)) => format!("{s:?}"),
            Err((s, ..)) => format!("{s:?}"),
        }
    }

    /// The design a pass reports, in u: the best feasible design the trail holds (SLSQP hands
    /// back its start when it stops on a failure, most often a line search that rounding defeats
    /// at a sharp antiresonance), or `fallback` when none is feasible.
    fn best_of(&self, trail: &Trail, fallback: &[f64]) -> Vec<f64> {
        let best = trail
            .history
            .iter()
            .filter(|h| h.violation <= FEASIBLE && h.worst_response.is_finite())
            .min_by(|a, b| a.worst_response.total_cmp(&b.worst_response));
        match best {
            Some(b) => b.x.iter().zip(&self.variables).map(|(x, v)| (x - v.lower) / (v.upper - v.lower)).collect(),
            None => fallback.to_vec(),
        }
    }
}
