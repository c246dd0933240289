//! Cyclic symmetry: the harmonic balance of N identical absorbers by one scaled representative
//! (the unison response) plus one small Floquet block per identical set (the non-unison, or
//! non-zero wavenumber, motions).
//!
//! # Method
//!
//! Take N identical subtrees (absorbers) hanging from one parent body whose origin is fixed in
//! the world (every joint from ground to it is revolute or fixed, and all but the root sit at
//! their parent's origin): same topology, joint kinds, masses, inertias, springs, dampers,
//! couplings and own torques, differing only by a rotation θ_j of their whole geometry about the
//! parent's origin (joint points, centres of mass, slide axes and path mounts turned by θ_j).
//! Without gravity or world-frame forces a member's equations do not depend on θ_j, and the
//! parent and every ancestor feel a member only through its torque about that fixed origin,
//! which does not depend on θ_j either. Hence:
//!
//! 1. **Unison.** In a motion where every member has the same coordinates, the ancestors feel N
//!    times one member. Every term of a member's equations (inertia, springs, dampers,
//!    couplings, own torques) is linear in its mass, inertia and force parameters, so one
//!    *representative* with all of them multiplied by N has N times one member's equations,
//!    which have the same solutions, and exerts N times its torque on the parent. The harmonic
//!    balance of the *reduced* mechanism (the others removed) is therefore the unison response
//!    exactly, not approximately; [`RoutedHbm`] expands each solution to the full mechanism
//!    (every member gets the representative's Fourier coefficients), so every consumer sees a
//!    full-size [`HbmSolution`].
//! 2. **Non-unison stability.** A member's rows of the variational equations
//!    `C δq̈ + B δq̇ + A δq = 0` involve only its own coordinates and its ancestors' (a speed's
//!    partial velocities are non-zero only on the bodies it moves, for joint rates and absolute
//!    angular velocities alike), and the ancestors' rows see the members only through
//!    `Σ_j δq_j`, each member entering with the same coefficients in unison. Deviations with
//!    `Σ_j δq_j = 0` and the ancestors held therefore solve the equations: each member then obeys
//!    `C_ss δq̈ + B_ss δq̇ + A_ss δq = 0` with its own rows and columns only, the same for every
//!    member and, up to the common factor N, the representative's rows and columns of the
//!    reduced problem. Its 2m multipliers (m coordinates per member) stand for the N − 1
//!    independent non-unison combinations (the wavenumbers k = 1..N−1 of the set's discrete
//!    Fourier transform), and the reduced problem's own multipliers are the unison ones: together
//!    `2(n_reduced) − 1 + 2m(N − 1) = 2n − 1`, the general route's count. Members are coupled only
//!    through the parent (a joint's spring, damper and couplings act inside it), so one block
//!    serves all k ≠ 0.
//!
//! The monodromy of the full problem has these multipliers with multiplicity N − 1; the general
//! route must resolve them from a 2n × 2n eigenproblem (and locates their crossings on the
//! repeated values), the cyclic route computes them once from a 2m × 2m one.
//!
//! # Detection
//!
//! [`detect`] groups the children of each eligible parent by their shape (subtree topology and
//! joint kinds). A group of two or more whose members are all identical to the first becomes a
//! [`CyclicSet`]; a group whose members are alike but not identical is a mistuned set, and the
//! whole mechanism takes the general route (it stays the reference), as it does with gravity or
//! a world-frame force, with gears, with a point force on a member, or with an excitation input
//! inside a member. Identical means: joint kinds, path shapes, couplings, rollers and own torques
//! equal; scalars (masses, inertias, stiffnesses, dampers, free angles, ground dampers) equal to
//! a relative 1e-12; vectors equal after the rotation θ_j (found from the first non-zero vector)
//! to 1e-12 of the members' largest vector. Splitting one mass over N pendulums, or placing
//! them by `cos`/`sin` of 2πj/N, differs from exact by a few roundings (≈1e-16 relative), far
//! inside; a deliberate mistuning of 1e-9 (to run the general solver on a set) is far outside.
//! The tolerance is harmless on the other side too: a difference of 1e-12 in a parameter moves
//! the solution and its (non-defective, symmetry-repeated) multipliers by O(1e-12), two
//! orders below Newton's tolerance.

