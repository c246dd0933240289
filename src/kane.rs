//! The numeric Kane engine: `M(q) u̇ = F(q, u, t)` and `ẋ = [W⁻¹u; M⁻¹F]` for any revolute tree.
//!
//! Per evaluation, in tree order (parents first):
//! 1. forward kinematics: body rotations, joint points `o_k`, centres of mass `r_j`;
//! 2. speeds: `q̇ = W⁻¹u`, absolute angular velocities ω_j;
//! 3. bias accelerations at `u̇ = 0`: with W constant, `q̈ = 0`, every angular acceleration is zero
//!    and each point only has its centripetal terms, `a(o_child) = a(o_parent) − ω_parent²(o_child −
//!    o_parent)`, `a⁰_j = a(o_j) − ω_j²(r_j − o_j)`;
//! 4. Kane's partial velocities of body j: for each joint k on its path, `∂ω_j/∂q̇_k = 1`,
//!    `∂v_j/∂q̇_k = ẑ × (r_j − o_k)`, mapped to the speeds by W⁻¹ (a 3×d Jacobian, d = depth);
//! 5. `M_rs = Σ_j m_j v_{j,r}·v_{j,s} + I_j ω_{j,r} ω_{j,s}`,
//!    `F_r = Σ_j (F_j − m_j a⁰_j)·v_{j,r} + T_j ω_{j,r}` plus the joint torques `τ_k ∂q̇_k/∂u_r`.
//!
//! Every vector is expressed in one basis per subtree. When no load needs the world orientation
//! (no gravity, no world-frame force), that basis is the root body's own frame: the root angle is
//! cyclic, so its sine and cosine are never computed (one `sin_cos` fewer per call for a rotor,
//! and no loss of precision when the spin angle grows to 10⁴ rad in a long sweep). Dot products,
//! hence M and F, do not depend on the basis.
//!
//! All work buffers are sized in [`Kane::new`]; evaluating does no heap allocation.

use crate::error::{EngineError, Error, Result};
use crate::excitation::Excitation;
use crate::loads::{ForceFrame, JointTorque};
use crate::math::{Vec2, cross2, perp, rotate_cs};
use crate::mechanism::Mechanism;
use crate::speeds::Speeds;
use nalgebra::{DMatrix, DVector};

/// Relative size (to the largest diagonal entry of M) below which a Cholesky pivot counts as zero.
const PIVOT_TOL: f64 = 1e-12;

/// The equation-of-motion evaluator of one mechanism, with its work buffers.
#[derive(Debug, Clone)]
pub struct Kane {
    mech: Mechanism,
    n: usize,
    parent: Vec<Option<usize>>,
    speeds: Speeds,
    world: bool,
    // Constants per body / joint.
    mass: Vec<f64>,
    i_com: Vec<f64>,
    com_local: Vec<Vec2>,
    at: Vec<Vec2>,
    k_spring: Vec<f64>,
    q_free: Vec<f64>,
    c_joint: Vec<f64>,
    c_ground: Vec<f64>,
    path_start: Vec<usize>,
    path: Vec<usize>,
    torques: Vec<JointTorque>,
    // Work buffers.
    cs: Vec<(f64, f64)>,
    origin: Vec<Vec2>,
    com: Vec<Vec2>,
    omega: Vec<f64>,
    acc_o: Vec<Vec2>,
    acc_c: Vec<Vec2>,
    qdot: Vec<f64>,
    force: Vec<Vec2>,
    torque: Vec<f64>,
    tau: Vec<f64>,
    jv: Vec<Vec2>,
    jw: Vec<f64>,
    m: Vec<f64>,
    f: Vec<f64>,
    l: Vec<f64>,
    m_out: DMatrix<f64>,
    f_out: DVector<f64>,
}

impl Kane {
    /// Builds the evaluator and checks that M is positive definite at q = 0.
    pub fn new(mech: &Mechanism) -> Result<Self> {
        Self::build(mech, mech.loads.needs_world_orientation())
    }

    /// Like [`Kane::new`], but always expresses vectors in the world frame (every angle's
    /// trigonometry is evaluated). Results are identical up to rounding; for tests and for
    /// world-frame outputs.
    pub fn new_world_frame(mech: &Mechanism) -> Result<Self> {
        Self::build(mech, true)
    }

