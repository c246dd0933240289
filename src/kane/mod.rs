//! The numeric Kane engine: `M(q) u̇ = F(q, u, t)` and `ẋ = [W⁻¹u; M⁻¹F]` for any revolute tree.
//!
//! The algorithm is DESIGN.md's: forward kinematics, partial velocities from the tree paths
//! (`∂ω_j/∂q̇_k = 1`, `∂v_j/∂q̇_k = ẑ × (r_j − o_k)` for each joint k on body j's path, mapped to
//! the speeds by W⁻¹), centripetal bias accelerations at `u̇ = 0` (W is constant for both speed
//! choices, so `q̈ = 0`), and Kane's sums `M_rs = Σ_j m_j v_{j,r}·v_{j,s} + I_j ω_{j,r} ω_{j,s}`,
//! `F_r = Σ_j (F_j − m_j a⁰_j)·v_{j,r} + T_j ω_{j,r}` plus the joint torques `τ_k ∂q̇_k/∂u_r`.
//! The sums are not formed body by body but regrouped, exactly, into fewer operations: by subtree
//! (composite bodies) for joint rates, by pairs of speeds with coefficients precomputed from the
//! constant partial-velocity vectors for absolute angular velocities (see [`Kane::evaluate`]).
//! The tests rebuild M and F body by body from [`Kane::partial_velocities`].
//!
//! Every vector is expressed in one basis per subtree. When no load needs the world orientation
//! (no gravity, no world-frame force), that basis is the root body's own frame: the root angle is
//! cyclic, so its sine and cosine are never computed (one `sin_cos` fewer per call for a rotor,
//! and no loss of precision when the spin angle grows to 10⁴ rad in a long sweep). Dot products,
//! hence M and F, do not depend on the basis.
//!
//! All work buffers are sized in [`Kane::new`]; evaluating does no heap allocation.

use crate::error::{EngineError, Error, Result};
use crate::model::excitation::Excitation;
use crate::model::loads::{ForceFrame, JointTorque, PointForce};
use crate::model::math::{Vec2, cross2, perp, rotate_cs};
use crate::model::mechanism::Mechanism;

pub mod kinematics;
use crate::model::speeds::Speeds;
use nalgebra::{DMatrix, DVector};

/// Relative size (to the largest diagonal entry of M) below which a Cholesky pivot counts as zero.
const PIVOT_TOL: f64 = 1e-12;

/// Parent index of a root body (hangs from ground).
const GROUND_PARENT: usize = usize::MAX;

/// Calls `recv.method::<N>(args)` with a literal `N` for n = 1..=6 and `N = 0` (n read at run
/// time) above.
macro_rules! with_literal_n {
    ($n:expr, $recv:ident . $method:ident ( $($arg:expr),* )) => {
        match $n {
            1 => $recv.$method::<1>($($arg),*),
            2 => $recv.$method::<2>($($arg),*),
            3 => $recv.$method::<3>($($arg),*),
            4 => $recv.$method::<4>($($arg),*),
            5 => $recv.$method::<5>($($arg),*),
            6 => $recv.$method::<6>($($arg),*),
            _ => $recv.$method::<0>($($arg),*),
        }
    };
}

/// `Σ a_k b_k` over the shorter of the two slices.
#[inline(always)]
fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).fold(0.0, |s, (x, y)| s + x * y)
}

/// Constant data of one body and its inboard joint, packed so the hot loop touches one record.
#[derive(Debug, Clone, Copy)]
struct Node {
    parent: usize,
    mass: f64,
    com_local: Vec2,
    at: Vec2,
    k_spring: f64,
    q_free: f64,
    c_joint: f64,
    c_ground: f64,
    forces: (usize, usize),
    /// Mass of the subtree rooted at this body, kg.
    subtree_mass: f64,
    /// `I + m |c|²`: the body's own inertia about its joint point (rotation invariant), kg·m².
    j_own: f64,
    /// `M_kk` for absolute angular velocities: `j_own + Σ_children M_c |at_c|²`, constant
    /// (each child subtree's partial velocity for u_k is that of a point mass at the child's joint).
    diag_abs: f64,
    /// The matching first moment in the body frame, `m c + Σ_children M_c at_c`, kg·m.
    first_abs: Vec2,
}

