//! The numeric Kane engine: `M(q) u̇ = F(q, u, t)` and `ẋ = [W⁻¹u; M⁻¹F]` for any tree of the
//! joint kinds of [`crate::model::joint::JointKind`].
//!
//! The method (docs/design/kane.md) is Kane's: forward kinematics, the partial velocities
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
//! chosen when the model is built) with the same results, and a rotor carrying one path absorber
//! a pair form of its own (`path_pair`, equal to rounding).
//!
//! [`ldlt`] factors M and solves for u̇ (dense), [`tree`] along the tree's branches;
//! [`articulated`] solves for u̇ without forming M (Featherstone's articulated-body algorithm,
//! O(n), chosen at build for deep trees); [`mapped`]
//! takes the composite-body form to absolute speeds, [`couplings`] adds the joints' nonlinear
//! couplings, [`reduce`](mod@reduce) reduces a geared tree to its independent speeds, [`reactions`]
//! gives the joint reactions and [`kinematics`] world-frame poses, velocities and energies for
//! outputs and tests.
//!
//! Every vector is expressed in one basis per subtree. When no load needs the world orientation
//! (no gravity, no world-frame force), that basis is a revolute root body's own frame: its angle
//! is cyclic, so its sine and cosine are never computed (one `sin_cos` fewer per call for a
//! rotor, and no loss of precision when the spin angle grows to 10⁴ rad in a long sweep). Dot
//! products, hence M and F, do not depend on the basis.
//!
//! # Model and workspace
//!
//! What is fixed once the mechanism is known is the [`Model`]: the mechanism, its dimensions, the
//! per-body records, the rollers, the pair coefficients, the fixed-size form's packed data, the
//! geared reduction, the tree order and the loads. What one evaluation writes is a [`Workspace`]:
//! every buffer, sized from the model when it is made, so evaluating allocates nothing. Every
//! form is a function of `(&Model, &mut Workspace, state)` (methods of [`Model`] taking the
//! workspace; the fixed-size forms keep their storage on the stack and read the model only), one
//! form per file. A [`Kane`] is the handle most callers want: an `Arc<Model>` and its own
//! workspace. Cloning a `Kane` shares the model and makes fresh buffers; parallel callers build
//! the model once and give each task a [`Kane::with_model`].
//!
//! Three things change after a build, and each is kept where it preserves both the semantics and
//! the right-hand side's instruction count:
//!
//! - the applied joint torques ([`Kane::set_joint_torque`]) and the choice of the dense
//!   factorisation ([`Kane::use_dense_factorisation`]) are part of the model, changed by copy on
//!   write (`Arc::make_mut`): the fixed-size forms pack each speed's torque index with the rest
//!   of their constants, and whether such a form applies at all (and, for a rotor carrying one
//!   path absorber, whether its pair form reproduces the general one) depends on the torque list,
//!   so moving the torques into the workspace would move a choice of form there too and make
//!   the right-hand side read its constants from two places. Both are set-up steps, made before
//!   a run; a handle whose model is shared gets its own copy on the first change, the others
//!   keep theirs;
//! - the suspension of the couplings ([`Kane::suspend_couplings`]) is a flag of the workspace:
//!   it is toggled around every difference Jacobian of the linear analysis, where a copy of the
//!   model per toggle would allocate, and the flag is only read on the general forms' path of a
//!   mechanism that has couplings (which never takes the fixed-size forms).

use crate::error::{EngineError, Result};
use crate::model::coupling::Couplings;
use crate::model::excitation::Excitation;
use crate::model::joint::JointKind;
use crate::model::loads::{JointTorque, PointForce};
use crate::model::math::Vec2;
use crate::model::mechanism::Mechanism;
use crate::model::speeds::Speeds;
use nalgebra::{DMatrix, DVector};
use std::sync::Arc;

