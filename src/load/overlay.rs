//! Overlays: a mechanism spec that names a `base` file whose bodies, joints, loads and gears come
//! first, the overlay's own added after them.
//!
//! The base is validated on its own first (by the caller), so that its errors point into its own
//! file; its file parts are resolved from its own folder. Then the overlay's names are checked
//! against the base's (a clash is an error at the overlay's name), the two are merged and the
//! merged spec is validated; an error there is moved back to the file and item it came from
//! (`bodies[N]` of the merged spec is the overlay's `bodies[N − n_base]`). The base's `speeds` and
//! `gravity` apply: an overlay that sets others is refused rather than silently overridden.

use super::parts::{folder_of, with_part};
use crate::error::{Error, Result};
use crate::io::{ReadPolicy, Source};
use crate::model::mechanism::MechanismSpec;

/// The base of an overlay, read but not yet validated.
pub(super) struct Base {
    /// The base file's spec.
    pub(super) spec: MechanismSpec,
    /// The base file's text, for locating errors in it.
    pub(super) src: Source,
}

/// Reads the base file `base` named by the overlay in `src`; a base that is itself an overlay
/// is refused (overlays do not nest).
pub(super) fn read_base(base: &str, src: &Source, policy: &ReadPolicy) -> Result<Base> {
    let folder = folder_of(&src.file);
    let file = policy.resolve(&folder, base).map_err(|m| src.error("base", format!("base mechanism: {m}")))?;
    let base_src = Source::read_with(&file, policy).map_err(|e| src.error("base", format!("base mechanism: {e}")))?;
    let base_spec: MechanismSpec = base_src.parse_as("Mechanism")?;
    if base_spec.base.is_some() {
        return Err(base_src.error(
            "base",
            format!(
                "`{base}` is itself an overlay; an overlay's base must be a complete mechanism (overlays do not nest)"
            ),
        ));
    }
    Ok(Base { spec: base_spec, src: base_src })
}

/// The merged spec of the (validated) base and the overlay `spec`, and the base's count of
/// bodies, joints, loads and gears (for [`relocate`]). `base_src` is the base file's text.
pub(super) fn merge(
    spec: &MechanismSpec,
    base_name: &str,
    mut base_spec: MechanismSpec,
    base_src: &Source,
    src: &Source,
    policy: &ReadPolicy,
) -> Result<(MechanismSpec, [(&'static str, usize); 4])> {
    let base_folder = folder_of(&base_src.file);
    for (i, b) in base_spec.bodies.iter_mut().enumerate() {
        *b = with_part(b, &base_folder, base_src, &format!("bodies[{i}]"), policy)?;
    }
    for (k, j) in base_spec.joints.iter_mut().enumerate() {
        *j = with_part(j, &base_folder, base_src, &format!("joints[{k}]"), policy)?;
    }
    check_kept_settings(spec, &base_spec, src)?;
    check_clashes(spec, &base_spec, base_name, src)?;
    let counts = [
        ("bodies", base_spec.bodies.len()),
        ("joints", base_spec.joints.len()),
        ("loads", base_spec.loads.len()),
        ("gears", base_spec.gears.len()),
    ];
    let merged = MechanismSpec {
        name: spec.name.clone(),
        base: None,
        speeds: base_spec.speeds,
        gravity: base_spec.gravity,
        bodies: base_spec.bodies.into_iter().chain(spec.bodies.iter().cloned()).collect(),
        joints: base_spec.joints.into_iter().chain(spec.joints.iter().cloned()).collect(),
        loads: base_spec.loads.into_iter().chain(spec.loads.iter().cloned()).collect(),
        gears: base_spec.gears.into_iter().chain(spec.gears.iter().cloned()).collect(),
    };
    Ok((merged, counts))
}

/// The base's `speeds` and `gravity` apply; an overlay that sets others is refused. A field the
/// overlay writes counts as set even when it holds the default value (which the parsed spec
/// alone cannot tell from an absent field): it would otherwise be ignored without a word.
fn check_kept_settings(spec: &MechanismSpec, base_spec: &MechanismSpec, src: &Source) -> Result<()> {
    let written = |field: &str| crate::io::locate(&src.text, field).is_some();
    let speeds_set = spec.speeds != crate::model::speeds::Speeds::default() || written("speeds");
    let gravity_set = spec.gravity != (0.0, 0.0) || written("gravity");
    if spec.speeds != base_spec.speeds && speeds_set {
        return Err(src
            .error("speeds", format!("an overlay keeps its base's speeds ({:?}); remove `speeds`", base_spec.speeds)));
    }
    if spec.gravity != base_spec.gravity && gravity_set {
        return Err(src.error(
            "gravity",
            format!("an overlay keeps its base's gravity ({:?}); remove `gravity`", base_spec.gravity),
        ));
    }
    Ok(())
}

/// An overlay body or joint may not take a name the base already uses.
fn check_clashes(spec: &MechanismSpec, base_spec: &MechanismSpec, base: &str, src: &Source) -> Result<()> {
    let clash = |list: &str, name: Option<&String>, base_names: &[Option<&String>]| {
        let n = name?;
        let k = base_names.iter().position(|b| *b == Some(n))?;
        Some(format!("`{n}` is already a name in the base `{base}` ({list}[{k}] there); choose another name"))
    };
    let base_bodies: Vec<Option<&String>> = base_spec.bodies.iter().map(|x| x.name.as_ref()).collect();
    for (i, b) in spec.bodies.iter().enumerate() {
        if let Some(msg) = clash("bodies", b.name.as_ref(), &base_bodies) {
            return Err(src.error(&format!("bodies[{i}].name"), msg));
        }
    }
    let base_joints: Vec<Option<&String>> = base_spec.joints.iter().map(|x| x.name.as_ref()).collect();
    for (k, j) in spec.joints.iter().enumerate() {
        if let Some(msg) = clash("joints", j.name.as_ref(), &base_joints) {
            return Err(src.error(&format!("joints[{k}].name"), msg));
        }
    }
    Ok(())
}

/// Moves an error in the merged spec back to the file and item it came from: `list[N]` with N
/// below the base's count is the base's own item, above it the overlay's `list[N − n_base]`.
pub(super) fn relocate(e: Error, counts: &[(&str, usize)], src: &Source, base_src: &Source) -> Error {
    let limit = e.is_limit();
    match e {
        // Errors inside a part file are already where they belong.
        Error::Input { location, message } | Error::Limit { location, message } if location.file == src.file => {
            let relocated = counts.iter().find_map(|&(list, n)| {
                let rest = location.path.strip_prefix(list)?.strip_prefix('[')?;
                let (index, tail) = rest.split_once(']')?;
                let index: usize = index.parse().ok()?;
                Some(if index < n {
                    base_src.locate(&location.path)
                } else {
                    src.locate(&format!("{list}[{}]{tail}", index - n))
                })
            });
            Error::Input { location: relocated.unwrap_or_else(|| src.locate(&location.path)), message }.limit_if(limit)
        }
        other => other,
    }
}
