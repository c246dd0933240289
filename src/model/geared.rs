//! A geared mechanism's queries (issue 15, item 1; docs/design/model.md, "Gears"): the map from the
//! reduced state to every joint's coordinate and rate, the unconstrained tree the engine
//! evaluates before reducing (`expanded`), its reduction matrix T, and locking a gear train.
//! Kept apart from [`super::gears`] (the couplings as data) so that the mechanism, which holds
//! them, and these methods, which read the mechanism, do not import each other.

use crate::error::{Error, Result};
use crate::model::gears::{Follow, Gear, LOOP_TOL, renumber};
use crate::model::mechanism::Mechanism;
use crate::model::speeds::Speeds;

impl Mechanism {
    /// True when the mechanism has couplings (rigid or compliant): the engine then evaluates the
    /// unconstrained tree and reduces it.
    pub fn is_geared(&self) -> bool {
        !self.gears.is_empty()
    }

    /// Per joint, how its coordinate follows from the reduced state; `None` for a joint without
    /// coordinate (`Fixed`). A rigidly driven joint has `coordinate: None` in
    /// [`Joint::coordinate`](crate::model::joint::Joint::coordinate) but a `Follow` here, so its angle and rate stay readable.
    pub fn follow_map(&self) -> Vec<Option<Follow>> {
        let mut out: Vec<Option<Follow>> = self
            .joints
            .iter()
            .map(|j| j.coordinate.map(|coordinate| Follow { coordinate, factor: 1.0, offset: 0.0 }))
            .collect();
        // A chain a ← b ← c resolves in at most (number of couplings) sweeps; `resolve` refused
        // or cut every loop, so this terminates.
        let rigid: Vec<&Gear> = self.gears.iter().filter(|g| g.mesh.is_none()).collect();
        for _ in 0..=rigid.len() {
            let mut changed = false;
            for g in &rigid {
                if out[g.joint].is_none()
                    && let Some(f) = out[g.follows]
                {
                    out[g.joint] = Some(Follow {
                        coordinate: f.coordinate,
                        factor: g.ratio * f.factor,
                        offset: g.ratio * f.offset + g.offset,
                    });
                    changed = true;
                }
            }
            if !changed {
                break;
            }
        }
        out
    }

    /// The coordinate of joint `j` (rad or m) at reduced coordinates `q`, also for a rigidly
    /// driven joint; `None` for a joint without coordinate.
    pub fn joint_coordinate(&self, j: usize, q: &[f64]) -> Option<f64> {
        let f = self.follow_map()[j]?;
        Some(f.factor * q[f.coordinate] + f.offset)
    }

    /// The rate of joint `j` (rad/s or m/s) at reduced coordinate rates `qdot`, also for a
    /// rigidly driven joint; `None` for a joint without coordinate.
    pub fn joint_rate(&self, j: usize, qdot: &[f64]) -> Option<f64> {
        let f = self.follow_map()[j]?;
        Some(f.factor * qdot[f.coordinate])
    }

    /// The rotating joints on the path from ground to body `body` as (coordinate, factor) pairs:
    /// the body's absolute angle is `Σ factor · q[coordinate]` plus the offsets. Equals
    /// [`Mechanism::rotation_coordinates`] with factors 1 when no rigidly geared joint is on the
    /// path.
    pub fn rotation_rates(&self, body: usize) -> Vec<(usize, f64)> {
        let map = self.follow_map();
        self.path_to(body)
            .into_iter()
            .filter(|&j| self.joints[j].kind.rotates())
            .filter_map(|j| map[j].map(|f| (f.coordinate, f.factor)))
            .collect()
    }