pub use couplings::CouplingsSuspended;

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
pub mod articulated;
mod axial;
mod build;
pub mod couplings;
mod dispatch;
pub mod kinematics;
pub mod ldlt;
pub mod mapped;
mod path_pair;
pub mod rates;
pub mod reactions;
pub mod reduce;
pub mod reference;
mod small;
mod small_rates;
mod star;
pub mod tree;

/// The inputs of the vectorised passes' bit-equality tests (`axial`, `star`): `len` smooth,
/// distinct values per seed `a`, and whether the processor runs the AVX2 builds at all.
#[cfg(all(test, target_arch = "x86_64"))]
mod vector_tests {
    /// `((i + 1) a).sin() (1 + a)` for i < `len`.
    pub(super) fn series(len: usize, a: f64) -> Vec<f64> {
        (0..len).map(|i| ((i as f64 + 1.0) * a).sin() * (1.0 + a)).collect()
    }

    /// True where the AVX2 builds can be run and compared.
    pub(super) fn avx2() -> bool {
        std::arch::is_x86_feature_detected!("avx2")
    }
}

/// Largest number of speeds served by the fixed-size right-hand sides ([`small`], [`small_rates`]).
const SMALL: usize = 6;

/// In the fixed-size forms: a speed without applied joint torque, a missing parent or speed
/// parent.
const NONE: usize = usize::MAX;

/// An instance of a fixed-size right-hand side for one literal n.
type SmallRhs = fn(&Model, f64, &[f64], &mut [f64]) -> Result<(), EngineError>;

/// `Σ a_k b_k` over the shorter of the two slices.
#[inline(always)]
fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).fold(0.0, |s, (x, y)| s + x * y)
}

/// Which regrouping of Kane's sums evaluates this mechanism (see the module doc).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Form {
    /// Absolute angular velocities on a purely revolute tree: `Model::evaluate_absolute`.
    Pairs,
    /// Joint rates: `Model::evaluate_rates`.
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

/// A path joint's rollers as the engine carries them (docs/design/paths.md, "Rollers"): one rigid
/// body hanging from the path's parent and moved by the path's coordinate
/// ([`JointKind`]'s `roller_motion`); its terms are added by `Model::add_rollers` (`rates.rs`).
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

/// The built, read-only part of the engine for one mechanism (see the module doc): everything
/// the forms read and never write. Shared between threads in an `Arc` ([`Kane::model`],
/// [`Kane::with_model`]); each thread evaluates it with a [`Workspace`] of its own.
#[derive(Debug, Clone)]
pub struct Model {
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
    /// The coordinates with nonlinear couplings ([`couplings`]).
    couplings: Vec<Coupled>,
    /// Absolute speeds: the constant coefficients `(α, β)` of every ancestor pair (k, j), in the
    /// order the forward pass walks them (j ascending, then k from j's parent up to the root); see
    /// `Model::evaluate_absolute`.
    pairs: Vec<(f64, f64)>,
    /// The data of the fixed-size right-hand side, when it applies ([`small`]).
    small: Option<small::Small>,
    /// The unconstrained tree of a mechanism with couplings ([`Form::Geared`]).
    geared: Option<Box<reduce::Geared>>,
    /// Per speed, the nearest speed above it in the tree (`NONE` for a root's), when the
    /// right-hand side solves `M u̇ = F` by the tree's own factorisation ([`tree`]); `None`: the
    /// dense LDLᵀ.
    tree: Option<Vec<usize>>,
    /// True when `tree` is roots and leaves alone ([`Model::is_star`]), solved by
    /// `Model::factor_solve_star`.
    star: bool,
    /// The packed constants of the one-pass right-hand side of a rotor carrying leaves
    /// ([`star`]), used while `tree` is kept and the articulated route is not forced.
    fast_star: Option<star::Star>,
    /// The constants of the one-pass right-hand side of bodies on one axis carrying leaves
    /// ([`axial`]), taken where `fast_star` is not.
    fast_axial: Option<axial::Axial>,
    /// True when the right-hand side takes the articulated-body route ([`articulated`]),
    /// which never forms M; it then ignores `tree`.
    articulated: bool,
    /// Per body, the index in `rollers` of the rollers its path joint moves (`NONE`: none), for
    /// the articulated-body route; `None` when some path joint had two sets (that route is then
    /// not taken).
    roller_of: Option<Vec<usize>>,
}

