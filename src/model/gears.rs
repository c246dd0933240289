//! Gear pairs and fixed-ratio couplings between joints (issue 15, item 1).
//!
//! A rigid coupling is a motion constraint on two joint coordinates,
//! `q_joint = ratio · q_follows + offset`, hence on their rates `q̇_joint = ratio · q̇_follows`
//! (a gear mesh with its sign, a belt or a chain; the rates are each joint's rate relative to its
//! parent). Kane's method treats it by dependent speeds: `u_d = A u_i` with A constant, so the
//! state is the independent coordinates alone and the reduced equations are
//! `F̃_r + F̃*_r = 0`, `F̃ = F_i + Aᵀ F_d` ([`crate::kane`]'s `reduce` module does the reduction;
//! docs/design.md, "Gears").
//!
//! A compliant coupling (`mesh: (stiffness: k, damping: c)`) is no constraint: both joints keep
//! their coordinates and a spring and damper act on the mesh deflection measured at the driving
//! joint, `e = q_follows − (q_joint − offset) / ratio` (the driver's coordinate minus the driven
//! one's reflected through the ratio; a shaft between the driver and a rigid gear stage is the
//! same spring). Its potential `½ k e²` gives the generalized forces `−(k e + c ė)` on `follows`
//! and `+(k e + c ė) / ratio` on `joint`.
//!
//! Here: the RON form ([`GearSpec`]), the resolved coupling ([`Gear`]), the map from the reduced
//! state to every joint's coordinate ([`Follow`], [`Mechanism::follow_map`]) and the unconstrained
//! tree the engine evaluates before reducing ([`Mechanism::expanded`]). Validation with located
//! errors is [`resolve`], called by [`crate::load`].

use crate::error::{Error, Result};
use crate::io::Source;
use crate::model::joint::{Joint, JointKind};
use crate::model::mechanism::{Mechanism, known_list};
use crate::model::speeds::Speeds;
use serde::{Deserialize, Serialize};

/// Relative tolerance on the product of the ratios around a loop of couplings (and on its
/// offset) for the loop to count as consistent: rounding of a few multiplications.
const LOOP_TOL: f64 = 1e-12;

/// A coupling as written in the mechanism file's `gears: [...]`:
/// `Gear(joint: "output", follows: "input", ratio: -3.2)` says `q̇_output = −3.2 · q̇_input`.
///
/// # Common mistake
/// The ratio is the driven joint's rate over the driver's, `ratio = q̇_joint / q̇_follows`: a
/// 3.2 : 1 reduction (output slower, turning the other way) is `ratio: -0.3125`, not `-3.2`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename = "Gear", deny_unknown_fields)]
pub struct GearSpec {
    /// The driven joint (rigid coupling: its coordinate becomes dependent).
    pub joint: String,
    /// The driving joint.
    pub follows: String,
    /// `q̇_joint / q̇_follows`, signed (negative for an external mesh); rad/rad, m/rad for a rack
    /// on a pinion, and so on in the two coordinates' units. Finite and non-zero.
    pub ratio: f64,
    /// `q_joint − ratio · q_follows` (rad or m of the driven joint), default 0: both at zero
    /// together.
    #[serde(default)]
    pub offset: f64,
    /// A compliant mesh instead of a rigid constraint.
    #[serde(default)]
    pub mesh: Option<Mesh>,
}

/// The stiffness and damping of a compliant mesh, reflected to the driving joint's coordinate
/// (`follows`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Mesh {
    /// k on the deflection `q_follows − (q_joint − offset) / ratio`: N·m/rad on a revolute driving
    /// joint (N/m on a prismatic one). Finite and positive.
    pub stiffness: f64,
    /// c on the deflection rate, N·m·s/rad (N·s/m), default 0. Finite and non-negative.
    #[serde(default)]
    pub damping: f64,
}

/// A resolved coupling: joints by their tree index.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Gear {
    /// The driven joint.
    pub joint: usize,
    /// The driving joint.
    pub follows: usize,
    /// `q̇_joint / q̇_follows`.
    pub ratio: f64,
    /// `q_joint − ratio · q_follows` at rest in a rigid coupling; the mesh's free deflection
    /// otherwise.
    pub offset: f64,
    /// `Some` for a compliant mesh (both joints independent), `None` for a rigid constraint.
    pub mesh: Option<Mesh>,
}

/// How a joint's coordinate follows from the reduced state:
/// `q_joint = factor · q[coordinate] + offset`, `q̇_joint = factor · q̇[coordinate]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Follow {
    /// The independent (reduced) coordinate it moves with.
    pub coordinate: usize,
    /// The product of the ratios from that coordinate's joint down to this one (1 for an
    /// independent joint).
    pub factor: f64,
    /// Its offset, rad or m (0 for an independent joint).
    pub offset: f64,
}