    /// The rigid rotation driven by root joint `spin` (issue 29, item 1): per reduced coordinate,
    /// its rate when the spin coordinate turns at unit rate and no spring, shaft or mesh deflects
    /// (z with `z[s] = 1`). Rigid gears are already in the coordinates; a compliant mesh between
    /// a turning joint and another passes the rotation on through its ratio (`q̇_joint = ratio ·
    /// q̇_follows` leaves its deflection unchanged), so a branched gearbox whose shafts are springs
    /// between meshes turns as a whole along z. Coordinates the rotation does not reach (a
    /// pendulum, a shaft's twist behind a hub) get 0.
    ///
    /// The linear analysis and harmonic balance expand about `q⁰ + Ωt z`, which is a steady motion
    /// only when shifting the coordinates along z changes no force: every joint that turns with
    /// the rotation must turn about a fixed axis of its own (a revolute joint on ground) with no
    /// spring, staged spring or end stop to ground. Errs with the reason otherwise, and when a
    /// loop of meshes has ratios whose product is not 1 (then no rigid rotation exists: the train
    /// locks up statically).
    pub fn rigid_rotation(&self, spin: usize) -> std::result::Result<Vec<f64>, String> {
        if self.joints.get(spin).and_then(|j| j.coordinate).is_none() {
            return Err("the spin joint has no coordinate".to_string());
        }
        let (z, disagreement) = self.rotation_propagated(spin);
        if let Some(why) = disagreement {
            return Err(why);
        }
        let map = self.follow_map();
        for (j, joint) in self.joints.iter().enumerate() {
            let Some(r) = map[j].map(|f| f.factor * z[f.coordinate]) else { continue };
            if j == spin || r == 0.0 {
                continue;
            }
            let sprung = joint.spring.is_some_and(|sp| sp.stiffness != 0.0);
            let staged = joint.couplings.stages.is_some() || joint.couplings.stops.is_some();
            if joint.parent.is_some() || !joint.kind.rotates() || sprung || staged {
                return Err(format!(
                    "joint `{}` turns with the spin joint `{}` (through a gear or mesh) and {}, so the \
                     rotation is not cyclic; the linear analysis and harmonic balance need every joint that \
                     turns with the spin to turn on a bearing of its own (a revolute joint on ground) with no \
                     spring to ground (put a shaft's compliance in a mesh of ratio 1 between two such joints, \
                     or in a joint spring behind them)",
                    joint.name,
                    self.joints[spin].name,
                    if sprung {
                        "has a spring"
                    } else if staged {
                        "has a staged spring or end stops"
                    } else {
                        "does not turn about a fixed axis of its own"
                    }
                ));
            }
        }
        Ok(z)
    }

    /// The first rigidly driven rotating joint on the path from ground to body `body`, if any: the
    /// body's angle then involves a gear ratio, which [`Mechanism::rotation_coordinates`] leaves
    /// out and [`Mechanism::rotation_rates`] (what probes and study responses use) holds.
    pub fn driven_joint_above(&self, body: usize) -> Option<usize> {
        let map = self.follow_map();
        self.path_to(body).into_iter().find(|&j| {
            let joint = &self.joints[j];
            joint.kind.rotates() && joint.coordinate.is_none() && map[j].is_some()
        })
    }

    /// The unconstrained tree: every joint that has a coordinate kind gets one (in tree order),
    /// no couplings, joint rates as speeds. The engine evaluates it at the expanded state and
    /// reduces (`kane::reduce`); tests compare with the textbook reduction `TᵀMT`, `TᵀF`.
    pub fn expanded(&self) -> Mechanism {
        let mut out = self.clone();
        out.gears.clear();
        out.speeds = Speeds::JointRates;
        let mut next = 0;
        for j in &mut out.joints {
            j.coordinate = (j.kind.dof() == 1).then(|| {
                next += 1;
                next - 1
            });
        }
        out
    }

    /// Per coordinate of [`Mechanism::expanded`] (in its order), the reduced coordinate it
    /// follows, the factor and the offset: `q_full = factor · q[coordinate] + offset`. An
    /// independent joint's entry is (its coordinate, 1, 0). The same map as
    /// [`Mechanism::reduction_matrix`], kept sparse.
    pub fn expansion(&self) -> Vec<(usize, f64, f64)> {
        self.follow_map()
            .into_iter()
            .zip(&self.joints)
            .filter(|(_, j)| j.kind.dof() == 1)
            .filter_map(|(f, _)| f.map(|f| (f.coordinate, f.factor, f.offset)))
            .collect()
    }