use super::{Branch, ContinuationOptions, Hbm, HbmError, HbmOptions, HbmSolution, Parameter, Stability};
use crate::kane::Kane;
use crate::model::excitation::Harmonic;
use crate::model::loads::JointTorque;
use crate::model::math::{Vec2, rotate_cs};
use crate::model::mechanism::Mechanism;
use std::fmt;

/// Relative tolerance of the identity test (module docs, "Detection").
const TOL: f64 = 1e-12;

/// N identical absorbers on one parent body, solved by one representative.
#[derive(Debug, Clone, PartialEq)]
pub struct CyclicSet {
    /// The body the members hang from.
    pub parent: String,
    /// The members' inboard joints, the representative (the first in the mechanism) first.
    pub members: Vec<String>,
    /// Number m of coordinates of one member: its non-unison Floquet block is 2m × 2m.
    pub member_dof: usize,
}

impl fmt::Display for CyclicSet {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let last = self.members.last().map_or("", String::as_str);
        write!(f, "{} × {}…{} on {}", self.members.len(), self.members[0], last, self.parent)
    }
}

/// How a harmonic-balance problem is solved.
#[derive(Debug, Clone, PartialEq)]
pub enum Route {
    /// The whole mechanism, every coordinate an unknown (the reference).
    General {
        /// Why not cyclic, in words (no identical set, mistuned, gravity, …).
        reason: String,
    },
    /// Each identical set by one scaled representative (the unison response) and one Floquet
    /// block for its non-unison motions (module docs).
    Cyclic {
        /// The identical sets.
        sets: Vec<CyclicSet>,
    },
}

impl Route {
    /// `general` or `cyclic`.
    pub fn name(&self) -> &'static str {
        match self {
            Route::General { .. } => "general",
            Route::Cyclic { .. } => "cyclic",
        }
    }
}

impl fmt::Display for Route {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Route::General { reason } => write!(f, "general ({reason})"),
            Route::Cyclic { sets } => {
                let sets: Vec<String> = sets.iter().map(ToString::to_string).collect();
                write!(f, "cyclic ({})", sets.join("; "))
            }
        }
    }
}

/// The non-unison block of one identical set in a reduced problem: the representative's
/// coordinates (reduced numbering) and how many independent combinations it stands for.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct NonUnison {
    pub(crate) label: String,
    pub(crate) coordinates: Vec<usize>,
    pub(crate) multiplicity: usize,
}

/// Joints of the subtree below (and including) joint `j`, in index order.
fn subtree(mech: &Mechanism, j: usize) -> Vec<usize> {
    let mut inside = vec![false; mech.joints.len()];
    inside[j] = true;
    let mut out = vec![j];
    for i in j + 1..mech.joints.len() {
        if mech.joints[i].parent.is_some_and(|p| inside[p]) {
            inside[i] = true;
            out.push(i);
        }
    }
    out
}

/// The shape of a subtree: per joint, its parent's position in the list and its kind's variant.
fn shape(mech: &Mechanism, sub: &[usize]) -> Vec<(Option<usize>, &'static str)> {
    sub.iter()
        .map(|&j| {
            let joint = &mech.joints[j];
            let parent = joint.parent.and_then(|p| sub.iter().position(|&x| x == p));
            (parent, joint.kind.name())
        })
        .collect()
}

fn close(a: f64, b: f64) -> bool {
    a == b || (a - b).abs() <= TOL * a.abs().max(b.abs())
}

/// The vectors of a member that turn with it, in a fixed order (joint points, slide axes, path
/// mounts as unit vectors, centres of mass).
fn vectors(mech: &Mechanism, sub: &[usize]) -> Vec<Vec2> {
    let mut out = Vec::new();
    for &j in sub {
        let joint = &mech.joints[j];
        out.push(joint.at);
        out.extend(joint.kind.direction());
        out.push(mech.bodies[j].inertia.com);
    }
    out
}

