//! The right-hand side of the pair form ([`super::absolute`]) for small trees, in fixed-size
//! storage: absolute angular velocities on a revolute tree of at most [`SMALL`] speeds without
//! point forces (any topology, springs, dampers, ground dampers, joint torques and gravity).
//!
//! The terms are those of `Model::evaluate_absolute`, summed in the same order, and the solve
//! is `Model::factor_solve`'s LDLᵀ in the same order, so the results are identical to the general
//! path's whenever the joint torques are listed in joint order (every example; otherwise their
//! sum is ordered by joint, a difference of rounding). What differs is where the data live.
//! Everything the evaluation reads is packed at construction into arrays indexed by speed
//! (parents, the constant diagonal, the pair coefficients by (k, j) rather than in walk order,
//! the path between every ancestor pair, each speed's excitation), M and F stay in local arrays
//! the compiler keeps in registers, and the loops, the factorisation's included, unroll for the
//! literal n.
//!
//! NOTE: a fast path beside the general pair form rather than a change to it: the general form
//! writes M and F into the engine's buffers (read back by `mass_matrix_and_forcing_rows` and the
//! harmonic-balance Jacobian), walks each body's ancestors in a loop of run-time length and
//! solves with a loop-based LDLᵀ; for the small trees of torsional work those costs were most of
//! the engine's own instructions (measured, BENCHMARKS.md).

use super::{Model, PIVOT_TOL};
use crate::error::EngineError;
use crate::model::math::{Vec2, cross2, rotate_cs};

use super::{NONE, SMALL, SmallRhs};

/// A root's parent: past the end of the speeds, so that a root's parent speed reads as zero.
const GROUND: usize = usize::MAX;

/// Marks a pair (k, j) of which k is not an ancestor of j (`Small::via`).
const NOT_ANCESTOR: usize = usize::MAX;

/// `(cos, sin)` of the sum of two angles given by theirs.
#[inline(always)]
fn compose((ac, as_): (f64, f64), (bc, bs): (f64, f64)) -> (f64, f64) {
    (ac * bc - as_ * bs, as_ * bc + ac * bs)
}

/// The constant data of the fixed-size path, packed once at construction.
#[derive(Debug, Clone)]
pub(super) struct Small {
    /// The instance of [`Model::rhs_small`] for this n.
    pub(super) rhs: SmallRhs,
    /// Per speed: its parent speed, [`GROUND`] for a root.
    parent: [usize; SMALL],
    /// Per speed: a root expressed in its own frame, whose joint angle needs no trigonometry.
    own_frame: [bool; SMALL],
    /// `M_kk`, constant (`Node::diag_abs`).
    diag: [f64; SMALL],
    /// `1 / M_00`: the first pivot of the factorisation is constant.
    diag0_inv: f64,
    /// Pivots at or below this stop the solve (`PIVOT_TOL` times the largest diagonal entry,
    /// constant in this form).
    pivot_min: f64,
    /// For k < j: the child of k on the path to j (j itself when k is j's parent), so that
    /// `Δ_kj = q_c + Δ_cj`; `NOT_ANCESTOR` when k is not an ancestor of j.
    via: [[usize; SMALL]; SMALL],
    /// The pair coefficients `(α, β)` of (k, j), as `Model::build` derives them.
    pair: [[(f64, f64); SMALL]; SMALL],
    k_spring: [f64; SMALL],
    q_free: [f64; SMALL],
    c_joint: [f64; SMALL],
    c_ground: [f64; SMALL],
    /// Per speed: the index of its joint's applied torque in `Model::torques`, or `NONE`.
    torque: [usize; SMALL],
    /// First moments in the body frames (`Node::first_abs`), for gravity.
    first: [Vec2; SMALL],
    /// Gravity, when the evaluation is in the world frame and it is not zero.
    gravity: Option<Vec2>,
    /// The data of the composite-body instance ([`super::small_rates`]; default for the pair form).
    pub(super) rates: super::small_rates::Packed,
}

impl Small {
    /// Packs the data of `kane` (already built) when a fixed-size path applies: this module's
    /// for the pair form, [`super::small_rates`]'s for the mapped composite-body form.
    pub(super) fn new(kane: &Model) -> Option<Small> {
        let n = kane.n;
        if n > SMALL || kane.nb != n || !kane.point_forces.is_empty() {
            return None;
        }
        match kane.form {
            super::Form::Pairs => Self::pairs(kane),
            super::Form::MappedRates => {
                super::path_pair::choose(kane, false, &Self::install).map(|(rhs, p)| Self::with_rates(rhs, p))
            }
            // With joint rates only a rotor carrying one path absorber, whose joint rates are its
            // absolute speeds (W = I), has a fixed-size form: the pair form of `small_rates`.
            super::Form::Rates => {
                super::path_pair::choose(kane, true, &Self::install).map(|(rhs, p)| Self::with_rates(rhs, p))
            }
            // Geared trees (whose state is reduced) take the general form.
            super::Form::Geared => None,
        }
    }

