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
/// torque would act inside a merged body there), each once, finite shares and phases; amplitude
/// laws only where the analysis takes them (`laws_at`: the speeds, rpm, it evaluates them at),
/// each well formed and, for a table, covering every one of those speeds.
pub(crate) fn check_excite(
    src: &Source,
    spec: &StudySpec,
    mech: &Mechanism,
    path: &str,
    list: &[crate::study::ExciteAt],
    laws_at: Option<&[f64]>,
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
        check_law(src, &format!("{p}.law"), &e.law, laws_at)?;
    }
    Ok(())
}

/// One joint's amplitude law: taken by this analysis at all, its numbers sound, and a table
/// spanning every speed it is read at (refused rather than extrapolated).
fn check_law(src: &Source, p: &str, law: &crate::study::AmplitudeLaw, laws_at: Option<&[f64]>) -> Result<()> {
    use crate::study::AmplitudeLaw;
    let Some(speeds) = laws_at else {
        if law.is_constant() {
            return Ok(());
        }
        return Err(src.error(
            p,
            "an amplitude law in speed is taken by LinearResponse and MultiOrder only; here the share is \
             constant (leave `law` out, or fold the factor into `scale`)",
        ));
    };
    match law {
        AmplitudeLaw::Constant => {}
        AmplitudeLaw::Rpm2 { reference_rpm } => {
            if !(reference_rpm.is_finite() && *reference_rpm > 0.0 && *reference_rpm <= super::MAX_RPM) {
                return Err(src.error(
                    p,
                    format!("reference_rpm must lie in 0 < rpm ≤ {}, got {}", g(super::MAX_RPM), g(*reference_rpm)),
                ));
            }
        }
        AmplitudeLaw::Table(points) => {
            if points.len() < 2 || points.len() > MAX_LIST {
                return Err(src.error(p, format!("a table needs 2 to {MAX_LIST} (rpm, factor) points")));
            }
            for (i, &(r, f)) in points.iter().enumerate() {
                if !(0.0..=super::MAX_RPM).contains(&r) {
                    return Err(
                        src.error(p, format!("point {i}: rpm must lie in 0..={}, got {}", g(super::MAX_RPM), g(r)))
                    );
                }
                if !(f.is_finite() && f.abs() <= 1e6) {
                    return Err(src.error(p, format!("point {i}: factor must be finite, |factor| ≤ 1e6, got {}", g(f))));
                }
                if i > 0 && r <= points[i - 1].0 {
                    return Err(
                        src.error(p, format!("point {i}: rpm {} does not increase on {}", g(r), g(points[i - 1].0)))
                    );
                }
            }
        }
    }
    if let Some(&r) = speeds.iter().find(|&&r| law.factor(r).is_none()) {
        let (lo, hi) = match law {
            AmplitudeLaw::Table(v) => (v[0].0, v[v.len() - 1].0),
            _ => (f64::NAN, f64::NAN),
        };
        return Err(src.error(
            p,
            format!(
                "the table covers {} to {} rpm, not the analysis's speed {} rpm (no extrapolation)",
                g(lo),
                g(hi),
                g(r)
            ),
        ));
    }
    Ok(())
}