/// Why member `d` is not member `c` turned about the parent's origin, or None when it is
/// (module docs, "Detection"); both subtrees have the same shape.
fn difference(mech: &Mechanism, torques: &[JointTorque], c: &[usize], d: &[usize]) -> Option<String> {
    let (vc, vd) = (vectors(mech, c), vectors(mech, d));
    let scale = vc.iter().chain(&vd).map(|v| v.norm()).fold(0.0, f64::max);
    // The turn θ from the first vector that is not zero.
    let theta =
        vc.iter().zip(&vd).find(|(a, _)| a.norm() > TOL * scale).map_or(0.0, |(a, b)| b.y.atan2(b.x) - a.y.atan2(a.x));
    let (s, co) = theta.sin_cos();
    let dname = &mech.joints[d[0]].name;
    let differs = |what: String| Some(format!("`{dname}` differs from `{}` in {what}", mech.joints[c[0]].name));
    for (k, (a, b)) in vc.iter().zip(&vd).enumerate() {
        if (rotate_cs(co, s, *a) - b).norm() > TOL * scale {
            return differs(format!("geometry (vector {k} of the member, turned by {theta:.6} rad)"));
        }
    }
    let damper = |b: usize| -> f64 { mech.loads.ground_dampers.iter().filter(|g| g.body == b).map(|g| g.c).sum() };
    for (&jc, &jd) in c.iter().zip(d) {
        let (a, b) = (&mech.joints[jc], &mech.joints[jd]);
        let (ba, bb) = (&mech.bodies[jc].inertia, &mech.bodies[jd].inertia);
        let name = &b.name;
        // The shapes agree (checked before); a path's curve and travel must too (its mount is
        // among the vectors that turn).
        let kinds_equal = match (a.kind.path(), b.kind.path()) {
            (Some(pa), Some(pb)) => pa.shape == pb.shape && pa.travel == pb.travel,
            _ => true,
        };
        if !kinds_equal {
            return differs(format!("the path of `{name}`"));
        }
        if !close(ba.mass, bb.mass) {
            return differs(format!("the mass of the body of `{name}` ({} vs {} kg)", bb.mass, ba.mass));
        }
        if !close(ba.i_com, bb.i_com) {
            return differs(format!("the inertia of the body of `{name}`"));
        }
        if !close(a.damper, b.damper) {
            return differs(format!("the damper of `{name}`"));
        }
        let springs = match (a.spring, b.spring) {
            (None, None) => true,
            (Some(x), Some(y)) => close(x.stiffness, y.stiffness) && close(x.free_angle, y.free_angle),
            _ => false,
        };
        if !springs {
            return differs(format!("the spring of `{name}`"));
        }
        if a.couplings != b.couplings || a.rollers != b.rollers {
            return differs(format!("the couplings or rollers of `{name}`"));
        }
        if !close(damper(jc), damper(jd)) {
            return differs(format!("the ground damper of the body of `{name}`"));
        }
        let own = |j: usize| torques.iter().find(|t| t.joint == j).map(|t| &t.excitation);
        if own(jc) != own(jd) {
            return differs(format!("the torque applied at `{name}`"));
        }
    }
    None
}

/// Whether body `p`'s origin stays fixed in the world: every joint from ground to it revolute or
/// fixed, and every one but the root at its parent's origin.
fn fixed_origin(mech: &Mechanism, p: usize) -> bool {
    mech.path_to(p).iter().all(|&j| {
        let joint = &mech.joints[j];
        joint.kind.keeps_origin() && (joint.parent.is_none() || joint.at == Vec2::zeros())
    })
}

