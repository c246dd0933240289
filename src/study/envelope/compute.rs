//! The map's computation: the problem on its route (and, for period doublings, the problem of half
//! the base frequency), the seed branches at the seed values of the second parameter, the
//! boundaries walked from their seeds, and the codimension-two points and sections read off
//! each.

use super::curves::{Walked, covered, crossings_at, meets_fold, sections_at, seeds_on, walk_boundary};
use super::doubling::{doubling_screen, doubling_seeds};
use super::plane::{Axis, Second};
use super::{
    Boundary, BoundaryKind, EnvelopeParameter, EnvelopePlane, EnvelopeResult, EnvelopeSpec, MapPoint, MapPointKind,
    Section, TORQUE_COLUMN,
};
use crate::error::Result;
use crate::hbm::{
    ContinuationOptions, FoldCurveOptions, FoldCurvePoint, FoldPlane, Hbm, HbmError, HbmOptions, MechanismFamily,
    RoutedHbm, Singularity,
};
use crate::kane::Kane;
use crate::model::excitation::Harmonic;
use crate::plot::num;
use crate::study::Study;
use crate::study::hbm::hbm_error;

/// The study's mechanism with the envelope's parameter `par` at `p` (its unit), checked.
pub(super) fn mechanism_at(
    study: &Study,
    par: &EnvelopeParameter,
    p: f64,
) -> Result<crate::model::mechanism::Mechanism> {
    let err = |m: String| crate::error::Error::Model {
        mechanism: study.mechanism.name.clone(),
        message: format!("{} = {p}: {m}", par.name),
    };
    let mut mech = study.mechanism.clone();
    crate::study::design::set_quantity(&mut mech, &par.quantity, p).map_err(err)?;
    crate::study::design::check_masses(&mech).map_err(err)?;
    Ok(mech)
}

/// Largest arclength step of a seed branch, twice the default: the seeds' crossings are found
/// by sign changes of test functions at any step (`hbm::continuation`), and each seed is then
/// solved exactly on its curve, so a coarser branch finds the same boundaries (on the paper's
/// map the same points to the bit; BENCHMARKS.md has the cost).
const SEED_DS_MAX: f64 = 0.2;