/// Per-evaluation state of one body: its pose and rates (in the subtree's basis), the composite
/// sums of its subtree about its joint point o, and its joint's rate and torque.
///
/// NOTE: one record per body rather than one buffer per quantity: each buffer costs a length
/// check and a register (or a stack spill) per call (measured: 805 → 761 instructions per CPVA
/// call, callgrind, tests/rhs_count.rs).
#[derive(Debug, Clone, Copy, Default)]
struct BodyState {
    /// Cosine and sine of the body's angle.
    c: f64,
    s: f64,
    /// Cosine and sine of the joint angle q_j (absolute speeds only).
    jc: f64,
    js: f64,
    /// Joint point o_j.
    origin: Vec2,
    /// `o_j − o_parent` (zero for a root).
    d: Vec2,
    /// Absolute angular velocity ω_j, rad/s.
    omega: f64,
    /// Bias acceleration of o_j at u̇ = 0.
    acc_o: Vec2,
    /// Joint rates only: first moment S = Σ m (r − o) and inertia J = Σ I + m |r − o|².
    first: Vec2,
    inertia: f64,
    /// Resultant force of the subtree and its moment about o (applied minus inertial).
    force: Vec2,
    moment: f64,
    /// Joint rate q̇_j and joint torque τ_j (spring, damper, excitation).
    qdot: f64,
    tau: f64,
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
    /// Absolute speeds: the constant coefficients `(α, β)` of every ancestor pair (k, j), in the
    /// order the forward pass walks them (j ascending, then k from j's parent up to the root); see
    /// [`Kane::evaluate_absolute`].
    pairs: Vec<(f64, f64)>,
    // Work buffers.
    /// The joints of one ancestor walk, for [`Kane::residual_jacobian`] (capacity n).
    walk: Vec<usize>,
    state: Vec<BodyState>,
    qdot: Vec<f64>,
    m: Vec<f64>,
    f: Vec<f64>,
    l: Vec<f64>,
    d_inv: Vec<f64>,
    row: Vec<f64>,
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
        let mut subtree_mass: Vec<f64> = mech.bodies.iter().map(|b| b.inertia.mass).collect();
        for j in (0..n).rev() {
            if let Some(p) = parent[j] {
                subtree_mass[p] += subtree_mass[j];
            }
        }
        let mut nodes = Vec::with_capacity(n);
        for j in 0..n {
            let f0 = point_forces.iter().position(|p| p.body == j).unwrap_or(0);
            let f1 = f0 + point_forces.iter().filter(|p| p.body == j).count();
            let (b, jt) = (&mech.bodies[j], &mech.joints[j]);
            nodes.push(Node {
                parent: jt.parent.unwrap_or(GROUND_PARENT),
                mass: b.inertia.mass,
                com_local: b.inertia.com,
                at: jt.at,
                k_spring: jt.spring.map_or(0.0, |s| s.stiffness),
                q_free: jt.spring.map_or(0.0, |s| s.free_angle),
                c_joint: jt.damper,
                c_ground: c_ground[j],
                forces: (f0, f1),
                subtree_mass: subtree_mass[j],
                j_own: b.inertia.i_com + b.inertia.mass * b.inertia.com.norm_squared(),
                diag_abs: 0.0,
                first_abs: b.inertia.mass * b.inertia.com,
            });
        }
        for j in 0..n {
            nodes[j].diag_abs += nodes[j].j_own;
            if let Some(p) = parent[j] {
                let (mass, at) = (nodes[j].subtree_mass, nodes[j].at);
                nodes[p].diag_abs += mass * at.norm_squared();
                nodes[p].first_abs += mass * at;
            }
        }
        // Absolute speeds: for an ancestor k of body j (c: k's child on the path), every body of
        // j's subtree moves with u_k like a point at c's joint, so `M_kj = (R_k at_c)·(R_j S'_j)`
        // with both vectors constant in their own frames: with Δ = θ_j − θ_k,
        // `M_kj = α cos Δ − β sin Δ`, α = at_c·S'_j, β = at_c × S'_j.
        let mut pairs = Vec::new();
        for j in 0..n {
            let (mut c, mut k) = (j, parent[j]);
            while let Some(kk) = k {
                let (at, first) = (nodes[c].at, nodes[j].first_abs);
                pairs.push((at.dot(&first), cross2(at, first)));
                (c, k) = (kk, parent[kk]);
            }
        }
        let mut k = Kane {
            mech: mech.clone(),
            pairs,
            n,
            speeds: mech.speeds,
            absolute: mech.speeds == Speeds::AbsoluteAngularVelocities,
            world,
            gravity: mech.loads.gravity,
            nodes,
            point_forces,
            torques: mech.loads.joint_torques.clone(),
            state: vec![BodyState::default(); n],
            qdot: vec![0.0; n],
            walk: Vec::with_capacity(n),
            m: vec![0.0; n * n],
            f: vec![0.0; n],
            l: vec![0.0; n * n],
            d_inv: vec![0.0; n],
            row: vec![0.0; n],
            m_out: DMatrix::zeros(n, n),
            f_out: DVector::zeros(n),
            parent,
        };
        let mut zeros = vec![0.0; n];
        k.evaluate(0.0, &zeros, &zeros, false);
        k.factor_solve(&mut zeros)?;
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