    fn build(mech: &Mechanism, world: bool) -> Result<Self> {
        let n = mech.ndof();
        let parent = mech.parents();
        for (j, p) in parent.iter().enumerate() {
            if p.is_some_and(|p| p >= j) {
                return Err(Error::Model {
                    mechanism: mech.name.clone(),
                    message: format!("internal: joint `{}` is listed before its parent", mech.joints[j].name),
                });
            }
        }
        let mut path_start = Vec::with_capacity(n + 1);
        let mut path = Vec::new();
        let mut depth = 0;
        for j in 0..n {
            path_start.push(path.len());
            let p = mech.path_to(j);
            depth = depth.max(p.len());
            path.extend(p);
        }
        path_start.push(path.len());
        let mut c_ground = vec![0.0; n];
        for g in &mech.loads.ground_dampers {
            c_ground[g.body] += g.c;
        }
        let mut k = Kane {
            mech: mech.clone(),
            n,
            speeds: mech.speeds,
            world,
            mass: mech.bodies.iter().map(|b| b.inertia.mass).collect(),
            i_com: mech.bodies.iter().map(|b| b.inertia.i_com).collect(),
            com_local: mech.bodies.iter().map(|b| b.inertia.com).collect(),
            at: mech.joints.iter().map(|j| j.at).collect(),
            k_spring: mech.joints.iter().map(|j| j.spring.map_or(0.0, |s| s.stiffness)).collect(),
            q_free: mech.joints.iter().map(|j| j.spring.map_or(0.0, |s| s.free_angle)).collect(),
            c_joint: mech.joints.iter().map(|j| j.damper).collect(),
            c_ground,
            path_start,
            path,
            torques: mech.loads.joint_torques.clone(),
            cs: vec![(1.0, 0.0); n],
            origin: vec![Vec2::zeros(); n],
            com: vec![Vec2::zeros(); n],
            omega: vec![0.0; n],
            acc_o: vec![Vec2::zeros(); n],
            acc_c: vec![Vec2::zeros(); n],
            qdot: vec![0.0; n],
            force: vec![Vec2::zeros(); n],
            torque: vec![0.0; n],
            tau: vec![0.0; n],
            jv: vec![Vec2::zeros(); depth],
            jw: vec![0.0; depth],
            m: vec![0.0; n * n],
            f: vec![0.0; n],
            l: vec![0.0; n * n],
            m_out: DMatrix::zeros(n, n),
            f_out: DVector::zeros(n),
            parent,
        };
        let q0 = vec![0.0; n];
        k.positions(&q0);
        k.accumulate(false);
        k.factor()?;
        Ok(k)
    }

    /// The mechanism this evaluator was built from.
    pub fn mechanism(&self) -> &Mechanism {
        &self.mech
    }

    /// Number of degrees of freedom n (the state has 2n entries, `[q; u]`).
    pub fn ndof(&self) -> usize {
        self.n
    }

    /// Replaces the applied torque of joint `joint` (index) by `excitation` (adds one if the joint
    /// had none). Springs and dampers are not affected.
    pub fn set_joint_torque(&mut self, joint: usize, excitation: Excitation) {
        match self.torques.iter_mut().find(|t| t.joint == joint) {
            Some(t) => t.excitation = excitation,
            None => self.torques.push(JointTorque { joint, excitation }),
        }
    }

    /// The applied joint torques currently in effect.
    pub fn joint_torques(&self) -> &[JointTorque] {
        &self.torques
    }

    /// The mass matrix M(q) (kg·m² for rotational speeds), symmetric positive definite.
    pub fn mass_matrix(&mut self, q: &[f64]) -> &DMatrix<f64> {
        self.positions(q);
        self.accumulate(false);
        self.copy_out();
        &self.m_out
    }

    /// The forcing vector F(q, u, t) of `M u̇ = F` (N·m for rotational speeds): applied forces
    /// minus the inertia forces at `u̇ = 0`.
    pub fn forcing(&mut self, t: f64, q: &[f64], u: &[f64]) -> &DVector<f64> {
        self.evaluate(t, q, u);
        self.copy_out();
        &self.f_out
    }

    /// Both M and F at one state.
    pub fn mass_matrix_and_forcing(&mut self, t: f64, q: &[f64], u: &[f64]) -> (&DMatrix<f64>, &DVector<f64>) {
        self.evaluate(t, q, u);
        self.copy_out();
        (&self.m_out, &self.f_out)
    }

    /// `q̇ = W⁻¹ u` (rad/s).
    pub fn qdot(&mut self, u: &[f64]) -> &[f64] {
        self.speeds.qdot(&self.parent, u, &mut self.qdot);
        &self.qdot
    }