impl Mechanism {
    /// True when the mechanism has couplings (rigid or compliant): the engine then evaluates the
    /// unconstrained tree and reduces it.
    pub fn is_geared(&self) -> bool {
        !self.gears.is_empty()
    }

    /// Per joint, how its coordinate follows from the reduced state; `None` for a joint without
    /// coordinate (`Fixed`). A rigidly driven joint has `coordinate: None` in
    /// [`Joint::coordinate`] but a `Follow` here, so its angle and rate stay readable.
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

    /// Why the spin angle of root joint `spin` is not cyclic through a coupling, if it is not: the
    /// linear analysis drops that angle, which is right only when shifting it changes no force.
    /// A joint geared to the spin coordinate keeps it cyclic when it turns about a fixed axis of
    /// its own (a revolute joint on ground) with no spring and no compliant mesh; any other joint
    /// moved by the spin angle through a coupling changes the forces with it.
    pub fn spin_breaks_cyclic(&self, spin: usize) -> Option<String> {
        let s = self.joints.get(spin)?.coordinate?;
        let map = self.follow_map();
        for (j, joint) in self.joints.iter().enumerate() {
            if j == spin || map[j].is_none_or(|f| f.coordinate != s) {
                continue;
            }
            let meshed = self.gears.iter().any(|g| g.mesh.is_some() && (g.joint == j || g.follows == j));
            let sprung = joint.spring.is_some_and(|sp| sp.stiffness != 0.0);
            if joint.parent.is_some() || joint.kind != JointKind::Revolute || sprung || meshed {
                return Some(format!(
                    "joint `{}` is geared to the spin joint `{}` and {}, so the spin angle is not cyclic; the \
                     linear analysis needs it cyclic (put the compliance in a shaft spring after a rigid gear, or \
                     mount the gears on a carrier driven by the spin joint)",
                    joint.name,
                    self.joints[spin].name,
                    if meshed {
                        "meshes compliantly"
                    } else if sprung {
                        "has a spring"
                    } else {
                        "does not turn about a fixed axis of its own"
                    }
                ));
            }
        }
        // The spin joint's own mesh turns with its angle too.
        if self.gears.iter().any(|g| g.mesh.is_some() && (g.joint == spin || g.follows == spin)) {
            return Some(format!(
                "the spin joint `{}` meshes compliantly with another joint, so the spin angle is not cyclic; the \
                 linear analysis needs it cyclic (mount the gears on a carrier driven by the spin joint, or use a \
                 rigid gear and a shaft spring)",
                self.joints[spin].name
            ));
        }
        None
    }

