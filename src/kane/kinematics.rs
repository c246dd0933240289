//! World-frame poses and velocities of a mechanism's bodies (for outputs, energies and tests).
//!
//! The engine's hot forward pass lives in [`crate::kane`], which may express each subtree in its
//! root body's frame; the functions here always use the world frame and allocate their result.

use crate::model::math::{Vec2, perp, rot2};
use crate::model::mechanism::Mechanism;

/// A body's pose in the world frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose {
    /// Absolute angle β (rad): the sum of the joint angles from ground.
    pub angle: f64,
    /// The body frame's origin (its inboard joint point), m.
    pub origin: Vec2,
    /// The centre of mass, m.
    pub com: Vec2,
}

/// Poses of all bodies at coordinates `q` (rad for angles, m for slides), from the joints'
/// transforms.
pub fn world_poses(mech: &Mechanism, q: &[f64]) -> Vec<Pose> {
    let mut out: Vec<Pose> = Vec::with_capacity(mech.bodies.len());
    for (j, joint) in mech.joints.iter().enumerate() {
        let mo = joint.kind.motion(joint.at, joint.coordinate.map_or(0.0, |k| q[k]));
        // The unwrapped relative rotation (q itself for a revolute joint, α(s) on a path), so an
        // angle keeps counting past ±π.
        let turn = joint.coordinate.map_or(0.0, |k| joint.kind.turn(q[k]));
        let (angle, origin) = match joint.parent {
            None => (turn, mo.origin),
            Some(p) => (out[p].angle + turn, out[p].origin + rot2(out[p].angle) * mo.origin),
        };
        let com = origin + rot2(angle) * mech.bodies[j].inertia.com;
        out.push(Pose { angle, origin, com });
    }
    out
}

/// World-frame velocity of each body: (angular velocity ω, rad/s; centre-of-mass velocity, m/s),
/// from the coordinates' rates `qdot` — not from the generalized speeds.
pub fn world_velocities(mech: &Mechanism, q: &[f64], qdot: &[f64]) -> Vec<(f64, Vec2)> {
    let poses = world_poses(mech, q);
    let nb = mech.bodies.len();
    let mut w = vec![0.0; nb];
    let mut v_origin = vec![Vec2::zeros(); nb];
    let mut out = Vec::with_capacity(nb);
    for (j, joint) in mech.joints.iter().enumerate() {
        let (qj, qdj) = joint.coordinate.map_or((0.0, 0.0), |k| (q[k], qdot[k]));
        let mo = joint.kind.motion(joint.at, qj);
        let (wp, vo, parent_angle) = match joint.parent {
            None => (0.0, Vec2::zeros(), 0.0),
            Some(p) => (w[p], v_origin[p] + w[p] * perp(poses[j].origin - poses[p].origin), poses[p].angle),
        };
        w[j] = wp + mo.omega * qdj;
        v_origin[j] = vo + rot2(parent_angle) * mo.velocity * qdj;
        out.push((w[j], v_origin[j] + w[j] * perp(poses[j].com - poses[j].origin)));
    }
    out
}

/// Kinetic energy `Σ ½ m |v|² + ½ I ω²` (J), body by body, from joint rates.
pub fn kinetic_energy(mech: &Mechanism, q: &[f64], qdot: &[f64]) -> f64 {
    world_velocities(mech, q, qdot)
        .iter()
        .zip(&mech.bodies)
        .map(|((w, v), b)| 0.5 * b.inertia.mass * v.norm_squared() + 0.5 * b.inertia.i_com * w * w)
        .sum()
}

/// Potential energy of gravity and the joint springs (J).
pub fn potential_energy(mech: &Mechanism, q: &[f64]) -> f64 {
    let poses = world_poses(mech, q);
    let g = mech.loads.gravity;
    let grav: f64 = poses.iter().zip(&mech.bodies).map(|(p, b)| -b.inertia.mass * g.dot(&p.com)).sum();
    let springs: f64 = mech
        .joints
        .iter()
        .filter_map(|j| Some((j.spring?, q[j.coordinate?])))
        .map(|(s, qj)| 0.5 * s.stiffness * (qj - s.free_angle).powi(2))
        .sum();
    grav + springs
}

/// Angular momentum about the world origin (kg·m²/s), from joint rates.
pub fn angular_momentum(mech: &Mechanism, q: &[f64], qdot: &[f64]) -> f64 {
    let poses = world_poses(mech, q);
    world_velocities(mech, q, qdot)
        .iter()
        .zip(&mech.bodies)
        .zip(&poses)
        .map(|(((w, v), b), p)| b.inertia.i_com * w + b.inertia.mass * crate::model::math::cross2(p.com, *v))
        .sum()
}
