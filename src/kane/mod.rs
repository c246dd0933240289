//! The numeric Kane engine: `M(q) u̇ = F(q, u, t)` and `ẋ = [W⁻¹u; M⁻¹F]` for any tree of the
//! joint kinds of [`crate::model::joint::JointKind`].
//!
//! The method (docs/design.md) is Kane's: forward kinematics, the partial velocities
//! `v_{j,r} = ∂v_j/∂u_r` and `ω_{j,r} = ∂ω_j/∂u_r` of every body from the motion columns of the
//! joints on its path (mapped to the speeds by `q̇ = W⁻¹u`), the bias accelerations at `u̇ = 0`
//! (W is constant for both speed choices, so `q̈ = 0`), and Kane's sums
//! `M_rs = Σ_j m_j v_{j,r}·v_{j,s} + I_j ω_{j,r} ω_{j,s}` and `F_r + F*_r` with
//! `F*_r = −Σ_j (m_j a⁰_j·v_{j,r} + I_j α⁰_j ω_{j,r})`. Three forms compute the same sums:
//!
//! - [`reference`](mod@reference): the sums as the textbook writes them, body by body, allocating: the
//!   definition the other two are tested against;
//! - [`rates`]: regrouped by subtree (composite bodies) in one forward and one backward pass, for
//!   any joint kind; with absolute angular velocities on a tree that is not purely revolute its
//!   result is mapped to those speeds (`M ← Bᵀ M B`, `F ← Bᵀ F`, B = W⁻¹);
//! - [`absolute`]: regrouped by pairs of speeds with precomputed coefficients, for absolute
//!   angular velocities on a purely revolute tree (the paper's CPVA), with its exact Jacobian.
//!
//! For `rhs` on small trees (at most six speeds, no fixed joint, no point forces) the pair form
//! and the mapped composite-body form also have fixed-size instances (`small`, `small_rates`,
//! chosen in [`Kane::new`]) with the same results.
//!
//! [`ldlt`] factors M and solves for u̇; [`kinematics`] gives world-frame poses, velocities and
//! energies for outputs and tests.
//!
//! Every vector is expressed in one basis per subtree. When no load needs the world orientation
//! (no gravity, no world-frame force), that basis is a revolute root body's own frame: its angle
//! is cyclic, so its sine and cosine are never computed (one `sin_cos` fewer per call for a
//! rotor, and no loss of precision when the spin angle grows to 10⁴ rad in a long sweep). Dot
//! products, hence M and F, do not depend on the basis.
//!
//! All work buffers are sized in [`Kane::new`]; evaluating does no heap allocation.

use crate::error::{EngineError, Error, Result};
use crate::model::coupling::Couplings;
use crate::model::excitation::Excitation;
use crate::model::joint::JointKind;
use crate::model::loads::{JointTorque, PointForce};
use crate::model::math::{Vec2, cross2};
use crate::model::mechanism::Mechanism;
use crate::model::speeds::Speeds;
use nalgebra::{DMatrix, DVector};

/// Relative size (to the largest diagonal entry of M) below which a pivot of the LDLᵀ
/// factorisation counts as zero.
const PIVOT_TOL: f64 = 1e-12;

/// Parent index of a root body (hangs from ground).
const GROUND_PARENT: usize = usize::MAX;

/// Coordinate index of a joint without coordinate (`Fixed`).
const NO_COORD: usize = usize::MAX;

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

// The forms live in their own files; declared after the macro above so they can use it.
pub mod absolute;
pub mod kinematics;
pub mod ldlt;
pub mod rates;
pub mod reactions;
mod reduce;
pub mod reference;
mod small;
mod small_rates;

/// Largest number of speeds served by the fixed-size right-hand sides ([`small`], [`small_rates`]).
const SMALL: usize = 6;

/// In the fixed-size forms: a speed without applied joint torque, a missing parent or speed
/// parent.
const NONE: usize = usize::MAX;

/// An instance of a fixed-size right-hand side for one literal n.
type SmallRhs = fn(&Kane, f64, &[f64], &mut [f64]) -> Result<(), EngineError>;

