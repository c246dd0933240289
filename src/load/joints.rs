//! The joints of a mechanism spec: parts merged, names checked, each joint's parent and child
//! resolved against the bodies, and the tree ordered parents first.

use super::bodies::BodyTable;
use super::parts::{check_name, with_part};
use crate::error::Result;
use crate::io::known_list;
use crate::io::{ReadPolicy, Source};
use crate::model::joint::JointSpec;
use crate::model::mechanism::{GROUND, MechanismSpec};
use std::collections::HashMap;
use std::path::Path;

/// One joint as read: name, merged spec, parent body (`None`: ground) and child body, both as
/// file indices of the bodies.
pub(super) type JointRow = (String, JointSpec, Option<usize>, usize);

/// The spec's joints in file order, by name, and the joint that carries each body.
pub(super) struct JointTable {
    /// `joints[k]` as read.
    pub(super) specs: Vec<JointRow>,
    /// File index by name.
    pub(super) names: HashMap<String, usize>,
    /// For each body (file index), the joint whose child it is.
    pub(super) of_child: Vec<Option<usize>>,
}

/// Reads `spec.joints` against the bodies, resolving parts from `base` under `policy`; every
/// body must be the child of exactly one joint.
pub(super) fn read_joints(
    spec: &MechanismSpec,
    bodies: &BodyTable,
    src: &Source,
    policy: &ReadPolicy,
    base: &Path,
) -> Result<JointTable> {
    let mut table = JointTable {
        specs: Vec::with_capacity(spec.joints.len()),
        names: HashMap::new(),
        of_child: vec![None; bodies.specs.len()],
    };
    for (k, j) in spec.joints.iter().enumerate() {
        let path = format!("joints[{k}]");
        j.check_numbers(src, &path)?;
        let merged = with_part(j, base, src, &path, policy)?;
        let Some(name) = merged.name.clone() else {
            return Err(src.error(&path, "joint has no `name`"));
        };
        check_name(src, &format!("{path}.name"), &name)?;
        if let Some(prev) = table.names.insert(name.clone(), k) {
            return Err(
                src.error(&format!("{path}.name"), format!("duplicate joint name `{name}` (also joints[{prev}])"))
            );
        }
        let (parent_idx, child_idx) = ends(&merged, &name, bodies, src, &path)?;
        if let Some(prev) = table.of_child[child_idx] {
            return Err(src.error(
                &format!("{path}.child"),
                format!(
                    "body `{}` has two parents: joints `{}` and `{name}`",
                    bodies.specs[child_idx].0,
                    spec.joints[prev].name.as_deref().unwrap_or("?")
                ),
            ));
        }
        table.of_child[child_idx] = Some(k);
        table.specs.push((name, merged, parent_idx, child_idx));
    }
    for (i, j) in table.of_child.iter().enumerate() {
        if j.is_none() {
            return Err(src.error(
                &format!("bodies[{i}]"),
                format!("body `{}` is not attached: no joint has it as `child`", bodies.specs[i].0),
            ));
        }
    }
    Ok(table)
}

/// The parent (`None`: ground) and child body of joint `name`, as file indices.
fn ends(
    merged: &JointSpec,
    name: &str,
    bodies: &BodyTable,
    src: &Source,
    path: &str,
) -> Result<(Option<usize>, usize)> {
    let known = || known_list(bodies.names());
    let Some(parent) = merged.parent.clone() else {
        return Err(src.error(path, format!("joint `{name}` has no `parent` (a body name or `ground`)")));
    };
    let Some(child) = merged.child.clone() else {
        return Err(src.error(path, format!("joint `{name}` has no `child` body")));
    };
    let parent_idx = if parent == GROUND {
        None
    } else {
        match bodies.index.get(&parent) {
            Some(&p) => Some(p),
            None => {
                return Err(src.error(
                    &format!("{path}.parent"),
                    format!("joint `{name}`: unknown parent body `{parent}` (bodies: ground, {})", known()),
                ));
            }
        }
    };
    let child_idx = match bodies.index.get(&child) {
        Some(&c) => c,
        None if child == GROUND => {
            return Err(src.error(&format!("{path}.child"), format!("joint `{name}`: `ground` cannot be a child")));
        }
        None => {
            return Err(src.error(
                &format!("{path}.child"),
                format!("joint `{name}`: unknown child body `{child}` (bodies: {})", known()),
            ));
        }
    };
    if parent_idx == Some(child_idx) {
        return Err(src.error(&format!("{path}.parent"), format!("joint `{name}` joins body `{child}` to itself")));
    }
    Ok((parent_idx, child_idx))
}

/// The tree order: `order[t]` is the file index of the joint placed t-th, `new_index[b]` the
/// tree index of body b (file index). Repeatedly takes, in file order, a joint whose parent is
/// already placed, so a file already written parents-first keeps its order (and q follows it).
pub(super) fn tree_order(
    bodies: &BodyTable,
    joints: &JointTable,
    src: &Source,
) -> Result<(Vec<Option<usize>>, Vec<usize>)> {
    let nb = bodies.specs.len();
    let mut new_index: Vec<Option<usize>> = vec![None; nb];
    let mut order = Vec::with_capacity(nb);
    let mut placed_any = true;
    while order.len() < nb && placed_any {
        placed_any = false;
        for (k, (_, _, parent, child)) in joints.specs.iter().enumerate() {
            if new_index[*child].is_none() && parent.is_none_or(|p| new_index[p].is_some()) {
                new_index[*child] = Some(order.len());
                order.push(k);
                placed_any = true;
            }
        }
    }
    if order.len() < nb {
        let stuck: Vec<&str> =
            (0..nb).filter(|&b| new_index[b].is_none()).map(|b| bodies.specs[b].0.as_str()).collect();
        let k = joints.of_child[(0..nb).find(|&b| new_index[b].is_none()).unwrap_or(0)].unwrap_or(0);
        return Err(src.error(
            &format!("joints[{k}]"),
            format!("the joints form a cycle: bodies {} are not connected to ground", stuck.join(", ")),
        ));
    }
    Ok((new_index, order))
}