    /// Like [`Kane::mass_matrix_and_forcing`], as slices into the engine's buffers: M row-major
    /// (`m[r·n + c]`) and F. It skips the copy into nalgebra types, which measured 8 % of the
    /// instructions of a harmonic-balance branch (one copy per engine call).
    pub fn mass_matrix_and_forcing_rows(&mut self, t: f64, q: &[f64], u: &[f64]) -> (&[f64], &[f64]) {
        self.evaluate(t, q, u, true);
        (&self.m, &self.f)
    }

    /// True when [`Kane::residual_jacobian`] applies: absolute angular velocities, no gravity, no
    /// point forces.
    pub fn has_residual_jacobian(&self) -> bool {
        let gravity = self.world && self.gravity != Vec2::zeros();
        self.absolute && !gravity && self.point_forces.is_empty()
    }

    /// The residual `r = M(q) u̇ − F(q, u, t)` with its exact derivatives `∂r/∂q` and `∂r/∂u`
    /// (row-major n × n), and M (row-major) into `m_out`, for absolute angular velocities
    /// without gravity or point forces: there every q-dependence is a pair term of
    /// [`Kane::evaluate_absolute`], `M_kj = α cos Δ − β sin Δ` and `D = α sin Δ + β cos Δ`, with
    /// `∂M_kj/∂Δ = −D`, `∂D/∂Δ = M_kj`, and Δ = θ_j − θ_k the sum of the joint angles on the path
    /// from k (exclusive) to j, so the derivatives cost one extra walk over the pairs instead of
    /// 2n (q) + 2n (u) central differences. Returns false, writing nothing, for the other
    /// cases (joint-rate speeds, gravity, point forces): difference
    /// [`Kane::mass_matrix_and_forcing_rows`] there. Excitation torques depend on t only.
    #[allow(clippy::too_many_arguments)]
    pub fn residual_jacobian(
        &mut self,
        t: f64,
        q: &[f64],
        u: &[f64],
        udot: &[f64],
        r: &mut [f64],
        dr_dq: &mut [f64],
        dr_du: &mut [f64],
        m_out: &mut [f64],
    ) -> bool {
        if !self.has_residual_jacobian() {
            return false;
        }
        let n = self.n;
        self.evaluate(t, q, u, true);
        let (m, f) = (&self.m[..n * n], &self.f[..n]);
        m_out[..n * n].copy_from_slice(m);
        for i in 0..n {
            let mut acc = -f[i];
            for j in 0..n {
                acc += m[i * n + j] * udot[j];
            }
            r[i] = acc;
        }
        let (dq, du) = (&mut dr_dq[..n * n], &mut dr_du[..n * n]);
        dq.fill(0.0);
        du.fill(0.0);
        // The walk's joints between k and j (j first).
        let path = &mut self.walk;
        let (nodes, st, pairs) = (&self.nodes[..n], &self.state[..n], &self.pairs[..]);
        let mut pair = 0;
        for j in 0..n {
            let nd = &nodes[j];
            let (w, root) = (u[j], nd.parent == GROUND_PARENT);
            // Spring and dampers: τ = −k (q_j − q₀) − c (u_j − u_p) acts +τ on j, −τ on p;
            // the ground damper −c_g u_j on j; r carries −F.
            dq[j * n + j] += nd.k_spring;
            du[j * n + j] += nd.c_joint + nd.c_ground;
            if !root {
                let p = nd.parent;
                dq[p * n + j] -= nd.k_spring;
                du[j * n + p] -= nd.c_joint;
                du[p * n + j] -= nd.c_joint;
                du[p * n + p] += nd.c_joint;
            }
            path.clear();
            path.push(j);
            let b = &st[j];
            let (mut rc, mut rs, mut k) = (b.jc, b.js, nd.parent);
            while k != GROUND_PARENT {
                let (alpha, beta) = pairs[pair];
                pair += 1;
                // M_kj as `evaluate` wrote it; D, its Δ-derivative up to sign.
                let v = m[k * n + j];
                let d = alpha * rs + beta * rc;
                // r_k = … + M_kj u̇_j − ω_j² D, r_j = … + M_kj u̇_k + ω_k² D.
                let (wk, gk, gj) = (u[k], -d * udot[j] - w * w * v, -d * udot[k] + u[k] * u[k] * v);
                for &l in path.iter() {
                    dq[k * n + l] += gk;
                    dq[j * n + l] += gj;
                }
                du[k * n + j] -= 2.0 * w * d;
                du[j * n + k] += 2.0 * wk * d;
                path.push(k);
                let next = nodes[k].parent;
                if next != GROUND_PARENT {
                    let a = &st[k];
                    (rc, rs) = (a.jc * rc - a.js * rs, a.js * rc + a.jc * rs);
                }
                k = next;
            }
        }
        true
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
        with_literal_n!(self.n, self.rhs_n(t, x, xdot))
    }