/// The buffers one evaluation of a [`Model`] writes, sized from it once ([`Workspace::new`]):
/// one per thread. Evaluating with it does no heap allocation.
#[derive(Debug, Clone)]
pub struct Workspace {
    /// The joints of one ancestor walk, for `Model::residual_jacobian` (capacity n).
    walk: Vec<usize>,
    state: Vec<BodyState>,
    /// q̇ (and, in the mapped form, the joint rates handed to the rates form).
    qdot: Vec<f64>,
    m: Vec<f64>,
    f: Vec<f64>,
    l: Vec<f64>,
    d_inv: Vec<f64>,
    row: Vec<f64>,
    /// The joint angles' sines and cosines, for the forms that take them all at once.
    sin: Vec<f64>,
    cos: Vec<f64>,
    m_out: DMatrix<f64>,
    f_out: DVector<f64>,
    /// The unconstrained tree's buffers of a geared mechanism.
    geared: Option<Box<reduce::GearedWork>>,
    /// F without the couplings' forces ([`Kane::suspend_couplings`]).
    couplings_suspended: bool,
    /// The articulated-body route's records, one per body ([`articulated`]).
    aba: Vec<articulated::Articulated>,
}

impl Workspace {
    /// Buffers sized for `model`.
    pub fn new(model: &Model) -> Self {
        let (n, nb) = (model.n, model.nb);
        Workspace {
            state: vec![BodyState::default(); nb],
            qdot: vec![0.0; n],
            walk: Vec::with_capacity(nb),
            m: vec![0.0; n * n],
            f: vec![0.0; n],
            l: vec![0.0; n * n],
            d_inv: vec![0.0; n],
            row: vec![0.0; n],
            sin: vec![0.0; n],
            cos: vec![0.0; n],
            m_out: DMatrix::zeros(n, n),
            f_out: DVector::zeros(n),
            geared: model.geared.as_deref().map(|g| Box::new(g.workspace())),
            couplings_suspended: false,
            aba: vec![articulated::Articulated::default(); nb],
        }
    }
}

/// The equation-of-motion evaluator of one mechanism: a shared, read-only [`Model`] and this
/// handle's own [`Workspace`]. `Clone` shares the model and makes fresh buffers (keeping the
/// couplings' suspension).
#[derive(Debug)]
pub struct Kane {
    model: Arc<Model>,
    work: Workspace,
}

impl Clone for Kane {
    fn clone(&self) -> Self {
        let mut work = Workspace::new(&self.model);
        work.couplings_suspended = self.work.couplings_suspended;
        Kane { model: Arc::clone(&self.model), work }
    }
}

impl Kane {
    /// Builds the evaluator and checks that M is positive definite at q = 0.
    pub fn new(mech: &Mechanism) -> Result<Self> {
        let (model, work) = Model::build(mech, mech.loads.needs_world_orientation())?;
        Ok(Kane { model: Arc::new(model), work })
    }

    /// Like [`Kane::new`], but always expresses vectors in the world frame (every angle's
    /// trigonometry is evaluated). Results are identical up to rounding; for tests and for
    /// world-frame outputs.
    pub fn new_world_frame(mech: &Mechanism) -> Result<Self> {
        let (model, work) = Model::build(mech, true)?;
        Ok(Kane { model: Arc::new(model), work })
    }

    /// An evaluator of an already built (shared) model, with buffers of its own: how parallel
    /// tasks share one build.
    pub fn with_model(model: Arc<Model>) -> Self {
        let work = Workspace::new(&model);
        Kane { model, work }
    }

