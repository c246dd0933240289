//! Branch switching in a study (`switch: true`): at the branch points of a unison branch, the
//! non-unison branches (the symmetry that swaps two identical absorbers, `Symmetry::Swap`); at
//! its period doublings, the period-doubled branches (on the problem of half the base frequency,
//! `Symmetry::HalfPeriod`); and where each switched branch goes.

use super::HbmSpec;
use crate::hbm::{BifurcationClass, Branch, BranchEnd, ContinuationOptions, HbmOptions, RoutedHbm, Symmetry};
use crate::model::excitation::Harmonic;
use crate::model::mechanism::Mechanism;
use crate::study::Study;

/// The permutation of the coordinates that swaps the two identical absorbers of `route`'s one
/// identical set (for [`crate::hbm::Hbm::switch_at`]), or why there is none.
pub(crate) fn switch_mirror(mech: &Mechanism, route: &crate::hbm::Route) -> std::result::Result<Vec<usize>, String> {
    let crate::hbm::Route::Cyclic { sets } = route else {
        return Err(format!("the mechanism `{}` has no identical absorbers to leave unison ({route})", mech.name));
    };
    let [set] = &sets[..] else {
        return Err(format!("switching takes one identical set, the mechanism has {}", sets.len()));
    };
    if set.members.len() != 2 || set.member_dof != 1 {
        return Err(format!(
            "switching takes two identical one-coordinate absorbers (a one-dimensional kernel), the set is {set} with {} coordinate(s) each",
            set.member_dof
        ));
    }
    let coord = |name: &str| mech.joint_index(name).and_then(|j| mech.joints[j].coordinate);
    let (Some(a), Some(b)) = (coord(&set.members[0]), coord(&set.members[1])) else {
        return Err(format!("the members of {set} have no coordinates"));
    };
    let mut mirror: Vec<usize> = (0..mech.ndof()).collect();
    mirror.swap(a, b);
    Ok(mirror)
}

/// The branches switched at the branch points of the unison branch `b` (the non-unison ones)
/// and at its period doublings (the period-doubled ones), in the solver's parameter `range`,
/// each with its wall time, the point it was switched at and whether it is period-doubled; a
/// failure (naming the analysis and the field `switch`) for a branch with neither and for every
/// switch that fails.
pub(super) fn switched(
    study: &Study,
    spec: &HbmSpec,
    (omega, harmonics, per_omega2): (f64, &[Harmonic], &[Harmonic]),
    b: &Branch,
    range: (f64, f64),
    failures: &mut Vec<String>,
    what: &str,
) -> Vec<SwitchedRow> {
    let of = |class: BifurcationClass| -> Vec<f64> {
        b.bifurcations.iter().filter(|x| x.class == class).map(|x| x.parameter).collect()
    };
    let (points, doublings) = (of(BifurcationClass::BranchPoint), of(BifurcationClass::PeriodDoubling));
    if points.is_empty() && doublings.is_empty() {
        failures.push(format!(
            "{}{what}: `switch` ({}): the branch has no branch point (a multiplier through +1 that is not a fold) \
             and no period doubling (through −1) in the range: no branch switch exists here",
            spec.name,
            switch_field(study, spec)
        ));
        return Vec::new();
    }
    let mut out = Vec::new();
    let fail = |e: String| format!("{}{what}: `switch` ({}): {e}", spec.name, switch_field(study, spec));
    let kane = match study.kane(false) {
        Ok(k) => k,
        Err(e) => {
            failures.push(fail(e.to_string()));
            return out;
        }
    };
    let inputs = study.excited_joints(&study.mechanism, &spec.excite);
    let input_joints: Vec<usize> = inputs.iter().map(|i| i.0).collect();
    let mirror = if points.is_empty() {
        None
    } else {
        match switch_mirror(&study.mechanism, &crate::hbm::route_for(&kane, study.spin, &input_joints)) {
            Ok(m) => Some(m),
            Err(e) => {
                failures.push(fail(e));
                None
            }
        }
    };
    let opts = HbmOptions { harmonics: spec.harmonics, ..HbmOptions::default() };
    let defaults = ContinuationOptions::default();
    let ds_max = spec.max_step.unwrap_or(defaults.ds_max);
    let copts = ContinuationOptions {
        ds_max,
        ds: defaults.ds.min(ds_max),
        deadline: study.spec.integration.deadline,
        ..defaults
    };
    // A period-doubled branch is solved on the problem of half the base frequency, with twice
    // the harmonics (the same resolution of the excitation's own harmonics).
    let base = b.points.first().map(|p| p.solution.base_frequency / (p.solution.order * p.solution.omega));
    let mut halved = harmonics.to_vec();
    halved.push(Harmonic { multiple: 0.5 * base.unwrap_or(1.0), amplitude: 0.0, phase: 0.0 });
    let switches = mirror
        .iter()
        .flat_map(|m| points.iter().map(move |&at| (at, Symmetry::Swap(m.clone()))))
        .chain(doublings.iter().map(|&at| (at, Symmetry::HalfPeriod)));
    for (at, symmetry) in switches {
        let start = std::time::Instant::now();
        let Some(guess) = b.guesses_at(at).first().map(|g| (*g).clone()) else { continue };
        let doubled = symmetry == Symmetry::HalfPeriod;
        let (forcing, opts) = if doubled {
            ((&halved[..], per_omega2), HbmOptions { harmonics: 2 * spec.harmonics, ..opts })
        } else {
            ((harmonics, per_omega2), opts)
        };
        let solved = RoutedHbm::new_general(&kane, study.spin, omega, forcing, &inputs, opts).and_then(|mut hbm| {
            let sw = hbm.hbm_mut().switch_at(b.parameter, at, &guess, &symmetry, range, &copts)?;
            Ok((hbm, sw))
        });
        match solved {
            Ok((hbm, sw)) => out.push((hbm, sw, start.elapsed().as_secs_f64(), Some(at), doubled)),
            Err(e) => failures.push(fail(format!("the switch at {at}: {e}"))),
        }
    }
    out
}

