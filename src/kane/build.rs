//! Building the [`Model`] of a mechanism: the per-body records, the rollers, the pair
//! coefficients of the absolute-speed form, the couplings, the geared reduction, the choice of
//! form and factorisation, and the fixed-size form's packed data; and a joint's applied torque
//! changed after the build, which repacks that data (see the module doc of [`crate::kane`]).

use super::{Coupled, Form, GROUND_PARENT, Model, NO_COORD, Node, Satellite, Workspace, reduce, small};
use crate::error::{Error, Result};
use crate::model::excitation::Excitation;
use crate::model::loads::{JointTorque, PointForce};
use crate::model::math::cross2;
use crate::model::mechanism::Mechanism;
use crate::model::speeds::Speeds;

impl Model {
    /// Builds the model of `mech` (vectors in the world frame when `world`) with a workspace
    /// sized for it, and checks that M is positive definite at q = 0.
    pub(super) fn build(mech: &Mechanism, world: bool) -> Result<(Self, Workspace)> {
        Self::build_checked(mech, world, true)
    }

    /// [`Model::build`], the positive-definiteness check optional: a geared mechanism's
    /// unconstrained tree may hold massless pinions whose rows only the reduction `Tᵀ M T` fills
    /// (the reduced M is checked instead).
    pub(super) fn build_checked(mech: &Mechanism, world: bool, check: bool) -> Result<(Self, Workspace)> {
        let (n, nb) = (mech.ndof(), mech.bodies.len());
        let parent = mech.parents();
        let joint_of = check_numbering(mech, &parent)?;
        // Point forces grouped by body so each body's iteration finds its own.
        let mut point_forces = mech.loads.point_forces.clone();
        point_forces.sort_by_key(|p| p.body);
        let mut nodes = nodes_of(mech, &parent, &point_forces);
        let satellites = satellites_of(mech, &mut nodes);
        let revolute = mech.joints.iter().all(|j| j.kind.rotates());
        let form = match mech.speeds {
            Speeds::JointRates => Form::Rates,
            Speeds::AbsoluteAngularVelocities if revolute => Form::Pairs,
            Speeds::AbsoluteAngularVelocities => Form::MappedRates,
        };
        let form = if mech.is_geared() { Form::Geared } else { form };
        let pairs = if form == Form::Pairs { pair_coefficients(&mut nodes, &parent) } else { Vec::new() };
        let speed_parent = mech.speed_parents();
        let couplings = (0..nb)
            .filter_map(|j| {
                let jt = &mech.joints[j];
                let coord = jt.coordinate?;
                let absolute = mech.speeds == Speeds::AbsoluteAngularVelocities;
                let parent_speed = if absolute { speed_parent[coord] } else { None };
                (!jt.couplings.is_empty()).then(|| Coupled { coord, parent_speed, law: jt.couplings.clone() })
            })
            .collect();
        let mut k = Model {
            couplings,
            mech: mech.clone(),
            pairs,
            small: None,
            geared: None,
            tree: None,
            star: false,
            fast_star: None,
            fast_axial: None,
            articulated: false,
            roller_of: None,
            n,
            nb,
            speed_parent,
            joint_of,
            speeds: mech.speeds,
            form,
            world,
            gravity: mech.loads.gravity,
            nodes,
            rollers: satellites,
            point_forces,
            torques: mech.loads.joint_torques.clone(),
        };
        if form == Form::Geared {
            k.geared = Some(Box::new(reduce::Geared::new(mech, world)?));
        }
        let mut ws = Workspace::new(&k);
        let mut zeros = vec![0.0; n];
        if check {
            k.evaluate(&mut ws, 0.0, &zeros, &zeros, false);
            k.factor_solve(&mut ws, &mut zeros)?;
        }
        k.small = k.small_form();
        k.tree = k.tree_order();
        k.star = k.tree.as_deref().is_some_and(Model::is_star);
        k.roller_of = k.rollers_by_body();
        k.articulated = k.articulated_choice();
        k.fast_star = k.star_rhs();
        k.fast_axial = k.axial_rhs();
        Ok((k, ws))
    }

    /// The fixed-size right-hand side when it applies; never with couplings, whose forces only
    /// the general forms add ([`super::couplings`]).
    fn small_form(&self) -> Option<small::Small> {
        // Rollers take the general forms too (`Model::add_rollers`).
        if self.couplings.is_empty() && self.rollers.is_empty() { small::Small::new(self) } else { None }
    }

    /// Replaces the applied torque of joint `joint` (index) by `excitation` (adds one if the joint
    /// had none); ignored on a joint without coordinate. See [`super::Kane::set_joint_torque`].
    pub(super) fn set_joint_torque(&mut self, joint: usize, excitation: Excitation) {
        self.set_geared_torque(joint, &excitation);
        if self.nodes.get(joint).is_none_or(|nd| nd.coord == NO_COORD) {
            return;
        }
        match self.torques.iter_mut().find(|t| t.joint == joint) {
            Some(t) => t.excitation = excitation,
            None => self.torques.push(JointTorque { joint, excitation }),
        }
        // The fixed-size path maps each speed to its torque's place in the list.
        if self.small.is_some() {
            self.small = self.small_form();
        }
    }
}

