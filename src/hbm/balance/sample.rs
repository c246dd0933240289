//! The per-sample evaluator of the harmonic balance (sections "Residual" and "Jacobian" of the
//! room's docs): Kane's equations as the residual
//! `R(t) = M(q) W q̈ − F(q, W q̇, t) − g·T(t)` at one time sample, and its derivatives
//! `A = ∂R/∂q`, `B = ∂R/∂q̇` (central differences of the engine, the spin angle's column of A
//! zero as the angle is cyclic; or one call of the engine's closed-form residual Jacobian where it
//! has one) and `C = ∂R/∂q̈ = M W`.

use crate::kane::Kane;
use crate::model::speeds::Speeds;

/// The step of one-sided differences ([`Evaluator::one_sided`]): rad for angles, relative (times
/// max(1, |q̇|)) for rates; near √ε, where truncation and rounding errors balance.
const ONE_SIDED_STEP: f64 = 1e-7;

/// The engine wrapped to evaluate `R = M W q̈ − F(q, W q̇) − g T` and its per-sample derivatives.
#[derive(Debug, Clone)]
pub(in crate::hbm) struct Evaluator {
    kane: Kane,
    n: usize,
    pub(in crate::hbm) speeds: Speeds,
    pub(in crate::hbm) parents: Vec<Option<usize>>,
    /// W, row-major.
    pub(in crate::hbm) w: Vec<f64>,
    /// W's non-zeros row by row, `(k, W_jk)` for row j: `M W` and `∂R/∂u W` skip W's zeros
    /// (most of it on a tree: the absolute speeds' W has 2n − 1 non-zeros), which summed
    /// in the same order gives the same numbers; n³ per sample was 7 % of a 16-pendulum branch.
    w_rows: Vec<Vec<(usize, f64)>>,
    /// Generalized force (in speeds) of a unit torque in the spin joint.
    pub(in crate::hbm) g: Vec<f64>,
    u: Vec<f64>,
    ud: Vec<f64>,
    rp: Vec<f64>,
    rm: Vec<f64>,
    /// ∂R/∂u and M (row-major) from the engine's closed-form derivatives.
    dr_du: Vec<f64>,
    mass: Vec<f64>,
    /// Difference the derivatives one-sidedly (1 + n evaluations per sample instead of
    /// 1 + 2(n − 1) + 2n, about 1e-8 relative instead of 1e-11): for the Jacobians of a branch
    /// whose points are only starting guesses, where they steer Newton's method and the steps but
    /// decide no reported number.
    pub(in crate::hbm) one_sided: bool,
}

/// Per-sample linearisation: R, and row-major `A = ∂R/∂q`, `B = ∂R/∂q̇`, `C = ∂R/∂q̈`.
#[derive(Debug, Clone)]
pub(in crate::hbm) struct SampleLin {
    /// R, n entries.
    pub(in crate::hbm) r: Vec<f64>,
    /// ∂R/∂q, n × n.
    pub(in crate::hbm) a: Vec<f64>,
    /// ∂R/∂q̇, n × n.
    pub(in crate::hbm) b: Vec<f64>,
    /// ∂R/∂q̈ = M W, n × n.
    pub(in crate::hbm) c: Vec<f64>,
}

impl SampleLin {
    /// Zeroed buffers for n coordinates.
    pub(in crate::hbm) fn new(n: usize) -> Self {
        Self { r: vec![0.0; n], a: vec![0.0; n * n], b: vec![0.0; n * n], c: vec![0.0; n * n] }
    }
}

impl Evaluator {
    /// The evaluator of `kane`'s mechanism (its spin torque already removed) with `speeds`, the
    /// joints' `parents`, W (row-major) and the generalized force `g` of a unit spin torque.
    pub(in crate::hbm) fn new(
        kane: Kane,
        speeds: Speeds,
        parents: Vec<Option<usize>>,
        w: Vec<f64>,
        g: Vec<f64>,
    ) -> Self {
        let n = kane.ndof();
        let w_rows =
            (0..n).map(|j| (0..n).filter(|&k| w[j * n + k] != 0.0).map(|k| (k, w[j * n + k])).collect()).collect();
        Self {
            w_rows,
            kane,
            n,
            speeds,
            parents,
            w,
            g,
            u: vec![0.0; n],
            ud: vec![0.0; n],
            rp: vec![0.0; n],
            rm: vec![0.0; n],
            dr_du: vec![0.0; n * n],
            mass: vec![0.0; n * n],
            one_sided: false,
        }
    }