/// The route for `mech` with the applied joint torques `torques` (the evaluator's, see
/// [`Kane::joint_torques`]), the spin joint `spin_joint` and the excitation inputs at the joints
/// `inputs`: cyclic when it holds identical sets and nothing breaks their symmetry (module docs,
/// "Detection"), else general with the reason.
pub fn detect(mech: &Mechanism, torques: &[JointTorque], spin_joint: usize, inputs: &[usize]) -> Route {
    let general = |reason: &str| Route::General { reason: reason.into() };
    if mech.loads.needs_world_orientation() {
        return general("gravity or a world-frame force");
    }
    if !mech.gears.is_empty() {
        return general("gears");
    }
    let mut sets = Vec::new();
    // Joints inside a set's members: a set nested in another's members is left to the general
    // equations of the reduced problem (its parent is then a representative), not reduced twice.
    let mut in_set = vec![false; mech.joints.len()];
    for p in 0..mech.bodies.len() {
        if in_set[p] || !fixed_origin(mech, p) {
            continue;
        }
        let children: Vec<usize> = (0..mech.joints.len()).filter(|&j| mech.joints[j].parent == Some(p)).collect();
        let subs: Vec<Vec<usize>> = children.iter().map(|&c| subtree(mech, c)).collect();
        let shapes: Vec<_> = subs.iter().map(|s| shape(mech, s)).collect();
        let mut grouped = vec![false; children.len()];
        for i in 0..children.len() {
            if grouped[i] {
                continue;
            }
            let group: Vec<usize> = (i..children.len()).filter(|&k| !grouped[k] && shapes[k] == shapes[i]).collect();
            for &k in &group {
                grouped[k] = true;
            }
            if group.len() < 2 {
                continue;
            }
            let members: Vec<&Vec<usize>> = group.iter().map(|&k| &subs[k]).collect();
            let excited = |s: &Vec<usize>| s.iter().any(|j| inputs.contains(j) || *j == spin_joint);
            if members.iter().any(|s| excited(s)) {
                return general("an excitation input inside a set of alike absorbers");
            }
            let loaded = |s: &Vec<usize>| s.iter().any(|&j| mech.loads.point_forces.iter().any(|f| f.body == j));
            if members.iter().any(|s| loaded(s)) {
                return general("a point force on one of a set of alike absorbers");
            }
            for m in &members[1..] {
                if let Some(why) = difference(mech, torques, members[0], m) {
                    return Route::General { reason: format!("mistuned: {why}") };
                }
            }
            for &j in members.iter().flat_map(|s| s.iter()) {
                in_set[j] = true;
            }
            sets.push(CyclicSet {
                parent: mech.bodies[p].name.clone(),
                members: members.iter().map(|s| mech.joints[s[0]].name.clone()).collect(),
                member_dof: members[0].iter().filter(|&&j| mech.joints[j].coordinate.is_some()).count(),
            });
        }
    }
    if sets.is_empty() { general("no identical absorbers") } else { Route::Cyclic { sets } }
}

/// The reduced mechanism of a cyclic route and the maps between it and the full one.
#[derive(Debug, Clone)]
struct Reduction {
    mech: Mechanism,
    /// Full joint → reduced joint (a member's joint → the representative's).
    joint_map: Vec<usize>,
    /// Full coordinate → reduced coordinate.
    coord_map: Vec<usize>,
    /// Reduced coordinate → a full coordinate it stands for (the representative's own).
    coord_back: Vec<usize>,
    non_unison: Vec<NonUnison>,
}

