//! Kane's method as the textbook writes it, body by body: the definition that the fast forms
//! ([`super::rates`], [`super::absolute`]) regroup and are tested against.
//!
//! For each body j, in the world frame:
//! 1. its pose (angle θ_j, joint point o_j, centre of mass r_j) from the joints' transforms;
//! 2. its partial velocities with respect to the joint rates, from the joints' motion columns:
//!    `∂ω_j/∂q̇_k = ω_k` and `∂v_j/∂q̇_k = v_k + ω_k ẑ × (r_j − o_k)` for each joint k on its path
//!    (`v_k`, `ω_k` the columns of joint k turned into the world frame), and with respect to the
//!    speeds through the constant `B = W⁻¹` of `q̇ = B u`:
//!    `v_{j,r} = Σ_k ∂v_j/∂q̇_k B_kr`, `ω_{j,r} = Σ_k ∂ω_j/∂q̇_k B_kr`;
//! 3. its bias accelerations α⁰_j, a⁰_j at u̇ = 0 (hence q̈ = 0), from the joints' velocity-product
//!    terms and the transport and Coriolis terms of the tree;
//! 4. its generalized active forces `F_r = Σ_j f_j·v_{j,r} + T_j ω_{j,r}` (gravity and point forces
//!    at their points, ground dampers) plus each joint's own generalized force
//!    `τ_k ∂q̇_k/∂u_r = τ_k B_kr` (springs, dampers, excitations), and its generalized inertia forces
//!    `F*_r = −Σ_j (m_j a⁰_j·v_{j,r} + I_j α⁰_j ω_{j,r})`;
//! 5. `M_rs = Σ_j m_j v_{j,r}·v_{j,s} + I_j ω_{j,r} ω_{j,s}` and `F = F_r + F*_r`, so that
//!    `M u̇ = F`.
//!
//! Clarity first: every quantity is formed and stored; allocation is fine here.

use super::Model;
use crate::model::loads::ForceFrame;
use crate::model::math::{Vec2, cross2, perp, rotate_cs};
use crate::model::mechanism::Mechanism;
use nalgebra::{DMatrix, DVector};

/// One body's kinematics at a state, in the world frame, as Kane's method uses them.
#[derive(Debug, Clone, PartialEq)]
pub struct BodyKinematics {
    /// Absolute angle θ_j, rad.
    pub angle: f64,
    /// The body frame's origin (its inboard joint point), m.
    pub origin: Vec2,
    /// Centre of mass r_j, m.
    pub com: Vec2,
    /// Angular velocity ω_j, rad/s.
    pub omega: f64,
    /// Velocity of the centre of mass, m/s.
    pub velocity: Vec2,
    /// Partial angular velocities `ω_{j,r}`, one per speed.
    pub partial_omega: Vec<f64>,
    /// Partial velocities of the centre of mass `v_{j,r}`, one per speed.
    pub partial_velocity: Vec<Vec2>,
    /// Angular acceleration at u̇ = 0, rad/s².
    pub alpha0: f64,
    /// Acceleration of the centre of mass at u̇ = 0, m/s².
    pub acc0: Vec2,
}

/// The matrix B = W⁻¹ of `q̇ = B u` ([`crate::model::speeds::Speeds::w_inverse_matrix`]).
pub fn speeds_to_rates(mech: &Mechanism) -> DMatrix<f64> {
    mech.speeds.w_inverse_matrix(&mech.speed_parents())
}

/// Every body's kinematics at coordinates `q` and speeds `u` (steps 1–3 of the module doc).
pub fn body_kinematics(mech: &Mechanism, q: &[f64], u: &[f64]) -> Vec<BodyKinematics> {
    let b = speeds_to_rates(mech);
    let qdot = &b * DVector::from_column_slice(&u[..mech.ndof()]);
    kinematics(mech, &b, &qdot, q).0
}

/// The kinematics of each path joint's rollers ([`Mechanism::roller_sets`], in that order) as one
/// body of mass N m_r and centroidal inertia N I_r at their centroid, turning with ψ relative to
/// the path's parent (the angle and origin are the centroid's): the same steps as for a body.
pub fn roller_kinematics(mech: &Mechanism, q: &[f64], u: &[f64]) -> Vec<BodyKinematics> {
    let b = speeds_to_rates(mech);
    let qdot = &b * DVector::from_column_slice(&u[..mech.ndof()]);
    kinematics(mech, &b, &qdot, q).1
}