    /// Gives `kane` the composite-body instance `rhs` with its data (the pair form's selection
    /// compares against it on a copy of the engine).
    fn install(kane: &mut Model, rhs: SmallRhs, rates: super::small_rates::Packed) {
        kane.small = Some(Self::with_rates(rhs, rates));
    }

    /// The composite-body instance `rhs` with its data: the pair form's fields stay unused.
    fn with_rates(rhs: SmallRhs, rates: super::small_rates::Packed) -> Small {
        Small {
            rhs,
            parent: [GROUND; SMALL],
            own_frame: [false; SMALL],
            diag: [0.0; SMALL],
            diag0_inv: 0.0,
            pivot_min: 0.0,
            via: [[NOT_ANCESTOR; SMALL]; SMALL],
            pair: [[(0.0, 0.0); SMALL]; SMALL],
            k_spring: [0.0; SMALL],
            q_free: [0.0; SMALL],
            c_joint: [0.0; SMALL],
            c_ground: [0.0; SMALL],
            torque: [NONE; SMALL],
            first: [Vec2::zeros(); SMALL],
            gravity: None,
            rates,
        }
    }

    /// The pair form's data (absolute speeds on a revolute tree).
    fn pairs(kane: &Model) -> Option<Small> {
        let n = kane.n;
        let nodes = &kane.nodes[..n];
        let rhs: SmallRhs = match n {
            1 => Model::rhs_small::<1>,
            2 => Model::rhs_small::<2>,
            3 => Model::rhs_small::<3>,
            4 => Model::rhs_small::<4>,
            5 => Model::rhs_small::<5>,
            6 => Model::rhs_small::<6>,
            _ => return None,
        };
        let mut s = Small {
            rhs,
            parent: [GROUND; SMALL],
            own_frame: [false; SMALL],
            diag: [0.0; SMALL],
            diag0_inv: 1.0 / nodes[0].diag_abs,
            pivot_min: PIVOT_TOL * nodes.iter().fold(0.0f64, |a, nd| a.max(nd.diag_abs.abs())),
            via: [[NOT_ANCESTOR; SMALL]; SMALL],
            pair: [[(0.0, 0.0); SMALL]; SMALL],
            k_spring: [0.0; SMALL],
            q_free: [0.0; SMALL],
            c_joint: [0.0; SMALL],
            c_ground: [0.0; SMALL],
            first: [Vec2::zeros(); SMALL],
            torque: [NONE; SMALL],
            gravity: (kane.world && kane.gravity != Vec2::zeros()).then_some(kane.gravity),
            rates: Default::default(),
        };
        let mut pair = kane.pairs.iter();
        for (j, nd) in nodes.iter().enumerate() {
            let root = nd.parent == super::GROUND_PARENT;
            s.parent[j] = if root { GROUND } else { nd.parent };
            s.own_frame[j] = root && !kane.world;
            s.diag[j] = nd.diag_abs;
            (s.k_spring[j], s.q_free[j], s.c_joint[j], s.c_ground[j]) =
                (nd.k_spring, nd.q_free, nd.c_joint, nd.c_ground);
            s.first[j] = nd.first_abs;
            // `Model::build` pushed the pairs of j walking up from its parent: take them in that order.
            let (mut c, mut k) = (j, nd.parent);
            while k != super::GROUND_PARENT {
                s.via[k][j] = c;
                s.pair[k][j] = *pair.next()?;
                (c, k) = (k, nodes[k].parent);
            }
        }
        // One torque per joint (a second one on the same joint takes the general path).
        for (i, jt) in kane.torques.iter().enumerate() {
            if jt.joint >= n || s.torque[jt.joint] != NONE {
                return None;
            }
            s.torque[jt.joint] = i;
        }
        Some(s)
    }
}

