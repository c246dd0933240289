//! A mechanism: bodies, joints (a tree rooted at `ground`), generalized speeds and loads, read
//! from RON and validated once, as plain vectors with `parent(i) < i`.

use crate::error::{Error, Result};
use crate::model::body::{Body, BodySpec};
use crate::model::gears::{Gear, GearSpec};
use crate::model::joint::{Joint, JointKind, JointMotion, JointSpec};
use crate::model::loads::{LoadSpec, Loads};
use crate::model::math::Vec2;
use crate::model::path::Rollers;
use crate::model::speeds::Speeds;
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// The implicit root body's name.
pub const GROUND: &str = "ground";

/// A mechanism file as written (the user guide's `docs/guide/src/mechanism.md` has an annotated example).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename = "Mechanism", deny_unknown_fields)]
pub struct MechanismSpec {
    /// Name used in reports and output folders.
    pub name: String,
    /// An overlay's base: another mechanism file (relative to this one) whose bodies, joints,
    /// loads and gears come first; this file's are added to them (absorbers on an imported
    /// shaft line, say). The base's `speeds` and `gravity` apply, and a base cannot itself have
    /// a base ([`crate::load`] merges them).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub base: Option<String>,
    /// Choice of generalized speeds (default `JointRates`).
    #[serde(default)]
    pub speeds: Speeds,
    /// Gravitational acceleration in the world frame, m/s² (default off: `(0.0, 0.0)`).
    #[serde(default)]
    pub gravity: (f64, f64),
    /// The bodies.
    pub bodies: Vec<BodySpec>,
    /// The joints, one per body (each body has exactly one parent).
    pub joints: Vec<JointSpec>,
    /// External loads.
    #[serde(default)]
    pub loads: Vec<LoadSpec>,
    /// Gear pairs and fixed-ratio couplings between joints ([`crate::model::gears`]).
    #[serde(default)]
    pub gears: Vec<GearSpec>,
}

/// A validated mechanism (built by [`crate::load`]). Body `i` hangs from joint `i`; parents come
/// before children (`joints[i].parent < Some(i)`). Coordinates are numbered in the same order over
/// the joints that have one (all but `Fixed`), so a mechanism without fixed joints has coordinate
/// `q[i]` at joint `i`.
#[derive(Debug, Clone, PartialEq)]
pub struct Mechanism {
    /// Name.
    pub name: String,
    /// File it was read from, if any.
    pub file: Option<PathBuf>,
    /// Choice of generalized speeds.
    pub speeds: Speeds,
    /// Bodies in tree order.
    pub bodies: Vec<Body>,
    /// Joints; `joints[i]` is the inboard joint of `bodies[i]`.
    pub joints: Vec<Joint>,
    /// External loads.
    pub loads: Loads,
    /// Couplings between joints; a rigidly driven joint has no coordinate of its own
    /// ([`Mechanism::follow_map`] gives it).
    pub gears: Vec<Gear>,
}

/// One path joint's rollers as the engine carries them (docs/design/paths.md, "Rollers"): a rigid body
/// of mass N m_r and centroidal inertia N I_r hanging from the path joint's parent, moved by the
/// path's coordinate through [`JointKind`]'s `roller_motion`, plus the rollers' spread
/// `N m_r spread²`, a constant inertia of that parent.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RollerSet {
    /// The path joint (its index).
    pub joint: usize,
    /// The path joint's parent body, `None` for ground.
    pub parent: Option<usize>,
    /// The path's coordinate (index in q).
    pub coordinate: usize,
    /// The path joint's kind and point (`at`, parent frame, m).
    pub kind: JointKind,
    /// See `kind`.
    pub at: Vec2,
    /// The rollers.
    pub rollers: Rollers,
    /// The vertex's centre of curvature P in the path's own frame, m ([`Rollers::vertex_centre`]).
    pub centre: Vec2,
}

impl RollerSet {
    /// The rollers' motion relative to the parent at the path's arc length `s` (m): centroid,
    /// rotation ψ, columns and bias terms ([`JointKind`]'s `roller_motion`).
    #[inline]
    pub fn motion(&self, s: f64) -> JointMotion {
        self.kind.roller_motion(self.at, s, self.centre, self.rollers.turn_rate())
    }
}

impl Mechanism {
    /// The rollers of every path joint that has them, in tree order (empty for most mechanisms).
    pub fn roller_sets(&self) -> Vec<RollerSet> {
        self.joints
            .iter()
            .enumerate()
            .filter_map(|(j, joint)| {
                let rollers = joint.rollers?;
                let shape = joint.kind.path()?.shape;
                Some(RollerSet {
                    joint: j,
                    parent: joint.parent,
                    coordinate: joint.coordinate?,
                    kind: joint.kind,
                    at: joint.at,
                    rollers,
                    centre: Rollers::vertex_centre(shape),
                })
            })
            .collect()
    }