/// [`body_kinematics`] and [`roller_kinematics`] with B and the joint rates `q̇ = B u` already
/// formed.
fn kinematics(
    mech: &Mechanism,
    b: &DMatrix<f64>,
    qdot: &DVector<f64>,
    q: &[f64],
) -> (Vec<BodyKinematics>, Vec<BodyKinematics>) {
    let n = mech.ndof();
    // Per body, by joint rate k: ∂ω/∂q̇_k and ∂v_o/∂q̇_k of its joint point o.
    struct Frame {
        angle: f64,
        origin: Vec2,
        omega: f64,
        v_origin: Vec2,
        alpha0: f64,
        a0_origin: Vec2,
        dw: Vec<f64>,
        dv: Vec<Vec2>,
    }
    let mut frames: Vec<Frame> = Vec::with_capacity(mech.bodies.len());
    let mut out = Vec::with_capacity(mech.bodies.len());
    // The bodies, then the rollers (each a body moved by its path's coordinate, hanging from the
    // path's parent: docs/design/paths.md, "Rollers"), whose frames are pushed after the bodies'.
    let sets = mech.roller_sets();
    let entries = mech.joints.iter().enumerate().map(|(j, joint)| {
        let coord = joint.coordinate;
        let qj = coord.map_or(0.0, |k| q[k]);
        (joint.parent, coord, joint.kind.motion(joint.at, qj), mech.bodies[j].inertia.com)
    });
    let rollers =
        sets.iter().map(|set| (set.parent, Some(set.coordinate), set.motion(q[set.coordinate]), Vec2::zeros()));
    for (parent, coordinate, mo, com) in entries.chain(rollers) {
        let qdj = coordinate.map_or(0.0, |k| qdot[k]);
        let ground = Frame {
            angle: 0.0,
            origin: Vec2::zeros(),
            omega: 0.0,
            v_origin: Vec2::zeros(),
            alpha0: 0.0,
            a0_origin: Vec2::zeros(),
            dw: vec![0.0; n],
            dv: vec![Vec2::zeros(); n],
        };
        let p = match parent {
            Some(p) => &frames[p],
            None => &ground,
        };
        let (pc, ps) = (p.angle.cos(), p.angle.sin());
        let to_world = |v: Vec2| rotate_cs(pc, ps, v);
        // Transform: the child frame relative to the parent's.
        let angle = p.angle + mo.sin.atan2(mo.cos);
        let d = to_world(mo.origin);
        let origin = p.origin + d;
        // Motion columns in the world frame.
        let (col_w, col_v) = (mo.omega, to_world(mo.velocity));
        let mut dw = p.dw.clone();
        let mut dv: Vec<Vec2> = p.dv.iter().zip(&p.dw).map(|(v, &w)| v + w * perp(d)).collect();
        if let Some(k) = coordinate {
            dw[k] += col_w;
            dv[k] += col_v;
        }
        // Velocities and the accelerations at q̈ = 0: transport (α_p ẑ×d − ω_p² d), Coriolis
        // (2 ω_p ẑ × v_rel) and the joint's velocity-product terms.
        let v_rel = col_v * qdj;
        let omega = p.omega + col_w * qdj;
        let v_origin = p.v_origin + p.omega * perp(d) + v_rel;
        let alpha0 = p.alpha0 + mo.bias_alpha * qdj * qdj;
        let a0_origin = p.a0_origin + p.alpha0 * perp(d) - p.omega * p.omega * d
            + 2.0 * p.omega * perp(v_rel)
            + to_world(mo.bias_acc) * (qdj * qdj);
        let frame = Frame { angle, origin, omega, v_origin, alpha0, a0_origin, dw, dv };
        // The centre of mass.
        let arm = rotate_cs(angle.cos(), angle.sin(), com);
        let dv_com: Vec<Vec2> = frame.dv.iter().zip(&frame.dw).map(|(v, &w)| v + w * perp(arm)).collect();
        // From joint rates to speeds: v_{j,r} = Σ_k ∂v/∂q̇_k B_kr.
        let partial_velocity: Vec<Vec2> =
            (0..n).map(|r| (0..n).fold(Vec2::zeros(), |acc, k| acc + dv_com[k] * b[(k, r)])).collect();
        let partial_omega: Vec<f64> = (0..n).map(|r| (0..n).map(|k| frame.dw[k] * b[(k, r)]).sum()).collect();
        out.push(BodyKinematics {
            angle,
            origin,
            com: origin + arm,
            omega,
            velocity: v_origin + omega * perp(arm),
            partial_omega,
            partial_velocity,
            alpha0,
            acc0: a0_origin + alpha0 * perp(arm) - omega * omega * arm,
        });
        frames.push(frame);
    }
    let rollers = out.split_off(mech.bodies.len());
    (out, rollers)
}