/// The reduced mechanism: each set's first member with its mass, inertia, springs, dampers,
/// couplings, rollers, own torques and ground dampers multiplied by N, the others removed.
fn reduce(mech: &Mechanism, torques: &[JointTorque], sets: &[CyclicSet]) -> Reduction {
    let nj = mech.joints.len();
    let mut joint_map: Vec<usize> = (0..nj).collect();
    let mut removed = vec![false; nj];
    let mut scale = vec![1.0; nj];
    let mut reps = Vec::new();
    for set in sets {
        let idx = |name: &String| mech.joint_index(name).unwrap_or(usize::MAX);
        let rep = subtree(mech, idx(&set.members[0]));
        let n = set.members.len() as f64;
        for &j in &rep {
            scale[j] = n;
        }
        for m in &set.members[1..] {
            for (&jm, &jr) in subtree(mech, idx(m)).iter().zip(&rep) {
                removed[jm] = true;
                joint_map[jm] = jr;
            }
        }
        reps.push((rep, set.members.len()));
    }
    // Kept joints renumbered in order (parents stay first).
    let mut new_index = vec![usize::MAX; nj];
    let mut next = 0;
    for j in 0..nj {
        if !removed[j] {
            new_index[j] = next;
            next += 1;
        }
    }
    for j in 0..nj {
        joint_map[j] = new_index[joint_map[j]];
    }
    let mut out = mech.clone();
    out.name = format!("{}_cyclic", mech.name);
    for j in 0..nj {
        let s = scale[j];
        if s == 1.0 {
            continue;
        }
        let (body, joint) = (&mut out.bodies[j].inertia, &mut out.joints[j]);
        body.mass *= s;
        body.i_com *= s;
        joint.damper *= s;
        if let Some(sp) = &mut joint.spring {
            sp.stiffness *= s;
        }
        let c = &mut joint.couplings;
        if let Some(st) = &mut c.stages {
            for stage in st.drive.iter_mut().chain(st.coast.iter_mut().flatten()) {
                stage.stiffness *= s;
            }
        }
        if let Some(f) = &mut c.friction {
            f.torque *= s;
        }
        if let Some(e) = &mut c.stops {
            e.stiffness *= s;
            e.damping *= s;
        }
        if let Some(r) = &mut joint.rollers {
            r.mass *= s;
            r.inertia *= s;
        }
    }
    for g in &mut out.loads.ground_dampers {
        g.c *= scale[g.body];
    }
    out.loads.ground_dampers.retain(|g| !removed[g.body]);
    for g in &mut out.loads.ground_dampers {
        g.body = new_index[g.body];
    }
    // Point forces never sit on members (`detect`), only their indices move.
    for f in &mut out.loads.point_forces {
        f.body = new_index[f.body];
    }
    let reduced_torques: Vec<JointTorque> = torques
        .iter()
        .filter(|t| !removed[t.joint])
        .map(|t| {
            let s = scale[t.joint];
            let mut e = t.excitation.clone();
            e.mean *= s;
            for h in &mut e.harmonics {
                h.amplitude *= s;
            }
            JointTorque { joint: new_index[t.joint], excitation: e }
        })
        .collect();
    // The evaluator's torques (they may differ from the file's), scaled and renumbered.
    out.loads.joint_torques = reduced_torques;
    let keep: Vec<usize> = (0..nj).filter(|&j| !removed[j]).collect();
    out.bodies = keep.iter().map(|&j| out.bodies[j].clone()).collect();
    out.joints = keep.iter().map(|&j| out.joints[j].clone()).collect();
    let mut k = 0;
    for joint in &mut out.joints {
        joint.parent = joint.parent.map(|p| new_index[p]);
        if joint.coordinate.is_some() {
            joint.coordinate = Some(k);
            k += 1;
        }
    }
    let coord_map: Vec<usize> = (0..mech.ndof())
        .map(|c| {
            let j = mech.joint_of(c);
            out.joints[joint_map[j]].coordinate.unwrap_or(usize::MAX)
        })
        .collect();
    let mut coord_back = vec![usize::MAX; k];
    for (c, &r) in coord_map.iter().enumerate() {
        if coord_back[r] == usize::MAX {
            coord_back[r] = c;
        }
    }
    let non_unison = reps
        .iter()
        .zip(sets)
        .map(|((rep, n), set)| NonUnison {
            label: format!("non-unison {}, wavenumbers 1..{}", set, n - 1),
            coordinates: rep.iter().filter_map(|&j| out.joints[new_index[j]].coordinate).collect(),
            multiplicity: n - 1,
        })
        .collect();
    Reduction { mech: out, joint_map, coord_map, coord_back, non_unison }
}

/// A harmonic-balance problem with its route chosen ([`detect`]): on the cyclic route the
/// problem solved is the reduced mechanism's, and every solution, branch and stability verdict
/// returned is the full mechanism's (module docs); on the general route it is [`Hbm`] itself.
#[derive(Debug, Clone)]
pub struct RoutedHbm {
    hbm: Hbm,
    route: Route,
    reduction: Option<Reduction>,
}

/// The route [`RoutedHbm::new`] takes for `kane`'s mechanism with its torques, excited at the
/// joints `inputs`: [`detect`], or the general one for a geared mechanism.
pub fn route_for(kane: &Kane, spin_joint: usize, inputs: &[usize]) -> Route {
    if kane.unconstrained().is_some() {
        Route::General { reason: "gears".into() }
    } else {
        detect(kane.mechanism(), kane.joint_torques(), spin_joint, inputs)
    }
}

