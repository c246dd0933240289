//! The bodies of a mechanism spec: parts merged, numbers and names checked, inertias formed.

use super::parts::{check_name, with_part};
use crate::error::Result;
use crate::io::{ReadPolicy, Source};
use crate::model::inertia::PlanarInertia;
use crate::model::mechanism::{GROUND, MechanismSpec};
use std::collections::HashMap;
use std::path::Path;

/// The spec's bodies in file order, by name, with the massless ones kept for a later check.
pub(super) struct BodyTable {
    /// Name and inertia of `bodies[i]`.
    pub(super) specs: Vec<(String, PlanarInertia)>,
    /// File index by name.
    pub(super) index: HashMap<String, usize>,
    /// File indices of the bodies with neither mass nor inertia.
    pub(super) massless: Vec<usize>,
}

impl BodyTable {
    /// The bodies' names, for messages that list the choices.
    pub(super) fn names(&self) -> impl Iterator<Item = &str> {
        self.specs.iter().map(|(n, _)| n.as_str())
    }
}

/// Reads `spec.bodies`, resolving parts from `base` under `policy`.
pub(super) fn read_bodies(spec: &MechanismSpec, src: &Source, policy: &ReadPolicy, base: &Path) -> Result<BodyTable> {
    let mut table =
        BodyTable { specs: Vec::with_capacity(spec.bodies.len()), index: HashMap::new(), massless: Vec::new() };
    for (i, b) in spec.bodies.iter().enumerate() {
        let path = format!("bodies[{i}]");
        b.check_numbers(src, &path)?;
        let merged = with_part(b, base, src, &path, policy)?;
        let Some(name) = merged.name.clone() else {
            return Err(src.error(&path, "body has no `name`"));
        };
        check_name(src, &format!("{path}.name"), &name)?;
        if name == GROUND {
            return Err(src.error(&format!("{path}.name"), "`ground` is the implicit root and cannot be a body"));
        }
        if let Some(prev) = table.index.insert(name.clone(), i) {
            return Err(
                src.error(&format!("{path}.name"), format!("duplicate body name `{name}` (also bodies[{prev}])"))
            );
        }
        let props = merged.inertia_props(src, &path)?;
        // Checked once the couplings are known: a massless body is harmless on a joint
        // without a coordinate of its own (a pinion whose inertia its gear carries).
        if props.mass == 0.0 && props.i_com == 0.0 {
            table.massless.push(i);
        }
        table.specs.push((name, props));
    }
    Ok(table)
}