    /// R at one sample; writes `M W` into `mw` when given.
    #[allow(clippy::too_many_arguments)]
    pub(in crate::hbm) fn residual(
        &mut self,
        t: f64,
        q: &[f64],
        qd: &[f64],
        qdd: &[f64],
        torque: f64,
        r: &mut [f64],
        mw: Option<&mut [f64]>,
    ) {
        let n = self.n;
        self.speeds.u_from_qdot(&self.parents, qd, &mut self.u);
        self.speeds.u_from_qdot(&self.parents, qdd, &mut self.ud);
        let (m, f) = self.kane.mass_matrix_and_forcing_rows(t, q, &self.u);
        for i in 0..n {
            let mut s = -f[i] - self.g[i] * torque;
            for j in 0..n {
                s += m[i * n + j] * self.ud[j];
            }
            r[i] = s;
        }
        if let Some(mw) = mw {
            for i in 0..n {
                for k in 0..n {
                    let mut s = 0.0;
                    for j in 0..n {
                        s += m[i * n + j] * self.w[j * n + k];
                    }
                    mw[i * n + k] = s;
                }
            }
        }
    }

    /// R, A, B, C at one sample by central differences (q and q̇ are restored on return). When
    /// the spin angle is `cyclic` its column of A is zero and not differenced.
    #[allow(clippy::too_many_arguments)]
    pub(in crate::hbm) fn linearize(
        &mut self,
        t: f64,
        q: &mut [f64],
        qd: &mut [f64],
        qdd: &[f64],
        torque: f64,
        spin: usize,
        cyclic: bool,
        h: f64,
        lin: &mut SampleLin,
    ) {
        let n = self.n;
        // Closed-form derivatives where the engine has them (absolute speeds, no gravity or
        // point forces): one evaluation instead of 1 + 2(n − 1) + 2n (fewer instructions for a
        // whole CPVA branch, see `BENCHMARKS.md`).
        if self.kane.has_residual_jacobian() {
            self.speeds.u_from_qdot(&self.parents, qd, &mut self.u);
            self.speeds.u_from_qdot(&self.parents, qdd, &mut self.ud);
            let (du, m) = (&mut self.dr_du, &mut self.mass);
            self.kane.residual_jacobian(t, q, &self.u, &self.ud, &mut lin.r, &mut lin.a, du, m);
            for i in 0..n {
                lin.r[i] -= self.g[i] * torque;
                if cyclic {
                    lin.a[i * n + spin] = 0.0;
                }
                let (b, c) = (&mut lin.b[i * n..(i + 1) * n], &mut lin.c[i * n..(i + 1) * n]);
                b.fill(0.0);
                c.fill(0.0);
                for (j, row) in self.w_rows.iter().enumerate() {
                    let (dij, mij) = (du[i * n + j], m[i * n + j]);
                    for &(k, wjk) in row {
                        b[k] += dij * wjk;
                        c[k] += mij * wjk;
                    }
                }
            }
            return;
        }
        let (mut rp, mut rm) = (std::mem::take(&mut self.rp), std::mem::take(&mut self.rm));
        self.residual(t, q, qd, qdd, torque, &mut lin.r, Some(&mut lin.c));
        for k in 0..n {
            if k == spin && cyclic {
                for i in 0..n {
                    lin.a[i * n + k] = 0.0;
                }
                continue;
            }
            let q0 = q[k];
            if self.one_sided {
                q[k] = q0 + ONE_SIDED_STEP;
                self.residual(t, q, qd, qdd, torque, &mut rp, None);
                q[k] = q0;
                for i in 0..n {
                    lin.a[i * n + k] = (rp[i] - lin.r[i]) / ONE_SIDED_STEP;
                }
                continue;
            }
            q[k] = q0 + h;
            self.residual(t, q, qd, qdd, torque, &mut rp, None);
            q[k] = q0 - h;
            self.residual(t, q, qd, qdd, torque, &mut rm, None);
            q[k] = q0;
            for i in 0..n {
                lin.a[i * n + k] = (rp[i] - rm[i]) / (2.0 * h);
            }
        }
        for k in 0..n {
            let v0 = qd[k];
            if self.one_sided {
                let hv = ONE_SIDED_STEP * v0.abs().max(1.0);
                qd[k] = v0 + hv;
                self.residual(t, q, qd, qdd, torque, &mut rp, None);
                qd[k] = v0;
                for i in 0..n {
                    lin.b[i * n + k] = (rp[i] - lin.r[i]) / hv;
                }
                continue;
            }
            let hv = h * v0.abs().max(1.0);
            qd[k] = v0 + hv;
            self.residual(t, q, qd, qdd, torque, &mut rp, None);
            qd[k] = v0 - hv;
            self.residual(t, q, qd, qdd, torque, &mut rm, None);
            qd[k] = v0;
            for i in 0..n {
                lin.b[i * n + k] = (rp[i] - rm[i]) / (2.0 * hv);
            }
        }
        self.rp = rp;
        self.rm = rm;
    }
}
