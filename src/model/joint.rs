//! Joint specifications (the RON form), joint kinds and resolved joints.

use crate::error::Result;
use crate::io::Source;
use crate::model::math::Vec2;
use serde::{Deserialize, Serialize};

/// The joint vocabulary. Each kind gives its transform, its motion columns and its bias term; only
/// the planar revolute joint exists so far (prismatic, fixed and absorber path joints are planned).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum JointKind {
    /// Rotation about z through the joint point; one coordinate, the relative angle (rad).
    #[default]
    Revolute,
}

/// A linear torsional spring inside a joint: torque `−stiffness·(q − free_angle)` on the child.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Spring {
    /// Torsional stiffness, N·m/rad.
    pub stiffness: f64,
    /// Angle at which the spring is relaxed, rad.
    #[serde(default)]
    pub free_angle: f64,
}

/// A joint as written in a mechanism or catalog file.
///
/// `at` is the joint point in the parent's frame (m; in the world frame when the parent is
/// `ground`). The child's frame has its origin at that point and is parallel to the parent's at
/// q = 0. With `part`, the catalog file's fields come first and the ones given here override them.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename = "Joint", deny_unknown_fields)]
pub struct JointSpec {
    /// Unique name (required once parts are merged).
    pub name: Option<String>,
    /// Catalog file to start from, relative to the file that names it.
    pub part: Option<String>,
    /// Joint kind (default `Revolute`).
    pub kind: Option<JointKind>,
    /// Parent body name, or `ground`.
    pub parent: Option<String>,
    /// Child body name.
    pub child: Option<String>,
    /// Joint point in the parent frame, m (default the parent's origin).
    pub at: Option<(f64, f64)>,
    /// Internal torsional spring.
    pub spring: Option<Spring>,
    /// Internal viscous damper, N·m·s/rad: torque `−damper·q̇` on the child, the reverse on the parent.
    pub damper: Option<f64>,
}

impl JointSpec {
    /// Fields of `over` replace those of `self`.
    pub fn merged(&self, over: &JointSpec) -> JointSpec {
        JointSpec {
            name: over.name.clone().or_else(|| self.name.clone()),
            part: None,
            kind: over.kind.or(self.kind),
            parent: over.parent.clone().or_else(|| self.parent.clone()),
            child: over.child.clone().or_else(|| self.child.clone()),
            at: over.at.or(self.at),
            spring: over.spring.or(self.spring),
            damper: over.damper.or(self.damper),
        }
    }

    /// Checks the numbers given in this spec (before merging), naming the field at `path`.
    pub fn check_numbers(&self, src: &Source, path: &str) -> Result<()> {
        if let Some((x, y)) = self.at
            && !(x.is_finite() && y.is_finite())
        {
            return Err(src.error(&format!("{path}.at"), "joint point must be finite"));
        }
        if let Some(c) = self.damper
            && !(c.is_finite() && c >= 0.0)
        {
            return Err(src.error(
                &format!("{path}.damper"),
                format!("damping must be finite and non-negative (N·m·s/rad), got {c}"),
            ));
        }
        if let Some(s) = self.spring {
            if !(s.stiffness.is_finite() && s.stiffness >= 0.0) {
                return Err(src.error(
                    &format!("{path}.spring.stiffness"),
                    format!("stiffness must be finite and non-negative (N·m/rad), got {}", s.stiffness),
                ));
            }
            if !s.free_angle.is_finite() {
                return Err(src.error(&format!("{path}.spring.free_angle"), "free angle must be finite"));
            }
        }
        Ok(())
    }
}

/// A resolved joint. In a [`crate::model::mechanism::Mechanism`], joint `i` is the inboard joint of body `i`
/// and owns coordinate `q[i]`.
#[derive(Debug, Clone, PartialEq)]
pub struct Joint {
    /// Unique name.
    pub name: String,
    /// Kind.
    pub kind: JointKind,
    /// Parent body index, `None` for ground.
    pub parent: Option<usize>,
    /// Joint point in the parent frame (world frame for ground), m.
    pub at: Vec2,
    /// Internal spring.
    pub spring: Option<Spring>,
    /// Internal viscous damping, N·m·s/rad (0 when none).
    pub damper: f64,
}