impl RoutedHbm {
    /// [`Hbm::with_speed_forcing`] on the route [`detect`] chooses for `kane`'s mechanism: the
    /// same arguments, in the full mechanism's joint numbering.
    pub fn new(
        kane: &Kane,
        spin_joint: usize,
        omega: f64,
        forcing: (&[Harmonic], &[Harmonic]),
        inputs: &[(usize, f64, f64)],
        options: HbmOptions,
    ) -> Result<Self, HbmError> {
        let mech = kane.mechanism();
        let input_joints: Vec<usize> = inputs.iter().map(|i| i.0).collect();
        let route = route_for(kane, spin_joint, &input_joints);
        let Route::Cyclic { sets } = &route else {
            return Self::general(kane, spin_joint, omega, forcing, inputs, options, route);
        };
        let red = reduce(mech, kane.joint_torques(), sets);
        let rkane = Kane::new(&red.mech).map_err(|e| HbmError::Invalid(format!("reduced mechanism: {e}")))?;
        let rinputs: Vec<(usize, f64, f64)> = inputs.iter().map(|&(j, s, p)| (red.joint_map[j], s, p)).collect();
        let mut hbm =
            Hbm::with_speed_forcing(&rkane, red.joint_map[spin_joint], omega, forcing.0, forcing.1, &rinputs, options)?;
        hbm.non_unison = red.non_unison.clone();
        Ok(Self { hbm, route, reduction: Some(red) })
    }

    /// The general route, whatever the mechanism (the reference), with `route` as its report.
    fn general(
        kane: &Kane,
        spin_joint: usize,
        omega: f64,
        forcing: (&[Harmonic], &[Harmonic]),
        inputs: &[(usize, f64, f64)],
        options: HbmOptions,
        route: Route,
    ) -> Result<Self, HbmError> {
        let hbm = Hbm::with_speed_forcing(kane, spin_joint, omega, forcing.0, forcing.1, inputs, options)?;
        Ok(Self { hbm, route, reduction: None })
    }

    /// The general route forced (the reference the cyclic route is checked against).
    pub fn new_general(
        kane: &Kane,
        spin_joint: usize,
        omega: f64,
        forcing: (&[Harmonic], &[Harmonic]),
        inputs: &[(usize, f64, f64)],
        options: HbmOptions,
    ) -> Result<Self, HbmError> {
        let route = Route::General { reason: "requested".into() };
        Self::general(kane, spin_joint, omega, forcing, inputs, options, route)
    }

    /// The route taken.
    pub fn route(&self) -> &Route {
        &self.route
    }

    /// The problem actually solved: the reduced mechanism's on the cyclic route (its solutions
    /// are reduced-size; prefer the methods of [`RoutedHbm`]).
    pub fn hbm(&self) -> &Hbm {
        &self.hbm
    }

    /// The problem actually solved, to continue or analyse it further (fold and unison-loss
    /// curves in two parameters, `hbm::fold2`): its states are the reduced mechanism's on the
    /// cyclic route.
    pub fn hbm_mut(&mut self) -> &mut Hbm {
        &mut self.hbm
    }

    /// Sets the torque scale s of the fixed-parameter solves ([`Hbm::set_torque_scale`]).
    pub fn set_torque_scale(&mut self, scale: f64) -> Result<(), HbmError> {
        self.hbm.set_torque_scale(scale)
    }

    /// Sets the mean speed Ω of the fixed-parameter solves, rad/s ([`Hbm::set_speed`]).
    pub fn set_speed(&mut self, omega: f64) -> Result<(), HbmError> {
        self.hbm.set_speed(omega)
    }

    /// [`Hbm::solve`] on the route; `guess` and the result are full-size (a guess is read in
    /// unison, by each set's representative, on the cyclic route).
    pub fn solve(&mut self, order: f64, guess: Option<&HbmSolution>) -> Result<HbmSolution, HbmError> {
        let guess = guess.map(|g| self.restrict(g));
        let sol = self.hbm.solve(order, guess.as_ref())?;
        Ok(self.expand(sol))
    }

    /// [`Hbm::stability`] of a full-size solution (in unison on the cyclic route): on the cyclic
    /// route its blocks are the unison one and one per set, each with its multiplicity.
    pub fn stability(&mut self, sol: &HbmSolution) -> Result<Stability, HbmError> {
        if !self.in_unison(sol) {
            return Err(HbmError::Invalid(
                "cyclic route: the solution is not in unison (its stability needs the general route)".into(),
            ));
        }
        let sol = self.restrict(sol);
        self.hbm.stability(&sol)
    }

    /// Whether every member of each set has its representative's coefficients (to 1e-12 rad
    /// relative to the largest coefficient); always true on the general route.
    fn in_unison(&self, sol: &HbmSolution) -> bool {
        let Some(red) = &self.reduction else { return true };
        let nb = 2 * sol.harmonics + 1;
        if sol.coefficients.len() != red.coord_map.len() * nb {
            return true;
        }
        let scale = sol.coefficients.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        red.coord_map.iter().enumerate().all(|(c, &r)| {
            let rep = red.coord_back[r];
            (0..nb).all(|h| (sol.coefficients[c * nb + h] - sol.coefficients[rep * nb + h]).abs() <= 1e-12 * scale)
        })
    }

