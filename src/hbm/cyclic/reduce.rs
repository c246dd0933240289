//! The reduced mechanism of the cyclic route (the room's docs, item 1): each identical set by
//! its first member with every mass, inertia and force parameter multiplied by N, the others
//! removed, and the maps between the reduced and the full numbering.

use super::detect::{CyclicSet, subtree};
use crate::hbm::balance::NonUnison;
use crate::model::loads::JointTorque;
use crate::model::mechanism::Mechanism;

/// The reduced mechanism of a cyclic route and the maps between it and the full one.
#[derive(Debug, Clone)]
pub(super) struct Reduction {
    pub(super) mech: Mechanism,
    /// Full joint → reduced joint (a member's joint → the representative's).
    pub(super) joint_map: Vec<usize>,
    /// Full coordinate → reduced coordinate.
    pub(super) coord_map: Vec<usize>,
    /// Reduced coordinate → a full coordinate it stands for (the representative's own).
    pub(super) coord_back: Vec<usize>,
    pub(super) non_unison: Vec<NonUnison>,
}

/// The reduced mechanism: each set's first member with its mass, inertia, springs, dampers,
/// couplings, rollers, own torques and ground dampers multiplied by N, the others removed.
pub(super) fn reduce(mech: &Mechanism, torques: &[JointTorque], sets: &[CyclicSet]) -> Reduction {
    let nj = mech.joints.len();
    let Members { mut joint_map, removed, scale, reps } = members(mech, sets);
    // Kept joints renumbered in order (parents stay first).
    let mut new_index = vec![usize::MAX; nj];
    let mut next = 0;
    for j in 0..nj {
        if !removed[j] {
            new_index[j] = next;
            next += 1;
        }
    }
    for j in 0..nj {
        joint_map[j] = new_index[joint_map[j]];
    }
    let mut out = mech.clone();
    out.name = format!("{}_cyclic", mech.name);
    scale_members(&mut out, &scale);
    renumber_loads(&mut out, torques, (&removed, &scale, &new_index));
    let keep: Vec<usize> = (0..nj).filter(|&j| !removed[j]).collect();
    out.bodies = keep.iter().map(|&j| out.bodies[j].clone()).collect();
    out.joints = keep.iter().map(|&j| out.joints[j].clone()).collect();
    let mut k = 0;
    for joint in &mut out.joints {
        joint.parent = joint.parent.map(|p| new_index[p]);
        if joint.coordinate.is_some() {
            joint.coordinate = Some(k);
            k += 1;
        }
    }
    let coord_map: Vec<usize> = (0..mech.ndof())
        .map(|c| {
            let j = mech.joint_of(c);
            out.joints[joint_map[j]].coordinate.unwrap_or(usize::MAX)
        })
        .collect();
    let mut coord_back = vec![usize::MAX; k];
    for (c, &r) in coord_map.iter().enumerate() {
        if coord_back[r] == usize::MAX {
            coord_back[r] = c;
        }
    }
    let non_unison = reps
        .iter()
        .zip(sets)
        .map(|((rep, n), set)| NonUnison {
            label: format!("non-unison {}, wavenumbers 1..{}", set, n - 1),
            coordinates: rep.iter().filter_map(|&j| out.joints[new_index[j]].coordinate).collect(),
            multiplicity: n - 1,
        })
        .collect();
    Reduction { mech: out, joint_map, coord_map, coord_back, non_unison }
}

/// What [`reduce`] keeps and scales: the joint map (a member's joint → the representative's,
/// full numbering), the removed joints, each joint's factor N (1 outside the sets), and each
/// set's representative subtree with its member count.
struct Members {
    joint_map: Vec<usize>,
    removed: Vec<bool>,
    scale: Vec<f64>,
    reps: Vec<(Vec<usize>, usize)>,
}

/// The representatives of `sets` in `mech` and the members they stand for.
fn members(mech: &Mechanism, sets: &[CyclicSet]) -> Members {
    let nj = mech.joints.len();
    let mut joint_map: Vec<usize> = (0..nj).collect();
    let mut removed = vec![false; nj];
    let mut scale = vec![1.0; nj];
    let mut reps = Vec::new();
    for set in sets {
        let idx = |name: &String| mech.joint_index(name).unwrap_or(usize::MAX);
        let rep = subtree(mech, idx(&set.members[0]));
        let n = set.members.len() as f64;
        for &j in &rep {
            scale[j] = n;
        }
        for m in &set.members[1..] {
            for (&jm, &jr) in subtree(mech, idx(m)).iter().zip(&rep) {
                removed[jm] = true;
                joint_map[jm] = jr;
            }
        }
        reps.push((rep, set.members.len()));
    }
    Members { joint_map, removed, scale, reps }
}

