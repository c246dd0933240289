//! Validation of a design study at load: names resolved, quantities that apply to the mechanism
//! and the analysis, values in their physical ranges, the analysis valid by itself; every error
//! located at its field.

use super::sampling::case_count;
use super::{DesignParameter, DesignSpec, Distribution, Quantity, Sampling};
use super::{MAX_CASES, MAX_MECHANISM_VALUE, MAX_PARAMETERS, MAX_VALUES};
use crate::error::Result;
use crate::io::Source;
use crate::model::mechanism::Mechanism;
use crate::study::validate::limits::{MAX_ORDER, MAX_RPM, MAX_TORQUE_NM, check_file_name};
use crate::study::{AnalysisSpec, HbmParameter, StudySpec};

/// Checks the kind of analysis a design study runs (analysis `k` of the study file); errors
/// are located at the offending field. Then `validate` checks that analysis by itself, and
/// [`check_parameters`] the parameters.
pub(crate) fn check(src: &Source, spec: &StudySpec, mech: &Mechanism, k: usize, d: &DesignSpec) -> Result<()> {
    let _ = mech;
    let at = |field: &str| format!("analyses[{k}].{field}");
    let inner = d.analysis.as_ref();
    if let Some((a, b)) = d.operating {
        if !matches!(inner, AnalysisSpec::HarmonicBalance(_)) {
            return Err(src.error(&at("operating"), "an operating range counts a harmonic balance's jumps"));
        }
        if !(a.is_finite() && b.is_finite() && a < b) {
            return Err(src.error(&at("operating"), format!("need finite from < to, got ({a}, {b})")));
        }
    }
    match inner {
        AnalysisSpec::HarmonicBalance(h) if h.overlay.is_some() => {
            return Err(src.error(&at("analysis.overlay"), "a design study's cases draw no figure to overlay"));
        }
        AnalysisSpec::HarmonicBalance(_) => {}
        AnalysisSpec::LinearResponse(l) => {
            if !l.variants.is_empty() {
                return Err(src.error(
                    &at("analysis.variants"),
                    "a design study takes no damping variants: vary `JointDamping(…)` as a parameter instead",
                ));
            }
            if spec.lock.is_empty() {
                return Err(src.error(
                    &at("analysis"),
                    "a linear response in a design study needs a locked joint (`lock`): its results are n_t and \
                     ratios to the locked twin",
                ));
            }
        }
        other => {
            return Err(src.error(
                &at("analysis"),
                format!("a design study runs HarmonicBalance or LinearResponse per case, not {}", other.kind()),
            ));
        }
    }
    Ok(())
}

/// Checks a design study's parameters and sampling (analysis `k` of the study file) against the
/// mechanism, after its analysis was checked by itself; errors located at the offending field.
pub(crate) fn check_parameters(src: &Source, mech: &Mechanism, spin: usize, k: usize, d: &DesignSpec) -> Result<()> {
    let at = |field: &str| format!("analyses[{k}].{field}");
    let inner = d.analysis.as_ref();
    if d.parameters.is_empty() || d.parameters.len() > MAX_PARAMETERS {
        return Err(src.error(&at("parameters"), format!("give 1 to {MAX_PARAMETERS} parameters")));
    }
    let mut names = std::collections::HashSet::new();
    for (j, p) in d.parameters.iter().enumerate() {
        let pat = |field: &str| format!("analyses[{k}].parameters[{j}].{field}");
        if let Err(m) = check_file_name(&p.name) {
            return Err(src.error(&pat("name"), m));
        }
        if !names.insert(p.name.as_str()) {
            return Err(src.error(&pat("name"), format!("parameter `{}` is named twice", p.name)));
        }
        if d.parameters[..j].iter().any(|q| q.quantity == p.quantity) {
            return Err(src.error(&pat("quantity"), format!("the {} is varied twice", p.quantity.describe())));
        }
        check_quantity(src, &pat("quantity"), mech, spin, inner, &p.quantity)?;
        check_values(src, &pat(""), d.sampling, p, |v| value_ok(&p.quantity, Some(inner), v))?;
    }
    match d.sampling {
        Sampling::Grid => {}
        Sampling::LatinHypercube { n, .. } | Sampling::MonteCarlo { n, .. } => {
            if n == 0 || n > MAX_CASES {
                return Err(src.error(&at("sampling"), format!("give 1 to {MAX_CASES} cases")));
            }
        }
    }
    let n = case_count(d);
    if n > MAX_CASES {
        return Err(src.error(
            &at("parameters"),
            format!("the grid has {n} cases; at most {MAX_CASES} (sample it with LatinHypercube or MonteCarlo)"),
        ));
    }
    Ok(())
}