    /// [`Hbm::continue_in`] on the route, the branch full-size.
    pub fn continue_in(
        &mut self,
        parameter: Parameter,
        from: f64,
        to: f64,
        guess: Option<&HbmSolution>,
        copts: &ContinuationOptions,
    ) -> Result<Branch, HbmError> {
        let guess = guess.map(|g| self.restrict(g));
        let mut b = self.hbm.continue_in(parameter, from, to, guess.as_ref(), copts)?;
        if self.reduction.is_some() {
            for p in &mut b.points {
                p.solution = self.expand(std::mem::replace(&mut p.solution, empty()));
                if !p.d_coefficients.is_empty() {
                    p.d_coefficients = self.expand_coefficients(&p.d_coefficients, p.solution.harmonics);
                }
            }
            let harmonics = b.points.first().map_or(0, |p| p.solution.harmonics);
            for f in &mut b.folds {
                if !f.critical.is_empty() {
                    f.critical = self.expand_coefficients(&f.critical, harmonics);
                }
            }
        }
        Ok(b)
    }

    /// [`Hbm::set_on_point`] on the problem solved (the reduced one on the cyclic route).
    pub fn set_on_point(&mut self, hook: Option<super::PointHook>) {
        self.hbm.set_on_point(hook);
    }

    /// [`RoutedHbm::continue_in`] in the order.
    pub fn continue_in_order(
        &mut self,
        n_from: f64,
        n_to: f64,
        guess: Option<&HbmSolution>,
        copts: &ContinuationOptions,
    ) -> Result<Branch, HbmError> {
        self.continue_in(Parameter::Order, n_from, n_to, guess, copts)
    }

    /// Full-size coefficients (per full coordinate, `2H + 1` each) from reduced ones.
    fn expand_coefficients(&self, reduced: &[f64], harmonics: usize) -> Vec<f64> {
        let Some(red) = &self.reduction else { return reduced.to_vec() };
        let nb = 2 * harmonics + 1;
        red.coord_map.iter().flat_map(|&r| reduced[r * nb..(r + 1) * nb].iter().copied()).collect()
    }

    /// The full mechanism's solution from the reduced one's (module docs, item 1).
    fn expand(&self, sol: HbmSolution) -> HbmSolution {
        let Some(red) = &self.reduction else { return sol };
        let coefficients = self.expand_coefficients(&sol.coefficients, sol.harmonics);
        let spin = red.coord_back[sol.spin];
        let rotation = red.coord_map.iter().map(|&r| sol.rotation[r]).collect();
        HbmSolution { coefficients, spin, rotation, ..sol }
    }

    /// The reduced problem's solution read from a full one (each set by its representative).
    fn restrict(&self, sol: &HbmSolution) -> HbmSolution {
        let Some(red) = &self.reduction else { return sol.clone() };
        let nb = 2 * sol.harmonics + 1;
        if sol.coefficients.len() != red.coord_map.len() * nb {
            // Not the full mechanism's: passed on for Hbm's own check to name.
            return sol.clone();
        }
        let coefficients =
            red.coord_back.iter().flat_map(|&c| sol.coefficients[c * nb..(c + 1) * nb].iter().copied()).collect();
        let rotation = red.coord_back.iter().map(|&c| sol.rotation[c]).collect();
        HbmSolution { coefficients, spin: red.coord_map[sol.spin], rotation, ..sol.clone() }
    }
}