    /// Number of degrees of freedom (= coordinates = speeds): one per joint that has a coordinate.
    pub fn ndof(&self) -> usize {
        self.joints.iter().filter(|j| j.coordinate.is_some()).count()
    }

    /// Parent body indices (None = ground), one per body (= per joint).
    pub fn parents(&self) -> Vec<Option<usize>> {
        self.joints.iter().map(|j| j.parent).collect()
    }

    /// The coordinate of joint `j`, `None` for a joint without one (Fixed).
    pub fn coordinate(&self, j: usize) -> Option<usize> {
        self.joints[j].coordinate
    }

    /// The joint that owns coordinate `k`.
    pub fn joint_of(&self, k: usize) -> usize {
        self.joints.iter().position(|j| j.coordinate == Some(k)).unwrap_or(usize::MAX)
    }

    /// The coordinate of the joint named `name`, if it exists and has one.
    pub fn coordinate_index(&self, name: &str) -> Option<usize> {
        self.joint_index(name).and_then(|j| self.coordinate(j))
    }

    /// For each coordinate k, the coordinate whose speed is subtracted in `q̇_k = u_k − u_p` under
    /// absolute angular velocities ([`Speeds::qdot`]): for a rotating joint, the nearest rotating
    /// joint above it (whose speed is the parent body's absolute angular velocity); `None` for a
    /// root rotation and for every non-rotating coordinate (its speed is its own rate).
    pub fn speed_parents(&self) -> Vec<Option<usize>> {
        let mut out = Vec::with_capacity(self.ndof());
        for (j, joint) in self.joints.iter().enumerate() {
            if joint.coordinate.is_none() {
                continue;
            }
            out.push(if joint.kind.rotates() { self.rotation_coordinates_above(j).last().copied() } else { None });
        }
        out
    }

    /// The path joint nearest body `body` on its way from ground (its own joint included) whose
    /// carried body turns with its coordinate, if any: the body's absolute angle then has the
    /// path's rotation law α(s) in it, which [`Mechanism::rotation_coordinates`] and the body
    /// probes built on it do not sum (they add revolute angles only), so callers refuse it.
    pub fn turning_path_above(&self, body: usize) -> Option<usize> {
        self.path_to(body).into_iter().rev().find(|&j| self.joints[j].kind.path().is_some_and(|p| p.shape.turns()))
    }

    /// The coordinates of the rotating joints on the path from ground to body `body`, root first:
    /// the body's absolute angle is their sum (every joint kind keeps the child parallel to the
    /// parent at zero coordinate), and so are its angular velocity and acceleration from q̇ and q̈.
    pub fn rotation_coordinates(&self, body: usize) -> Vec<usize> {
        let mut out = self.rotation_coordinates_above(body);
        if self.joints[body].kind.rotates()
            && let Some(k) = self.joints[body].coordinate
        {
            out.push(k);
        }
        out
    }

    /// [`Mechanism::rotation_coordinates`] of the parent of `body` (empty for a root).
    fn rotation_coordinates_above(&self, body: usize) -> Vec<usize> {
        let mut path = self.path_to(body);
        path.pop();
        path.into_iter().filter(|&j| self.joints[j].kind.rotates()).filter_map(|j| self.joints[j].coordinate).collect()
    }
    /// The first path joint whose coordinate in `q` (all n coordinates) is at or beyond its end
    /// of travel (or not finite), as the engine's error naming it; `None` when every path joint
    /// is on its path.
    pub fn path_out_of_travel(&self, q: &[f64]) -> Option<crate::error::EngineError> {
        // Only path joints have an end: a NaN angle of another joint is the engine's own
        // non-finite error, not a path's.
        self.joints.iter().filter_map(|j| Some((j, j.kind.path()?))).find_map(|(j, path)| {
            let s = *q.get(j.coordinate?)?;
            let travel = j.kind.travel();
            let limit = path.travel.is_some_and(|t| t < path.shape.travel());
            // A NaN coordinate is off the path too.
            let on_path = s.abs() < travel;
            (!on_path).then(|| crate::error::EngineError::OutOfTravel {
                joint: j.name.clone(),
                coordinate: s,
                travel,
                limit,
            })
        })
    }

    /// Index of a body by name.
    pub fn body_index(&self, name: &str) -> Option<usize> {
        self.bodies.iter().position(|b| b.name == name)
    }