    /// The state derivative `ẋ = [W⁻¹u; M⁻¹F]` for `x = [q; u]`. No heap allocation.
    pub fn rhs(&mut self, t: f64, x: &[f64], xdot: &mut [f64]) -> Result<(), EngineError> {
        let n = self.n;
        if x.len() != 2 * n || xdot.len() != 2 * n {
            let (what, got) = if x.len() != 2 * n { ("state x", x.len()) } else { ("derivative ẋ", xdot.len()) };
            return Err(EngineError::Dimension { what, got, expected: 2 * n });
        }
        let (q, u) = x.split_at(n);
        self.evaluate(t, q, u);
        self.factor()?;
        let (qd, ud) = xdot.split_at_mut(n);
        qd.copy_from_slice(&self.qdot);
        ud.copy_from_slice(&self.f);
        self.solve(ud);
        Ok(())
    }

    /// Full evaluation of M, F and q̇ into the work buffers.
    fn evaluate(&mut self, t: f64, q: &[f64], u: &[f64]) {
        self.positions(q);
        self.rates_and_bias(u);
        self.applied(t, q);
        self.accumulate(true);
    }

    /// Step 1: rotations, joint points and centres of mass.
    #[inline]
    fn positions(&mut self, q: &[f64]) {
        for j in 0..self.n {
            match self.parent[j] {
                None => {
                    self.cs[j] = if self.world {
                        let (s, c) = q[j].sin_cos();
                        (c, s)
                    } else {
                        (1.0, 0.0)
                    };
                    self.origin[j] = self.at[j];
                }
                Some(p) => {
                    let (s, c) = q[j].sin_cos();
                    let (cp, sp) = self.cs[p];
                    self.cs[j] = (cp * c - sp * s, sp * c + cp * s);
                    self.origin[j] = self.origin[p] + rotate_cs(cp, sp, self.at[j]);
                }
            }
            let (c, s) = self.cs[j];
            self.com[j] = self.origin[j] + rotate_cs(c, s, self.com_local[j]);
        }
    }

    /// Steps 2 and 3: joint rates, angular velocities and centripetal bias accelerations.
    #[inline]
    fn rates_and_bias(&mut self, u: &[f64]) {
        self.speeds.qdot(&self.parent, u, &mut self.qdot);
        for j in 0..self.n {
            match self.parent[j] {
                None => {
                    self.omega[j] = self.qdot[j];
                    self.acc_o[j] = Vec2::zeros();
                }
                Some(p) => {
                    self.omega[j] = self.omega[p] + self.qdot[j];
                    let wp = self.omega[p];
                    self.acc_o[j] = self.acc_o[p] - wp * wp * (self.origin[j] - self.origin[p]);
                }
            }
            let w = self.omega[j];
            self.acc_c[j] = self.acc_o[j] - w * w * (self.com[j] - self.origin[j]);
        }
    }

    /// Applied loads: joint torques τ (springs, dampers, excitations), body forces and torques.
    #[inline]
    fn applied(&mut self, t: f64, q: &[f64]) {
        for k in 0..self.n {
            self.tau[k] = -self.k_spring[k] * (q[k] - self.q_free[k]) - self.c_joint[k] * self.qdot[k];
        }
        for jt in &self.torques {
            self.tau[jt.joint] += jt.excitation.torque(t);
        }
        let g = self.mech.loads.gravity;
        for j in 0..self.n {
            self.force[j] = self.mass[j] * g;
            self.torque[j] = -self.c_ground[j] * self.omega[j];
        }
        for pf in &self.mech.loads.point_forces {
            let b = pf.body;
            let (c, s) = self.cs[b];
            let f = match pf.frame {
                ForceFrame::World => pf.force,
                ForceFrame::Body => rotate_cs(c, s, pf.force),
            };
            let p = self.origin[b] + rotate_cs(c, s, pf.at);
            self.force[b] += f;
            self.torque[b] += cross2(p - self.com[b], f);
        }
    }