    /// The body of [`Kane::rhs`] for `N` degrees of freedom (`N = 0`: any).
    ///
    /// NOTE: one dispatch on n for the whole evaluation, assembly, factorisation and solve, so
    /// the copies into ẋ have a literal length too (with a run-time length each was a `memcpy`
    /// call: 20 of the CPVA's ~980 instructions per call).
    #[inline(always)]
    fn rhs_n<const N: usize>(&mut self, t: f64, x: &[f64], xdot: &mut [f64]) -> Result<(), EngineError> {
        let n = if N == 0 { self.n } else { N };
        let (q, u) = x.split_at(n);
        self.evaluate_n::<N>(t, q, u, true);
        let (qd, ud) = xdot.split_at_mut(n);
        for (qd, st) in qd.iter_mut().zip(&self.state[..n]) {
            *qd = st.qdot;
        }
        self.factor_solve_n::<N>(ud)?;
        Ok(())
    }

    /// Evaluates M (and F, q̇ when `forcing`; only then are `u` and `t` read) into the buffers.
    ///
    /// Kane's sums `M_rs = Σ_j m_j v_{j,r}·v_{j,s} + I_j ω_{j,r} ω_{j,s}` and
    /// `F_r = Σ_j f_j·v_{j,r} + T_j ω_{j,r}` over the bodies j below speed r are regrouped so
    /// that no per-body partial velocity is stored: by subtree for joint rates
    /// ([`Kane::evaluate_rates`]), by pairs of speeds for absolute angular velocities
    /// ([`Kane::evaluate_absolute`], where every partial velocity is a constant vector in one
    /// body's frame). `partial_velocities` exposes the per-body v_{j,r}, and the tests rebuild M
    /// and F from them body by body. Only entries (k, l) with one an ancestor of the other are
    /// written: the others are zero for a tree and stay as allocated.
    fn evaluate(&mut self, t: f64, q: &[f64], u: &[f64], forcing: bool) {
        with_literal_n!(self.n, self.evaluate_n(t, q, u, forcing))
    }

