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
//! The model keeps the unconstrained tree ([`crate::model::mechanism::Mechanism::expanded`],
//! joint rates as speeds) as an inner [`Model`] of its own numbering, and the workspace its
//! buffers; every evaluation of the geared mechanism expands q and u, runs the inner forms, adds
//! the compliant meshes' forces and reduces M and F into the outer buffers. T has one non-zero per row, so the reduction is one
//! pass over M. A mechanism without couplings never reaches this module.

use super::{Model, Workspace};
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

/// One coupling as [`Model::gear_torques`] reads it.
#[derive(Debug, Clone, Copy)]
enum Link {
    /// A rigid coupling: expanded coordinates of the driven and the driving joint, the ratio.
    Rigid { joint: usize, follows: usize, ratio: f64 },
    /// A compliant mesh: its index in `Geared::meshes`.
    Mesh(usize),
}

/// The unconstrained tree of a geared mechanism and the constant map to its reduced state.
#[derive(Debug, Clone)]
pub(super) struct Geared {
    /// The model of the unconstrained tree (joint rates).
    full: Model,
    /// Per expanded coordinate: (reduced coordinate, factor, offset), `q_f = factor q_r + offset`.
    map: Vec<(usize, f64, f64)>,
    meshes: Vec<MeshLoad>,
    /// Per coupling of the mechanism (its `gears` order): a rigid one's expanded driven and
    /// driving coordinates and ratio, or a compliant one's index in `meshes`.
    links: Vec<Link>,
}

/// The buffers of a geared mechanism's evaluation: the unconstrained tree's, and the expanded
/// state.
#[derive(Debug, Clone)]
pub(super) struct GearedWork {
    full: Workspace,
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
        let mut n_mesh = 0;
        let links = mech
            .gears
            .iter()
            .map(|g| match g.mesh {
                None => Link::Rigid { joint: expanded[g.joint], follows: expanded[g.follows], ratio: g.ratio },
                Some(_) => {
                    n_mesh += 1;
                    Link::Mesh(n_mesh - 1)
                }
            })
            .collect();
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
        let (mut full, _) = Model::build_checked(&full_mech, world, false)?;
        // NOTE: an independent joint's nonlinear couplings (stages, friction, stops) are the
        // outer engine's, which adds them on the reduced coordinates (with their exact
        // Jacobians); the inner tree keeps only the driven joints'. Keeping both counted them
        // twice (issue 15 regression, tests/it/gear_reactions.rs).
        let independent: Vec<usize> = full_mech
            .joints
            .iter()
            .zip(&mech.joints)
            .filter(|(_, outer)| outer.coordinate.is_some())
            .filter_map(|(inner, _)| inner.coordinate)
            .collect();
        full.couplings.retain(|c| !independent.contains(&c.coord));
        Ok(Geared { full, map, meshes, links })
    }

    /// Buffers sized for this reduction.
    pub(super) fn workspace(&self) -> GearedWork {
        let nf = self.map.len();
        GearedWork { full: Workspace::new(&self.full), q: vec![0.0; nf], u: vec![0.0; nf] }
    }
}