    /// The expanded tree's state from the reduced one: coordinates `q_full = T q + offsets`
    /// (rad or m), rates `q̇_full = T q̇` and accelerations `q̈_full = T q̈` (T constant, so no
    /// `Ṫ q̇` term), in [`Mechanism::expanded`]'s numbering. Without couplings the copies of the
    /// inputs.
    pub fn expand_state(&self, q: &[f64], qdot: &[f64], qddot: &[f64]) -> [Vec<f64>; 3] {
        let map = self.expansion();
        let q_full = map.iter().map(|&(k, a, o)| a * q[k] + o).collect();
        let qd_full = map.iter().map(|&(k, a, _)| a * qdot[k]).collect();
        let qdd_full = map.iter().map(|&(k, a, _)| a * qddot[k]).collect();
        [q_full, qd_full, qdd_full]
    }

    /// The coupling that drives joint `j` (rigid or compliant: `gears[i].joint == j`), if exactly
    /// one does; `Err` with the couplings' indices when several compliant meshes drive it.
    pub fn gear_driving(&self, j: usize) -> std::result::Result<Option<usize>, Vec<usize>> {
        let found: Vec<usize> = (0..self.gears.len()).filter(|&i| self.gears[i].joint == j).collect();
        match found.len() {
            0 => Ok(None),
            1 => Ok(Some(found[0])),
            _ => Err(found),
        }
    }

    /// The offset of body `body`'s absolute angle from `Σ factor · q[coordinate]` over
    /// [`Mechanism::rotation_rates`]: the sum of the rigid couplings' offsets (rad) of the
    /// rotating joints on its path.
    pub fn rotation_offset(&self, body: usize) -> f64 {
        let map = self.follow_map();
        self.path_to(body)
            .into_iter()
            .filter(|&j| self.joints[j].kind.rotates())
            .filter_map(|j| map[j].map(|f| f.offset))
            .sum()
    }

    /// Each joint's rate (relative to its parent) per unit rate of the spin joint `spin` in the
    /// steady rigid rotation of the driveline: the spin joint at 1, every joint geared to it at
    /// its factor (the product of the ratios down its chain, rigid couplings and compliant meshes
    /// alike: a compliant mesh's steady deflection rate is zero), every other joint at rest
    /// relative to its parent. Without couplings: 1 at the spin joint, 0 elsewhere.
    pub fn steady_rates(&self, spin: usize) -> Vec<f64> {
        let (z, _) = self.rotation_propagated(spin);
        self.follow_map().iter().map(|f| f.map_or(0.0, |f| f.factor * z[f.coordinate])).collect()
    }

    /// The rotation from the spin coordinate through the compliant meshes, per reduced
    /// coordinate (see [`Mechanism::rigid_rotation`]), and the first disagreement around a loop
    /// of meshes, if any (the first rate to reach a coordinate is kept). Zeros without a spin
    /// coordinate.
    fn rotation_propagated(&self, spin: usize) -> (Vec<f64>, Option<String>) {
        let Some(s) = self.joints.get(spin).and_then(|j| j.coordinate) else { return (vec![0.0; self.ndof()], None) };
        let map = self.follow_map();
        let mut z: Vec<Option<f64>> = vec![None; self.ndof()];
        z[s] = Some(1.0);
        let rate = |z: &[Option<f64>], j: usize| map[j].and_then(|f| z[f.coordinate].map(|r| f.factor * r));
        let meshes: Vec<&Gear> = self.gears.iter().filter(|g| g.mesh.is_some()).collect();
        let mut disagreement = None;
        // Each sweep reaches at least one more coordinate or stops: at most one per mesh.
        for _ in 0..=meshes.len() {
            let mut changed = false;
            for g in &meshes {
                let (Some(fj), Some(ff)) = (map[g.joint], map[g.follows]) else { continue };
                match (rate(&z, g.joint), rate(&z, g.follows)) {
                    (None, Some(rf)) => {
                        z[fj.coordinate] = Some(g.ratio * rf / fj.factor);
                        changed = true;
                    }
                    (Some(rj), None) => {
                        z[ff.coordinate] = Some(rj / g.ratio / ff.factor);
                        changed = true;
                    }
                    (Some(rj), Some(rf))
                        if disagreement.is_none()
                            && (rj - g.ratio * rf).abs() > LOOP_TOL * rj.abs().max((g.ratio * rf).abs()) =>
                    {
                        disagreement = Some(format!(
                            "the mesh of joint `{}` on `{}` (ratio {}) closes a loop of couplings whose ratios \
                             disagree: turning the train as a whole needs {} here, so the gears cannot turn without \
                             deflecting a mesh (no rigid rotation; check the ratios' values and signs)",
                            self.joints[g.joint].name,
                            self.joints[g.follows].name,
                            g.ratio,
                            rj / rf
                        ));
                    }
                    _ => {}
                }
            }
            if !changed {
                break;
            }
        }
        (z.into_iter().map(|r| r.unwrap_or(0.0)).collect(), disagreement)
    }