    /// The body of [`Kane::evaluate`] for `N` degrees of freedom (`N = 0`: any, read at run time).
    ///
    /// NOTE: a literal n lets the compiler unroll the loops and drop most bounds checks for the
    /// small mechanisms that dominate torsional work.
    #[inline(always)]
    fn evaluate_n<const N: usize>(&mut self, t: f64, q: &[f64], u: &[f64], forcing: bool) {
        // NOTE: one test of the speed choice per call, outside the loops (measured: 761 → 730
        // instructions per CPVA call against testing it inside).
        if self.absolute {
            self.evaluate_absolute::<N>(t, q, u, forcing);
        } else {
            self.evaluate_rates::<N>(t, q, u, forcing);
        }
    }

    /// [`Kane::evaluate`] for absolute angular velocities, in pair-coefficient form.
    ///
    /// Kane's sums regrouped by pairs of speeds: with u_k = ω_k, a body i below k has
    /// `ω_{i,k} = δ_ik` and `v_{i,k} = ẑ × R_k r_ik` with r_ik constant in body k's frame (the
    /// centre of mass offset for i = k, the joint offset `at_c` of k's child c towards i
    /// otherwise). So every term of `M_rs = Σ_i m_i v_{i,r}·v_{i,s} + I_i ω_{i,r} ω_{i,s}` is a
    /// constant vector pair turned by the relative angle of two bodies:
    ///
    /// - `M_kk` is constant (`diag_abs`), and for k an ancestor of j (Δ = θ_j − θ_k)
    ///   `M_kj = α cos Δ − β sin Δ`, with `α = at_c·S'_j`, `β = at_c × S'_j` precomputed
    ///   (S'_j: first moment of j's subtree as seen by u_j, constant in j's frame);
    /// - at u̇ = 0 the bias accelerations are purely centripetal, `a⁰_i = −Σ_l ω_l² R_l r_il`, so
    ///   the inertia forces `−Σ_i m_i a⁰_i·v_{i,r}` of the same pair are `±ω² ∂M_kj/∂θ_k`:
    ///   `F_k += ω_j² D`, `F_j −= ω_k² D` with `D = α sin Δ + β cos Δ`;
    /// - gravity adds `(R_k S'_k) × g` to F_k; a joint torque τ_j adds to F_j and subtracts from
    ///   F_parent (q̇_j = u_j − u_parent); a point force f at P on body b adds `(R_k r) × f` to
    ///   every F_k on b's path (r = P − o_b for k = b, `at_c` above).
    ///
    /// Δ is composed along the walk from the joint angles' sines and cosines, so each body costs
    /// one `sin_cos` (none for a root in its own frame) and each pair a few multiplications.
    ///
    /// NOTE: this replaced a composite-body recursion (forward pass of poses and centripetal
    /// accelerations, backward pass of subtree forces and moments): the same sums, but 708 → 616
    /// instructions per CPVA call (tests/rhs_count.rs, callgrind; the closed form takes 301),
    /// because the accelerations, forces and moments about joint points are never formed.
    #[inline(always)]
    fn evaluate_absolute<const N: usize>(&mut self, t: f64, q: &[f64], u: &[f64], forcing: bool) {
        let n = if N == 0 { self.n } else { N };
        let (q, u) = (&q[..n], &u[..n]);
        let (world, g) = (self.world, self.gravity);
        let gravity = world && g != Vec2::zeros();
        let oriented = gravity || !self.point_forces.is_empty();
        let nodes = &self.nodes[..n];
        let st = &mut self.state[..n];
        let m = &mut self.m[..n * n];
        let f = &mut self.f[..n];
        let (pairs, mut pair) = (&self.pairs[..], 0);
        for j in 0..n {
            let nd = &nodes[j];
            let root = nd.parent == GROUND_PARENT;
            let (js, jc) = if root && !world { (0.0, 1.0) } else { q[j].sin_cos() };
            // NOTE: the body's own orientation is only needed by gravity and point forces; the
            // pairs use relative angles (measured: 616 → 610 instructions per CPVA call).
            let (c, s) = if root || !oriented {
                (jc, js)
            } else {
                let p = &st[nd.parent];
                (p.c * jc - p.s * js, p.s * jc + p.c * js)
            };
            let b = &mut st[j];
            (b.c, b.s, b.jc, b.js) = (c, s, jc, js);
            m[j * n + j] = nd.diag_abs;
            let w = u[j];
            if forcing {
                let qd = if root { w } else { w - u[nd.parent] };
                b.qdot = qd;
                let tau = -nd.k_spring * (q[j] - nd.q_free) - nd.c_joint * qd;
                f[j] = tau - nd.c_ground * w;
                if !root {
                    f[nd.parent] -= tau;
                }
                if gravity {
                    f[j] += cross2(rotate_cs(c, s, nd.first_abs), g);
                }
            }
            // Ancestors k of j, nearest first, with (rc, rs) the cosine and sine of θ_j − θ_k.
            let (mut rc, mut rs, mut k) = (jc, js, nd.parent);
            while k != GROUND_PARENT {
                // NOTE: one pair per step of this walk, in the order `build` pushed them.
                let (alpha, beta) = pairs[pair];
                pair += 1;
                let v = alpha * rc - beta * rs;
                m[k * n + j] = v;
                m[j * n + k] = v;
                if forcing {
                    let d = alpha * rs + beta * rc;
                    f[k] += w * w * d;
                    f[j] -= u[k] * u[k] * d;
                }
                let next = nodes[k].parent;
                if next != GROUND_PARENT {
                    let a = &st[k];
                    (rc, rs) = (a.jc * rc - a.js * rs, a.js * rc + a.jc * rs);
                }
                k = next;
            }
        }
        if !forcing {
            return;
        }
        for pfc in &self.point_forces {
            let b = &st[pfc.body];
            let force = match pfc.frame {
                ForceFrame::World => pfc.force,
                ForceFrame::Body => rotate_cs(b.c, b.s, pfc.force),
            };
            f[pfc.body] += cross2(rotate_cs(b.c, b.s, pfc.at), force);
            let (mut c, mut k) = (pfc.body, nodes[pfc.body].parent);
            while k != GROUND_PARENT {
                let a = &st[k];
                f[k] += cross2(rotate_cs(a.c, a.s, nodes[c].at), force);
                (c, k) = (k, nodes[k].parent);
            }
        }
        for jt in &self.torques {
            let tau = jt.excitation.torque(t);
            f[jt.joint] += tau;
            let p = nodes[jt.joint].parent;
            if p != GROUND_PARENT {
                f[p] -= tau;
            }
        }
    }