/// Where the study file sets the analysis's `switch` (file:line:col).
fn switch_field(study: &Study, spec: &HbmSpec) -> String {
    // A design study's own analysis is not in the list: its study's `analyses` then.
    let field = match study.spec.analyses.iter().position(|a| a.name() == spec.name) {
        Some(k) => format!("analyses[{k}].switch"),
        None => "analyses".into(),
    };
    study.source.locate(&field).to_string()
}

/// A row of [`switched`]: the problem, the branch, its wall time (s), the point it was switched
/// at, and whether it is period-doubled.
pub(super) type SwitchedRow = (RoutedHbm, Branch, f64, Option<f64>, bool);

/// Where a switched branch goes, in words, in the continued parameter's unit (`to_unit`); a
/// period-doubled one returns to the period-1 branch rather than to unison.
pub(super) fn goes(b: &Branch, to_unit: f64, period_doubled: bool) -> String {
    let Some(last) = b.points.last() else { return "no point".into() };
    let at = last.parameter * to_unit;
    let folds = if b.folds.is_empty() {
        String::new()
    } else {
        format!(
            ", after folds at {}",
            super::summary::list(&b.folds.iter().map(|f| f.parameter * to_unit).collect::<Vec<_>>())
        )
    };
    match b.end {
        BranchEnd::Unison if period_doubled => {
            format!("returns to the period-1 branch at {at:.7} (a period doubling of it){folds}")
        }
        BranchEnd::Unison => format!("returns to unison at {at:.7} (a branch point of the unison branch){folds}"),
        BranchEnd::ReachedTarget | BranchEnd::LeftRange => format!("leaves the range at {at:.7}{folds}"),
        BranchEnd::StepTooSmall => format!("stops at {at:.7}: the corrector failed at every step{folds}"),
        BranchEnd::MaxPoints => format!("stops at {at:.7}: the largest number of points{folds}"),
        BranchEnd::Watchdog => format!("stops at {at:.7}: the time budget{folds}"),
    }
}
