//! Gear pairs and fixed-ratio couplings between joints (issue 15, item 1).
//!
//! A rigid coupling is a motion constraint on two joint coordinates,
//! `q_joint = ratio · q_follows + offset`, hence on their rates `q̇_joint = ratio · q̇_follows`
//! (a gear mesh with its sign, a belt or a chain; the rates are each joint's rate relative to its
//! parent). Kane's method treats it by dependent speeds: `u_d = A u_i` with A constant, so the
//! state is the independent coordinates alone and the reduced equations are
//! `F̃_r + F̃*_r = 0`, `F̃ = F_i + Aᵀ F_d` ([`crate::kane`]'s `reduce` module does the reduction;
//! docs/design/model.md, "Gears").
//!
//! A compliant coupling (`mesh: (stiffness: k, damping: c)`) is no constraint: both joints keep
//! their coordinates and a spring and damper act on the mesh deflection measured at the driving
//! joint, `e = q_follows − (q_joint − offset) / ratio` (the driver's coordinate minus the driven
//! one's reflected through the ratio; a shaft between the driver and a rigid gear stage is the
//! same spring). Its potential `½ k e²` gives the generalized forces `−(k e + c ė)` on `follows`
//! and `+(k e + c ė) / ratio` on `joint`.
//!
//! Here: the RON form ([`GearSpec`]), the resolved coupling ([`Gear`]) and the map entry from the
//! reduced state to a joint's coordinate ([`Follow`]); validation with located errors is
//! `resolve`, called by [`crate::load`]. The mechanism's geared queries (its follow map, the
//! unconstrained tree the engine evaluates before reducing, locking a gear train) are in
//! [`super::geared`].

use crate::error::Result;
use crate::io::Source;
use crate::io::known_list;
use crate::model::joint::Joint;
use crate::model::speeds::Speeds;
use serde::{Deserialize, Serialize};

/// Relative tolerance on the product of the ratios around a loop of couplings (and on its
/// offset) for the loop to count as consistent: rounding of a few multiplications.
pub(crate) const LOOP_TOL: f64 = 1e-12;

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
            match joints[j].kind.uncouplable() {
                None => Ok(j),
                Some(why) => Err(src.error(&format!("{path}.{field}"), format!("joint `{name}` {why}"))),
            }
        };
        let joint = joint_of("joint", &g.joint)?;
        let follows = joint_of("follows", &g.follows)?;
        if joint == follows {
            return Err(src.error(&format!("{path}.follows"), format!("joint `{}` cannot follow itself", g.joint)));
        }
        if !super::ranges::within(g.ratio.abs(), &super::ranges::GEAR_RATIO) {
            return Err(src.error(
                &format!("{path}.ratio"),
                format!(
                    "the ratio q̇_joint / q̇_follows must be non-zero and finite, its size in {} (either sign), got {:e}",
                    super::ranges::show(&super::ranges::GEAR_RATIO),
                    g.ratio
                ),
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
