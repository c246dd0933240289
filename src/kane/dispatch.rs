//! The evaluation of a [`Model`] at one state: the dispatch on the form chosen at build (pairs,
//! composite-body rates, mapped rates, geared; see the module doc of [`super`]) and on a literal
//! count of degrees of freedom, the couplings added after, and the solve for u̇ that makes
//! `ẋ = [W⁻¹u; M⁻¹F]`.

use super::{Form, Model, Workspace};
use crate::error::EngineError;

impl Model {
    #[inline(always)]
    pub(super) fn check_lengths(&self, x: &[f64], xdot: &[f64]) -> Result<(), EngineError> {
        let n = self.n;
        if x.len() != 2 * n || xdot.len() != 2 * n {
            let (what, got) = if x.len() != 2 * n { ("state x", x.len()) } else { ("derivative ẋ", xdot.len()) };
            return Err(EngineError::Dimension { what, got, expected: 2 * n });
        }
        Ok(())
    }

    /// [`Kane::rhs`] by the general forms, inlined into `Kane::rhs_general` (its one caller).
    #[inline(always)]
    pub(super) fn rhs_general(
        &self,
        ws: &mut Workspace,
        t: f64,
        x: &[f64],
        xdot: &mut [f64],
    ) -> Result<(), EngineError> {
        // Checked again here so the compiler knows x has 2N entries in the literal instances
        // and drops the slices' range checks.
        self.check_lengths(x, xdot)?;
        // NOTE: dispatched on n itself (not on a copy of it), for the same reason.
        let n = self.n;
        let out = if let Some(star) = self.fast_star.as_ref().filter(|_| self.solves_star()) {
            self.rhs_star(star, ws, t, x, xdot)
        } else if let Some(ax) = &self.fast_axial {
            self.rhs_axial(ax, ws, t, x, xdot)
        } else if self.articulated {
            self.rhs_articulated(ws, t, x, xdot)
        } else if self.nb == n {
            with_literal_n!(n, self.rhs_n(ws, t, x, xdot))
        } else {
            self.rhs_n::<0>(ws, t, x, xdot)
        };
        // NOTE: a path evaluated beyond its end gives NaN (`PathShape::at`); only on that failure
        // is the state searched for the joint to name, so a successful call pays nothing. The
        // fixed-size composite-body path (`small_rates`) maps its failures the same way.
        out.map_err(|e| match e {
            EngineError::NonFinite { .. } => self.mech.path_out_of_travel(&x[..n]).unwrap_or(e),
            e => e,
        })
    }

    /// The body of [`Kane::rhs`] for `N` degrees of freedom (`N = 0`: any).
    ///
    /// NOTE: one dispatch on n for the whole evaluation, assembly, factorisation and solve, so
    /// the copies into ẋ have a literal length too (with a run-time length each was a `memcpy`
    /// call; BENCHMARKS.md).
    #[inline(always)]
    pub(super) fn rhs_n<const N: usize>(
        &self,
        ws: &mut Workspace,
        t: f64,
        x: &[f64],
        xdot: &mut [f64],
    ) -> Result<(), EngineError> {
        let n = if N == 0 { self.n } else { N };
        let (q, u) = x.split_at(n);
        self.evaluate_n::<N>(ws, t, q, u, true);
        let (qd, ud) = xdot.split_at_mut(n);
        // Each body's record holds its joint's rate; with fixed joints, bodies and coordinates differ.
        if N != 0 || self.nb == n {
            for (qd, st) in qd.iter_mut().zip(&ws.state[..n]) {
                *qd = st.qdot;
            }
        } else {
            for (qd, &j) in qd.iter_mut().zip(&self.joint_of) {
                *qd = ws.state[j].qdot;
            }
        }
        if N == 0 && self.tree.is_some() {
            self.factor_solve_tree(ws, ud)?;
        } else {
            self.factor_solve_n::<N>(ws, ud)?;
        }
        Ok(())
    }

    /// Evaluates M (and F, q̇ when `forcing`; only then are `u` and `t` read) into the buffers,
    /// by the form chosen at build (see the module doc). Only entries (k, l) with one an ancestor
    /// of the other are written: the others are zero for a tree and stay as allocated.
    pub(super) fn evaluate(&self, ws: &mut Workspace, t: f64, q: &[f64], u: &[f64], forcing: bool) {
        if self.nb == self.n {
            with_literal_n!(self.n, self.evaluate_n(ws, t, q, u, forcing))
        } else {
            self.evaluate_n::<0>(ws, t, q, u, forcing)
        }
    }

    /// The body of `Model::evaluate` for `N` degrees of freedom (`N = 0`: any, read at run time).
    ///
    /// NOTE: a literal n lets the compiler unroll the loops and drop most bounds checks for the
    /// small mechanisms that dominate torsional work.
    #[inline(always)]
    pub(super) fn evaluate_n<const N: usize>(&self, ws: &mut Workspace, t: f64, q: &[f64], u: &[f64], forcing: bool) {
        // NOTE: one test of the form per call, outside the loops (measured against testing the
        // speed choice inside them; BENCHMARKS.md).
        match self.form {
            Form::Pairs => self.evaluate_absolute::<N>(ws, t, q, u, forcing),
            Form::Rates => {
                self.evaluate_rates::<N>(ws, t, q, u, forcing);
                if !self.rollers.is_empty() {
                    self.add_rollers(ws, q, u, forcing);
                }
            }
            Form::MappedRates => self.evaluate_mapped(ws, t, q, u, forcing),
            Form::Geared => self.evaluate_geared(ws, t, q, u, forcing),
        }
        if forcing && !self.couplings.is_empty() && !ws.couplings_suspended {
            self.add_couplings(ws, q, u);
        }
    }

    /// Copies M and F from the row-major buffers into the nalgebra ones.
    pub(super) fn copy_out(&self, ws: &mut Workspace) {
        let n = self.n;
        for r in 0..n {
            for c in 0..n {
                ws.m_out[(r, c)] = ws.m[r * n + c];
            }
            ws.f_out[r] = ws.f[r];
        }
    }
}
