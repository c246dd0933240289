//! Joint reactions by a Newton–Euler pass once the accelerations are known: the force and the
//! moment the parent exerts on the child through each joint (pivot loads, the load on a path's
//! track, what a spin bearing carries).
//!
//! A forward pass gives every body's angular velocity and acceleration and its centre of mass's
//! acceleration from `q, q̇, q̈` through the joint interface (motion columns and velocity-product
//! terms, the same the engine uses):
//! `α_j = α_p + ω_col q̈ + α_bias q̇²`,
//! `a_Oj = a_Op + α_p × d − ω_p² d + 2 ω_p × (R_p v_col q̇) + R_p (v_col q̈ + a_bias q̇²)`
//! with `d = O_j − O_p`, and `a_c = a_Oj + α_j × r − ω_j² r` for the centre of mass at `r`.
//! A backward pass over the subtree S_j of each joint then gives, from Newton and Euler about
//! the joint point O_j (valid about any point when the accelerations are absolute),
//! `F_j = Σ_{k∈S_j} (m_k a_k − F_k^ext)` and
//! `M_j = Σ_{k∈S_j} (I_k α_k + (r_k − O_j) × m_k a_k − M_{k,O_j}^ext)`,
//! the external loads being gravity, point forces and dampers to ground. Joint torques, springs
//! and dampers inside S_j cancel in pairs; those of joint j itself are part of what the parent
//! exerts, so a revolute joint's moment is its spring, damper and applied torque (its
//! constraint carries no moment), a path or slide joint's moment includes the track's.
//!
//! Geared mechanisms (docs/design/model.md, "Gears"): the pass runs on the unconstrained tree at the
//! expanded state `q_full = T q + o`, `q̇_full = T q̇`, `q̈_full = T q̈` (T constant). A rigid
//! coupling `q̇_d = r q̇_f` acts on that tree as the generalized constraint force `Gᵀλ` of its
//! Jacobian row `G = e_d − r e_f`: a joint torque λ at the driven joint d and `−r λ` at the
//! driving joint f (no net power: `λ q̇_d − r λ q̇_f = 0`). So a driven revolute joint's moment is
//! its own torques plus λ, and the driving one's includes `−r λ`. λ itself, the mesh torque, is
//! [`crate::kane::Kane::gear_torques`]: the residual `R = M_full q̈_full − F_full` of the unconstrained tree
//! equals `Gᵀλ`, so `λ_d = R_d + Σ_e r_e λ_e` over the couplings e that follow d (solved from
//! the ends of each gear chain back). The tooth force itself is not resolved into the bearing
//! forces: the model has no pitch radii, only the ratio, so a gear shaft's radial and
//! tangential reactions carry its inertia and loads but not the mesh force.

use crate::model::loads::ForceFrame;
use crate::model::math::{Vec2, cross2, perp, rot2};
use crate::model::mechanism::Mechanism;

/// What the parent exerts on the child through one joint.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reaction {
    /// The force, world frame, N.
    pub force_world: Vec2,
    /// The force along the joint's radial direction, N: the direction in the parent frame from
    /// the parent's origin to the child's frame origin (outward positive; the world x axis for a
    /// joint to ground, or when the two coincide).
    pub radial: f64,
    /// The force along the tangential direction (the radial one turned by +90°), N.
    pub tangential: f64,
    /// The moment about the joint point, N·m.
    pub moment: f64,
}

/// Every joint's reaction at coordinates `q`, rates `qdot` and accelerations `qddot` (joint
/// rates, `q̇ = W⁻¹u`, `q̈ = W⁻¹u̇`), in joint order. On a geared mechanism these are its
/// reduced coordinates: the pass runs on the unconstrained tree at the expanded state
/// ([`Mechanism::expand_state`]), so a driven joint's moment holds the torque its mesh exerts
/// on it and a driving joint's the reflection (see the module doc).
pub fn joint_reactions(mech: &Mechanism, q: &[f64], qdot: &[f64], qddot: &[f64]) -> Vec<Reaction> {
    if mech.is_geared() {
        let [q, qd, qdd] = mech.expand_state(q, qdot, qddot);
        return tree_reactions(&mech.expanded(), &q, &qd, &qdd);
    }
    tree_reactions(mech, q, qdot, qddot)
}

