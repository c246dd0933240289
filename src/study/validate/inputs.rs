//! Checks of the joints an excitation acts at (`excite`), shared by every analysis that takes
//! one, and the longest transient.

use super::{MAX_LIST, g};
use crate::error::Result;
use crate::io::Source;
use crate::model::mechanism::Mechanism;
use crate::study::StudySpec;

/// Longest transient, s of simulated time (a day, the limit of every time run,
/// [`super::MAX_RUN_S`]); the estimated work is checked in `plan`.
pub const MAX_TRANSIENT_S: f64 = super::MAX_RUN_S;

/// An analysis's `excite` list: known joints with a coordinate, none locked in the twin (its
/// torque would act inside a merged body there), each once, finite shares and phases.
pub(crate) fn check_excite(
    src: &Source,
    spec: &StudySpec,
    mech: &Mechanism,
    path: &str,
    list: &[crate::study::ExciteAt],
) -> Result<()> {
    if list.len() > MAX_LIST {
        return Err(src.error(path, format!("at most {MAX_LIST} excited joints")));
    }
    for (i, e) in list.iter().enumerate() {
        let p = format!("{path}[{i}]");
        let Some(j) = mech.joint_index(&e.joint) else {
            let names: Vec<&str> = mech.joints.iter().map(|j| j.name.as_str()).collect();
            return Err(
                src.error(&format!("{p}.joint"), format!("unknown joint `{}` (joints: {})", e.joint, names.join(", ")))
            );
        };
        // A rigidly driven joint has no coordinate but its torque drives its gear train (Tᵀ).
        if mech.follow_map()[j].is_none() {
            return Err(src
                .error(&format!("{p}.joint"), format!("joint `{}` is Fixed: a torque there drives nothing", e.joint)));
        }
        if spec.lock.contains(&e.joint) {
            return Err(src.error(
                &format!("{p}.joint"),
                format!(
                    "joint `{}` is locked in the reference twin, where its torque would act inside one body",
                    e.joint
                ),
            ));
        }
        if list[..i].iter().any(|o| o.joint == e.joint) {
            return Err(src.error(&format!("{p}.joint"), format!("joint `{}` is listed twice", e.joint)));
        }
        if !(e.scale.is_finite() && e.scale.abs() <= 1e6) {
            return Err(
                src.error(&format!("{p}.scale"), format!("share must be finite, |scale| ≤ 1e6, got {}", g(e.scale)))
            );
        }
        if !(e.phase.is_finite() && e.phase.abs() <= 1e3) {
            return Err(src.error(
                &format!("{p}.phase"),
                format!("phase must be finite, |phase| ≤ 1000 rad, got {}", g(e.phase)),
            ));
        }
    }
    Ok(())
}