/// The map: every boundary its seeds reach, with its codimension-two points; a seed branch or a
/// walk that fails is listed and the rest kept.
pub(crate) fn compute(study: &Study, spec: &EnvelopeSpec) -> Result<(EnvelopeResult, Vec<String>)> {
    let start = std::time::Instant::now();
    let kane = study.kane(false)?;
    let inputs = study.excited_joints(&study.mechanism, &spec.excite);
    let second = Second::of(study, spec);
    let opts = HbmOptions { harmonics: spec.harmonics, stability_samples: 0, ..HbmOptions::default() };
    let mut ax = Axis::of(spec);
    if spec.speed_is_second() {
        // The layout problem's speed (each state's own is the second parameter).
        ax.omega = second.range.0;
    }
    let forcing = (&second.harmonics[..], &[][..]);
    let (mut routed, general) = match &spec.parameter {
        None => (RoutedHbm::new(&kane, study.spin, ax.omega, forcing, &inputs, opts).map_err(hbm_error(study))?, false),
        Some(par) => {
            // One route along the whole range: the cyclic one only where the mechanism keeps its
            // identical sets at both ends (a parameter of one absorber of a set parts them).
            let at = |p: f64| -> Result<RoutedHbm> {
                let k = Kane::new(&mechanism_at(study, par, p)?)?;
                RoutedHbm::new(&k, study.spin, ax.omega, forcing, &inputs, opts).map_err(hbm_error(study))
            };
            let (lo, hi) = (at(par.from)?, at(par.to)?);
            let cyclic = |r: &RoutedHbm| matches!(r.route(), crate::hbm::Route::Cyclic { .. });
            if cyclic(&lo) && cyclic(&hi) && lo.hbm().unknowns() == hi.hbm().unknowns() {
                (lo, false)
            } else {
                let k = Kane::new(&mechanism_at(study, par, par.from)?)?;
                (
                    RoutedHbm::new_general(&k, study.spin, ax.omega, forcing, &inputs, opts)
                        .map_err(hbm_error(study))?,
                    true,
                )
            }
        }
    };
    let route = routed.route().to_string();
    // The problem of half the base frequency (the extra multiple at zero amplitude, twice the
    // harmonics), on which period doublings are followed.
    let ratio = routed.hbm().base_frequency(1.0) / routed.hbm().omega();
    let mut halved = second.harmonics.clone();
    halved.push(Harmonic { multiple: 0.5 * ratio, amplitude: 0.0, phase: 0.0 });
    let opts2 = HbmOptions { harmonics: 2 * spec.harmonics, ..opts };
    // The problem at a value of a mechanism parameter, on the route chosen, with the forcing
    // and options given (the base frequency's, or half of it).
    let build_with = |p: f64, forcing, opts| -> std::result::Result<Hbm, HbmError> {
        let par = spec.parameter.as_ref().ok_or_else(|| HbmError::Invalid("no mechanism parameter".into()))?;
        // The speed's problems share the study's mechanism; a mechanism parameter's are at the
        // map's speed.
        let rebuilt;
        let (k, omega) = if spec.speed_is_second() {
            (&kane, p)
        } else {
            let mech = mechanism_at(study, par, p).map_err(|e| HbmError::Invalid(e.to_string()))?;
            rebuilt = Kane::new(&mech).map_err(|e| HbmError::Invalid(format!("{} = {p}: {e}", par.name)))?;
            (&rebuilt, ax.omega)
        };
        let r = if general {
            RoutedHbm::new_general(k, study.spin, omega, forcing, &inputs, opts)?
        } else {
            RoutedHbm::new(k, study.spin, omega, forcing, &inputs, opts)?
        };
        Ok(r.hbm().clone())
    };
    let build = |p: f64| build_with(p, forcing, opts);
    let build_half = |p: f64| build_with(p, (&halved[..], &[][..]), opts2);
    let (reference, speed) = (second.range.0.abs().max(second.range.1.abs()), spec.speed_is_second());
    let family = spec.parameter.as_ref().map(|_| MechanismFamily { build: &build, scale: 1.0, reference, speed });
    let family_half =
        spec.parameter.as_ref().map(|_| MechanismFamily { build: &build_half, scale: 1.0, reference, speed });
    let (fam, fam_half) = (family.as_ref(), family_half.as_ref());
    let hbm = routed.hbm_mut();
    let mut tests = vec![(BoundaryKind::Jump, None, Singularity::Jacobian)];
    tests.extend(hbm.unison_loss_tests().into_iter().map(|(l, t)| (BoundaryKind::UnisonLoss, Some(l), t)));
    let fopts = FoldCurveOptions { range: ax.range, scales: second.range, ..FoldCurveOptions::default() };
    // On a mechanism parameter's plane the linear screen looks at the mechanism at both ends of
    // the range, and the half-frequency problems are the family's too.
    let screened = match &spec.parameter {
        Some(par) if !speed => [par.from, par.to].iter().filter_map(|&p| mechanism_at(study, par, p).ok()).collect(),
        _ => vec![study.mechanism.clone()],
    };
    let speeds = match ax.fold {
        FoldPlane::Order if speed => vec![second.range.0, second.range.1],
        FoldPlane::Order | FoldPlane::Torque { .. } => vec![ax.omega],
        FoldPlane::Speed { .. } => vec![ax.range.0, ax.range.1],
    };
    let screen = doubling_screen(&screened, &study.spec.spin_joint, &ax, &speeds, &second.harmonics, ratio);
    // The half-frequency problem the period-doubling curves are evaluated on (on a mechanism
    // parameter's plane the one at its lower end, for the layout only).
    let mut half: Option<Hbm> = match (&screen, &spec.parameter) {
        (Err(_), _) => None,
        (Ok(_), None) => RoutedHbm::new(&kane, study.spin, ax.omega, (&halved[..], &[][..]), &inputs, opts2)
            .ok()
            .map(|r| r.hbm().clone()),
        (Ok(_), Some(_)) => build_half(second.range.0).ok(),
    };
    // The seed branches only supply starting points (each seed is solved exactly on its curve
    // by `singular_at`): guesses at a loose corrector tolerance with one-sided derivatives, as
    // the multi-order analysis's order branches (`study::hbm::branch`).
    let copts = ContinuationOptions {
        stability: false,
        refine_folds: false,
        one_sided: true,
        corrector_tol: Some(crate::study::hbm::GUESS_TOL),
        deadline: study.spec.integration.deadline,
        ds_max: SEED_DS_MAX,
        ..ContinuationOptions::default()
    };
    let mut failures = Vec::new();
    let mut walked: Vec<Walked> = Vec::new();
    // A speed branch starts at the highest speed, where the torque is smallest against the
    // centrifugal stiffness (∝ Ω²) and the one state there is the small one: from the lowest,
    // it may start on a large state that never folds back (the Table 1 set at 500 rpm). If it
    // fails, from the other end.
    let ends = match ax.fold {
        FoldPlane::Order | FoldPlane::Torque { .. } => ax.range,
        FoldPlane::Speed { .. } => (ax.range.1, ax.range.0),
    };
    for &s in &second.seeds {
        // The seed's problem: this one at torque scale s, or the family's at p = s.
        let mut own;
        let hk: &mut Hbm = match fam {
            None => &mut *hbm,
            Some(f) => match (f.build)(s) {
                Ok(h) => {
                    own = h;
                    &mut own
                }
                Err(e) => {
                    failures.push(format!("{}: seed branch at {}: {e}", spec.name, second.words(s)));
                    continue;
                }
            },
        };
        let scale = fam.map_or(s, |f| f.scale);
        let branch = hk
            .set_torque_scale(scale)
            .and_then(|()| hk.continue_in(ax.param, ends.0, ends.1, None, &copts))
            .or_else(|e| hk.continue_in(ax.param, ends.1, ends.0, None, &copts).map_err(|_| e));
        let branch = match branch {
            Ok(b) => b,
            Err(e) => {
                failures.push(format!("{}: seed branch at {}: {e}", spec.name, second.words(second.value(s))));
                continue;
            }
        };
        // Where a boundary was seeded, for its failures.
        let origin = |kind: BoundaryKind, seed: &FoldCurvePoint| {
            format!(
                "{}: {} boundary from {} at {}",
                spec.name,
                kind.words(),
                num(ax.value(seed.order, seed.omega, seed.scale), 8),
                second.words(second.value(s))
            )
        };
        for (kind, set, test) in &tests {
            for seed in seeds_on(hk, &ax, fam, *test, &branch, s) {
                if covered(hk, &ax, fam, &walked, *test, &seed) {
                    continue;
                }
                let origin = origin(*kind, &seed);
                let w = walk_boundary(hk, &ax, fam, &seed, (*kind, set.clone(), *test), &fopts, &mut failures, &origin);
                walked.push(w);
            }
        }
        // Period doublings, on the problem of half the base frequency at the same scale (or
        // the family's at the same p).
        let mut own_half;
        let h2: Option<&mut Hbm> = match (fam_half, half.as_mut()) {
            (_, None) => None,
            (None, Some(h2)) => Some(h2),
            (Some(f), Some(_)) => match (f.build)(s) {
                Ok(h) => {
                    own_half = h;
                    Some(&mut own_half)
                }
                Err(e) => {
                    failures.push(format!("{}: half-frequency problem at {}: {e}", spec.name, second.words(s)));
                    None
                }
            },
        };
        if let Some(h2) = h2
            && h2.set_torque_scale(scale).is_ok()
        {
            // The set's label of a non-unison doubling (its test the set's representative's
            // block at half the base frequency).
            let mut halves = vec![(None, Singularity::HalfPeriod)];
            halves.extend(h2.unison_loss_tests().into_iter().map(|(l, t)| (Some(l), t.halved())));
            let tests: Vec<Singularity> = halves.iter().map(|h| h.1).collect();
            for (test, seed) in doubling_seeds(h2, &ax, fam_half, &branch, s, &tests) {
                if covered(h2, &ax, fam_half, &walked, test, &seed) {
                    continue;
                }
                let kind = BoundaryKind::PeriodDoubling;
                let set = halves.iter().find(|h| h.1 == test).and_then(|h| h.0.clone());
                let origin = origin(kind, &seed);
                let w = walk_boundary(h2, &ax, fam_half, &seed, (kind, set, test), &fopts, &mut failures, &origin);
                walked.push(w);
            }
        }
    }
    let mut boundaries = Vec::new();
    let mut points = Vec::new();
    for (i, w) in walked.iter().enumerate() {
        // A period-doubling curve lives on the problem of half the base frequency.
        let (hbm, fam): (&mut Hbm, _) = match (w.test, half.as_mut()) {
            (t, Some(h2)) if t.on_half_period() => (h2, fam_half),
            _ => (&mut *hbm, fam),
        };
        let at_top = crossings_at(hbm, &ax, fam, w, second.range.1);
        for c in &w.curves {
            for p in &c.cusps {
                points.push(MapPoint {
                    kind: MapPointKind::Cusp,
                    boundary: i,
                    value: ax.value(p.order, p.omega, p.scale),
                    second_value: second.value(p.parameter),
                });
            }
            if w.kind == BoundaryKind::UnisonLoss {
                for p in meets_fold(hbm, &ax, fam, w.test, c) {
                    points.push(MapPoint {
                        kind: MapPointKind::UnisonLossMeetsJump,
                        boundary: i,
                        value: ax.value(p.order, p.omega, p.scale),
                        second_value: second.value(p.parameter),
                    });
                }
            }
            for p in &c.scale_extrema {
                let kind = match w.kind {
                    BoundaryKind::Jump => MapPointKind::JumpOnset,
                    BoundaryKind::UnisonLoss => MapPointKind::UnisonLossOnset,
                    BoundaryKind::PeriodDoubling => MapPointKind::PeriodDoublingOnset,
                };
                points.push(MapPoint {
                    kind,
                    boundary: i,
                    value: ax.value(p.order, p.omega, p.scale),
                    second_value: second.value(p.parameter),
                });
            }
        }
        let sections = spec
            .sections
            .iter()
            .map(|&v| Section {
                value: v,
                second_values: sections_at(hbm, &ax, fam, second.range, w, v)
                    .into_iter()
                    .map(|s| second.value(s))
                    .collect(),
            })
            .collect();
        boundaries.push(Boundary {
            sections,
            kind: w.kind,
            set: w.set.clone(),
            values: w.points.iter().map(|p| ax.value(p.order, p.omega, p.scale)).collect(),
            second_values: w.points.iter().map(|p| second.value(p.parameter)).collect(),
            at_second_max: at_top,
            ends: w.ends.clone(),
        });
    }
    let result = EnvelopeResult {
        name: spec.name.clone(),
        parameter: match spec.plane {
            EnvelopePlane::Order => "order".into(),
            EnvelopePlane::Speed { .. } => "speed_rpm".into(),
            EnvelopePlane::Torque { .. } => TORQUE_COLUMN.into(),
        },
        held: match spec.plane {
            EnvelopePlane::Order => spec.rpm,
            EnvelopePlane::Speed { order, .. } | EnvelopePlane::Torque { order, .. } => order,
        },
        range: match spec.plane {
            EnvelopePlane::Torque { torque_min, torque_max, .. } => [torque_min, torque_max],
            _ => [ax.range.0 * ax.to_unit, ax.range.1 * ax.to_unit],
        },
        second_range: second
            .shown
            .map_or([second.value(second.range.0), second.value(second.range.1)], |(lo, hi)| [lo, hi]),
        second: second.column.clone(),
        second_unit: second.unit.clone(),
        second_label: second.label.clone(),
        fixed: second.fixed.clone(),
        log_second: second.log,
        route,
        seeds: second.seeds.iter().map(|&s| second.value(s)).collect(),
        boundaries,
        points,
        period_doubling_search: match screen {
            Ok(w) | Err(w) => w,
        },
        time_s: start.elapsed().as_secs_f64(),
    };
    Ok((result, failures))
}
