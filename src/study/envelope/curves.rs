//! The boundary curves of the map: their seeds on a one-parameter branch (the singular points
//! of a test function, localised at the seed's value), each followed both ways in the second
//! parameter by two-parameter continuation (`hbm::fold_curves`), and what is read off a followed curve:
//! its crossings of a value of either parameter (each solved there exactly) and the points where a
//! unison-loss curve meets a fold (bisected on the sign of the whole Jacobian's determinant).

use super::plane::Axis;
use super::{BoundaryKind, SAME_CURVE};
use crate::hbm::{FoldCurve, FoldCurveOptions, FoldCurvePoint, Hbm, HbmSolution, MechanismFamily, Singularity};

/// A curve being mapped: its kind, its test, and the walks from its start both ways.
pub(super) struct Walked {
    pub(super) kind: BoundaryKind,
    pub(super) set: Option<String>,
    pub(super) test: Singularity,
    /// The down walk reversed, then the up walk (its start dropped).
    pub(super) points: Vec<FoldCurvePoint>,
    pub(super) curves: Vec<FoldCurve>,
    pub(super) ends: [String; 2],
}

/// The singular points of `test` on `branch` (torque scale s): folds for the Jacobian, sign
/// changes of the block's determinant otherwise; each localised at s from the nearer state.
pub(super) fn seeds_on(
    hbm: &mut Hbm,
    ax: &Axis,
    family: Option<&MechanismFamily<'_>>,
    test: Singularity,
    branch: &crate::hbm::Branch,
    s: f64,
) -> Vec<FoldCurvePoint> {
    let guesses: Vec<HbmSolution> = match test {
        Singularity::Jacobian => branch.folds.iter().map(|f| branch.points[f.after].solution.clone()).collect(),
        Singularity::Block { .. } => {
            let signs: Vec<f64> = branch.points.iter().map(|p| hbm.singularity_sign(&p.solution, test)).collect();
            signs
                .windows(2)
                .enumerate()
                .filter(|(_, w)| w[0] * w[1] < 0.0)
                .map(|(i, _)| branch.points[i].solution.clone())
                .collect()
        }
        // The envelope draws no period-doubling curves yet (they are continued on the problem of
        // half the base frequency, which its seed branches are not).
        Singularity::HalfPeriod | Singularity::HalfPeriodBlock { .. } => Vec::new(),
    };
    guesses.iter().filter_map(|g| hbm.singular_at_with(ax.fold, family, test, s, g).ok()).collect()
}

/// The values `solve` gives from the walked curve `w`'s nearer point of each pair of consecutive
/// points across which `offset` changes sign, repeats within `tol` dropped, ascending.
fn solved_crossings(
    w: &Walked,
    offset: impl Fn(&FoldCurvePoint) -> f64,
    mut solve: impl FnMut(&FoldCurvePoint) -> Option<f64>,
    tol: f64,
) -> Vec<f64> {
    let mut out: Vec<f64> = Vec::new();
    for pair in w.points.windows(2) {
        let (a, b) = (offset(&pair[0]), offset(&pair[1]));
        if a * b > 0.0 {
            continue;
        }
        let near = if a.abs() < b.abs() { &pair[0] } else { &pair[1] };
        if let Some(v) = solve(near)
            && !out.iter().any(|&n| (n - v).abs() <= tol)
        {
            out.push(v);
        }
    }
    out.sort_by(f64::total_cmp);
    out
}

/// The values (axis unit) where the walked curve `w` crosses the second parameter's value `s`
/// (the torque scale, or p on a mechanism plane): each solved at `s`, repeats (within
/// [`SAME_CURVE`] of the range) dropped, ascending.
pub(super) fn crossings_at(
    hbm: &mut Hbm,
    ax: &Axis,
    family: Option<&MechanismFamily<'_>>,
    w: &Walked,
    s: f64,
) -> Vec<f64> {
    let solve = |near: &FoldCurvePoint| {
        let p = hbm.singular_at_with(ax.fold, family, w.test, s, &near.solution).ok()?;
        Some(ax.value(p.order, p.omega, p.scale))
    };
    solved_crossings(w, |p| p.parameter - s, solve, SAME_CURVE * ax.range.1 * ax.to_unit)
}

/// The second parameter (s, or p) where the walked curve `w` crosses the first parameter's
/// value `v` (results' unit: order, or rpm): each solved at `v`, the second parameter free,
/// those inside `range` kept, repeats (within [`SAME_CURVE`] of it) dropped, ascending.
pub(super) fn sections_at(
    hbm: &mut Hbm,
    ax: &Axis,
    family: Option<&MechanismFamily<'_>>,
    range: (f64, f64),
    w: &Walked,
    v: f64,
) -> Vec<f64> {
    let solve = |near: &FoldCurvePoint| {
        let p =
            hbm.singular_at_value_with(ax.fold, family, w.test, v / ax.to_unit, near.parameter, &near.solution).ok()?;
        (range.0..=range.1).contains(&p.parameter).then_some(p.parameter)
    };
    solved_crossings(w, |p| ax.value(p.order, p.omega, p.scale) - v, solve, SAME_CURVE * range.1.abs())
}

