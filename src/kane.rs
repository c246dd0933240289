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
use crate::loads::{ForceFrame, JointTorque, PointForce};
use crate::math::{Vec2, cross2, perp, rotate_cs};
use crate::mechanism::Mechanism;
use crate::speeds::Speeds;
use nalgebra::{DMatrix, DVector};

/// Relative size (to the largest diagonal entry of M) below which a Cholesky pivot counts as zero.
const PIVOT_TOL: f64 = 1e-12;

/// Parent index of a root body (hangs from ground).
const GROUND_PARENT: usize = usize::MAX;

/// Constant data of one body and its inboard joint, packed so the hot loop touches one record.
#[derive(Debug, Clone, Copy)]
struct Node {
    parent: usize,
    mass: f64,
    i_com: f64,
    com_local: Vec2,
    at: Vec2,
    k_spring: f64,
    q_free: f64,
    c_joint: f64,
    c_ground: f64,
    forces: (usize, usize),
}

/// Composite sums of a subtree about its root joint's point o: mass, first moment S = Σ m (r − o),
/// inertia J = Σ I + m |r − o|², resultant force and moment about o (applied minus inertial).
#[derive(Debug, Clone, Copy, Default)]
struct Composite {
    mass: f64,
    first: Vec2,
    inertia: f64,
    force: Vec2,
    moment: f64,
}

/// Per-evaluation kinematic state of one body (in the subtree's basis).
#[derive(Debug, Clone, Copy, Default)]
struct Frame {
    c: f64,
    s: f64,
    origin: Vec2,
    com: Vec2,
    omega: f64,
    acc_o: Vec2,
}

