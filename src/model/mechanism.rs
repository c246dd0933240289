//! A mechanism: bodies, joints (a tree rooted at `ground`), generalized speeds and loads, read
//! from RON and validated once, as plain vectors with `parent(i) < i`.

use crate::error::{Error, Result};
use crate::model::body::{Body, BodySpec};
use crate::model::joint::{Joint, JointSpec};
use crate::model::loads::{LoadSpec, Loads};
use crate::model::math::Vec2;
use crate::model::speeds::Speeds;
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// The implicit root body's name.
pub const GROUND: &str = "ground";

/// A mechanism file as written (see the README for an annotated example).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename = "Mechanism", deny_unknown_fields)]
pub struct MechanismSpec {
    /// Name used in reports and output folders.
    pub name: String,
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
}

/// A validated mechanism (built by [`crate::load`]). Body `i` hangs from joint `i`, which owns coordinate `q[i]`; parents
/// come before children (`joints[i].parent < Some(i)`).
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
}

impl Mechanism {
    /// Number of degrees of freedom (= coordinates = speeds).
    pub fn ndof(&self) -> usize {
        self.joints.len()
    }

    /// Parent indices (None = ground), one per body.
    pub fn parents(&self) -> Vec<Option<usize>> {
        self.joints.iter().map(|j| j.parent).collect()
    }

    /// Index of a body by name.
    pub fn body_index(&self, name: &str) -> Option<usize> {
        self.bodies.iter().position(|b| b.name == name)
    }

    /// Index of a joint (= its coordinate) by name.
    pub fn joint_index(&self, name: &str) -> Option<usize> {
        self.joints.iter().position(|j| j.name == name)
    }

    /// Total mass, kg.
    pub fn total_mass(&self) -> f64 {
        self.bodies.iter().map(|b| b.inertia.mass).sum()
    }

    /// The mechanism with joint `name` locked at angle `q_lock` (rad): its child body is merged
    /// rigidly into the parent (parallel-axis inertia), the child's children hang from the parent
    /// at their transformed joint points, the locked joint's spring, damper and applied torque
    /// disappear, and loads on the child move to the parent. Used for the "locked pendulum"
    /// reference of the paper (Fig. 2 and 5). Locking a joint to ground is refused: it would weld
    /// the whole subtree to ground.
    pub fn lock(&self, name: &str, q_lock: f64) -> Result<Mechanism> {
        let model = |message: String| Error::Model { mechanism: self.name.clone(), message };
        let c = self.joint_index(name).ok_or_else(|| {
            model(format!(
                "cannot lock unknown joint `{name}` (joints: {})",
                known_list(self.joints.iter().map(|j| j.name.as_str()))
            ))
        })?;
        let Some(p) = self.joints[c].parent else {
            return Err(model(format!(
                "joint `{name}` connects to ground; locking it would weld its subtree to ground"
            )));
        };
        let rot = crate::model::math::rot2(q_lock);
        let at_c = self.joints[c].at;
        // Child-frame vectors expressed in the parent frame.
        let to_parent = |v: Vec2| at_c + rot * v;
        let mut out = self.clone();
        out.name = format!("{}_locked", self.name);
        let child = &self.bodies[c].inertia;
        let moved = crate::model::inertia::PlanarInertia::new(child.mass, to_parent(child.com), child.i_com);
        out.bodies[p].inertia = out.bodies[p].inertia + moved;
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
                    f.force = rot * f.force;
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

pub(crate) fn known_list<'a>(names: impl Iterator<Item = &'a str>) -> String {
    names.collect::<Vec<_>>().join(", ")
}