    /// The built model this evaluator reads, to share with other threads ([`Kane::with_model`]).
    pub fn model(&self) -> &Arc<Model> {
        &self.model
    }

    /// The model for a change after build: this handle's own copy once it is shared (the
    /// handles that share it keep theirs; see the module doc).
    fn model_mut(&mut self) -> &mut Model {
        Arc::make_mut(&mut self.model)
    }

    /// True when the right-hand side solves `M u̇ = F` along the tree (the leaves-first
    /// factorisation of [`crate::kane::tree`]), false when by the dense LDLᵀ; chosen at build.
    pub fn factorises_along_tree(&self) -> bool {
        self.model.factorises_along_tree()
    }

    /// Makes the right-hand side use the dense LDLᵀ whatever the tree (for checks and benchmarks
    /// of the two routes against each other).
    pub fn use_dense_factorisation(&mut self) {
        let model = self.model_mut();
        model.tree = None;
        model.articulated = false;
        model.fast_axial = None;
    }

    /// True when the right-hand side takes the one-pass evaluation and solve of a rotor carrying
    /// leaves (chosen at build for the pair form with
    /// more than six speeds, speed 0 spinning on the ground and every other body a leaf on it,
    /// no gravity, point forces or couplings); [`Kane::use_dense_factorisation`] and
    /// [`Kane::use_articulated_bodies`] turn it off.
    pub fn solves_rotor_and_leaves(&self) -> bool {
        self.model.fast_star.is_some() && self.model.solves_star()
    }

    /// Makes the right-hand side form M and solve it along the tree ([`crate::kane::tree`])
    /// where it would take the articulated-body route (for checks and benchmarks of the routes
    /// against each other); the dense LDLᵀ where the tree's factorisation does not pay.
    pub fn use_mass_matrix(&mut self) {
        let model = self.model_mut();
        model.articulated = false;
        model.fast_axial = None;
    }

    /// Makes the right-hand side take the articulated-body route ([`crate::kane::articulated`])
    /// wherever it applies (no geared couplings, at most one roller set per path joint),
    /// whatever the size and depth of the tree (for checks and benchmarks of the routes against
    /// each other). Returns whether it applies.
    pub fn use_articulated_bodies(&mut self) -> bool {
        if !self.model.articulated_applies() {
            return false;
        }
        let model = self.model_mut();
        model.articulated = true;
        model.fast_axial = None;
        true
    }

    /// True when the right-hand side takes the one-pass evaluation and solve of bodies on one
    /// axis carrying leaves ([`crate::kane`]'s `axial` form: the pair form, every inertial
    /// coupling between a body and a leaf pivoted off its axis, as on an elastic crankshaft with
    /// pendulums; chosen at build where the rotor-and-leaves pass does not apply);
    /// [`Kane::use_dense_factorisation`], [`Kane::use_mass_matrix`] and
    /// [`Kane::use_articulated_bodies`] turn it off.
    pub fn solves_axial(&self) -> bool {
        let m = &self.model;
        m.fast_axial.is_some() && !m.solves_star()
    }

    /// True when the right-hand side solves by the articulated-body algorithm
    /// ([`crate::kane::articulated`]), never forming M; chosen at build.
    pub fn solves_articulated(&self) -> bool {
        self.model.articulated
    }

    /// True when some joint has nonlinear couplings ([`crate::model::coupling`]) and they are not
    /// suspended ([`Kane::suspend_couplings`]).
    pub fn has_couplings(&self) -> bool {
        self.model.has_couplings() && !self.work.couplings_suspended
    }