    /// [`Kane::evaluate`] for joint rates (u = q̇), by composite bodies.
    ///
    /// With `v_{j,k} = ẑ × (r_j − o_k)` and `ω_{j,k} = 1` for every joint k on body j's path,
    /// grouping Kane's sums by subtree gives, for l on the path to k,
    /// `M_kl = J_k + S_k·(o_k − o_l)` (J_k, S_k: the subtree's inertia and first moment about o_k)
    /// and `F_k = τ_k +` the subtree's resultant moment about o_k (applied minus inertial), all
    /// accumulated child → parent in one backward pass: O(n·depth) instead of O(Σ depth²).
    #[inline(always)]
    fn evaluate_rates<const N: usize>(&mut self, t: f64, q: &[f64], u: &[f64], forcing: bool) {
        let n = if N == 0 { self.n } else { N };
        let (q, u) = (&q[..n], &u[..n]);
        let (world, g) = (self.world, self.gravity);
        let nodes = &self.nodes[..n];
        let st = &mut self.state[..n];
        let m = &mut self.m[..n * n];
        let f = &mut self.f[..n];
        // Forward pass, parents first: poses, rates, centripetal bias accelerations (q̈ = 0 at
        // u̇ = 0), and each body's own contribution to its composite sums about its origin o_j.
        for j in 0..n {
            let nd = &nodes[j];
            let root = nd.parent == GROUND_PARENT;
            // NOTE: the record is written field by field in place (not built and copied), so
            // fields that are not needed are not stored (measured: 730 → 711 instructions per
            // CPVA call when both speed choices shared this pass).
            let (done, rest) = st.split_at_mut(j);
            let b = &mut rest[0];
            let (w_p, acc_p) = if root {
                (b.s, b.c) = if world { q[j].sin_cos() } else { (0.0, 1.0) };
                (b.origin, b.d) = (nd.at, Vec2::zeros());
                (0.0, Vec2::zeros())
            } else {
                let p = &done[nd.parent];
                let (s, c) = q[j].sin_cos();
                b.c = p.c * c - p.s * s;
                b.s = p.s * c + p.c * s;
                b.d = rotate_cs(p.c, p.s, nd.at);
                b.origin = p.origin + b.d;
                (p.omega, p.acc_o)
            };
            let arm = rotate_cs(b.c, b.s, nd.com_local);
            b.first = nd.mass * arm;
            b.inertia = nd.j_own;
            if forcing {
                let qd = u[j];
                b.qdot = qd;
                b.omega = w_p + qd;
                b.acc_o = acc_p - w_p * w_p * b.d;
                let acc_c = b.acc_o - b.omega * b.omega * arm;
                // Applied force at the centre of mass minus the inertia force m a⁰, and torque.
                let fi = nd.mass * (g - acc_c);
                b.force = fi;
                b.moment = cross2(arm, fi) - nd.c_ground * b.omega;
                // NOTE: tested first so that the common body without point forces skips the
                // slice's range checks.
                if nd.forces.1 > nd.forces.0 {
                    for pfc in &self.point_forces[nd.forces.0..nd.forces.1] {
                        let force = match pfc.frame {
                            ForceFrame::World => pfc.force,
                            ForceFrame::Body => rotate_cs(b.c, b.s, pfc.force),
                        };
                        b.force += force;
                        b.moment += cross2(rotate_cs(b.c, b.s, pfc.at), force);
                    }
                }
                // Joint torque (spring, damper; the excitations are added below).
                b.tau = -nd.k_spring * (q[j] - nd.q_free) - nd.c_joint * qd;
            }
        }
        if forcing {
            for jt in &self.torques {
                st[jt.joint].tau += jt.excitation.torque(t);
            }
        }
        // Backward pass, children first: composite sums, rows of M and entries of F.
        for j in (0..n).rev() {
            let (nd, b) = (&nodes[j], st[j]);
            if forcing {
                f[j] = b.moment + b.tau;
            }
            m[j * n + j] = b.inertia;
            let mut l = nd.parent;
            while l != GROUND_PARENT {
                let v = b.inertia + b.first.dot(&(b.origin - st[l].origin));
                m[j * n + l] = v;
                m[l * n + j] = v;
                l = nodes[l].parent;
            }
            let p = nd.parent;
            if p != GROUND_PARENT {
                let d = b.d;
                let bp = &mut st[p];
                bp.force += b.force;
                bp.moment += b.moment + cross2(d, b.force);
                let mass = nd.subtree_mass;
                bp.inertia += b.inertia + 2.0 * d.dot(&b.first) + mass * d.norm_squared();
                bp.first += b.first + mass * d;
            }
        }
    }

