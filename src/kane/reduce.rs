//! Couplings as Kane motion constraints: the reduced equations of a geared mechanism.
//!
//! A rigid coupling makes a joint rate dependent, `u_d = A u_i` with A constant (products of gear
//! ratios). Kane's reduced equations keep one equation per independent speed,
//! `F̃_r + F̃*_r = 0` with `F̃_r = F_r + Σ_d A_dr F_d` (and the same for F*): with `T` the constant
//! map from the independent speeds to all of them (`u_full = T u`, the identity rows for the
//! independent speeds and A's rows for the dependent ones), the partial velocities of the
//! constrained system are those of the unconstrained tree times T, so
//!
//!   `M̃ = Tᵀ M T`,  `F̃ = Tᵀ F`,
//!
//! with M and F the unconstrained tree's at the expanded state `q_full = T q + offset`,
//! `u_full = T u`. Since `Ṫ = 0` no velocity term `Tᵀ M Ṫ u` appears.
//!
//! The engine keeps the unconstrained tree ([`crate::model::mechanism::Mechanism::expanded`],
//! joint rates as speeds) as an inner evaluator of its own numbering; every evaluation of the
//! geared mechanism expands q and u, runs the inner forms, adds the compliant meshes' forces and
//! reduces M and F into the outer buffers. T has one non-zero per row, so the reduction is one
//! pass over M. A mechanism without couplings never reaches this module.

use super::Kane;
use crate::error::Result;
use crate::model::mechanism::Mechanism;

/// A compliant mesh in the unconstrained tree's coordinates.
#[derive(Debug, Clone, Copy)]
struct MeshLoad {
    /// Expanded coordinate of the driven joint.
    joint: usize,
    /// Expanded coordinate of the driving joint.
    follows: usize,
    ratio: f64,
    offset: f64,
    stiffness: f64,
    damping: f64,
}

/// The unconstrained tree of a geared mechanism and the constant map to its reduced state.
#[derive(Debug, Clone)]
pub(super) struct Geared {
    /// The evaluator of the unconstrained tree (joint rates).
    full: Kane,
    /// Per expanded coordinate: (reduced coordinate, factor, offset), `q_f = factor q_r + offset`.
    map: Vec<(usize, f64, f64)>,
    meshes: Vec<MeshLoad>,
    /// The expanded state of one evaluation.
    q: Vec<f64>,
    u: Vec<f64>,
}

impl Geared {
    /// The inner evaluator for `mech` (geared), in the world frame when `world`.
    pub(super) fn new(mech: &Mechanism, world: bool) -> Result<Self> {
        let full_mech = mech.expanded();
        let follow = mech.follow_map();
        let mut map = Vec::with_capacity(full_mech.ndof());
        let mut expanded = vec![usize::MAX; mech.joints.len()];
        for (j, joint) in full_mech.joints.iter().enumerate() {
            if let (Some(k), Some(f)) = (joint.coordinate, follow[j]) {
                debug_assert_eq!(k, map.len(), "internal: expanded coordinates are numbered in tree order");
                map.push((f.coordinate, f.factor, f.offset));
                expanded[j] = k;
            }
        }
        let meshes = mech
            .gears
            .iter()
            .filter_map(|g| {
                let m = g.mesh?;
                Some(MeshLoad {
                    joint: expanded[g.joint],
                    follows: expanded[g.follows],
                    ratio: g.ratio,
                    offset: g.offset,
                    stiffness: m.stiffness,
                    damping: m.damping,
                })
            })
            .collect();
        let mut full = Kane::build(&full_mech, world)?;
        // The reduced evaluator adds the couplings of the independent joints itself (after the
        // reduction, in its own coordinates, where the linearisation can suspend them); the
        // unconstrained tree keeps only those of driven joints, which have no reduced coordinate:
        // otherwise an independent joint's coupling would act twice.
        let driven: Vec<usize> = (0..mech.joints.len())
            .filter(|&j| mech.joints[j].coordinate.is_none() && expanded[j] != usize::MAX)
            .map(|j| expanded[j])
            .collect();
        full.couplings.retain(|c| driven.contains(&c.coord));
        let nf = map.len();
        Ok(Geared { full, map, meshes, q: vec![0.0; nf], u: vec![0.0; nf] })
    }
}