    /// Steps 4 and 5: partial velocities per body, then M (and F when `forcing`).
    #[inline]
    fn accumulate(&mut self, forcing: bool) {
        let n = self.n;
        self.m.iter_mut().for_each(|x| *x = 0.0);
        if forcing {
            // A joint torque's generalized force is τ_k ∂q̇_k/∂u_r.
            self.f.copy_from_slice(&self.tau);
            if self.speeds == Speeds::AbsoluteAngularVelocities {
                for k in 0..n {
                    if let Some(p) = self.parent[k] {
                        self.f[p] -= self.tau[k];
                    }
                }
            }
        }
        let absolute = self.speeds == Speeds::AbsoluteAngularVelocities;
        for j in 0..n {
            let path = &self.path[self.path_start[j]..self.path_start[j + 1]];
            let d = path.len();
            let r = self.com[j];
            for (a, &k) in path.iter().enumerate() {
                self.jv[a] = perp(r - self.origin[k]);
                self.jw[a] = 1.0;
            }
            if absolute {
                // ∂q̇_k/∂u = e_k − e_parent(k): the column of u_k is the joint-rate column of k
                // minus that of the next joint on the path, i.e. ẑ × (o_next − o_k), and only
                // the body's own speed turns it.
                for a in 0..d - 1 {
                    let next = self.jv[a + 1];
                    self.jv[a] -= next;
                    self.jw[a] = 0.0;
                }
            }
            let (m, i) = (self.mass[j], self.i_com[j]);
            for a in 0..d {
                let ra = path[a];
                let (va, wa) = (self.jv[a], self.jw[a]);
                for b in a..d {
                    self.m[ra * n + path[b]] += m * va.dot(&self.jv[b]) + i * wa * self.jw[b];
                }
            }
            if forcing {
                let fi = self.force[j] - m * self.acc_c[j];
                let ti = self.torque[j];
                for a in 0..d {
                    self.f[path[a]] += fi.dot(&self.jv[a]) + ti * self.jw[a];
                }
            }
        }
        // The loops above fill the upper triangle (path indices increase from the root).
        for r in 0..n {
            for s in 0..r {
                self.m[r * n + s] = self.m[s * n + r];
            }
        }
    }

    /// Cholesky factor L Lᵀ = M into `l` (row-major lower triangle).
    ///
    /// NOTE: written here rather than calling nalgebra's `Cholesky` so the factorisation works in
    /// place on the preallocated buffer (no allocation per call) and a failure names the speed
    /// (joint) whose pivot vanished; for n = 2 it is also a few ns faster.
    fn factor(&mut self) -> Result<(), EngineError> {
        let n = self.n;
        let scale = (0..n).map(|i| self.m[i * n + i].abs()).fold(0.0, f64::max);
        for j in 0..n {
            let mut d = self.m[j * n + j];
            for k in 0..j {
                d -= self.l[j * n + k] * self.l[j * n + k];
            }
            if d.is_nan() {
                return Err(EngineError::NonFinite { what: "mass matrix", index: j });
            }
            if d <= PIVOT_TOL * scale || d <= 0.0 {
                return Err(EngineError::NotPositiveDefinite {
                    dof: j,
                    joint: self.mech.joints[j].name.clone(),
                    pivot: d,
                });
            }
            let ljj = d.sqrt();
            self.l[j * n + j] = ljj;
            for i in j + 1..n {
                let mut s = self.m[i * n + j];
                for k in 0..j {
                    s -= self.l[i * n + k] * self.l[j * n + k];
                }
                self.l[i * n + j] = s / ljj;
            }
        }
        Ok(())
    }

    /// Solves `L Lᵀ x = b` in place.
    fn solve(&self, b: &mut [f64]) {
        let n = self.n;
        for i in 0..n {
            let mut s = b[i];
            for k in 0..i {
                s -= self.l[i * n + k] * b[k];
            }
            b[i] = s / self.l[i * n + i];
        }
        for i in (0..n).rev() {
            let mut s = b[i];
            for k in i + 1..n {
                s -= self.l[k * n + i] * b[k];
            }
            b[i] = s / self.l[i * n + i];
        }
    }

    fn copy_out(&mut self) {
        let n = self.n;
        for r in 0..n {
            for c in 0..n {
                self.m_out[(r, c)] = self.m[r * n + c];
            }
            self.f_out[r] = self.f[r];
        }
    }

    /// Kane's partial velocities of body `j` at `q`, in the evaluator's basis (world frame for an
    /// evaluator from [`Kane::new_world_frame`]): `(v_{j,r}, ω_{j,r})` for r = 0..n. Allocates;
    /// for tests and reports.
    pub fn partial_velocities(&mut self, q: &[f64], j: usize) -> (Vec<Vec2>, Vec<f64>) {
        self.positions(q);
        let mut v = vec![Vec2::zeros(); self.n];
        let mut w = vec![0.0; self.n];
        let path = self.mech.path_to(j);
        let d = path.len();
        let mut jv: Vec<Vec2> = path.iter().map(|&k| perp(self.com[j] - self.origin[k])).collect();
        let mut jw = vec![1.0; d];
        if self.speeds == Speeds::AbsoluteAngularVelocities {
            for a in 0..d - 1 {
                let next = jv[a + 1];
                jv[a] -= next;
                jw[a] = 0.0;
            }
        }
        for (a, &k) in path.iter().enumerate() {
            v[k] = jv[a];
            w[k] = jw[a];
        }
        (v, w)
    }
}
