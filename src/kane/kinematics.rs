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
    let (poses, w, v_origin) = frames(mech, q, qdot);
    (0..mech.bodies.len()).map(|j| (w[j], v_origin[j] + w[j] * perp(poses[j].com - poses[j].origin))).collect()
}

/// Poses, angular velocities and joint-point velocities of every body (world frame).
fn frames(mech: &Mechanism, q: &[f64], qdot: &[f64]) -> (Vec<Pose>, Vec<f64>, Vec<Vec2>) {
    let poses = world_poses(mech, q);
    let nb = mech.bodies.len();
    let mut w = vec![0.0; nb];
    let mut v_origin = vec![Vec2::zeros(); nb];
    for (j, joint) in mech.joints.iter().enumerate() {
        let (qj, qdj) = joint.coordinate.map_or((0.0, 0.0), |k| (q[k], qdot[k]));
        let mo = joint.kind.motion(joint.at, qj);
        let (wp, vo, parent_angle) = match joint.parent {
            None => (0.0, Vec2::zeros(), 0.0),
            Some(p) => (w[p], v_origin[p] + w[p] * perp(poses[j].origin - poses[p].origin), poses[p].angle),
        };
        w[j] = wp + mo.omega * qdj;
        v_origin[j] = vo + rot2(parent_angle) * mo.velocity * qdj;
    }
    (poses, w, v_origin)
}

/// The state of one path joint's rollers in the world frame (docs/design/paths.md, "Rollers").
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RollerState {
    /// The rollers' rotation: their parent's angle plus ψ = −s/(2 r_r), rad.
    pub angle: f64,
    /// Their centroid c̄, m.
    pub centroid: Vec2,
    /// Their angular velocity, rad/s.
    pub omega: f64,
    /// The centroid's velocity, m/s.
    pub velocity: Vec2,
    /// Their parent's angular velocity (the spread turns with it), rad/s.
    pub parent_omega: f64,
}

/// The rollers of every path joint that has them ([`Mechanism::roller_sets`], in that order), from
/// the coordinates' rates `qdot`.
pub fn roller_states(mech: &Mechanism, q: &[f64], qdot: &[f64]) -> Vec<RollerState> {
    let (poses, w, v_origin) = frames(mech, q, qdot);
    mech.roller_sets()
        .iter()
        .map(|set| {
            let (s, sd) = (q[set.coordinate], qdot[set.coordinate]);
            let mo = set.motion(s);
            let (pa, po, wp, vo) = match set.parent {
                None => (0.0, Vec2::zeros(), 0.0, Vec2::zeros()),
                Some(p) => (poses[p].angle, poses[p].origin, w[p], v_origin[p]),
            };
            let d = rot2(pa) * mo.origin;
            RollerState {
                angle: pa + set.rollers.turn_rate() * s,
                centroid: po + d,
                omega: wp + mo.omega * sd,
                velocity: vo + wp * perp(d) + rot2(pa) * mo.velocity * sd,
                parent_omega: wp,
            }
        })
        .collect()
}

/// Kinetic energy `Σ ½ m |v|² + ½ I ω²` (J), body by body, from joint rates, with the rollers of
/// path joints (`½ N m_r |v_c̄|² + ½ N I_r ω_r² + ½ N m_r spread² ω_parent²`).
pub fn kinetic_energy(mech: &Mechanism, q: &[f64], qdot: &[f64]) -> f64 {
    let bodies: f64 = world_velocities(mech, q, qdot)
        .iter()
        .zip(&mech.bodies)
        .map(|((w, v), b)| 0.5 * b.inertia.mass * v.norm_squared() + 0.5 * b.inertia.i_com * w * w)
        .sum();
    let rollers: f64 = roller_states(mech, q, qdot)
        .iter()
        .zip(mech.roller_sets())
        .map(|(st, set)| {
            let r = set.rollers;
            0.5 * r.total_mass() * st.velocity.norm_squared()
                + 0.5 * r.total_inertia() * st.omega * st.omega
                + 0.5 * r.spread_inertia() * st.parent_omega * st.parent_omega
        })
        .sum();
    bodies + rollers
}

/// Potential energy of gravity (on the bodies and the rollers) and the joint springs (J).
pub fn potential_energy(mech: &Mechanism, q: &[f64]) -> f64 {
    let poses = world_poses(mech, q);
    let g = mech.loads.gravity;
    let grav: f64 = poses.iter().zip(&mech.bodies).map(|(p, b)| -b.inertia.mass * g.dot(&p.com)).sum();
    let zeros = vec![0.0; q.len()];
    let rollers: f64 = roller_states(mech, q, &zeros)
        .iter()
        .zip(mech.roller_sets())
        .map(|(st, set)| -set.rollers.total_mass() * g.dot(&st.centroid))
        .sum();
    let springs: f64 = mech
        .joints
        .iter()
        .filter_map(|j| Some((j.spring?, q[j.coordinate?])))
        .map(|(s, qj)| 0.5 * s.stiffness * (qj - s.free_angle).powi(2))
        .sum();
    grav + rollers + springs
}

/// Angular momentum about the world origin (kg·m²/s), from joint rates, with the rollers.
pub fn angular_momentum(mech: &Mechanism, q: &[f64], qdot: &[f64]) -> f64 {
    let poses = world_poses(mech, q);
    let bodies: f64 = world_velocities(mech, q, qdot)
        .iter()
        .zip(&mech.bodies)
        .zip(&poses)
        .map(|(((w, v), b), p)| b.inertia.i_com * w + b.inertia.mass * crate::model::math::cross2(p.com, *v))
        .sum();
    let rollers: f64 = roller_states(mech, q, qdot)
        .iter()
        .zip(mech.roller_sets())
        .map(|(st, set)| {
            let r = set.rollers;
            r.total_inertia() * st.omega
                + r.spread_inertia() * st.parent_omega
                + r.total_mass() * crate::model::math::cross2(st.centroid, st.velocity)
        })
        .sum();
    bodies + rollers
}