/// The equation-of-motion evaluator of one mechanism, with its work buffers.
#[derive(Debug, Clone)]
pub struct Kane {
    mech: Mechanism,
    n: usize,
    parent: Vec<Option<usize>>,
    speeds: Speeds,
    absolute: bool,
    world: bool,
    gravity: Vec2,
    nodes: Vec<Node>,
    point_forces: Vec<PointForce>,
    torques: Vec<JointTorque>,
    // Work buffers.
    frames: Vec<Frame>,
    comp: Vec<Composite>,
    qdot: Vec<f64>,
    tau: Vec<f64>,
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
        let mut c_ground = vec![0.0; n];
        for g in &mech.loads.ground_dampers {
            c_ground[g.body] += g.c;
        }
        // Point forces grouped by body so each body's iteration finds its own.
        let mut point_forces = mech.loads.point_forces.clone();
        point_forces.sort_by_key(|p| p.body);
        let mut nodes = Vec::with_capacity(n);
        for j in 0..n {
            let f0 = point_forces.iter().position(|p| p.body == j).unwrap_or(0);
            let f1 = f0 + point_forces.iter().filter(|p| p.body == j).count();
            let (b, jt) = (&mech.bodies[j], &mech.joints[j]);
            nodes.push(Node {
                parent: jt.parent.unwrap_or(GROUND_PARENT),
                mass: b.inertia.mass,
                i_com: b.inertia.i_com,
                com_local: b.inertia.com,
                at: jt.at,
                k_spring: jt.spring.map_or(0.0, |s| s.stiffness),
                q_free: jt.spring.map_or(0.0, |s| s.free_angle),
                c_joint: jt.damper,
                c_ground: c_ground[j],
                forces: (f0, f1),
            });
        }
        let mut k = Kane {
            mech: mech.clone(),
            n,
            speeds: mech.speeds,
            absolute: mech.speeds == Speeds::AbsoluteAngularVelocities,
            world,
            gravity: mech.loads.gravity,
            nodes,
            point_forces,
            torques: mech.loads.joint_torques.clone(),
            frames: vec![Frame::default(); n],
            comp: vec![Composite::default(); n],
            qdot: vec![0.0; n],
            tau: vec![0.0; n],
            m: vec![0.0; n * n],
            f: vec![0.0; n],
            l: vec![0.0; n * n],
            m_out: DMatrix::zeros(n, n),
            f_out: DVector::zeros(n),
            parent,
        };
        let zeros = vec![0.0; n];
        k.evaluate(0.0, &zeros, &zeros, false);
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
        // Without forcing, `u` and `t` are not read.
        self.evaluate(0.0, q, q, false);
        self.copy_out();
        &self.m_out
    }

    /// The forcing vector F(q, u, t) of `M u̇ = F` (N·m for rotational speeds): applied forces
    /// minus the inertia forces at `u̇ = 0`.
    pub fn forcing(&mut self, t: f64, q: &[f64], u: &[f64]) -> &DVector<f64> {
        self.evaluate(t, q, u, true);
        self.copy_out();
        &self.f_out
    }

    /// Both M and F at one state.
    pub fn mass_matrix_and_forcing(&mut self, t: f64, q: &[f64], u: &[f64]) -> (&DMatrix<f64>, &DVector<f64>) {
        self.evaluate(t, q, u, true);
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
        self.evaluate(t, q, u, true);
        self.factor()?;
        let (qd, ud) = xdot.split_at_mut(n);
        qd.copy_from_slice(&self.qdot);
        ud.copy_from_slice(&self.f);
        self.solve(ud);
        Ok(())
    }

    /// Evaluates M (and F, q̇ when `forcing`; only then are `u` and `t` read) into the buffers.
    ///
    /// Kane's sums `M_rs = Σ_j m_j v_{j,r}·v_{j,s} + I_j ω_{j,r} ω_{j,s}` and
    /// `F_r = Σ_j f_j·v_{j,r} + T_j ω_{j,r}` are first formed for the joint rates, where
    /// `v_{j,k} = ẑ × (r_j − o_k)` and `ω_{j,k} = 1` for every body j below joint k. Grouping the
    /// bodies by subtree turns them into composite sums:
    /// `M_kl = Σ_{j below k} I_j + m_j (r_j − o_k)·(r_j − o_l) = J_k + S_k·(o_k − o_l)` for l on the
    /// path to k (J_k: the subtree's inertia about o_k; S_k: its first moment about o_k), and
    /// `F_k = Σ_{j below k} (r_j − o_k) × f_j + T_j` (the subtree's moment about o_k). One backward
    /// pass accumulates J, S and the moments child → parent, so the cost is O(n·depth) instead of
    /// O(Σ depth²), and for the CPVA it is a handful of flops. The speeds' `W⁻¹` is applied last:
    /// `M_u = W⁻ᵀ M_q̇ W⁻¹`, `F_u = W⁻ᵀ F_q̇`. `partial_velocities` exposes the per-body v_{j,r}
    /// and the tests rebuild M and F from them body by body.
    fn evaluate(&mut self, t: f64, q: &[f64], u: &[f64], forcing: bool) {
        // NOTE: a literal n per arm lets the compiler unroll the loops and drop most bounds checks
        // for the small mechanisms that dominate torsional work (measured: the CPVA's rhs went
        // from ~1300 to ~… instructions per call; see BENCHMARKS.md).
        match self.n {
            1 => self.evaluate_n::<1>(t, q, u, forcing),
            2 => self.evaluate_n::<2>(t, q, u, forcing),
            3 => self.evaluate_n::<3>(t, q, u, forcing),
            4 => self.evaluate_n::<4>(t, q, u, forcing),
            5 => self.evaluate_n::<5>(t, q, u, forcing),
            6 => self.evaluate_n::<6>(t, q, u, forcing),
            _ => self.evaluate_n::<0>(t, q, u, forcing),
        }
    }

    /// The body of [`Kane::evaluate`] for `N` degrees of freedom (`N = 0`: any, read at run time).
    #[inline(always)]
    fn evaluate_n<const N: usize>(&mut self, t: f64, q: &[f64], u: &[f64], forcing: bool) {
        let n = if N == 0 { self.n } else { N };
        let (q, u) = (&q[..n], &u[..n]);
        let (absolute, world, g) = (self.absolute, self.world, self.gravity);
        let nodes = &self.nodes[..n];
        let frames = &mut self.frames[..n];
        let comp = &mut self.comp[..n];
        let m = &mut self.m[..n * n];
        let f = &mut self.f[..n];
        let qdot = &mut self.qdot[..n];
        let tau = &mut self.tau[..n];
        if forcing {
            tau.iter_mut().for_each(|x| *x = 0.0);
            for jt in &self.torques {
                tau[jt.joint] += jt.excitation.torque(t);
            }
        }
        // Forward pass, parents first: poses, rates, centripetal bias accelerations (q̈ = 0 at
        // u̇ = 0), and each body's own contribution to its composite sums about its origin o_j.
        for j in 0..n {
            let nd = &nodes[j];
            let root = nd.parent == GROUND_PARENT;
            let mut fr = if root {
                let (s, c) = if world { q[j].sin_cos() } else { (0.0, 1.0) };
                Frame { c, s, origin: nd.at, ..Frame::default() }
            } else {
                let p = &frames[nd.parent];
                let (s, c) = q[j].sin_cos();
                Frame {
                    c: p.c * c - p.s * s,
                    s: p.s * c + p.c * s,
                    origin: p.origin + rotate_cs(p.c, p.s, nd.at),
                    ..Frame::default()
                }
            };
            let arm = rotate_cs(fr.c, fr.s, nd.com_local);
            let mut cj = Composite {
                mass: nd.mass,
                first: nd.mass * arm,
                inertia: nd.i_com + nd.mass * arm.norm_squared(),
                force: Vec2::zeros(),
                moment: 0.0,
            };
            if forcing {
                let (w_p, acc_p, o_p) = if root {
                    (0.0, Vec2::zeros(), fr.origin)
                } else {
                    let p = &frames[nd.parent];
                    (p.omega, p.acc_o, p.origin)
                };
                let qd = if absolute && !root { u[j] - u[nd.parent] } else { u[j] };
                qdot[j] = qd;
                fr.omega = w_p + qd;
                fr.acc_o = acc_p - w_p * w_p * (fr.origin - o_p);
                let acc_c = fr.acc_o - fr.omega * fr.omega * arm;
                // Applied force at the centre of mass minus the inertia force m a⁰, and torque.
                let fi = nd.mass * (g - acc_c);
                let mut ti = -nd.c_ground * fr.omega;
                let mut fsum = fi;
                let mut moment = cross2(arm, fi);
                for pfc in &self.point_forces[nd.forces.0..nd.forces.1] {
                    let force = match pfc.frame {
                        ForceFrame::World => pfc.force,
                        ForceFrame::Body => rotate_cs(fr.c, fr.s, pfc.force),
                    };
                    fsum += force;
                    moment += cross2(rotate_cs(fr.c, fr.s, pfc.at), force);
                }
                ti += moment;
                cj.force = fsum;
                cj.moment = ti;
                // Joint torque (spring, damper, excitation): +τ on the child, −τ on the parent;
                // in joint rates its generalized force is τ on its own coordinate.
                tau[j] += -nd.k_spring * (q[j] - nd.q_free) - nd.c_joint * qd;
            }
            fr.com = fr.origin + arm;
            frames[j] = fr;
            comp[j] = cj;
        }
        // Backward pass, children first: composite sums, rows of M and entries of F (joint rates).
        m.iter_mut().for_each(|x| *x = 0.0);
        for j in (0..n).rev() {
            let c = comp[j];
            let oj = frames[j].origin;
            m[j * n + j] = c.inertia;
            let mut l = nodes[j].parent;
            while l != GROUND_PARENT {
                let v = c.inertia + c.first.dot(&(oj - frames[l].origin));
                m[j * n + l] = v;
                m[l * n + j] = v;
                l = nodes[l].parent;
            }
            if forcing {
                f[j] = c.moment + tau[j];
            }
            let p = nodes[j].parent;
            if p != GROUND_PARENT {
                let d = oj - frames[p].origin;
                let cp = &mut comp[p];
                cp.inertia += c.inertia + 2.0 * d.dot(&c.first) + c.mass * d.norm_squared();
                cp.first += c.first + c.mass * d;
                cp.mass += c.mass;
                cp.moment += c.moment + cross2(d, c.force);
                cp.force += c.force;
            }
        }
        if absolute {
            // W⁻¹ has +1 at (k, k) and −1 at (k, parent(k)). Ascending k: a row or column is
            // used before its own children have modified it, so the update can be in place.
            for k in 0..n {
                let p = nodes[k].parent;
                if p == GROUND_PARENT {
                    continue;
                }
                for r in 0..n {
                    m[r * n + p] -= m[r * n + k];
                }
            }
            for k in 0..n {
                let p = nodes[k].parent;
                if p == GROUND_PARENT {
                    continue;
                }
                for c in 0..n {
                    m[p * n + c] -= m[k * n + c];
                }
                if forcing {
                    f[p] -= f[k];
                }
            }
            // The two passes round differently on each side: restore exact symmetry.
            for r in 0..n {
                for c in 0..r {
                    m[r * n + c] = m[c * n + r];
                }
            }
        }
    }

    /// Cholesky factor L Lᵀ = M into `l` (row-major lower triangle).
    ///
    /// NOTE: written here rather than calling nalgebra's `Cholesky` so the factorisation works in
    /// place on the preallocated buffer (no allocation per call) and a failure names the speed
    /// (joint) whose pivot vanished.
    fn factor(&mut self) -> Result<(), EngineError> {
        match self.n {
            1 => self.factor_n::<1>(),
            2 => self.factor_n::<2>(),
            3 => self.factor_n::<3>(),
            4 => self.factor_n::<4>(),
            5 => self.factor_n::<5>(),
            6 => self.factor_n::<6>(),
            _ => self.factor_n::<0>(),
        }
    }

    #[inline(always)]
    fn factor_n<const N: usize>(&mut self) -> Result<(), EngineError> {
        let n = if N == 0 { self.n } else { N };
        let (m, l) = (&self.m[..n * n], &mut self.l[..n * n]);
        let mut scale = 0.0f64;
        for i in 0..n {
            scale = scale.max(m[i * n + i].abs());
        }
        for j in 0..n {
            let mut d = m[j * n + j];
            for k in 0..j {
                d -= l[j * n + k] * l[j * n + k];
            }
            // NaN must fail too, so test for "not greater" rather than "less or equal".
            if d.is_nan() || d <= PIVOT_TOL * scale {
                return Err(if d.is_nan() {
                    EngineError::NonFinite { what: "mass matrix", index: j }
                } else {
                    EngineError::NotPositiveDefinite { dof: j, joint: self.mech.joints[j].name.clone(), pivot: d }
                });
            }
            let ljj = d.sqrt();
            l[j * n + j] = ljj;
            for i in j + 1..n {
                let mut s = m[i * n + j];
                for k in 0..j {
                    s -= l[i * n + k] * l[j * n + k];
                }
                l[i * n + j] = s / ljj;
            }
        }
        Ok(())
    }

    /// Solves `L Lᵀ x = b` in place.
    fn solve(&self, b: &mut [f64]) {
        match self.n {
            1 => self.solve_n::<1>(b),
            2 => self.solve_n::<2>(b),
            3 => self.solve_n::<3>(b),
            4 => self.solve_n::<4>(b),
            5 => self.solve_n::<5>(b),
            6 => self.solve_n::<6>(b),
            _ => self.solve_n::<0>(b),
        }
    }

    #[inline(always)]
    fn solve_n<const N: usize>(&self, b: &mut [f64]) {
        let n = if N == 0 { self.n } else { N };
        let (l, b) = (&self.l[..n * n], &mut b[..n]);
        for i in 0..n {
            let mut s = b[i];
            for k in 0..i {
                s -= l[i * n + k] * b[k];
            }
            b[i] = s / l[i * n + i];
        }
        for i in (0..n).rev() {
            let mut s = b[i];
            for k in i + 1..n {
                s -= l[k * n + i] * b[k];
            }
            b[i] = s / l[i * n + i];
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
        self.evaluate(0.0, q, q, false);
        let mut v = vec![Vec2::zeros(); self.n];
        let mut w = vec![0.0; self.n];
        let path = self.mech.path_to(j);
        let d = path.len();
        let com = self.frames[j].com;
        let mut jv: Vec<Vec2> = path.iter().map(|&k| perp(com - self.frames[k].origin)).collect();
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