/// `Σ a_k b_k` over the shorter of the two slices.
#[inline(always)]
fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).fold(0.0, |s, (x, y)| s + x * y)
}

/// Couplings taken out of a [`Kane`] by [`Kane::suspend_couplings`].
#[derive(Debug)]
pub struct CouplingsSuspended(Vec<Coupled>);

/// Which regrouping of Kane's sums evaluates this mechanism (see the module doc).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Form {
    /// Absolute angular velocities on a purely revolute tree: `Kane::evaluate_absolute`.
    Pairs,
    /// Joint rates: `Kane::evaluate_rates`.
    Rates,
    /// Absolute angular velocities with other joint kinds: the rates form, mapped to the speeds.
    MappedRates,
    /// A mechanism with couplings: the unconstrained tree, reduced (`reduce.rs`).
    Geared,
}

/// Constant data of one body and its inboard joint, packed so the hot loop touches one record.
#[derive(Debug, Clone, Copy)]
struct Node {
    parent: usize,
    /// The joint's coordinate (`NO_COORD` for a fixed joint).
    coord: usize,
    kind: JointKind,
    mass: f64,
    /// Centroidal inertia, kg·m².
    i_com: f64,
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

/// A path joint's rollers as the engine carries them (docs/design.md, "Rollers"): one rigid
/// body hanging from the path's parent and moved by the path's coordinate
/// ([`JointKind`]'s `roller_motion`); its terms are added by `Kane::add_rollers` (`rates.rs`).
#[derive(Debug, Clone, Copy)]
struct Satellite {
    /// The path's parent body (`GROUND_PARENT` for ground).
    parent: usize,
    /// The path's coordinate.
    coord: usize,
    /// The path joint's kind and point.
    kind: JointKind,
    at: Vec2,
    /// The vertex's centre of curvature P (path frame), m, and dψ/ds = −1/(2 r_r), rad/m.
    centre: Vec2,
    turn_rate: f64,
    /// N m_r, kg, and N I_r, kg·m².
    mass: f64,
    i_com: f64,
}

/// Per-evaluation state of one body: its pose and rates (in the subtree's basis), the composite
/// sums of its subtree about its joint point o, and its joint's rate and torque.
///
/// NOTE: one record per body rather than one buffer per quantity: each buffer costs a length
/// check and a register (or a stack spill) per call (measured, BENCHMARKS.md).
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
    /// Bias angular acceleration α⁰_j at u̇ = 0 (joint rates form), rad/s².
    alpha: f64,
    /// Bias acceleration of o_j at u̇ = 0.
    acc_o: Vec2,
    /// The joint's motion columns in the basis (joint rates form): partial angular velocity and
    /// partial velocity of o_j per unit rate.
    col_w: f64,
    col_v: Vec2,
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

/// The nonlinear couplings of one coordinate ([`Couplings`]), with the speed whose value is
/// subtracted to get the joint rate (`q̇_k = u_k − u_p`, absolute angular velocities only).
#[derive(Debug, Clone)]
struct Coupled {
    coord: usize,
    parent_speed: Option<usize>,
    law: Couplings,
}

/// The equation-of-motion evaluator of one mechanism, with its work buffers.
#[derive(Debug, Clone)]
pub struct Kane {
    mech: Mechanism,
    /// Number of coordinates (= speeds).
    n: usize,
    /// Number of bodies (n plus the fixed joints).
    nb: usize,
    /// Per coordinate: the speed subtracted in `q̇ = W⁻¹u` ([`Mechanism::speed_parents`]).
    speed_parent: Vec<Option<usize>>,
    /// Per coordinate: its joint (= body) index.
    joint_of: Vec<usize>,
    speeds: Speeds,
    form: Form,
    world: bool,
    gravity: Vec2,
    nodes: Vec<Node>,
    /// The rollers of path joints (empty for most mechanisms).
    rollers: Vec<Satellite>,
    point_forces: Vec<PointForce>,
    torques: Vec<JointTorque>,
    /// The coordinates with nonlinear couplings (added by [`Kane::add_couplings`]).
    couplings: Vec<Coupled>,
    /// Absolute speeds: the constant coefficients `(α, β)` of every ancestor pair (k, j), in the
    /// order the forward pass walks them (j ascending, then k from j's parent up to the root); see
    /// `Kane::evaluate_absolute`.
    pairs: Vec<(f64, f64)>,
    /// The data of the fixed-size right-hand side, when it applies ([`small`]).
    small: Option<small::Small>,
    /// The unconstrained tree of a mechanism with couplings ([`Form::Geared`]).
    geared: Option<Box<reduce::Geared>>,
    /// Per speed, the nearest speed above it in the tree (`NONE` for a root's), when the
    /// right-hand side solves `M u̇ = F` by the tree's own factorisation
    /// ([`Kane::factor_solve_tree`]); `None`: the dense LDLᵀ.
    tree: Option<Vec<usize>>,
    // Work buffers.
    /// The joints of one ancestor walk, for [`Kane::residual_jacobian`] (capacity n).
    walk: Vec<usize>,
    state: Vec<BodyState>,
    /// q̇ (and, in the mapped form, the joint rates handed to the rates form).
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
        let (n, nb) = (mech.ndof(), mech.bodies.len());
        let parent = mech.parents();
        let internal = |message: String| Error::Model { mechanism: mech.name.clone(), message };
        for (j, p) in parent.iter().enumerate() {
            if p.is_some_and(|p| p >= j) {
                return Err(internal(format!("internal: joint `{}` is listed before its parent", mech.joints[j].name)));
            }
        }
        let joint_of: Vec<usize> = (0..n).map(|k| mech.joint_of(k)).collect();
        if joint_of.iter().any(|&j| j >= nb) || mech.joints.len() != nb {
            return Err(internal("internal: coordinates are not numbered 0..n over the joints".into()));
        }
        let mut c_ground = vec![0.0; nb];
        for g in &mech.loads.ground_dampers {
            c_ground[g.body] += g.c;
        }
        // Point forces grouped by body so each body's iteration finds its own.
        let mut point_forces = mech.loads.point_forces.clone();
        point_forces.sort_by_key(|p| p.body);
        let mut subtree_mass: Vec<f64> = mech.bodies.iter().map(|b| b.inertia.mass).collect();
        // The rollers belong to the subtree of their path joint's parent (not of the absorber).
        let rollers = mech.roller_sets();
        for set in &rollers {
            if let Some(p) = set.parent {
                subtree_mass[p] += set.rollers.total_mass();
            }
        }
        for j in (0..nb).rev() {
            if let Some(p) = parent[j] {
                subtree_mass[p] += subtree_mass[j];
            }
        }
        let mut nodes = Vec::with_capacity(nb);
        for j in 0..nb {
            let f0 = point_forces.iter().position(|p| p.body == j).unwrap_or(0);
            let f1 = f0 + point_forces.iter().filter(|p| p.body == j).count();
            let (b, jt) = (&mech.bodies[j], &mech.joints[j]);
            nodes.push(Node {
                parent: jt.parent.unwrap_or(GROUND_PARENT),
                coord: jt.coordinate.unwrap_or(NO_COORD),
                kind: jt.kind,
                mass: b.inertia.mass,
                i_com: b.inertia.i_com,
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
        // Each path joint's rollers, and their spread as a constant inertia of the path's parent.
        let mut satellites = Vec::with_capacity(rollers.len());
        for set in &rollers {
            let r = set.rollers;
            if let Some(p) = set.parent {
                nodes[p].i_com += r.spread_inertia();
                nodes[p].j_own += r.spread_inertia();
            }
            satellites.push(Satellite {
                parent: set.parent.unwrap_or(GROUND_PARENT),
                coord: set.coordinate,
                kind: set.kind,
                at: set.at,
                centre: set.centre,
                turn_rate: r.turn_rate(),
                mass: r.total_mass(),
                i_com: r.total_inertia(),
            });
        }
        let revolute = mech.joints.iter().all(|j| j.kind.rotates());
        let form = match mech.speeds {
            Speeds::JointRates => Form::Rates,
            Speeds::AbsoluteAngularVelocities if revolute => Form::Pairs,
            Speeds::AbsoluteAngularVelocities => Form::MappedRates,
        };
        let form = if mech.is_geared() { Form::Geared } else { form };
        let mut pairs = Vec::new();
        if form == Form::Pairs {
            for j in 0..nb {
                nodes[j].diag_abs += nodes[j].j_own;
                if let Some(p) = parent[j] {
                    let (mass, at) = (nodes[j].subtree_mass, nodes[j].at);
                    nodes[p].diag_abs += mass * at.norm_squared();
                    nodes[p].first_abs += mass * at;
                }
            }
            // For an ancestor k of body j (c: k's child on the path), every body of j's subtree
            // moves with u_k like a point at c's joint, so `M_kj = (R_k at_c)·(R_j S'_j)` with
            // both vectors constant in their own frames: with Δ = θ_j − θ_k,
            // `M_kj = α cos Δ − β sin Δ`, α = at_c·S'_j, β = at_c × S'_j.
            for j in 0..nb {
                let (mut c, mut k) = (j, parent[j]);
                while let Some(kk) = k {
                    let (at, first) = (nodes[c].at, nodes[j].first_abs);
                    pairs.push((at.dot(&first), cross2(at, first)));
                    (c, k) = (kk, parent[kk]);
                }
            }
        }
        let speed_parent = mech.speed_parents();
        let couplings = (0..nb)
            .filter_map(|j| {
                let jt = &mech.joints[j];
                let coord = jt.coordinate?;
                let absolute = mech.speeds == Speeds::AbsoluteAngularVelocities;
                let parent_speed = if absolute { speed_parent[coord] } else { None };
                (!jt.couplings.is_empty()).then(|| Coupled { coord, parent_speed, law: jt.couplings.clone() })
            })
            .collect();
        let mut k = Kane {
            couplings,
            mech: mech.clone(),
            pairs,
            small: None,
            geared: None,
            tree: None,
            n,
            nb,
            speed_parent,
            joint_of,
            speeds: mech.speeds,
            form,
            world,
            gravity: mech.loads.gravity,
            nodes,
            rollers: satellites,
            point_forces,
            torques: mech.loads.joint_torques.clone(),
            state: vec![BodyState::default(); nb],
            qdot: vec![0.0; n],
            walk: Vec::with_capacity(nb),
            m: vec![0.0; n * n],
            f: vec![0.0; n],
            l: vec![0.0; n * n],
            d_inv: vec![0.0; n],
            row: vec![0.0; n],
            m_out: DMatrix::zeros(n, n),
            f_out: DVector::zeros(n),
        };
        if form == Form::Geared {
            k.geared = Some(Box::new(reduce::Geared::new(mech, world)?));
        }
        let mut zeros = vec![0.0; n];
        k.evaluate(0.0, &zeros, &zeros, false);
        k.factor_solve(&mut zeros)?;
        k.small = k.small_form();
        k.tree = k.tree_order();
        Ok(k)
    }

    /// The speeds' tree (each speed's nearest speed above it) when the right-hand side should
    /// factorise M along it: M of a tree is nonzero only between a speed and its ancestors, so
    /// the leaves-first factorisation costs Σ_k (depth_k + 1)² instead of the dense n³/6, and
    /// is chosen beyond the fixed-size instances (n > 6) where it halves the work at least (a
    /// rotor with 8 pendulums on: measured in BENCHMARKS.md). A geared mechanism's reduced M couples across branches: dense.
    fn tree_order(&self) -> Option<Vec<usize>> {
        let n = self.n;
        if n <= 6 || self.form == Form::Geared {
            return None;
        }
        let mut above = vec![NONE; n];
        let mut cost = 0.0;
        for (k, up) in above.iter_mut().enumerate() {
            let mut b = self.nodes[self.joint_of[k]].parent;
            while b != GROUND_PARENT && self.nodes[b].coord == NO_COORD {
                b = self.nodes[b].parent;
            }
            if b != GROUND_PARENT {
                *up = self.nodes[b].coord;
                if *up >= k {
                    return None;
                }
            }
        }
        for k in 0..n {
            let (mut depth, mut a) = (1.0, above[k]);
            while a != NONE {
                depth += 1.0;
                a = above[a];
            }
            cost += depth * depth;
        }
        let dense = (n * n * n) as f64 / 6.0;
        (2.0 * cost < dense).then_some(above)
    }

    /// The fixed-size right-hand side when it applies; never with couplings, whose forces only
    /// the general forms add ([`Kane::add_couplings`]).
    fn small_form(&self) -> Option<small::Small> {
        // Rollers take the general forms too (`Kane::add_rollers`).
        if self.couplings.is_empty() && self.rollers.is_empty() { small::Small::new(self) } else { None }
    }

    /// True when the right-hand side solves `M u̇ = F` along the tree (the leaves-first
    /// factorisation of [`crate::kane::ldlt`]), false when by the dense LDLᵀ; chosen at build.
    pub fn factorises_along_tree(&self) -> bool {
        self.tree.is_some()
    }

    /// Makes the right-hand side use the dense LDLᵀ whatever the tree (for checks and benchmarks
    /// of the two routes against each other).
    pub fn use_dense_factorisation(&mut self) {
        self.tree = None;
    }

    /// True when some joint has nonlinear couplings ([`crate::model::coupling`]).
    pub fn has_couplings(&self) -> bool {
        !self.couplings.is_empty()
    }

    /// The couplings' generalized forces added to F (in the speeds), in the one place every form
    /// goes through: τ(q_k, q̇_k) acts +τ on the child and −τ on the parent, so its generalized
    /// force is τ for the joint rate q̇_k, and with absolute angular velocities (q̇_k = u_k − u_p)
    /// +τ in row k and −τ in row p (Bᵀ applied to the joint-rate force, as for a spring).
    #[inline(never)]
    fn add_couplings(&mut self, q: &[f64], u: &[f64]) {
        for c in &self.couplings {
            let qd = u[c.coord] - c.parent_speed.map_or(0.0, |p| u[p]);
            let tau = c.law.torque(q[c.coord], qd);
            self.f[c.coord] += tau;
            if let Some(p) = c.parent_speed {
                self.f[p] -= tau;
            }
        }
    }

    /// Adds the couplings' exact local derivatives to the Jacobians of F (row-major n × n, in
    /// the speeds): `∂F/∂q` gets ∂τ/∂q (the local stiffness, with sign), `∂F/∂u` gets ∂τ/∂q̇
    /// mapped by `q̇_k = u_k − u_p`. At a stage breakpoint the stiffness of the stage beginning
    /// there; friction at q̇ = 0 gives the viscous slope −T_f/ε.
    pub fn add_coupling_jacobians(&self, q: &[f64], u: &[f64], f_q: &mut [f64], f_u: &mut [f64]) {
        self.coupling_jacobians(q, u, f_q, f_u, 1.0);
    }

    /// `sign` times the couplings' derivatives of F added to `f_q`, `f_u` (−1: of the residual
    /// `M u̇ − F`).
    fn coupling_jacobians(&self, q: &[f64], u: &[f64], f_q: &mut [f64], f_u: &mut [f64], sign: f64) {
        let n = self.n;
        for c in &self.couplings {
            let k = c.coord;
            let qd = u[k] - c.parent_speed.map_or(0.0, |p| u[p]);
            let (_, dq, dv) = c.law.torque_and_slopes(q[k], qd);
            let (dq, dv) = (sign * dq, sign * dv);
            f_q[k * n + k] += dq;
            f_u[k * n + k] += dv;
            if let Some(p) = c.parent_speed {
                f_q[p * n + k] -= dq;
                f_u[k * n + p] -= dv;
                f_u[p * n + k] -= dv;
                f_u[p * n + p] += dv;
            }
        }
    }

    /// Takes the couplings out of the evaluator (F without them), to be put back with
    /// [`Kane::restore_couplings`]: for derivatives taken by differences of the smooth part
    /// while the couplings' own derivatives are added exactly ([`Kane::add_coupling_jacobians`]).
    pub fn suspend_couplings(&mut self) -> CouplingsSuspended {
        CouplingsSuspended(std::mem::take(&mut self.couplings))
    }

    /// Puts back couplings taken out by [`Kane::suspend_couplings`].
    pub fn restore_couplings(&mut self, s: CouplingsSuspended) {
        self.couplings = s.0;
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
    /// had none). Springs and dampers are not affected. A joint without coordinate (`Fixed`) has
    /// nothing for a torque to drive, so the call is ignored there.
    pub fn set_joint_torque(&mut self, joint: usize, excitation: Excitation) {
        self.set_geared_torque(joint, &excitation);
        if self.nodes.get(joint).is_none_or(|nd| nd.coord == NO_COORD) {
            return;
        }
        match self.torques.iter_mut().find(|t| t.joint == joint) {
            Some(t) => t.excitation = excitation,
            None => self.torques.push(JointTorque { joint, excitation }),
        }
        // The fixed-size path maps each speed to its torque's place in the list.
        if self.small.is_some() {
            self.small = self.small_form();
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
    /// (`m[r·n + c]`) and F. It skips the copy into nalgebra types, a measurable share of a
    /// harmonic-balance branch (one copy per engine call; BENCHMARKS.md).
    pub fn mass_matrix_and_forcing_rows(&mut self, t: f64, q: &[f64], u: &[f64]) -> (&[f64], &[f64]) {
        self.evaluate(t, q, u, true);
        (&self.m, &self.f)
    }

    /// True when [`Kane::residual_jacobian`] applies: absolute angular velocities on a tree of
    /// revolute joints (the pair form), no gravity, no point forces.
    pub fn has_residual_jacobian(&self) -> bool {
        let gravity = self.world && self.gravity != Vec2::zeros();
        self.form == Form::Pairs && !gravity && self.point_forces.is_empty()
    }

    /// `q̇ = W⁻¹ u` (rad/s for angles, m/s for slides).
    pub fn qdot(&mut self, u: &[f64]) -> &[f64] {
        self.speeds.qdot(&self.speed_parent, u, &mut self.qdot);
        &self.qdot
    }

    /// The state derivative `ẋ = [W⁻¹u; M⁻¹F]` for `x = [q; u]`. No heap allocation.
    pub fn rhs(&mut self, t: f64, x: &[f64], xdot: &mut [f64]) -> Result<(), EngineError> {
        self.check_lengths(x, xdot)?;
        // NOTE: the fixed-size path's instance for this n was chosen at build: one indirect call
        // instead of a dispatch on n per call (measured, BENCHMARKS.md).
        if let Some(s) = &self.small {
            return (s.rhs)(self, t, x, xdot);
        }
        self.rhs_general(t, x, xdot)
    }

    #[inline(always)]
    fn check_lengths(&self, x: &[f64], xdot: &[f64]) -> Result<(), EngineError> {
        let n = self.n;
        if x.len() != 2 * n || xdot.len() != 2 * n {
            let (what, got) = if x.len() != 2 * n { ("state x", x.len()) } else { ("derivative ẋ", xdot.len()) };
            return Err(EngineError::Dimension { what, got, expected: 2 * n });
        }
        Ok(())
    }

    /// [`Kane::rhs`] by the general forms.
    ///
    /// NOTE: out of line, so that its large frame (every form, for every literal n) is not set
    /// up and torn down around the fixed-size path (measured, BENCHMARKS.md).
    #[inline(never)]
    fn rhs_general(&mut self, t: f64, x: &[f64], xdot: &mut [f64]) -> Result<(), EngineError> {
        // Checked again here so the compiler knows x has 2N entries in the literal instances
        // and drops the slices' range checks.
        self.check_lengths(x, xdot)?;
        // NOTE: dispatched on n itself (not on a copy of it), for the same reason.
        let n = self.n;
        let out = if self.nb == n { with_literal_n!(n, self.rhs_n(t, x, xdot)) } else { self.rhs_n::<0>(t, x, xdot) };
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
    fn rhs_n<const N: usize>(&mut self, t: f64, x: &[f64], xdot: &mut [f64]) -> Result<(), EngineError> {
        let n = if N == 0 { self.n } else { N };
        let (q, u) = x.split_at(n);
        self.evaluate_n::<N>(t, q, u, true);
        let (qd, ud) = xdot.split_at_mut(n);
        // Each body's record holds its joint's rate; with fixed joints, bodies and coordinates differ.
        if N != 0 || self.nb == n {
            for (qd, st) in qd.iter_mut().zip(&self.state[..n]) {
                *qd = st.qdot;
            }
        } else {
            for (qd, &j) in qd.iter_mut().zip(&self.joint_of) {
                *qd = self.state[j].qdot;
            }
        }
        if N == 0 && self.tree.is_some() {
            self.factor_solve_tree(ud)?;
        } else {
            self.factor_solve_n::<N>(ud)?;
        }
        Ok(())
    }

    /// Evaluates M (and F, q̇ when `forcing`; only then are `u` and `t` read) into the buffers,
    /// by the form chosen at build (see the module doc). Only entries (k, l) with one an ancestor
    /// of the other are written: the others are zero for a tree and stay as allocated.
    fn evaluate(&mut self, t: f64, q: &[f64], u: &[f64], forcing: bool) {
        if self.nb == self.n {
            with_literal_n!(self.n, self.evaluate_n(t, q, u, forcing))
        } else {
            self.evaluate_n::<0>(t, q, u, forcing)
        }
    }

    /// The body of `Kane::evaluate` for `N` degrees of freedom (`N = 0`: any, read at run time).
    ///
    /// NOTE: a literal n lets the compiler unroll the loops and drop most bounds checks for the
    /// small mechanisms that dominate torsional work.
    #[inline(always)]
    fn evaluate_n<const N: usize>(&mut self, t: f64, q: &[f64], u: &[f64], forcing: bool) {
        // NOTE: one test of the form per call, outside the loops (measured against testing the
        // speed choice inside them; BENCHMARKS.md).
        match self.form {
            Form::Pairs => self.evaluate_absolute::<N>(t, q, u, forcing),
            Form::Rates => {
                self.evaluate_rates::<N>(t, q, u, forcing);
                if !self.rollers.is_empty() {
                    self.add_rollers(q, u, forcing);
                }
            }
            Form::MappedRates => self.evaluate_mapped(t, q, u, forcing),
            Form::Geared => self.evaluate_geared(t, q, u, forcing),
        }
        if forcing && !self.couplings.is_empty() {
            self.add_couplings(q, u);
        }
    }

    /// [`Form::MappedRates`]: the joint-rate form at `q̇ = W⁻¹u`, mapped to the speeds.
    ///
    /// NOTE: kept out of line so the code of this rarer form does not crowd the pair form's
    /// registers in the hot, literal-n evaluation (measured, BENCHMARKS.md).
    #[inline(never)]
    fn evaluate_mapped(&mut self, t: f64, q: &[f64], u: &[f64], forcing: bool) {
        let mut rates = std::mem::take(&mut self.qdot);
        if forcing {
            self.speeds.qdot(&self.speed_parent, &u[..self.n], &mut rates);
        }
        self.evaluate_rates::<0>(t, q, &rates, forcing);
        if !self.rollers.is_empty() {
            self.add_rollers(q, &rates, forcing);
        }
        self.qdot = rates;
        self.map_rates_to_speeds(forcing);
    }

    /// Maps M and F from joint rates to absolute angular velocities: with `q̇ = B u`,
    /// `M ← Bᵀ M B` and `F ← Bᵀ F`. B has ones on the diagonal and `B[k][p] = −1` for each
    /// coordinate k with speed parent p < k, so column (then row) p takes away column (row) k,
    /// in increasing k so that every column subtracted is still the original one.
    fn map_rates_to_speeds(&mut self, forcing: bool) {
        let n = self.n;
        let (m, f) = (&mut self.m[..n * n], &mut self.f[..n]);
        for k in 0..n {
            if let Some(p) = self.speed_parent[k] {
                for r in 0..n {
                    m[r * n + p] -= m[r * n + k];
                }
            }
        }
        for k in 0..n {
            if let Some(p) = self.speed_parent[k] {
                for c in 0..n {
                    m[p * n + c] -= m[k * n + c];
                }
                if forcing {
                    f[p] -= f[k];
                }
            }
        }
        // Bᵀ M B is symmetric, but the two passes round its halves differently: mirror the lower.
        for r in 0..n {
            for c in 0..r {
                m[c * n + r] = m[r * n + c];
            }
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
}