/// The coordinates' joints, after checking the order the model relies on: every joint after
/// its parent, coordinates numbered 0..n over the joints.
fn check_numbering(mech: &Mechanism, parent: &[Option<usize>]) -> Result<Vec<usize>> {
    let (n, nb) = (mech.ndof(), mech.bodies.len());
    let internal = |message: String| Error::Model { mechanism: mech.name.clone(), message };
    for (j, p) in parent.iter().enumerate() {
        if p.is_some_and(|p| p >= j) {
            return Err(internal(format!("internal: joint `{}` is listed before its parent", mech.joints[j].name)));
        }
    }
    let joint_of: Vec<usize> = (0..n).map(|k| mech.joint_of(k)).collect();
    if joint_of.iter().any(|&j| j >= nb) || mech.joints.len() != nb {
        return Err(internal("internal: coordinates are not numbered 0..n over the joints".into()));
    }
    Ok(joint_of)
}

/// The per-body records: inertia, joint placement and elements, the body's slice of the sorted
/// `point_forces`, and the subtree's mass.
fn nodes_of(mech: &Mechanism, parent: &[Option<usize>], point_forces: &[PointForce]) -> Vec<Node> {
    let nb = mech.bodies.len();
    let mut c_ground = vec![0.0; nb];
    for g in &mech.loads.ground_dampers {
        c_ground[g.body] += g.c;
    }
    // NOTE: without the rollers: the composite-body form adds their terms apart, body by
    // body (`Model::add_rollers`); counted here too, their mass entered the composite sums of
    // every joint above their parent a second time (seen on deep random trees with rollers
    // against `reference`; a rotor carrying them, the parent being the root, never shifts its
    // sums, so no example moved).
    let mut subtree_mass: Vec<f64> = mech.bodies.iter().map(|b| b.inertia.mass).collect();
    for j in (0..nb).rev() {
        if let Some(p) = parent[j] {
            subtree_mass[p] += subtree_mass[j];
        }
    }
    let mut nodes = Vec::with_capacity(nb);
    for j in 0..nb {
        let f0 = point_forces.iter().position(|p| p.body == j).unwrap_or(0);
        let f1 = f0 + point_forces.iter().filter(|p| p.body == j).count();
        let (b, jt) = (&mech.bodies[j], &mech.joints[j]);
        nodes.push(Node {
            parent: jt.parent.unwrap_or(GROUND_PARENT),
            coord: jt.coordinate.unwrap_or(NO_COORD),
            kind: jt.kind,
            mass: b.inertia.mass,
            i_com: b.inertia.i_com,
            com_local: b.inertia.com,
            at: jt.at,
            k_spring: jt.spring.map_or(0.0, |s| s.stiffness),
            q_free: jt.spring.map_or(0.0, |s| s.free_angle),
            c_joint: jt.damper,
            c_ground: c_ground[j],
            forces: (f0, f1),
            subtree_mass: subtree_mass[j],
            j_own: b.inertia.i_com + b.inertia.mass * b.inertia.com.norm_squared(),
            diag_abs: 0.0,
            first_abs: b.inertia.mass * b.inertia.com,
        });
    }
    nodes
}

/// Each path joint's rollers as a satellite, their spread added to the path's parent as a
/// constant inertia.
fn satellites_of(mech: &Mechanism, nodes: &mut [Node]) -> Vec<Satellite> {
    let rollers = mech.roller_sets();
    // Each path joint's rollers, and their spread as a constant inertia of the path's parent.
    let mut satellites = Vec::with_capacity(rollers.len());
    for set in &rollers {
        let r = set.rollers;
        if let Some(p) = set.parent {
            nodes[p].i_com += r.spread_inertia();
            nodes[p].j_own += r.spread_inertia();
        }
        satellites.push(Satellite {
            parent: set.parent.unwrap_or(GROUND_PARENT),
            coord: set.coordinate,
            kind: set.kind,
            at: set.at,
            centre: set.centre,
            turn_rate: r.turn_rate(),
            mass: r.total_mass(),
            i_com: r.total_inertia(),
        });
    }
    satellites
}

/// The pair coefficients of the absolute-speed form (and each node's diagonal and first moment
/// about its joint, accumulated into `nodes`).
fn pair_coefficients(nodes: &mut [Node], parent: &[Option<usize>]) -> Vec<(f64, f64)> {
    let nb = nodes.len();
    let mut pairs = Vec::new();
    for j in 0..nb {
        nodes[j].diag_abs += nodes[j].j_own;
        if let Some(p) = parent[j] {
            let (mass, at) = (nodes[j].subtree_mass, nodes[j].at);
            nodes[p].diag_abs += mass * at.norm_squared();
            nodes[p].first_abs += mass * at;
        }
    }
    // For an ancestor k of body j (c: k's child on the path), every body of j's subtree
    // moves with u_k like a point at c's joint, so `M_kj = (R_k at_c)·(R_j S'_j)` with
    // both vectors constant in their own frames: with Δ = θ_j − θ_k,
    // `M_kj = α cos Δ − β sin Δ`, α = at_c·S'_j, β = at_c × S'_j.
    for j in 0..nb {
        let (mut c, mut k) = (j, parent[j]);
        while let Some(kk) = k {
            let (at, first) = (nodes[c].at, nodes[j].first_abs);
            pairs.push((at.dot(&first), cross2(at, first)));
            (c, k) = (kk, parent[kk]);
        }
    }
    pairs
}