    /// Adds the couplings' exact local derivatives to the Jacobians of F (row-major n × n, in
    /// the speeds): `∂F/∂q` gets ∂τ/∂q (the local stiffness, with sign), `∂F/∂u` gets ∂τ/∂q̇
    /// mapped by `q̇_k = u_k − u_p`. At a stage breakpoint the stiffness of the stage beginning
    /// there; friction at q̇ = 0 gives the viscous slope −T_f/ε. Nothing while the couplings are
    /// suspended.
    pub fn add_coupling_jacobians(&self, q: &[f64], u: &[f64], f_q: &mut [f64], f_u: &mut [f64]) {
        if !self.work.couplings_suspended {
            self.model.coupling_jacobians(q, u, f_q, f_u, 1.0);
        }
    }

    /// Takes the couplings out of the evaluator (F without them), to be put back with
    /// [`Kane::restore_couplings`]: for derivatives taken by differences of the smooth part
    /// while the couplings' own derivatives are added exactly ([`Kane::add_coupling_jacobians`]).
    pub fn suspend_couplings(&mut self) -> CouplingsSuspended {
        let was = std::mem::replace(&mut self.work.couplings_suspended, true);
        CouplingsSuspended { was_suspended: was }
    }

    /// Puts back couplings taken out by [`Kane::suspend_couplings`].
    pub fn restore_couplings(&mut self, s: CouplingsSuspended) {
        self.work.couplings_suspended = s.was_suspended;
    }

    /// The mechanism this evaluator was built from.
    pub fn mechanism(&self) -> &Mechanism {
        &self.model.mech
    }

    /// Number of degrees of freedom n (the state has 2n entries, `[q; u]`).
    pub fn ndof(&self) -> usize {
        self.model.n
    }

    /// Replaces the applied torque of joint `joint` (index) by `excitation` (adds one if the joint
    /// had none). Springs and dampers are not affected. A joint without coordinate (`Fixed`) has
    /// nothing for a torque to drive, so the call is ignored there. A shared model is copied
    /// first (see the module doc).
    pub fn set_joint_torque(&mut self, joint: usize, excitation: Excitation) {
        self.model_mut().set_joint_torque(joint, excitation);
    }

    /// The applied joint torques currently in effect.
    pub fn joint_torques(&self) -> &[JointTorque] {
        self.model.joint_torques()
    }

    /// The mass matrix M(q) (kg·m² for rotational speeds), symmetric positive definite.
    pub fn mass_matrix(&mut self, q: &[f64]) -> &DMatrix<f64> {
        // Without forcing, `u` and `t` are not read.
        self.model.evaluate(&mut self.work, 0.0, q, q, false);
        self.model.copy_out(&mut self.work);
        &self.work.m_out
    }

    /// The forcing vector F(q, u, t) of `M u̇ = F` (N·m for rotational speeds): applied forces
    /// minus the inertia forces at `u̇ = 0`.
    pub fn forcing(&mut self, t: f64, q: &[f64], u: &[f64]) -> &DVector<f64> {
        self.model.evaluate(&mut self.work, t, q, u, true);
        self.model.copy_out(&mut self.work);
        &self.work.f_out
    }

    /// Both M and F at one state.
    pub fn mass_matrix_and_forcing(&mut self, t: f64, q: &[f64], u: &[f64]) -> (&DMatrix<f64>, &DVector<f64>) {
        self.model.evaluate(&mut self.work, t, q, u, true);
        self.model.copy_out(&mut self.work);
        (&self.work.m_out, &self.work.f_out)
    }

    /// Like [`Kane::mass_matrix_and_forcing`], as slices into the engine's buffers: M row-major
    /// (`m[r·n + c]`) and F. It skips the copy into nalgebra types, a measurable share of a
    /// harmonic-balance branch (one copy per engine call; BENCHMARKS.md).
    pub fn mass_matrix_and_forcing_rows(&mut self, t: f64, q: &[f64], u: &[f64]) -> (&[f64], &[f64]) {
        self.model.evaluate(&mut self.work, t, q, u, true);
        (&self.work.m, &self.work.f)
    }