impl Kane {
    /// [`super::Form::Geared`]: the unconstrained tree at the expanded state, its meshes' forces
    /// added, reduced to `Tᵀ M T` and `Tᵀ F` in the engine's buffers.
    ///
    /// NOTE: out of line, so the plain forms' hot code does not carry it.
    #[inline(never)]
    pub(super) fn evaluate_geared(&mut self, t: f64, q: &[f64], u: &[f64], forcing: bool) {
        let n = self.n;
        let Some(g) = self.geared.as_deref_mut() else {
            debug_assert!(false, "internal: a geared form without its unconstrained tree");
            return;
        };
        for (f, &(k, a, o)) in g.map.iter().enumerate() {
            g.q[f] = a * q[k] + o;
            g.u[f] = if forcing { a * u[k] } else { 0.0 };
        }
        g.full.evaluate(t, &g.q, &g.u, forcing);
        let nf = g.map.len();
        let (mf, ff) = (&g.full.m[..nf * nf], &mut g.full.f[..nf]);
        if forcing {
            // The mesh spring and damper on the deflection at the driver,
            // e = q_follows − (q_joint − offset) / r: potential ½ k e².
            for mesh in &g.meshes {
                let e = g.q[mesh.follows] - (g.q[mesh.joint] - mesh.offset) / mesh.ratio;
                let edot = g.u[mesh.follows] - g.u[mesh.joint] / mesh.ratio;
                let force = mesh.stiffness * e + mesh.damping * edot;
                ff[mesh.follows] -= force;
                ff[mesh.joint] += force / mesh.ratio;
            }
        }
        let (m, f) = (&mut self.m[..n * n], &mut self.f[..n]);
        m.fill(0.0);
        if forcing {
            f.fill(0.0);
        }
        for (r, &(kr, ar, _)) in g.map.iter().enumerate() {
            for (c, &(kc, ac, _)) in g.map.iter().enumerate() {
                m[kr * n + kc] += ar * ac * mf[r * nf + c];
            }
            if forcing {
                f[kr] += ar * ff[r];
            }
        }
        // Tᵀ M T is symmetric; the sums above add its two halves in different orders: mirror.
        for r in 0..n {
            for c in 0..r {
                m[c * n + r] = m[r * n + c];
            }
        }
        if forcing {
            // With joint rates as speeds (required with couplings) q̇ = u.
            for (k, &j) in self.joint_of.iter().enumerate() {
                self.state[j].qdot = u[k];
            }
        }
    }

    /// The unconstrained tree's evaluator of a geared mechanism (`None` without couplings), for
    /// tests of the reduction.
    pub fn unconstrained(&self) -> Option<&Kane> {
        self.geared.as_deref().map(|g| &g.full)
    }

    /// Kane's partial velocities of body `j` of a geared mechanism at reduced `q`: the
    /// unconstrained tree's at the expanded state, times T (`v_{j,r} = Σ_f v_{j,f} T_fr`).
    /// `None` without couplings.
    pub(super) fn geared_partial_velocities(
        &self,
        q: &[f64],
        j: usize,
    ) -> Option<(Vec<crate::model::math::Vec2>, Vec<f64>)> {
        let g = self.geared.as_deref()?;
        let qf: Vec<f64> = g.map.iter().map(|&(k, a, o)| a * q[k] + o).collect();
        let (vf, wf) = g.full.partial_velocities(&qf, j);
        let mut v = vec![crate::model::math::Vec2::zeros(); self.n];
        let mut w = vec![0.0; self.n];
        for (f, &(k, a, _)) in g.map.iter().enumerate() {
            v[k] += a * vf[f];
            w[k] += a * wf[f];
        }
        Some((v, w))
    }

    /// Forwards a joint torque to the unconstrained tree (same joint indices), which is what a
    /// geared mechanism evaluates.
    pub(super) fn set_geared_torque(&mut self, joint: usize, excitation: &crate::model::excitation::Excitation) {
        if let Some(g) = self.geared.as_deref_mut() {
            g.full.set_joint_torque(joint, excitation.clone());
        }
    }
}