/// A mechanism quantity named outside a design study (an envelope's axis, at `path`): it names
/// a body or joint of the mechanism that has it, and both ends of its range `from`..`to` (at
/// `from_path` and `to_path`) are admissible values with `from < to`.
pub(crate) fn check_mechanism_quantity(
    src: &Source,
    path: &str,
    mech: &Mechanism,
    spin: usize,
    q: &Quantity,
    (from, to): (f64, f64),
    (from_path, to_path): (&str, &str),
) -> Result<()> {
    if matches!(q, Quantity::Rpm | Quantity::TorqueAmplitude | Quantity::Order) {
        return Err(src.error(
            path,
            format!("the {} is not a mechanism parameter: name a body's or joint's quantity", q.describe()),
        ));
    }
    check_names(src, path, mech, spin, q)?;
    value_ok(q, None, from).map_err(|m| src.error(from_path, m))?;
    value_ok(q, None, to).map_err(|m| src.error(to_path, m))?;
    if from >= to {
        return Err(src.error(to_path, format!("need from < to, got {from} and {to}")));
    }
    Ok(())
}

/// The quantity's name exists and the quantity applies to this mechanism and analysis.
fn check_quantity(
    src: &Source,
    path: &str,
    mech: &Mechanism,
    spin: usize,
    inner: &AnalysisSpec,
    q: &Quantity,
) -> Result<()> {
    check_names(src, path, mech, spin, q)?;
    check_applies(src, path, inner, q)
}

/// The body or joint a quantity names exists and has that quantity.
fn check_names(src: &Source, path: &str, mech: &Mechanism, spin: usize, q: &Quantity) -> Result<()> {
    if let Some(b) = q.body() {
        let Some(i) = mech.body_index(b) else {
            let names: Vec<&str> = mech.bodies.iter().map(|b| b.name.as_str()).collect();
            return Err(src.error(path, format!("unknown body `{b}` (bodies: {})", names.join(", "))));
        };
        if matches!(q, Quantity::BodyComRadius(_)) && mech.bodies[i].inertia.com.norm() == 0.0 {
            return Err(src.error(
                path,
                format!("body `{b}` has its centre of mass at its origin: no direction to move it along"),
            ));
        }
    }
    if let Some(jn) = q.joint() {
        let Some(j) = mech.joint_index(jn) else {
            let names: Vec<&str> = mech.joints.iter().map(|j| j.name.as_str()).collect();
            return Err(src.error(path, format!("unknown joint `{jn}` (joints: {})", names.join(", "))));
        };
        let joint = &mech.joints[j];
        if joint.kind.dof() == 0 && !matches!(q, Quantity::JointRadius(_)) {
            return Err(src.error(path, format!("joint `{jn}` is Fixed: it has no spring or damper")));
        }
        if matches!(q, Quantity::JointStiffness(_)) && j == spin {
            return Err(src.error(path, format!("`{jn}` is the spin joint: a spinning rotor cannot wind a spring")));
        }
        if matches!(q, Quantity::TuningOrder(_)) {
            let pendulum =
                crate::model::absorber::absorbers(mech).iter().any(|a| a.joint == *jn && a.kind == "Revolute pendulum");
            let leaf = !mech.joints.iter().any(|k| k.parent == Some(j));
            if !(pendulum && leaf) {
                return Err(src.error(
                    path,
                    format!(
                        "joint `{jn}` is not a revolute pendulum on a rotor carrying one body: its tuning order \
                         cannot be set through the centre-of-mass distance (vary the path's or body's own quantities)"
                    ),
                ));
            }
        }
        if matches!(q, Quantity::JointRadius(_)) && joint.at.norm() == 0.0 {
            return Err(
                src.error(path, format!("joint `{jn}` sits at its parent's origin: no direction to move it along"))
            );
        }
    }
    Ok(())
}

/// An analysis quantity (speed, torque, order) applies to the analysis run per case.
fn check_applies(src: &Source, path: &str, inner: &AnalysisSpec, q: &Quantity) -> Result<()> {
    let applies = match (q, inner) {
        (Quantity::Rpm, AnalysisSpec::HarmonicBalance(h)) => !matches!(h.parameter, HbmParameter::Speed { .. }),
        (Quantity::TorqueAmplitude, AnalysisSpec::HarmonicBalance(h)) => {
            !matches!(h.parameter, HbmParameter::Torque { .. })
        }
        (Quantity::Order, AnalysisSpec::HarmonicBalance(h)) => !matches!(h.parameter, HbmParameter::Order),
        (Quantity::Rpm, _) => true,
        (Quantity::TorqueAmplitude | Quantity::Order, _) => false,
        _ => true,
    };
    if !applies {
        return Err(src.error(
            path,
            format!(
                "the {} is not a parameter of this {}: {}",
                q.describe(),
                inner.kind(),
                match q {
                    Quantity::Rpm => "a Speed continuation continues it",
                    Quantity::TorqueAmplitude =>
                        "a linear response is per unit torque, and a Torque continuation \
                                                  continues it",
                    _ => "a linear response and an Order continuation sweep the order themselves",
                }
            ),
        ));
    }
    Ok(())
}