    /// True when [`Kane::residual_jacobian`] applies: absolute angular velocities on a tree of
    /// revolute joints (the pair form), no gravity, no point forces.
    pub fn has_residual_jacobian(&self) -> bool {
        self.model.has_residual_jacobian()
    }

    /// The residual `r = M(q) u̇ − F(q, u, t)` with its exact derivatives `∂r/∂q` and `∂r/∂u`
    /// (row-major n × n), and M (row-major) into `m_out`, for absolute angular velocities
    /// without gravity or point forces (`Model::residual_jacobian`, [`absolute`]). Returns false,
    /// writing nothing, for the other cases (joint-rate speeds, gravity, point forces):
    /// difference [`Kane::mass_matrix_and_forcing_rows`] there.
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
        self.model.residual_jacobian(&mut self.work, t, q, u, udot, r, dr_dq, dr_du, m_out)
    }

    /// `q̇ = W⁻¹ u` (rad/s for angles, m/s for slides).
    pub fn qdot(&mut self, u: &[f64]) -> &[f64] {
        self.model.speeds.qdot(&self.model.speed_parent, u, &mut self.work.qdot);
        &self.work.qdot
    }

    /// The state derivative `ẋ = [W⁻¹u; M⁻¹F]` for `x = [q; u]`. No heap allocation.
    pub fn rhs(&mut self, t: f64, x: &[f64], xdot: &mut [f64]) -> Result<(), EngineError> {
        let model = &*self.model;
        model.check_lengths(x, xdot)?;
        // NOTE: the fixed-size path's instance for this n was chosen at build: one indirect call
        // instead of a dispatch on n per call (measured, BENCHMARKS.md).
        if let Some(s) = &model.small {
            return (s.rhs)(model, t, x, xdot);
        }
        self.rhs_general(t, x, xdot)
    }

    /// [`Kane::rhs`] by the general forms (`Model::rhs_general`).
    ///
    /// NOTE: out of line, so that its large frame (every form, for every literal n) is not set
    /// up and torn down around the fixed-size path, and with `rhs`'s own arguments (the handle,
    /// not the model and the workspace apart): with one more argument `rhs` shuffled its
    /// registers on the fixed-size path too (measured, BENCHMARKS.md).
    #[inline(never)]
    fn rhs_general(&mut self, t: f64, x: &[f64], xdot: &mut [f64]) -> Result<(), EngineError> {
        self.model.rhs_general(&mut self.work, t, x, xdot)
    }

    /// The torque (N·m; N on a prismatic joint) each coupling's mesh exerts on its driven joint,
    /// in the mechanism's `gears` order (`Model::gear_torques`, [`reduce`](mod@reduce)): `udot`
    /// must be this engine's own accelerations at the state (from [`Kane::rhs`]). Empty without
    /// couplings.
    pub fn gear_torques(&mut self, t: f64, q: &[f64], u: &[f64], udot: &[f64]) -> Vec<f64> {
        self.model.gear_torques(&mut self.work, t, q, u, udot)
    }

    /// The unconstrained tree's model of a geared mechanism (`None` without couplings), for
    /// tests of the reduction and for its joint torques.
    pub fn unconstrained(&self) -> Option<&Model> {
        self.model.unconstrained()
    }

    /// Kane's partial velocities of body `j` at `q`, in the world frame, by the textbook route
    /// ([`reference::body_kinematics`]): `(v_{j,r}, ω_{j,r})` for r = 0..n. Allocates; for tests
    /// and reports.
    pub fn partial_velocities(&self, q: &[f64], j: usize) -> (Vec<Vec2>, Vec<f64>) {
        self.model.partial_velocities(q, j)
    }
}

impl Model {
    /// Builds the model of `mech` and checks that M is positive definite at q = 0; alone, for
    /// callers that share it before any handle evaluates it ([`Kane::with_model`]).
    pub fn new(mech: &Mechanism) -> Result<Self> {
        Ok(Self::build(mech, mech.loads.needs_world_orientation())?.0)
    }