    /// The constant map T from the reduced speeds (n) to the expanded tree's (columns of
    /// [`Mechanism::expanded`]'s coordinates): `u_full = T u`, row-major `nf × n`.
    pub fn reduction_matrix(&self) -> nalgebra::DMatrix<f64> {
        let full = self.expanded();
        let map = self.follow_map();
        let mut t = nalgebra::DMatrix::zeros(full.ndof(), self.ndof());
        for (j, joint) in full.joints.iter().enumerate() {
            if let (Some(r), Some(f)) = (joint.coordinate, map[j]) {
                t[(r, f.coordinate)] = f.factor;
            }
        }
        t
    }

    /// The rigid couplings whose joints are connected to joint `j` (its gear train), and `j`'s
    /// follow; empty when `j` is not rigidly coupled. For [`Mechanism::lock`].
    fn gear_train(&self, j: usize) -> Vec<usize> {
        let mut members = vec![j];
        let mut grew = true;
        while grew {
            grew = false;
            for g in self.gears.iter().filter(|g| g.mesh.is_none()) {
                let (a, b) = (members.contains(&g.joint), members.contains(&g.follows));
                if a != b {
                    members.push(if a { g.follows } else { g.joint });
                    grew = true;
                }
            }
        }
        if members.len() == 1 { Vec::new() } else { members }
    }

    /// [`Mechanism::lock`] of a joint in a rigid gear train: locking either side locks the whole
    /// train, each joint at the coordinate the train gives it when `name` is at `q_lock`.
    /// `Ok(None)` when the joint is not rigidly coupled (the caller locks it alone). A joint with a
    /// compliant mesh is refused: its spring would act between a weld and a moving joint, which
    /// the mesh does not model.
    pub(crate) fn lock_gear_train(&self, name: &str, q_lock: f64) -> Result<Option<Mechanism>> {
        let Some(c) = self.joint_index(name) else { return Ok(None) };
        let model = |message: String| Error::Model { mechanism: self.name.clone(), message };
        if self.gears.iter().any(|g| g.mesh.is_some() && (g.joint == c || g.follows == c)) {
            return Err(model(format!(
                "joint `{name}` has a compliant gear mesh; locking it is not supported (remove the mesh or lock \
                 another joint)"
            )));
        }
        let train = self.gear_train(c);
        if train.is_empty() {
            return Ok(None);
        }
        let map = self.follow_map();
        let Some(fc) = map[c] else { return Ok(None) };
        let names: Vec<String> = train.iter().map(|&j| self.joints[j].name.clone()).collect();
        // The train's independent coordinate at which `name` sits at q_lock.
        let root = (q_lock - fc.offset) / fc.factor;
        let coords: Vec<f64> = train.iter().map(|&j| map[j].map_or(0.0, |f| f.factor * root + f.offset)).collect();
        // Without the train's couplings its joints are plain joints: lock them one by one.
        let mut free = self.clone();
        free.gears.retain(|g| g.mesh.is_some() || !(train.contains(&g.joint) || train.contains(&g.follows)));
        renumber(&mut free.joints, &free.gears);
        let mut out = free;
        for (joint, q) in names.iter().zip(coords) {
            out = out.lock(joint, q).map_err(|e| match e {
                Error::Model { message, .. } => {
                    model(format!("locking `{name}` locks its gear train ({}): {message}", names.join(", ")))
                }
                e => e,
            })?;
        }
        out.name = format!("{}_locked", self.name);
        Ok(Some(out))
    }
}
