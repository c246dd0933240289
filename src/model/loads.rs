//! Applied loads: joint torques driven by an excitation, dampers to ground, point forces and
//! uniform gravity (joint springs and dampers live on the joints themselves).
//!
//! Sign conventions (docs/design/model.md): a joint torque τ acts +τ on the child and −τ on the parent, so its
//! generalized force is `τ · ∂q̇_joint/∂u`; a damper to ground puts `−c·ω` on its body.

use crate::model::excitation::Excitation;
use crate::model::math::Vec2;
use serde::{Deserialize, Serialize};

/// The frame in which a point force's components are given.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum ForceFrame {
    /// Fixed in the world (the force keeps its direction as the body turns).
    #[default]
    World,
    /// Fixed in the body (the force turns with the body, a follower force).
    Body,
}

/// A load as written in a mechanism file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum LoadSpec {
    /// An applied torque in a joint (+ on the child, − on the parent), N·m, from an excitation.
    JointTorque {
        /// Joint name.
        joint: String,
        /// The torque signal.
        excitation: Excitation,
    },
    /// A rotational viscous damper between a body and ground: torque `−c·ω_body`.
    GroundDamper {
        /// Body name.
        body: String,
        /// Damping, N·m·s/rad.
        c: f64,
    },
    /// A force applied at a point of a body.
    PointForce {
        /// Body name.
        body: String,
        /// Point of application in the body frame, m.
        at: (f64, f64),
        /// Force components, N.
        force: (f64, f64),
        /// Frame of the components (default `World`).
        #[serde(default)]
        frame: ForceFrame,
    },
}

/// A resolved joint torque.
#[derive(Debug, Clone, PartialEq)]
pub struct JointTorque {
    /// Joint index (= the index of the body it drives; its coordinate is that joint's `coordinate`).
    pub joint: usize,
    /// The torque signal, N·m.
    pub excitation: Excitation,
}

/// A resolved rotational damper to ground.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GroundDamper {
    /// Body index.
    pub body: usize,
    /// Damping, N·m·s/rad.
    pub c: f64,
}

/// A resolved point force.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointForce {
    /// Body index.
    pub body: usize,
    /// Point in the body frame, m.
    pub at: Vec2,
    /// Force, N, in `frame` components.
    pub force: Vec2,
    /// Frame of the components.
    pub frame: ForceFrame,
}

/// All external loads of a mechanism.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Loads {
    /// Uniform gravitational acceleration in the world frame, m/s² (zero by default).
    pub gravity: Vec2,
    /// Applied joint torques.
    pub joint_torques: Vec<JointTorque>,
    /// Dampers to ground.
    pub ground_dampers: Vec<GroundDamper>,
    /// Point forces.
    pub point_forces: Vec<PointForce>,
}

impl Loads {
    /// True when some load needs the bodies' absolute orientation in the world (gravity or a
    /// world-frame force). Otherwise the engine may express everything in each root body's frame
    /// and skip the root angles' trigonometry (the spin angle is cyclic).
    pub fn needs_world_orientation(&self) -> bool {
        self.gravity != Vec2::zeros() || self.point_forces.iter().any(|p| p.frame == ForceFrame::World)
    }
}