    /// The mechanism this model was built from.
    pub fn mechanism(&self) -> &Mechanism {
        &self.mech
    }

    /// Number of degrees of freedom n (the state has 2n entries, `[q; u]`).
    pub fn ndof(&self) -> usize {
        self.n
    }

    /// The applied joint torques in effect.
    pub fn joint_torques(&self) -> &[JointTorque] {
        &self.torques
    }

    /// True when the right-hand side solves `M u̇ = F` along the tree ([`tree`]), false when by
    /// the dense LDLᵀ ([`ldlt`]).
    pub fn factorises_along_tree(&self) -> bool {
        self.tree.is_some()
    }

    /// True when some joint has nonlinear couplings ([`crate::model::coupling`]).
    pub fn has_couplings(&self) -> bool {
        !self.couplings.is_empty()
    }

    /// True when the rotor-and-leaves pass ([`star`]) serves the right-hand side, if built.
    fn solves_star(&self) -> bool {
        self.fast_star.is_some() && !self.articulated && self.tree.is_some()
    }

    /// True when `Model::residual_jacobian` applies: absolute angular velocities on a tree of
    /// revolute joints (the pair form), no gravity, no point forces.
    pub fn has_residual_jacobian(&self) -> bool {
        let gravity = self.world && self.gravity != Vec2::zeros();
        self.form == Form::Pairs && !gravity && self.point_forces.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::{Kane, Model};
    use crate::model::excitation::Excitation;
    use std::sync::Arc;

    fn cpva() -> crate::model::mechanism::Mechanism {
        crate::cpva::CpvaParams::canonical().with_pendulums(2).mechanism(None).unwrap()
    }

    /// Handles on one model, on other threads, give the handle's own ẋ to the bit; a clone
    /// shares the model, and a joint torque set on one handle copies the model for it alone.
    #[test]
    fn handles_share_the_model_and_copy_it_on_write() {
        let mut kane = Kane::new(&cpva()).unwrap();
        let x = [0.1, 0.3, -0.2, 100.0, 101.0, 99.5];
        let mut own = [0.0; 6];
        kane.rhs(0.25, &x, &mut own).unwrap();
        let model: Arc<Model> = Arc::clone(kane.model());
        let from_threads: Vec<[f64; 6]> = std::thread::scope(|s| {
            let tasks: Vec<_> = (0..2)
                .map(|_| {
                    let model = Arc::clone(&model);
                    s.spawn(move || {
                        let mut k = Kane::with_model(model);
                        let mut xdot = [0.0; 6];
                        k.rhs(0.25, &x, &mut xdot).unwrap();
                        xdot
                    })
                })
                .collect();
            tasks.into_iter().map(|t| t.join().unwrap()).collect()
        });
        assert!(from_threads.iter().all(|xd| *xd == own));
        let mut driven = kane.clone();
        assert!(Arc::ptr_eq(kane.model(), driven.model()));
        driven.set_joint_torque(0, Excitation::constant(50.0));
        assert!(!Arc::ptr_eq(kane.model(), driven.model()));
        let (mut after, mut other) = ([0.0; 6], [0.0; 6]);
        kane.rhs(0.25, &x, &mut after).unwrap();
        driven.rhs(0.25, &x, &mut other).unwrap();
        assert_eq!(after, own);
        assert_ne!(other, own);
    }

    /// Suspending the couplings belongs to the handle: the model and other handles keep them.
    #[test]
    fn suspended_couplings_are_the_handles_own() {
        let file = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/dmf.ron");
        let mech = crate::model::mechanism::Mechanism::from_file(&file).unwrap();
        let mut kane = Kane::new(&mech).unwrap();
        assert!(kane.has_couplings());
        let other = kane.clone();
        let s = kane.suspend_couplings();
        assert!(!kane.has_couplings() && other.has_couplings() && kane.model().has_couplings());
        kane.restore_couplings(s);
        assert!(kane.has_couplings());
    }
}