impl Model {
    /// [`Kane::rhs`](super::Kane::rhs) by the fixed-size path for `N` speeds (`N = self.n ≤ SMALL`, `self.small`
    /// set; the caller has checked the lengths of `x` and `xdot`).
    ///
    /// NOTE: every local array has the literal length N (not `SMALL`: initialising the larger
    /// ones cost more than the evaluation's arithmetic) and is indexed by literal indices only
    /// (the loops over N unroll), so the compiler keeps M, F and the angles in registers; the
    /// tree's topology enters as tests of constant data (`via`, `torque`, `parent`) instead of
    /// run-time indices, which had put F on the stack and read it back across stores. Out of
    /// line, one function per N, called through `Small::rhs` (measured, BENCHMARKS.md).
    #[inline(never)]
    fn rhs_small<const N: usize>(&self, t: f64, x: &[f64], xdot: &mut [f64]) -> Result<(), EngineError> {
        let s = self.small.as_ref().expect("the fixed-size path is chosen with its data");
        let (q, u) = (&x[..N], &x[N..2 * N]);
        let (qd, ud) = xdot.split_at_mut(N);
        let ud = &mut ud[..N];
        // NOTE: the calls into libm first, so that no value is live (spilled) across them, and
        // the excitation torques before the joints' angles: the excitation's chain (phase, `sin`,
        // F, solve) is the longest of the evaluation (measured, BENCHMARKS.md).
        let mut exc = [0.0; N];
        for (j, exc) in exc.iter_mut().enumerate() {
            if s.torque[j] != NONE {
                *exc = self.torques[s.torque[j]].excitation.torque(t);
            }
        }
        let mut jt = [(1.0, 0.0); N];
        for (j, jt) in jt.iter_mut().enumerate() {
            if !s.own_frame[j] {
                let (sn, cs) = q[j].sin_cos();
                *jt = (cs, sn);
            }
        }
        let mut f = [0.0; N];
        let mut m = [[0.0; N]; N];
        // (cos, sin) of Δ_kj = θ_j − θ_k for every ancestor pair, and (gravity only) of each
        // body's absolute angle.
        let mut rel = [[(1.0, 0.0); N]; N];
        let mut ori = jt;
        for j in 0..N {
            let wj = u[j];
            // A root's parent is past the end of u: its speed reads as zero.
            let qdot = wj - u.get(s.parent[j]).map_or(0.0, |&w| w);
            qd[j] = qdot;
            let tau = -s.k_spring[j] * (q[j] - s.q_free[j]) - s.c_joint[j] * qdot;
            f[j] = tau - s.c_ground[j] * wj;
            m[j][j] = s.diag[j];
            if let Some(g) = s.gravity {
                for k in 0..j {
                    if s.parent[j] == k {
                        ori[j] = compose(ori[k], jt[j]);
                    }
                }
                let (c, sn) = ori[j];
                f[j] += cross2(rotate_cs(c, sn, s.first[j]), g);
            }
            // Ancestors k of j, nearest first (descending index), as `evaluate_absolute` walks them.
            for k in (0..j).rev() {
                let via = s.via[k][j];
                if via == NOT_ANCESTOR {
                    continue;
                }
                let (rc, rs) = if via == j {
                    // k is j's parent: the joint's torque acts +τ on j and −τ on k.
                    f[k] -= tau;
                    jt[j]
                } else {
                    // Δ_kj = q_c + Δ_cj for the child c of k on the path; c is found by
                    // comparison so that every index stays literal.
                    let mut r = (1.0, 0.0);
                    for c in k + 1..j {
                        if c == via {
                            r = compose(jt[c], rel[c][j]);
                        }
                    }
                    r
                };
                rel[k][j] = (rc, rs);
                let (alpha, beta) = s.pair[k][j];
                let v = alpha * rc - beta * rs;
                m[k][j] = v;
                m[j][k] = v;
                let d = alpha * rs + beta * rc;
                f[k] += wj * wj * d;
                f[j] -= u[k] * u[k] * d;
            }
        }
        for j in 0..N {
            if s.torque[j] != NONE {
                f[j] += exc[j];
                for k in 0..j {
                    if s.parent[j] == k {
                        f[k] -= exc[j];
                    }
                }
            }
        }
        self.ldlt_small::<N>(&m, &f, s.diag0_inv, s.pivot_min, ud)
    }

    /// `M x = F` by LDLᵀ on the local arrays of [`Model::rhs_small`]: `Model::factor_solve` with
    /// every sum in the same order (the same results), unrolled. The first pivot is given as
    /// `d0_inv = 1 / M_00` (a constant in the pair form), and checked by the caller; pivots at or
    /// below `pivot_min` stop the solve.
    ///
    /// NOTE: by hand rather than nalgebra's fixed-size Cholesky, for the reasons of
    /// `Model::factor_solve` (no square roots, a failure names the joint) and to keep the general
    /// path's results; Cramer's rule for n = 2 measured no faster (BENCHMARKS.md).
    #[inline(always)]
    pub(super) fn ldlt_small<const N: usize>(
        &self,
        m: &[[f64; N]; N],
        f: &[f64; N],
        d0_inv: f64,
        pivot_min: f64,
        x: &mut [f64],
    ) -> Result<(), EngineError> {
        let mut l = [[0.0; N]; N];
        let mut d_inv = [0.0; N];
        d_inv[0] = d0_inv;
        x[0] = f[0];
        for i in 1..N {
            // a_j = L_ij d_j, then L_ij, d_i and y_i, each sum in `factor_solve`'s order.
            let mut a = [0.0; N];
            for j in 0..i {
                let mut dot = 0.0;
                for k in 0..j {
                    dot += a[k] * l[j][k];
                }
                a[j] = m[i][j] - dot;
            }
            let (mut d, mut y) = (m[i][i], f[i]);
            for j in 0..i {
                let lij = a[j] * d_inv[j];
                l[i][j] = lij;
                d -= a[j] * lij;
                y -= lij * x[j];
            }
            if d.is_nan() || d <= pivot_min {
                return Err(self.pivot_error(i, d));
            }
            d_inv[i] = 1.0 / d;
            x[i] = y;
        }
        for i in 0..N {
            x[i] *= d_inv[i];
        }
        for i in (0..N).rev() {
            for k in 0..i {
                x[k] -= l[i][k] * x[i];
            }
        }
        Ok(())
    }
}
