//! The engine's check of a validated mechanism: the mass matrix at q = 0 must factorise and be
//! finite, and every stiffness and damping must set a time scale in the accepted range on the
//! inertia it moves (a value in the wrong units is refused here, named by its field).

use crate::error::{EngineError, Error, Result};
use crate::io::Source;
use crate::model::mechanism::Mechanism;

/// Checks `mech` with the engine. `order[j]` is the file index of tree joint j, for naming the
/// offending `joints[k]`; `ground_damper_at[i]` the file index of ground damper i.
pub(super) fn check_engine(mech: &Mechanism, order: &[usize], ground_damper_at: &[usize], src: &Source) -> Result<()> {
    // A tree whose mass matrix is singular or not finite at q = 0 cannot be simulated: say
    // which joint (in the file's numbering: coordinate i belongs to tree joint j = joint_of(i),
    // which is the file's `order[j]`).
    let at_coordinate = |i: usize| {
        let j = mech.joint_of(i);
        order.get(j).map_or_else(String::new, |k| format!("joints[{k}]"))
    };
    let mut kane = match crate::kane::Kane::new(mech) {
        Ok(kane) => kane,
        Err(e) => {
            let path = match &e {
                Error::Engine(EngineError::NotPositiveDefinite { dof, .. }) => at_coordinate(*dof),
                Error::Engine(EngineError::NonFinite { index, .. }) => at_coordinate(*index),
                _ => String::new(),
            };
            let message = match &e {
                // inf ≤ tolerance·inf: an overflow, not a missing inertia.
                Error::Engine(EngineError::NotPositiveDefinite { pivot, joint, .. }) if !pivot.is_finite() => {
                    format!(
                        "mass matrix at q = 0 is not finite (pivot {pivot} at joint `{joint}`); a body too heavy \
                         or too far from its joint for f64 (units kg and m?)"
                    )
                }
                _ => e.to_string(),
            };
            return Err(src.error(&path, message));
        }
    };
    // The factorisation lets an infinite pivot through (inf > 0), so look at M itself.
    let n = mech.ndof();
    let m = kane.mass_matrix(&vec![0.0; n]);
    if let Some((r, c)) = (0..n).flat_map(|r| (0..n).map(move |c| (r, c))).find(|&(r, c)| !m[(r, c)].is_finite()) {
        return Err(src.error(
            &at_coordinate(r.max(c)),
            format!(
                "mass matrix at q = 0 is not finite: M[{r}][{c}] = {}; a body too heavy or too far from \
                 its joint for f64 (units kg and m?)",
                m[(r, c)]
            ),
        ));
    }
    check_time_scales(
        mech,
        m,
        src,
        &|j| order.get(j).map_or_else(String::new, |k| format!("joints[{k}]")),
        ground_damper_at,
    )
}

/// Refuses a stiffness or damping whose time scale on the inertia it moves lies outside
/// [`crate::model::ranges::MAX_NATURAL_HZ`] / [`crate::model::ranges::MAX_DECAY_RATE`], naming the
/// field, the rate it sets and the largest coefficient that inertia accepts. `joint_path` maps a
/// tree joint to its `joints[k]`; `ground_damper_at` the ground dampers to their `loads[l]`.
fn check_time_scales(
    mech: &Mechanism,
    m: &nalgebra::DMatrix<f64>,
    src: &Source,
    joint_path: &dyn Fn(usize) -> String,
    ground_damper_at: &[usize],
) -> Result<()> {
    use crate::model::time_scales::{Element, compliances, time_scales};
    let Some(diag) = compliances(mech, m) else { return Ok(()) };
    for ts in time_scales(mech, &diag) {
        // A friction's smoothing has its own range (`ranges::FRICTION_SMOOTHING`): a near-Coulomb
        // law is stiff by choice, which the plan counts and the watchdog bounds.
        if ts.rate() <= ts.limit() || matches!(ts.element, Element::Friction(_)) {
            continue;
        }
        let joint = |j: usize| (joint_path(j), format!("joint `{}`", mech.joints[j].name));
        let gear = |g: usize| {
            let gr = &mech.gears[g];
            (
                format!("gears[{g}]"),
                format!("the mesh of `{}` on `{}`", mech.joints[gr.joint].name, mech.joints[gr.follows].name),
            )
        };
        let ((base, owner), field, what) = match ts.element {
            Element::Spring(j) => (joint(j), "spring.stiffness".to_string(), "spring stiffness"),
            Element::Stage(j, coast, i) => (
                joint(j),
                format!("stages.{}[{i}].stiffness", if coast { "coast" } else { "drive" }),
                "stage stiffness",
            ),
            Element::StopStiffness(j) => (joint(j), "stops.stiffness".to_string(), "end-stop stiffness"),
            Element::StopDamping(j) => (joint(j), "stops.damping".to_string(), "end-stop damping"),
            Element::Friction(_) => continue,
            Element::Damper(j) => (joint(j), "damper".to_string(), "damper"),
            Element::MeshStiffness(g) => (gear(g), "mesh.stiffness".to_string(), "mesh stiffness"),
            Element::MeshDamping(g) => (gear(g), "mesh.damping".to_string(), "mesh damping"),
            Element::GroundDamper(i) => (
                (
                    ground_damper_at.get(i).map_or_else(String::new, |l| format!("loads[{l}]")),
                    "a ground damper".to_string(),
                ),
                "c".to_string(),
                "ground damping",
            ),
        };
        let scale = if ts.is_stiffness() {
            format!(
                "rings at {:.3e} Hz on the inertia it moves (√(k/J)/2π with 1/J = {:.3e} from M⁻¹ at q = 0); the accepted \
                 range is up to {:.0e} Hz, here a stiffness up to {:.3e}",
                ts.rate(),
                ts.compliance,
                ts.limit(),
                ts.largest_coefficient()
            )
        } else {
            format!(
                "decays at {:.3e} 1/s on the inertia it moves (c/J with 1/J = {:.3e} from M⁻¹ at q = 0); the accepted \
                 range is up to {:.0e} 1/s (a time constant of 10 ns or more), here a damping up to {:.3e}",
                ts.rate(),
                ts.compliance,
                ts.limit(),
                ts.largest_coefficient()
            )
        };
        return Err(src.error(
            &format!("{base}.{field}"),
            format!("{owner}: {what} {:e} {scale}; a value in the wrong units?", ts.coefficient),
        ));
    }
    Ok(())
}