    /// Factors `M = L D Lᵀ` (L unit lower triangular, row-major in `l`; `d_inv` = D⁻¹) and
    /// solves `M x = F` into `x`.
    ///
    /// NOTE: written here rather than calling nalgebra's `Cholesky` so the factorisation works in
    /// place on the preallocated buffer (no allocation per call) and a failure names the speed
    /// (joint) whose pivot vanished. LDLᵀ rather than LLᵀ: no square roots, and one division per
    /// pivot that the solve reuses as a multiplication (n divisions in all, as many as Cramer's
    /// rule in the closed form for n = 2). Its pivots d_j are exactly Cholesky's squared ones.
    /// The forward substitution runs row by row with the factorisation, so each row of L is used
    /// while still in registers (the evaluation is latency bound, not flop bound: measured 711 →
    /// 707 instructions but 42 → 37 ns per CPVA call).
    fn factor_solve(&mut self, x: &mut [f64]) -> Result<(), EngineError> {
        with_literal_n!(self.n, self.factor_solve_n(x))
    }

    #[inline(always)]
    fn factor_solve_n<const N: usize>(&mut self, x: &mut [f64]) -> Result<(), EngineError> {
        let n = if N == 0 { self.n } else { N };
        let (m, l, f) = (&self.m[..n * n], &mut self.l[..n * n], &self.f[..n]);
        let (d_inv, a, x) = (&mut self.d_inv[..n], &mut self.row[..n], &mut x[..n]);
        let mut scale = 0.0f64;
        for i in 0..n {
            scale = scale.max(m[i * n + i].abs());
        }
        for i in 0..n {
            // Row i of M = Σ_k L_ik d_k L_jk: first a_j = L_ij d_j for j < i, then L_ij, d_i;
            // and y_i = F_i − Σ_j L_ij y_j (L y = F).
            for j in 0..i {
                a[j] = m[i * n + j] - dot(&a[..j], &l[j * n..j * n + j]);
            }
            let (mut d, mut y) = (m[i * n + i], f[i]);
            for j in 0..i {
                let lij = a[j] * d_inv[j];
                l[i * n + j] = lij;
                d -= a[j] * lij;
                y -= lij * x[j];
            }
            // NaN must fail too, so test for "not greater" rather than "less or equal".
            if d.is_nan() || d <= PIVOT_TOL * scale {
                return Err(if d.is_nan() {
                    EngineError::NonFinite { what: "mass matrix", index: i }
                } else {
                    EngineError::NotPositiveDefinite { dof: i, joint: self.mech.joints[i].name.clone(), pivot: d }
                });
            }
            d_inv[i] = 1.0 / d;
            x[i] = y;
        }
        // D z = y, then Lᵀ x = z by rows of L, so the inner loop reads L contiguously.
        for i in 0..n {
            x[i] *= d_inv[i];
        }
        for i in (0..n).rev() {
            let (head, tail) = x.split_at_mut(i);
            let xi = tail[0];
            for (xk, lik) in head.iter_mut().zip(&l[i * n..i * n + i]) {
                *xk -= lik * xi;
            }
        }
        Ok(())
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

    /// Forward kinematics only: each body's rotation, joint point o_j and `o_j − o_parent`, in the
    /// evaluator's basis (the absolute-speed evaluation never needs the points).
    fn pose(&mut self, q: &[f64]) {
        for j in 0..self.n {
            let nd = self.nodes[j];
            let (s, c) = if nd.parent == GROUND_PARENT && !self.world { (0.0, 1.0) } else { q[j].sin_cos() };
            let b = if nd.parent == GROUND_PARENT {
                BodyState { c, s, origin: nd.at, ..BodyState::default() }
            } else {
                let p = self.state[nd.parent];
                let d = rotate_cs(p.c, p.s, nd.at);
                BodyState {
                    c: p.c * c - p.s * s,
                    s: p.s * c + p.c * s,
                    origin: p.origin + d,
                    d,
                    ..BodyState::default()
                }
            };
            self.state[j] = b;
        }
    }

    /// Kane's partial velocities of body `j` at `q`, in the evaluator's basis (world frame for an
    /// evaluator from [`Kane::new_world_frame`]): `(v_{j,r}, ω_{j,r})` for r = 0..n. Allocates;
    /// for tests and reports.
    pub fn partial_velocities(&mut self, q: &[f64], j: usize) -> (Vec<Vec2>, Vec<f64>) {
        self.pose(q);
        let mut v = vec![Vec2::zeros(); self.n];
        let mut w = vec![0.0; self.n];
        let path = self.mech.path_to(j);
        let d = path.len();
        let b = &self.state[j];
        let com = b.origin + rotate_cs(b.c, b.s, self.nodes[j].com_local);
        let mut jv: Vec<Vec2> = path.iter().map(|&k| perp(com - self.state[k].origin)).collect();
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