/// M and F of `M u̇ = F` at time `t` (s), coordinates `q` and speeds `u`, by Kane's sums body by
/// body (steps 4–5 of the module doc). `torques` are the applied joint torques in effect
/// ([`super::Kane::joint_torques`], or the mechanism's own).
pub fn mass_matrix_and_forcing(
    mech: &Mechanism,
    torques: &[crate::model::loads::JointTorque],
    t: f64,
    q: &[f64],
    u: &[f64],
) -> (DMatrix<f64>, DVector<f64>) {
    let n = mech.ndof();
    let b = speeds_to_rates(mech);
    let qdot = &b * DVector::from_column_slice(&u[..n]);
    let (kin, roller_kin) = kinematics(mech, &b, &qdot, q);
    let sets = mech.roller_sets();
    let mut m = DMatrix::zeros(n, n);
    let mut f = DVector::zeros(n);
    let g = mech.loads.gravity;
    // Each body with its mass and centroidal inertia (the rollers' spread turns with their path's
    // parent: a constant inertia of that body), then the rollers' bodies.
    let nb = kin.len();
    let bodies = kin.iter().enumerate().map(|(j, k)| {
        let spread: f64 = sets.iter().filter(|r| r.parent == Some(j)).map(|r| r.rollers.spread_inertia()).sum();
        (Some(j), k, mech.bodies[j].inertia.mass, mech.bodies[j].inertia.i_com + spread)
    });
    let rollers =
        roller_kin.iter().zip(&sets).map(|(k, r)| (None, k, r.rollers.total_mass(), r.rollers.total_inertia()));
    for (body, k, mass, i_com) in bodies.chain(rollers) {
        let j = body.unwrap_or(nb);
        // Applied: gravity at the centre of mass, dampers to ground as a torque.
        let mut force = mass * g;
        let mut torque = -mech.loads.ground_dampers.iter().filter(|d| d.body == j).map(|d| d.c).sum::<f64>() * k.omega;
        // Point forces: a force at P is the same force at the centre of mass plus its moment.
        for pf in mech.loads.point_forces.iter().filter(|p| p.body == j) {
            let (c, s) = (k.angle.cos(), k.angle.sin());
            let fw = match pf.frame {
                ForceFrame::World => pf.force,
                ForceFrame::Body => rotate_cs(c, s, pf.force),
            };
            let point = k.origin + rotate_cs(c, s, pf.at);
            force += fw;
            torque += cross2(point - k.com, fw);
        }
        // Inertia force and torque at u̇ = 0.
        let (force_star, torque_star) = (-mass * k.acc0, -i_com * k.alpha0);
        for r in 0..n {
            f[r] += (force + force_star).dot(&k.partial_velocity[r]) + (torque + torque_star) * k.partial_omega[r];
            for s in 0..n {
                m[(r, s)] += mass * k.partial_velocity[r].dot(&k.partial_velocity[s])
                    + i_com * k.partial_omega[r] * k.partial_omega[s];
            }
        }
    }
    // Each joint's own generalized force τ_k (spring, damper, couplings, excitation) enters as
    // τ_k ∂q̇_k/∂u_r.
    for (jn, joint) in mech.joints.iter().enumerate() {
        let Some(k) = joint.coordinate else { continue };
        let mut tau = -joint.damper * qdot[k] + joint.couplings.torque(q[k], qdot[k]);
        if let Some(sp) = joint.spring {
            tau -= sp.stiffness * (q[k] - sp.free_angle);
        }
        tau += torques.iter().filter(|jt| jt.joint == jn).map(|jt| jt.excitation.torque(t)).sum::<f64>();
        for r in 0..n {
            f[r] += tau * b[(k, r)];
        }
    }
    (m, f)
}

impl Model {
    /// Kane's partial velocities of body `j` at `q`, in the world frame, by the textbook route
    /// ([`body_kinematics`]): `(v_{j,r}, ω_{j,r})` for r = 0..n. Allocates; for tests and reports.
    pub fn partial_velocities(&self, q: &[f64], j: usize) -> (Vec<Vec2>, Vec<f64>) {
        if let Some(geared) = self.geared_partial_velocities(q, j) {
            return geared;
        }
        let u = vec![0.0; self.n];
        let k = body_kinematics(&self.mech, q, &u).swap_remove(j);
        (k.partial_velocity, k.partial_omega)
    }
}