/// Every parameter of a representative's joint and body multiplied by its set's N (`scale`, 1
/// outside the sets): mass, inertia, damper, spring, couplings and rollers.
fn scale_members(out: &mut Mechanism, scale: &[f64]) {
    let nj = out.joints.len();
    for j in 0..nj {
        let s = scale[j];
        if s == 1.0 {
            continue;
        }
        let (body, joint) = (&mut out.bodies[j].inertia, &mut out.joints[j]);
        body.mass *= s;
        body.i_com *= s;
        joint.damper *= s;
        if let Some(sp) = &mut joint.spring {
            sp.stiffness *= s;
        }
        let c = &mut joint.couplings;
        if let Some(st) = &mut c.stages {
            for stage in st.drive.iter_mut().chain(st.coast.iter_mut().flatten()) {
                stage.stiffness *= s;
            }
        }
        if let Some(f) = &mut c.friction {
            f.torque *= s;
        }
        if let Some(e) = &mut c.stops {
            e.stiffness *= s;
            e.damping *= s;
        }
        if let Some(r) = &mut joint.rollers {
            r.mass *= s;
            r.inertia *= s;
        }
    }
}

/// The loads of the reduced mechanism: ground dampers scaled and those on removed bodies
/// dropped, point forces renumbered, and the evaluator's joint torques (they may differ from the
/// file's) scaled and renumbered; `(removed, scale, new_index)` per full joint.
fn renumber_loads(
    out: &mut Mechanism,
    torques: &[JointTorque],
    (removed, scale, new_index): (&[bool], &[f64], &[usize]),
) {
    for g in &mut out.loads.ground_dampers {
        g.c *= scale[g.body];
    }
    out.loads.ground_dampers.retain(|g| !removed[g.body]);
    for g in &mut out.loads.ground_dampers {
        g.body = new_index[g.body];
    }
    // Point forces never sit on members (`detect`), only their indices move.
    for f in &mut out.loads.point_forces {
        f.body = new_index[f.body];
    }
    let reduced_torques: Vec<JointTorque> = torques
        .iter()
        .filter(|t| !removed[t.joint])
        .map(|t| {
            let s = scale[t.joint];
            let mut e = t.excitation.clone();
            e.mean *= s;
            for h in &mut e.harmonics {
                h.amplitude *= s;
            }
            JointTorque { joint: new_index[t.joint], excitation: e }
        })
        .collect();
    // The evaluator's torques (they may differ from the file's), scaled and renumbered.
    out.loads.joint_torques = reduced_torques;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hbm::cyclic::detect::{Route, detect};
    use crate::kane::Kane;
    use approx::assert_abs_diff_eq;

    /// The reduced mechanism of a set of four: the rotor and one pendulum with four times the
    /// mass, inertia and damper of one member (the single pendulum of the same rotor), the
    /// coordinates of the three others mapped to it.
    #[test]
    fn the_reduced_mechanism_is_the_single_pendulum() {
        let p = crate::cpva::CpvaParams::canonical();
        let four = p.with_pendulums(4).mechanism(None).unwrap();
        let one = p.mechanism(None).unwrap();
        let kane = Kane::new(&four).unwrap();
        let Route::Cyclic { sets } = detect(&four, kane.joint_torques(), 0, &[0]) else { panic!("not cyclic") };
        assert_eq!(sets[0].members, ["pivot_1", "pivot_2", "pivot_3", "pivot_4"]);
        assert_eq!(sets[0].member_dof, 1);
        let red = reduce(&four, kane.joint_torques(), &sets);
        assert_eq!(red.coord_map, [0, 1, 1, 1, 1]);
        assert_eq!(red.coord_back, [0, 1]);
        assert_eq!(red.non_unison[0].coordinates, [1]);
        assert_eq!(red.non_unison[0].multiplicity, 3);
        assert_eq!(red.mech.bodies.len(), 2);
        for (a, b) in red.mech.bodies.iter().zip(&one.bodies) {
            assert_abs_diff_eq!(a.inertia.mass, b.inertia.mass, epsilon = 1e-15 * b.inertia.mass);
            assert_abs_diff_eq!(a.inertia.i_com, b.inertia.i_com, epsilon = 1e-15 * b.inertia.i_com);
            assert!((a.inertia.com - b.inertia.com).norm() <= 1e-15);
        }
        assert_abs_diff_eq!(red.mech.joints[1].damper, one.joints[1].damper, epsilon = 1e-18);
        assert_eq!(red.mech.joints[1].at, one.joints[1].at);
    }
}