/// Whether `v` is an admissible value of `q` in `inner` (None: a mechanism quantity outside a
/// design study), and if not, the admissible range.
fn value_ok(q: &Quantity, inner: Option<&AnalysisSpec>, v: f64) -> std::result::Result<(), String> {
    let within = |lo: f64, hi: f64, lo_open: bool| {
        let above = if lo_open { v > lo } else { v >= lo };
        v.is_finite() && above && v <= hi
    };
    let (ok, range) = match q {
        Quantity::BodyMass(_) | Quantity::BodyInertia(_) | Quantity::JointStiffness(_) | Quantity::JointDamping(_) => {
            (within(0.0, MAX_MECHANISM_VALUE, false), format!("0 ≤ value ≤ {MAX_MECHANISM_VALUE:e}"))
        }
        Quantity::BodyComRadius(_) | Quantity::JointRadius(_) => {
            (within(0.0, MAX_MECHANISM_VALUE, true), format!("0 < value ≤ {MAX_MECHANISM_VALUE:e} m"))
        }
        Quantity::Rpm => (within(0.0, MAX_RPM, true), format!("0 < rpm ≤ {MAX_RPM:e}")),
        Quantity::Order | Quantity::TuningOrder(_) => {
            (within(0.0, MAX_ORDER, true), format!("0 < order ≤ {MAX_ORDER}"))
        }
        Quantity::TorqueAmplitude => {
            // Harmonic balance has no periodic response to continue at zero torque.
            let zero_ok = !matches!(inner, Some(AnalysisSpec::HarmonicBalance(_)));
            (
                v.is_finite() && v.abs() <= MAX_TORQUE_NM && (zero_ok || v != 0.0),
                format!("0 < |T_n| ≤ {MAX_TORQUE_NM:e} N·m"),
            )
        }
    };
    if ok { Ok(()) } else { Err(format!("{} must satisfy {range}, got {v}", q.describe())) }
}

/// The values of one parameter: a list or a range for a grid, a range for random sampling, every
/// value (for a grid) or both ends admissible. `prefix` ends with a dot.
fn check_values(
    src: &Source,
    prefix: &str,
    sampling: Sampling,
    p: &DesignParameter,
    ok: impl Fn(f64) -> std::result::Result<(), String>,
) -> Result<()> {
    let field = |f: &str| format!("{prefix}{f}");
    let grid = sampling == Sampling::Grid;
    if let Some(values) = &p.values {
        if !grid {
            return Err(src.error(&field("values"), "random sampling draws from `from`..`to`: give those instead"));
        }
        if p.from.is_some() || p.to.is_some() || p.points.is_some() || p.log {
            return Err(src.error(&field("values"), "give either `values` or `from`, `to` and `points`, not both"));
        }
        if values.is_empty() || values.len() > MAX_VALUES {
            return Err(src.error(&field("values"), format!("give 1 to {MAX_VALUES} values")));
        }
        for (i, &v) in values.iter().enumerate() {
            ok(v).map_err(|m| src.error(&field(&format!("values[{i}]")), m))?;
        }
        return Ok(());
    }
    let (Some(a), Some(b)) = (p.from, p.to) else {
        let what = if grid { "`values`, or `from`, `to` and `points`" } else { "`from` and `to`" };
        return Err(src.error(&field(if p.from.is_none() { "from" } else { "to" }), format!("give {what}")));
    };
    ok(a).map_err(|m| src.error(&field("from"), m))?;
    ok(b).map_err(|m| src.error(&field("to"), m))?;
    if a >= b {
        return Err(src.error(&field("to"), format!("need from < to, got {a} and {b}")));
    }
    if p.log && a <= 0.0 {
        return Err(src.error(&field("log"), "log spacing needs from > 0"));
    }
    if let Distribution::Normal { mean, sd } = p.distribution {
        if grid {
            return Err(src.error(
                &field("distribution"),
                "a grid takes its values as written: draw from a distribution with LatinHypercube or MonteCarlo",
            ));
        }
        if p.log {
            return Err(src.error(&field("log"), "a Normal distribution is spread in the value, not its logarithm"));
        }
        if !(sd.is_finite() && sd > 0.0) {
            return Err(src.error(&field("distribution.sd"), format!("need a finite sd > 0, got {sd}")));
        }
        if !(mean.is_finite() && (a..=b).contains(&mean)) {
            return Err(src.error(
                &field("distribution.mean"),
                format!("the mean {mean} lies outside `from`..`to` ({a} to {b}), which truncate the distribution"),
            ));
        }
    }
    match (grid, p.points) {
        (true, Some(n)) if (2..=MAX_VALUES).contains(&n) => Ok(()),
        (true, _) => Err(src.error(&field("points"), format!("give 2 to {MAX_VALUES} points from `from` to `to`"))),
        (false, Some(_)) => Err(src.error(&field("points"), "random sampling takes its count from `sampling`'s `n`")),
        (false, None) => Ok(()),
    }
}