    /// Index of a joint (= its coordinate) by name.
    pub fn joint_index(&self, name: &str) -> Option<usize> {
        self.joints.iter().position(|j| j.name == name)
    }

    /// Total mass, kg, with the rollers of path joints.
    pub fn total_mass(&self) -> f64 {
        let rollers: f64 = self.joints.iter().filter_map(|j| j.rollers).map(|r| r.total_mass()).sum();
        self.bodies.iter().map(|b| b.inertia.mass).sum::<f64>() + rollers
    }

    /// The mechanism with joint `name` locked at angle `q_lock` (rad): its child body is merged
    /// rigidly into the parent (parallel-axis inertia), the child's children hang from the parent
    /// at their transformed joint points, the locked joint's spring, damper and applied torque
    /// disappear, and loads on the child move to the parent. Used for the "locked pendulum"
    /// reference of the paper (Fig. 2 and 5). Locking a joint to ground is refused: it would weld
    /// the whole subtree to ground.
    pub fn lock(&self, name: &str, q_lock: f64) -> Result<Mechanism> {
        // A joint in a rigid gear train locks the whole train (crate::model::gears).
        if let Some(out) = self.lock_gear_train(name, q_lock)? {
            return Ok(out);
        }
        let model = |message: String| Error::Model { mechanism: self.name.clone(), message };
        let c = self.joint_index(name).ok_or_else(|| {
            model(format!(
                "cannot lock unknown joint `{name}` (joints: {})",
                crate::io::known_list(self.joints.iter().map(|j| j.name.as_str()))
            ))
        })?;
        let Some(p) = self.joints[c].parent else {
            return Err(model(format!(
                "joint `{name}` connects to ground; locking it would weld its subtree to ground"
            )));
        };
        let lock = self.joints[c].kind.motion(self.joints[c].at, q_lock);
        // Child-frame vectors expressed in the parent frame.
        let rotate = |v: Vec2| crate::model::math::rotate_cs(lock.cos, lock.sin, v);
        let to_parent = |v: Vec2| lock.origin + rotate(v);
        let mut out = self.clone();
        out.name = format!("{}_locked", self.name);
        let child = &self.bodies[c].inertia;
        let moved = crate::model::inertia::PlanarInertia::new(child.mass, to_parent(child.com), child.i_com);
        out.bodies[p].inertia = out.bodies[p].inertia + moved;
        // A path joint's rollers are welded with it: their mass at their centroid, their own
        // inertias and their spread about it join the parent too.
        if let Some(set) = self.roller_sets().into_iter().find(|r| r.joint == c) {
            let r = set.rollers;
            let at = set.motion(q_lock).origin;
            let welded =
                crate::model::inertia::PlanarInertia::new(r.total_mass(), at, r.total_inertia() + r.spread_inertia());
            out.bodies[p].inertia = out.bodies[p].inertia + welded;
        }
        for (j, joint) in out.joints.iter_mut().enumerate() {
            if joint.parent == Some(c) {
                joint.parent = Some(p);
                joint.at = to_parent(self.joints[j].at);
            }
        }
        for g in &mut out.loads.ground_dampers {
            if g.body == c {
                g.body = p;
            }
        }
        for f in &mut out.loads.point_forces {
            if f.body == c {
                f.body = p;
                f.at = to_parent(f.at);
                if f.frame == crate::model::loads::ForceFrame::Body {
                    f.force = rotate(f.force);
                }
            }
        }
        out.loads.joint_torques.retain(|t| t.joint != c);
        // Remove body/joint c and shift the later indices down (order stays parents-first).
        out.bodies.remove(c);
        out.joints.remove(c);
        let shift = |i: usize| if i > c { i - 1 } else { i };
        for joint in &mut out.joints {
            joint.parent = joint.parent.map(shift);
        }
        for g in &mut out.loads.ground_dampers {
            g.body = shift(g.body);
        }
        for f in &mut out.loads.point_forces {
            f.body = shift(f.body);
        }
        for t in &mut out.loads.joint_torques {
            t.joint = shift(t.joint);
        }
        crate::model::gears::shift_after_removal(&mut out.gears, c);
        let mut next = 0;
        for joint in &mut out.joints {
            if joint.coordinate.is_some() {
                joint.coordinate = Some(next);
                next += 1;
            }
        }
        Ok(out)
    }

    /// Joint indices from the root to body `j` (inclusive).
    pub fn path_to(&self, j: usize) -> Vec<usize> {
        let mut path = vec![j];
        let mut b = j;
        while let Some(p) = self.joints[b].parent {
            path.push(p);
            b = p;
        }
        path.reverse();
        path
    }
}