/// [`joint_reactions`] of a tree without couplings (for a geared mechanism: its
/// [`Mechanism::expanded`] tree at the expanded state, which callers evaluating many samples
/// keep instead of expanding per call).
pub fn tree_reactions(mech: &Mechanism, q: &[f64], qdot: &[f64], qddot: &[f64]) -> Vec<Reaction> {
    debug_assert!(!mech.is_geared(), "internal: tree_reactions takes the expanded tree of a geared mechanism");
    let nb = mech.bodies.len();
    let mut angle = vec![0.0; nb];
    let mut omega = vec![0.0; nb];
    let mut alpha = vec![0.0; nb];
    let mut origin = vec![Vec2::zeros(); nb];
    let mut acc_origin = vec![Vec2::zeros(); nb];
    let mut com = vec![Vec2::zeros(); nb];
    let mut acc_com = vec![Vec2::zeros(); nb];
    // The radial direction of each joint, world frame.
    let mut radial = vec![Vec2::new(1.0, 0.0); nb];
    for (j, joint) in mech.joints.iter().enumerate() {
        let (qj, qdj, qddj) = joint.coordinate.map_or((0.0, 0.0, 0.0), |k| (q[k], qdot[k], qddot[k]));
        let mo = joint.kind.motion(joint.at, qj);
        let turn = joint.coordinate.map_or(0.0, |k| joint.kind.turn(q[k]));
        let (pa, pw, palpha, po, pacc) = match joint.parent {
            None => (0.0, 0.0, 0.0, Vec2::zeros(), Vec2::zeros()),
            Some(p) => (angle[p], omega[p], alpha[p], origin[p], acc_origin[p]),
        };
        let rp = rot2(pa);
        angle[j] = pa + turn;
        omega[j] = pw + mo.omega * qdj;
        alpha[j] = palpha + mo.omega * qddj + mo.bias_alpha * qdj * qdj;
        origin[j] = po + rp * mo.origin;
        let d = origin[j] - po;
        let v_rel = rp * mo.velocity * qdj;
        acc_origin[j] = pacc + palpha * perp(d) - pw * pw * d
            + 2.0 * pw * perp(v_rel)
            + rp * (mo.velocity * qddj + mo.bias_acc * qdj * qdj);
        let r = rot2(angle[j]) * mech.bodies[j].inertia.com;
        com[j] = origin[j] + r;
        acc_com[j] = acc_origin[j] + alpha[j] * perp(r) - omega[j] * omega[j] * r;
        if joint.parent.is_some() && d.norm() > 0.0 {
            radial[j] = d / d.norm();
        }
    }
    // Each body's own Newton–Euler terms: m a − F_ext, and the moment about the world origin
    // I α + r × m a − M_ext (moved to each joint point below).
    let g = mech.loads.gravity;
    let mut force = vec![Vec2::zeros(); nb];
    let mut moment0 = vec![0.0; nb];
    for k in 0..nb {
        let b = &mech.bodies[k].inertia;
        let mut f_ext = b.mass * g;
        let mut m_ext = cross2(com[k], b.mass * g);
        for d in mech.loads.ground_dampers.iter().filter(|d| d.body == k) {
            m_ext -= d.c * omega[k];
        }
        for pf in mech.loads.point_forces.iter().filter(|p| p.body == k) {
            let rk = rot2(angle[k]);
            let fw = match pf.frame {
                ForceFrame::World => pf.force,
                ForceFrame::Body => rk * pf.force,
            };
            f_ext += fw;
            m_ext += cross2(origin[k] + rk * pf.at, fw);
        }
        let ma = b.mass * acc_com[k];
        force[k] = ma - f_ext;
        moment0[k] = b.i_com * alpha[k] + cross2(com[k], ma) - m_ext;
    }
    // A path joint's rollers belong to the subtree of the path's parent (they roll on its track),
    // not to the absorber's: their Newton–Euler terms and their spread's I α join that parent, so
    // the path joint's reaction is what the rollers pass to the absorber.
    for set in mech.roller_sets() {
        let Some(p) = set.parent else { continue };
        let (s, sd, sdd) = (q[set.coordinate], qdot[set.coordinate], qddot[set.coordinate]);
        let mo = set.motion(s);
        let rp = rot2(angle[p]);
        let d = rp * mo.origin;
        let v_rel = rp * mo.velocity * sd;
        let acc = acc_origin[p] + alpha[p] * perp(d) - omega[p] * omega[p] * d
            + 2.0 * omega[p] * perp(v_rel)
            + rp * (mo.velocity * sdd + mo.bias_acc * sd * sd);
        let r = set.rollers;
        let c = origin[p] + d;
        let ma = r.total_mass() * acc;
        let weight = r.total_mass() * g;
        force[p] += ma - weight;
        moment0[p] += r.total_inertia() * (alpha[p] + mo.omega * sdd) + r.spread_inertia() * alpha[p] + cross2(c, ma)
            - cross2(c, weight);
    }
    // Subtree sums, children before parents (a parent's index is below its child's).
    for j in (0..nb).rev() {
        if let Some(p) = mech.joints[j].parent {
            let (f, m) = (force[j], moment0[j]);
            force[p] += f;
            moment0[p] += m;
        }
    }
    (0..nb)
        .map(|j| {
            let f = force[j];
            // Σ (I α + r × m a − M_ext) about O_j = the same about the origin − O_j × Σ(m a − F_ext).
            let moment = moment0[j] - cross2(origin[j], f);
            let e = radial[j];
            Reaction { force_world: f, radial: f.dot(&e), tangential: f.dot(&perp(e)), moment }
        })
        .collect()
}
