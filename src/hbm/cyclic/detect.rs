//! The detection of identical sets (the room's docs, "Detection"): siblings grouped by the
//! shape of their subtrees, each group's members compared with the first after the turn about
//! the parent's origin; the route and, where it is the general one, why.

use crate::kane::Kane;
use crate::model::loads::JointTorque;
use crate::model::math::{Vec2, rotate_cs};
use crate::model::mechanism::Mechanism;
use std::fmt;

/// Relative tolerance of the identity test (the room's docs, "Detection").
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
    /// block for its non-unison motions (the room's docs).
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

/// Joints of the subtree below (and including) joint `j`, in index order.
pub(super) fn subtree(mech: &Mechanism, j: usize) -> Vec<usize> {
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
/// (the room's docs, "Detection"); both subtrees have the same shape.
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
/// `inputs`: cyclic when it holds identical sets and nothing breaks their symmetry (the room's docs,
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

/// The route [`RoutedHbm::new`](crate::hbm::RoutedHbm::new) takes for `kane`'s mechanism with its torques, excited at the
/// joints `inputs`: [`detect`], or the general one for a geared mechanism.
pub fn route_for(kane: &Kane, spin_joint: usize, inputs: &[usize]) -> Route {
    if kane.unconstrained().is_some() {
        Route::General { reason: "gears".into() }
    } else {
        detect(kane.mechanism(), kane.joint_torques(), spin_joint, inputs)
    }
}