/// A placeholder while a point's solution is expanded in place.
fn empty() -> HbmSolution {
    HbmSolution {
        order: 0.0,
        omega: 0.0,
        torque_scale: 0.0,
        base_frequency: 0.0,
        harmonics: 0,
        spin: 0,
        rotation: Vec::new(),
        coefficients: Vec::new(),
        mean_torque: 0.0,
        iterations: 0,
        residual: 0.0,
        top_harmonic_ratio: 0.0,
        coupling_tail: 0.0,
        needs_more_harmonics: false,
        stability: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::excitation::rpm_to_rad_s;
    use crate::model::speeds::Speeds;
    use approx::assert_abs_diff_eq;

    /// The structure the non-unison block rests on (module docs, item 2), read from the general
    /// problem's per-sample A, B, C at a unison solution of three pendulums, for both speed
    /// choices: a pendulum's rows have no entry in another pendulum's columns, every pendulum
    /// has the same diagonal block, and the rotor's row has the same entry in every pendulum's
    /// column (it sees their sum). The cross entries are exactly zero (a pendulum's row does not
    /// read another's coordinates); the equal ones differ by the rounding of the central
    /// differences (ε/h ≈ 1e-10 times the row's terms, measured ≤ 1.3e-9 of the largest entry
    /// with joint rates): bound 1e-8 of the largest entry.
    #[test]
    fn members_couple_only_through_the_sum_the_parent_sees() {
        for speeds in [Speeds::AbsoluteAngularVelocities, Speeds::JointRates] {
            let mut mech = crate::cpva::CpvaParams::canonical().with_pendulums(3).mechanism(None).unwrap();
            mech.speeds = speeds;
            let kane = Kane::new(&mech).unwrap();
            let h = [Harmonic { multiple: 1.0, amplitude: 200.0, phase: 0.0 }];
            let mut hbm = Hbm::new(&kane, 0, rpm_to_rad_s(1000.0), &h, HbmOptions::default()).unwrap();
            let sol = hbm.solve(3.05, None).unwrap();
            hbm.stability(&sol).unwrap();
            let n = hbm.n;
            let nn = n * n;
            let largest = hbm.samples.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let tol = 1e-8 * largest;
            let mut worst = 0.0f64;
            for abc in hbm.samples.chunks_exact(3 * nn) {
                for m in abc.chunks_exact(nn) {
                    let e = |i: usize, k: usize| m[i * n + k];
                    for j in 1..n {
                        for k in 1..n {
                            assert!(j == k || e(j, k) == 0.0, "{speeds:?}: entry ({j}, {k}) = {:e}", e(j, k));
                        }
                        worst = worst.max((e(j, j) - e(1, 1)).abs());
                        worst = worst.max((e(0, j) - e(0, 1)).abs());
                        worst = worst.max((e(j, 0) - e(1, 0)).abs());
                    }
                }
            }
            assert!(worst <= tol, "{speeds:?}: {worst:e} of {largest:e}");
        }
    }

    /// The reduced mechanism of a set of four: the rotor and one pendulum with four times the
    /// mass, inertia and damper of one member (the single pendulum of the same rotor), the
    /// coordinates of the three others mapped to it.
    #[test]
    fn the_reduced_mechanism_is_the_single_pendulum() {
        let p = crate::cpva::CpvaParams::canonical();
        let four = p.with_pendulums(4).mechanism(None).unwrap();
        let one = p.mechanism(None).unwrap();
        let kane = Kane::new(&four).unwrap();
        let Route::Cyclic { sets } = detect(&four, kane.joint_torques(), 0, &[0]) else { panic!("not cyclic") };
        assert_eq!(sets[0].members, ["pivot_1", "pivot_2", "pivot_3", "pivot_4"]);
        assert_eq!(sets[0].member_dof, 1);
        let red = reduce(&four, kane.joint_torques(), &sets);
        assert_eq!(red.coord_map, [0, 1, 1, 1, 1]);
        assert_eq!(red.coord_back, [0, 1]);
        assert_eq!(red.non_unison[0].coordinates, [1]);
        assert_eq!(red.non_unison[0].multiplicity, 3);
        assert_eq!(red.mech.bodies.len(), 2);
        for (a, b) in red.mech.bodies.iter().zip(&one.bodies) {
            assert_abs_diff_eq!(a.inertia.mass, b.inertia.mass, epsilon = 1e-15 * b.inertia.mass);
            assert_abs_diff_eq!(a.inertia.i_com, b.inertia.i_com, epsilon = 1e-15 * b.inertia.i_com);
            assert!((a.inertia.com - b.inertia.com).norm() <= 1e-15);
        }
        assert_abs_diff_eq!(red.mech.joints[1].damper, one.joints[1].damper, epsilon = 1e-18);
        assert_eq!(red.mech.joints[1].at, one.joints[1].at);
    }
}
