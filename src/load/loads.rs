//! The loads of a mechanism spec: gravity, joint torques, ground dampers and point forces, each
//! resolved against the tree's bodies and joints.

use super::bodies::BodyTable;
use super::joints::JointTable;
use crate::error::Result;
use crate::io::{Source, known_list};
use crate::model::loads::{GroundDamper, JointTorque, LoadSpec, Loads, PointForce};
use crate::model::math::Vec2;
use crate::model::mechanism::MechanismSpec;

/// The loads in tree indices, and the file index (`loads[l]`) of each ground damper, for the
/// time-scale check's messages.
pub(super) fn read_loads(
    spec: &MechanismSpec,
    bodies: &BodyTable,
    joints: &JointTable,
    new_index: &[Option<usize>],
    src: &Source,
) -> Result<(Loads, Vec<usize>)> {
    let (gx, gy) = spec.gravity;
    if !(gx.is_finite() && gy.is_finite()) {
        return Err(src.error("gravity", "gravity must be finite (m/s²)"));
    }
    let mut loads = Loads { gravity: Vec2::new(gx, gy), ..Loads::default() };
    let mut ground_damper_at = Vec::new();
    let body_of =
        |name: &str, path: &str| -> Result<usize> {
            bodies.index.get(name).and_then(|&b| new_index[b]).ok_or_else(|| {
                src.error(path, format!("unknown body `{name}` (bodies: {})", known_list(bodies.names())))
            })
        };
    for (l, load) in spec.loads.iter().enumerate() {
        let path = format!("loads[{l}]");
        match load {
            LoadSpec::JointTorque { joint, excitation } => {
                let Some(&k) = joints.names.get(joint) else {
                    return Err(src.error(
                        &format!("{path}.joint"),
                        format!(
                            "unknown joint `{joint}` (joints: {})",
                            known_list(joints.specs.iter().map(|j| j.0.as_str()))
                        ),
                    ));
                };
                if let Err((field, msg)) = excitation.validate() {
                    return Err(src.error(&format!("{path}.excitation.{field}"), msg));
                }
                if joints.specs[k].1.kind.is_some_and(|kind| kind.dof() == 0) {
                    return Err(src.error(
                        &format!("{path}.joint"),
                        format!("joint `{joint}` is Fixed: it has no coordinate for a torque to drive"),
                    ));
                }
                let joint = new_index[joints.specs[k].3].unwrap_or(usize::MAX);
                loads.joint_torques.push(JointTorque { joint, excitation: excitation.clone() });
            }
            LoadSpec::GroundDamper { body, c } => {
                let b = body_of(body, &format!("{path}.body"))?;
                if !(c.is_finite() && *c >= 0.0) {
                    return Err(
                        src.error(&format!("{path}.c"), format!("damping must be finite and non-negative, got {c}"))
                    );
                }
                loads.ground_dampers.push(GroundDamper { body: b, c: *c });
                ground_damper_at.push(l);
            }
            LoadSpec::PointForce { body, at, force, frame } => {
                let b = body_of(body, &format!("{path}.body"))?;
                if ![at.0, at.1, force.0, force.1].iter().all(|v| v.is_finite()) {
                    return Err(src.error(&path, "point and force must be finite"));
                }
                loads.point_forces.push(PointForce {
                    body: b,
                    at: Vec2::new(at.0, at.1),
                    force: Vec2::new(force.0, force.1),
                    frame: *frame,
                });
            }
        }
    }
    Ok((loads, ground_damper_at))
}