    /// The first rigidly driven rotating joint on the path from ground to body `body`, if any: the
    /// body's angle then involves a gear ratio, which [`Mechanism::rotation_coordinates`] (and the
    /// probes and study responses built on it) leave out.
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

/// After body/joint `c` is removed from a mechanism, the couplings' joint indices shift down.
pub(crate) fn shift_after_removal(gears: &mut [Gear], c: usize) {
    let shift = |i: usize| if i > c { i - 1 } else { i };
    for g in gears {
        g.joint = shift(g.joint);
        g.follows = shift(g.follows);
    }
}

/// Numbers the coordinates over the joints that have a coordinate kind and are not rigidly
/// driven, in tree order; returns how many.
pub(crate) fn renumber(joints: &mut [Joint], gears: &[Gear]) -> usize {
    let mut next = 0;
    for (j, joint) in joints.iter_mut().enumerate() {
        let driven = gears.iter().any(|g| g.mesh.is_none() && g.joint == j);
        joint.coordinate = (joint.kind.dof() == 1 && !driven).then(|| {
            next += 1;
            next - 1
        });
    }
    next
}

/// Checks the file's couplings against the joints (in tree order, `index_of` a joint name's tree
/// index), numbers the coordinates of the reduced state and returns the resolved couplings. Every
/// error names `gears[i]` and the field.
pub(crate) fn resolve(
    specs: &[GearSpec],
    joints: &mut [Joint],
    speeds: Speeds,
    index_of: &dyn Fn(&str) -> Option<usize>,
    src: &Source,
) -> Result<Vec<Gear>> {
    let mut gears: Vec<Gear> = Vec::with_capacity(specs.len());
    // Which coupling (file index) drives each joint rigidly.
    let mut driven_by: Vec<Option<usize>> = vec![None; joints.len()];
    let mut file_index = Vec::with_capacity(specs.len());
    for (i, g) in specs.iter().enumerate() {
        let path = format!("gears[{i}]");
        if speeds != Speeds::JointRates {
            return Err(src.error(
                &path,
                "couplings need `speeds: JointRates` (a coupling fixes the ratio of two joint rates; with absolute \
                 angular velocities as speeds that is not a relation between speeds alone)",
            ));
        }
        let joint_of = |field: &str, name: &str| -> Result<usize> {
            let Some(j) = index_of(name) else {
                return Err(src.error(
                    &format!("{path}.{field}"),
                    format!("unknown joint `{name}` (joints: {})", known_list(joints.iter().map(|j| j.name.as_str()))),
                ));
            };
            match joints[j].kind {
                JointKind::Revolute | JointKind::Prismatic { .. } => Ok(j),
                JointKind::Fixed => Err(src.error(
                    &format!("{path}.{field}"),
                    format!("joint `{name}` is Fixed: it has no coordinate to couple"),
                )),
                JointKind::Path { .. } => Err(src.error(
                    &format!("{path}.{field}"),
                    format!(
                        "joint `{name}` is a path joint: couplings join revolute and prismatic joints (a gear does \
                         not drive an absorber along its path)"
                    ),
                )),
            }
        };
        let joint = joint_of("joint", &g.joint)?;
        let follows = joint_of("follows", &g.follows)?;
        if joint == follows {
            return Err(src.error(&format!("{path}.follows"), format!("joint `{}` cannot follow itself", g.joint)));
        }
        if !(g.ratio.is_finite() && g.ratio != 0.0) {
            return Err(src.error(
                &format!("{path}.ratio"),
                format!("the ratio q̇_joint / q̇_follows must be finite and non-zero, got {}", g.ratio),
            ));
        }
        if !g.offset.is_finite() {
            return Err(src.error(&format!("{path}.offset"), format!("the offset must be finite, got {}", g.offset)));
        }
        if let Some(m) = g.mesh {
            if !(m.stiffness.is_finite() && m.stiffness > 0.0) {
                return Err(src.error(
                    &format!("{path}.mesh.stiffness"),
                    format!("mesh stiffness must be finite and positive (N·m/rad), got {}", m.stiffness),
                ));
            }
            if !(m.damping.is_finite() && m.damping >= 0.0) {
                return Err(src.error(
                    &format!("{path}.mesh.damping"),
                    format!("mesh damping must be finite and non-negative (N·m·s/rad), got {}", m.damping),
                ));
            }
        } else {
            if let Some(prev) = driven_by[joint] {
                return Err(src.error(
                    &format!("{path}.joint"),
                    format!(
                        "joint `{}` is already driven by gears[{}]; a joint can follow only one other (couple \
                         the second joint to it instead)",
                        g.joint, file_index[prev]
                    ),
                ));
            }
            // Does this coupling close a loop? Walk the driving chain up from `follows`.
            let mut chain = vec![follows];
            let (mut factor, mut offset) = (1.0, 0.0);
            let mut at = follows;
            while let Some(k) = driven_by[at] {
                let prev = &gears[k];
                // q_at = r q_next + o, composed: q_follows = factor q_at + offset.
                offset += factor * prev.offset;
                factor *= prev.ratio;
                at = prev.follows;
                chain.push(at);
                if at == joint {
                    break;
                }
            }
            if at == joint {
                // Around the loop: q_joint = ratio (factor q_joint + offset) + g.offset.
                let (lf, lo) = (g.ratio * factor, g.ratio * offset + g.offset);
                let names: Vec<&str> = std::iter::once(joint).chain(chain).map(|j| joints[j].name.as_str()).collect();
                let scale = 1.0 + g.offset.abs() + (g.ratio * offset).abs();
                if (lf - 1.0).abs() <= LOOP_TOL && lo.abs() <= LOOP_TOL * scale {
                    // Consistent: redundant, implied by the others. Keep it out of the reduction.
                    continue;
                }
                return Err(src.error(
                    &format!("{path}.ratio"),
                    format!(
                        "this coupling closes a loop of ratios ({}) inconsistently: around the loop the ratios \
                         multiply to {lf} and the offsets add to {lo}, not 1 and 0, so the loop would lock",
                        names.join(" ← ")
                    ),
                ));
            }
            driven_by[joint] = Some(gears.len());
        }
        file_index.push(i);
        gears.push(Gear { joint, follows, ratio: g.ratio, offset: g.offset, mesh: g.mesh });
    }
    renumber(joints, &gears);
    Ok(gears)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shift_moves_later_indices_down() {
        let mut g = [Gear { joint: 3, follows: 1, ratio: 2.0, offset: 0.0, mesh: None }];
        shift_after_removal(&mut g, 2);
        assert_eq!((g[0].joint, g[0].follows), (2, 1));
    }
}
