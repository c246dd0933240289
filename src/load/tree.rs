//! The mechanism's tree from the ordered joints: each body and joint in tree order, joint kinds
//! normalised, welded joints checked for elements they cannot carry, coordinates numbered.

use super::bodies::BodyTable;
use super::joints::{JointRow, JointTable};
use crate::error::Result;
use crate::io::Source;
use crate::model::body::Body;
use crate::model::coupling::Couplings;
use crate::model::joint::{Joint, JointKind};
use crate::model::math::Vec2;

/// The bodies and joints in tree order (`order` from [`super::joints::tree_order`]).
pub(super) fn build_tree(
    bodies: &BodyTable,
    joints: &JointTable,
    new_index: &[Option<usize>],
    order: &[usize],
    src: &Source,
) -> Result<(Vec<Body>, Vec<Joint>)> {
    let nb = bodies.specs.len();
    let mut tree_bodies = Vec::with_capacity(nb);
    let mut tree_joints = Vec::with_capacity(nb);
    let mut ncoord = 0;
    for &k in order {
        let row = &joints.specs[k];
        let (name, js, parent, child) = row;
        let (bname, props) = &bodies.specs[*child];
        let path = format!("joints[{k}]");
        let kind = checked_kind(row, src, &path)?;
        let coordinate = (kind.dof() == 1).then(|| {
            ncoord += 1;
            ncoord - 1
        });
        tree_bodies.push(Body { name: bname.clone(), inertia: *props });
        tree_joints.push(Joint {
            name: name.clone(),
            kind,
            parent: parent.map(|p| new_index[p].unwrap_or(usize::MAX)),
            at: js.at.map_or(Vec2::zeros(), |(x, y)| Vec2::new(x, y)),
            coordinate,
            spring: js.spring,
            damper: js.damper.unwrap_or(0.0),
            couplings: Couplings { stages: js.stages.clone(), friction: js.friction, stops: js.stops },
            rollers: js.rollers,
        });
    }
    if ncoord == 0 {
        return Err(src.error("joints", "every joint is Fixed: the mechanism has no coordinate to move"));
    }
    Ok((tree_bodies, tree_joints))
}

/// The joint's normalised kind, its rollers checked against its path, and a welded joint
/// refused any element that needs a coordinate.
fn checked_kind(row: &JointRow, src: &Source, path: &str) -> Result<JointKind> {
    let (name, js, _, _) = row;
    let kind = js
        .kind
        .unwrap_or_default()
        .normalised()
        .map_err(|(field, msg)| src.error(&format!("{path}.kind.{field}"), format!("joint `{name}`: {msg}")))?;
    if let Some(rollers) = js.rollers {
        let on = match kind.path() {
            Some(p) => rollers.check_on(p.shape),
            None => Err(("rollers", format!("rollers carry a path absorber, but this joint is {kind:?}"))),
        };
        on.map_err(|(field, msg)| src.error(&format!("{path}.{field}"), format!("joint `{name}`: {msg}")))?;
    }
    if kind.dof() == 0 {
        for (field, given) in [
            ("spring", js.spring.is_some()),
            ("damper", js.damper.is_some_and(|c| c != 0.0)),
            ("stages", js.stages.is_some()),
            ("friction", js.friction.is_some()),
            ("stops", js.stops.is_some()),
        ] {
            if given {
                return Err(src.error(
                    &format!("{path}.{field}"),
                    format!("joint `{name}` is Fixed (welded, no coordinate): it cannot have a {field}"),
                ));
            }
        }
    }
    Ok(kind)
}

/// A massless body on a joint with its own coordinate leaves that coordinate without inertia
/// (the mass matrix singular); welded or rigidly geared, it adds nothing.
pub(super) fn check_massless(
    bodies: &BodyTable,
    tree_joints: &[Joint],
    new_index: &[Option<usize>],
    src: &Source,
) -> Result<()> {
    for &i in &bodies.massless {
        let t = new_index[i].unwrap_or(usize::MAX);
        if tree_joints.get(t).is_none_or(|j| j.coordinate.is_some()) {
            return Err(src.error(
                &format!("bodies[{i}]"),
                format!(
                    "body `{}` has no mass and no inertia (a massless body is accepted only on a welded or \
                     rigidly geared joint, whose motion it cannot leave without inertia)",
                    bodies.specs[i].0
                ),
            ));
        }
    }
    Ok(())
}