/// Whether `seed` lies on one of `walked` (same test): one of the curve's crossings of the
/// seed's second parameter is the seed.
pub(super) fn covered(
    hbm: &mut Hbm,
    ax: &Axis,
    family: Option<&MechanismFamily<'_>>,
    walked: &[Walked],
    test: Singularity,
    seed: &FoldCurvePoint,
) -> bool {
    let v = ax.value(seed.order, seed.omega, seed.scale);
    walked.iter().filter(|w| w.test == test).any(|w| {
        crossings_at(hbm, ax, family, w, seed.parameter)
            .iter()
            .any(|&n| (n - v).abs() <= SAME_CURVE * ax.range.1 * ax.to_unit)
    })
}

/// One boundary through `seed`, followed both ways in the second parameter on `hk` (its kind,
/// identical set and test), with its failures: each walk that fails is one, after `origin`
/// (where it was seeded).
pub(super) fn walk_boundary(
    hk: &mut Hbm,
    ax: &Axis,
    fam: Option<&MechanismFamily<'_>>,
    seed: &FoldCurvePoint,
    (kind, set, test): (BoundaryKind, Option<String>, Singularity),
    fopts: &FoldCurveOptions,
    origin: &str,
) -> (Walked, Vec<String>) {
    let mut failures = Vec::new();
    let fo = FoldCurveOptions { test, ..*fopts };
    let mut w =
        Walked { kind, set, test, points: Vec::new(), curves: Vec::new(), ends: [String::new(), String::new()] };
    for (k, up) in [false, true].into_iter().enumerate() {
        match hk.continue_fold_with(ax.fold, fam, seed, up, &fo) {
            Ok(c) => {
                w.ends[k] = end_words(&c);
                if up {
                    w.points.extend(c.points.iter().skip(1).cloned());
                } else {
                    w.points.extend(c.points.iter().rev().cloned());
                }
                w.curves.push(c);
            }
            Err(e) => {
                w.ends[k] = format!("failed: {e}");
                if !up {
                    w.points.push(seed.clone());
                }
                failures.push(format!("{origin}, {} in the second parameter: {e}", if up { "up" } else { "down" }));
            }
        }
    }
    (w, failures)
}

/// Where the unison-loss curve `c` (its test `test`, a representative's block) meets a fold:
/// its states where the whole Jacobian of the unison problem is singular too. Along the curve
/// the sign of that determinant changes there (the curve crosses the fold line of the
/// response surface); each change between two of its points is bisected in the second
/// parameter, the states solved on the curve at each value from the nearer point, until the
/// bracket is [`MEET_TOL`] of the value wide. On a mechanism parameter's plane (`family`) each
/// state's determinant is that of the problem built at its own p (the layouts are the same, so
/// the sign is continuous along the curve).
pub(super) fn meets_fold(
    hbm: &mut Hbm,
    ax: &Axis,
    family: Option<&MechanismFamily<'_>>,
    test: Singularity,
    c: &FoldCurve,
) -> Vec<FoldCurvePoint> {
    let sign = |hbm: &mut Hbm, p: &FoldCurvePoint| -> Option<f64> {
        match family {
            None => Some(hbm.singularity_sign(&p.solution, Singularity::Jacobian)),
            Some(f) => {
                let mut at = (f.build)(p.parameter).ok()?;
                at.set_torque_scale(f.scale).ok()?;
                Some(at.singularity_sign(&p.solution, Singularity::Jacobian))
            }
        }
    };
    let signs: Vec<Option<f64>> = c.points.iter().map(|p| sign(hbm, p)).collect();
    let mut out = Vec::new();
    for (i, w) in signs.windows(2).enumerate() {
        let (Some(sign_a), Some(sign_b)) = (w[0], w[1]) else { continue };
        if sign_a * sign_b >= 0.0 {
            continue;
        }
        let (mut a, mut b) = (c.points[i].clone(), c.points[i + 1].clone());
        while (a.parameter - b.parameter).abs() > MEET_TOL * a.parameter.abs().max(b.parameter.abs()) {
            let mid = 0.5 * (a.parameter + b.parameter);
            let near = if (mid - a.parameter).abs() <= (mid - b.parameter).abs() { &a } else { &b };
            let Ok(m) = hbm.singular_at_with(ax.fold, family, test, mid, &near.solution) else { break };
            match sign(hbm, &m) {
                Some(s) if s == sign_a => a = m,
                Some(_) => b = m,
                None => break,
            }
        }
        out.push(b);
    }
    out
}

/// Relative width in the second parameter to which [`meets_fold`] brackets a meeting.
const MEET_TOL: f64 = 1e-10;

fn end_words(c: &FoldCurve) -> String {
    match c.end {
        crate::hbm::FoldCurveEnd::LeftBox => "left the map",
        crate::hbm::FoldCurveEnd::MaxPoints => "most points",
        crate::hbm::FoldCurveEnd::StepTooSmall => "step too small",
    }
    .into()
}