impl Model {
    /// [`super::Form::Geared`]: the unconstrained tree at the expanded state, its meshes' forces
    /// added, reduced to `Tᵀ M T` and `Tᵀ F` in the engine's buffers.
    ///
    /// NOTE: out of line, so the plain forms' hot code does not carry it.
    #[inline(never)]
    pub(super) fn evaluate_geared(&self, ws: &mut Workspace, t: f64, q: &[f64], u: &[f64], forcing: bool) {
        let n = self.n;
        let (Some(g), Some(gw)) = (self.geared.as_deref(), ws.geared.as_deref_mut()) else {
            debug_assert!(false, "internal: a geared form without its unconstrained tree");
            return;
        };
        for (f, &(k, a, o)) in g.map.iter().enumerate() {
            gw.q[f] = a * q[k] + o;
            gw.u[f] = if forcing { a * u[k] } else { 0.0 };
        }
        g.full.evaluate(&mut gw.full, t, &gw.q, &gw.u, forcing);
        let nf = g.map.len();
        let (mf, ff) = (&gw.full.m[..nf * nf], &mut gw.full.f[..nf]);
        if forcing {
            // The mesh spring and damper on the deflection at the driver,
            // e = q_follows − (q_joint − offset) / r: potential ½ k e².
            for mesh in &g.meshes {
                let e = gw.q[mesh.follows] - (gw.q[mesh.joint] - mesh.offset) / mesh.ratio;
                let edot = gw.u[mesh.follows] - gw.u[mesh.joint] / mesh.ratio;
                let force = mesh.stiffness * e + mesh.damping * edot;
                ff[mesh.follows] -= force;
                ff[mesh.joint] += force / mesh.ratio;
            }
        }
        let (m, f) = (&mut ws.m[..n * n], &mut ws.f[..n]);
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
                ws.state[j].qdot = u[k];
            }
        }
    }

    /// The torque (N·m; N on a prismatic joint) each coupling's mesh exerts on its driven joint
    /// (`gears[i].joint`, as a joint torque: + on the child, − on the parent) at time `t`, reduced
    /// coordinates `q`, speeds `u` and their rates `udot`, in the mechanism's `gears` order; the
    /// driving joint receives `−ratio` times it (the same power with the opposite sign). Empty
    /// without couplings.
    ///
    /// A rigid coupling's torque is its constraint force λ: the unconstrained tree's residual
    /// `R = M_full T u̇ − F_full` at the expanded state is `Gᵀλ` (module doc of
    /// [`crate::kane::reactions`]), so `λ_d = R_d + Σ_e r_e λ_e` over the couplings e driven by
    /// d. A compliant mesh's is its spring and damper, `(k e + c ė) / ratio` with the deflection
    /// `e` at the driving joint. `udot` must be the engine's own accelerations at this state (from
    /// [`Kane::rhs`](super::Kane::rhs)) for λ to be the constraint's; the joint torques are this model's, so a
    /// torque applied at a driven joint must be set here as in the run. `ws` must be made for
    /// this model.
    pub fn gear_torques(&self, ws: &mut Workspace, t: f64, q: &[f64], u: &[f64], udot: &[f64]) -> Vec<f64> {
        if self.geared.is_none() {
            return Vec::new();
        }
        self.evaluate(ws, t, q, u, true);
        let (Some(g), Some(gw)) = (self.geared.as_deref(), ws.geared.as_deref()) else { return Vec::new() };
        let nf = g.map.len();
        let (mf, ff) = (&gw.full.m[..nf * nf], &gw.full.f[..nf]);
        let udot_full: Vec<f64> = g.map.iter().map(|&(k, a, _)| a * udot[k]).collect();
        let residual = |f: usize| -> f64 {
            let row = &mf[f * nf..(f + 1) * nf];
            row.iter().zip(&udot_full).map(|(m, a)| m * a).sum::<f64>() - ff[f]
        };
        let mut out = vec![f64::NAN; g.links.len()];
        // Chains resolve from their ends back: a coupling is ready once every rigid coupling it
        // drives is; `resolve` refused loops, so each sweep settles at least one.
        for _ in 0..=g.links.len() {
            let mut pending = false;
            for (i, link) in g.links.iter().enumerate() {
                if !out[i].is_nan() {
                    continue;
                }
                match *link {
                    Link::Mesh(m) => {
                        let mesh = &g.meshes[m];
                        let e = gw.q[mesh.follows] - (gw.q[mesh.joint] - mesh.offset) / mesh.ratio;
                        let edot = gw.u[mesh.follows] - gw.u[mesh.joint] / mesh.ratio;
                        out[i] = (mesh.stiffness * e + mesh.damping * edot) / mesh.ratio;
                    }
                    Link::Rigid { joint, .. } => {
                        let mut sum = residual(joint);
                        let mut ready = true;
                        for (e, other) in g.links.iter().enumerate() {
                            if let Link::Rigid { follows, ratio, .. } = *other
                                && follows == joint
                            {
                                ready &= !out[e].is_nan();
                                sum += ratio * out[e];
                            }
                        }
                        if ready {
                            out[i] = sum;
                        } else {
                            pending = true;
                        }
                    }
                }
            }
            if !pending {
                break;
            }
        }
        out
    }

    /// The unconstrained tree's model of a geared mechanism (`None` without couplings), for
    /// tests of the reduction and for its joint torques.
    pub fn unconstrained(&self) -> Option<&Model> {
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
