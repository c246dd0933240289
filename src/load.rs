//! Loading a mechanism: file → [`MechanismSpec`] → catalog parts merged → names, tree and
//! numbers validated → [`Mechanism`] → the engine's check that M is positive definite and finite
//! at q = 0, with every error located at the offending field (file:line:col).
//!
//! This stage sits above both the model and the engine, so the mechanism type never depends on
//! the engine that evaluates it. Its parts, in the order a spec goes through them: catalog parts
//! and the name rule (`load/parts.rs`), overlays on a base file (`load/overlay.rs`), the bodies
//! (`load/bodies.rs`), the joints and their tree order (`load/joints.rs`), the tree of bodies and
//! joints with its coordinates (`load/tree.rs`), the loads (`load/loads.rs`), the gears
//! (`crate::model::gears::resolve`) and the engine's check (`load/engine.rs`). The input rules
//! and error classes are in the guide (`docs/guide/src/mechanism.md`, `limits.md`).

mod bodies;
mod engine;
mod joints;
mod loads;
mod overlay;
mod parts;
pub(crate) use parts::check_printable;
mod tree;

use crate::error::Result;
use crate::io::ReadPolicy;
use crate::io::Source;
use crate::model::mechanism::{Mechanism, MechanismSpec};
use parts::folder_of;
use std::path::Path;

impl Mechanism {
    /// Reads and validates a mechanism file; catalog parts may only come from the file's own
    /// folder tree (see [`ReadPolicy::within`]).
    pub fn from_file(path: &Path) -> Result<Self> {
        Self::from_file_with(path, &ReadPolicy::within(&folder_of(path)))
    }

    /// Reads and validates a mechanism file under `policy` (allowed folders, size and body caps).
    pub fn from_file_with(path: &Path, policy: &ReadPolicy) -> Result<Self> {
        let src = Source::read_with(path, policy)?;
        Self::from_source(&src, policy)
    }

    /// Parses and validates mechanism text; catalog parts are resolved relative to `src.file`'s
    /// folder under `policy`, each part file size-capped too.
    pub fn from_source(src: &Source, policy: &ReadPolicy) -> Result<Self> {
        let spec: MechanismSpec = src.parse_as("Mechanism")?;
        Self::from_spec_with(&spec, src, policy)
    }

    /// Validates a spec built in code (no file): errors name the field path under
    /// `<spec: NAME>`, and catalog parts resolve relative to the current folder.
    pub fn from_spec(spec: &MechanismSpec) -> Result<Self> {
        let src = Source::from_text(&format!("<spec: {}>", spec.name), "");
        Self::from_spec_with(spec, &src, &ReadPolicy::within(Path::new("")))
    }

    /// Validates a parsed spec, reading catalog parts under `policy`; an overlay (a spec with a
    /// `base`) is merged with its base first (see [`MechanismSpec::base`]).
    pub fn from_spec_with(spec: &MechanismSpec, src: &Source, policy: &ReadPolicy) -> Result<Self> {
        if let Some(base) = &spec.base {
            let overlay::Base { spec: base_spec, src: base_src } = overlay::read_base(base, src, policy)?;
            Mechanism::from_spec_with(&base_spec, &base_src, policy)?;
            let (merged, counts) = overlay::merge(spec, base, base_spec, &base_src, src, policy)?;
            return Mechanism::from_spec_with(&merged, src, policy)
                .map_err(|e| overlay::relocate(e, &counts, src, &base_src));
        }
        check_counts(spec, src, policy)?;
        parts::check_printable(src, "name", &spec.name)?;
        let base = folder_of(&src.file);
        let body_table = bodies::read_bodies(spec, src, policy, &base)?;
        let joint_table = joints::read_joints(spec, &body_table, src, policy, &base)?;
        let (new_index, order) = joints::tree_order(&body_table, &joint_table, src)?;
        let (tree_bodies, mut tree_joints) = tree::build_tree(&body_table, &joint_table, &new_index, &order, src)?;
        // Couplings: a rigidly driven joint loses its coordinate (numbered again over the rest).
        let index_of = |name: &str| joint_table.names.get(name).and_then(|&k| new_index[joint_table.specs[k].3]);
        let gears = crate::model::gears::resolve(&spec.gears, &mut tree_joints, spec.speeds, &index_of, src)?;
        tree::check_massless(&body_table, &tree_joints, &new_index, src)?;
        let (loads, ground_damper_at) = loads::read_loads(spec, &body_table, &joint_table, &new_index, src)?;
        let mech = Mechanism {
            name: spec.name.clone(),
            file: Some(src.file.clone()),
            speeds: spec.speeds,
            bodies: tree_bodies,
            joints: tree_joints,
            loads,
            gears,
        };
        engine::check_engine(&mech, &order, &ground_damper_at, src)?;
        Ok(mech)
    }
}

/// Counts first: everything after is at least linear in them, the tree ordering quadratic.
fn check_counts(spec: &MechanismSpec, src: &Source, policy: &ReadPolicy) -> Result<()> {
    let max = policy.max_bodies;
    for (field, count, limit) in [
        ("bodies", spec.bodies.len(), max),
        ("joints", spec.joints.len(), max),
        ("loads", spec.loads.len(), max.saturating_mul(10)),
    ] {
        if count > limit {
            return Err(src
                .error(
                    field,
                    format!(
                        "{count} {field}, more than the limit of {limit} (the body cap is {max}, loads may be ten \
                     times as many); raise it with `--max-bodies N` if the mechanism is genuine"
                    ),
                )
                .limit_if(true));
        }
    }
    if spec.bodies.is_empty() {
        return Err(src.error("bodies", "no bodies: nothing to simulate"));
    }
    Ok(())
}
