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

/// The harmonic-balance problems of the map: the study's mechanism at the layout speed `omega`
/// (rad/s) with its excited joints, and the problem rebuilt at a value of the mechanism
/// parameter (or of the speed) on the route chosen for the whole range.
struct Problem<'a> {
    study: &'a Study,
    spec: &'a EnvelopeSpec,
    kane: &'a Kane,
    inputs: &'a [(usize, f64, f64)],
    omega: f64,
    /// Whether the problems take the general route (a mechanism parameter that parts the
    /// identical sets at an end of its range).
    general: bool,
}

impl Problem<'_> {
    /// The problem with `forcing` and `opts`, and whether its route is the general one by
    /// necessity: on a mechanism parameter's plane the cyclic route only where the mechanism
    /// keeps its identical sets at both ends (a parameter of one absorber of a set parts them).
    fn routed(&self, forcing: (&[Harmonic], &[Harmonic]), opts: HbmOptions) -> Result<(RoutedHbm, bool)> {
        let (study, omega, inputs) = (self.study, self.omega, self.inputs);
        let Some(par) = &self.spec.parameter else {
            let r = RoutedHbm::new(self.kane, study.spin, omega, forcing, inputs, opts).map_err(hbm_error(study))?;
            return Ok((r, false));
        };
        let at = |p: f64| -> Result<RoutedHbm> {
            let k = Kane::new(&mechanism_at(study, par, p)?)?;
            RoutedHbm::new(&k, study.spin, omega, forcing, inputs, opts).map_err(hbm_error(study))
        };
        let (lo, hi) = (at(par.from)?, at(par.to)?);
        let cyclic = |r: &RoutedHbm| matches!(r.route(), crate::hbm::Route::Cyclic { .. });
        if cyclic(&lo) && cyclic(&hi) && lo.hbm().unknowns() == hi.hbm().unknowns() {
            return Ok((lo, false));
        }
        let k = Kane::new(&mechanism_at(study, par, par.from)?)?;
        let r = RoutedHbm::new_general(&k, study.spin, omega, forcing, inputs, opts).map_err(hbm_error(study))?;
        Ok((r, true))
    }

    /// The problem at a value `p` of the mechanism parameter (or of the speed), on the route
    /// chosen, with the forcing and options given (the base frequency's, or half of it).
    fn at(&self, p: f64, forcing: (&[Harmonic], &[Harmonic]), opts: HbmOptions) -> std::result::Result<Hbm, HbmError> {
        let (study, spec) = (self.study, self.spec);
        let par = spec.parameter.as_ref().ok_or_else(|| HbmError::Invalid("no mechanism parameter".into()))?;
        // The speed's problems share the study's mechanism; a mechanism parameter's are at the
        // map's speed.
        let rebuilt;
        let (k, omega) = if spec.speed_is_second() {
            (self.kane, p)
        } else {
            let mech = mechanism_at(study, par, p).map_err(|e| HbmError::Invalid(e.to_string()))?;
            rebuilt = Kane::new(&mech).map_err(|e| HbmError::Invalid(format!("{} = {p}: {e}", par.name)))?;
            (&rebuilt, self.omega)
        };
        let r = if self.general {
            RoutedHbm::new_general(k, study.spin, omega, forcing, self.inputs, opts)?
        } else {
            RoutedHbm::new(k, study.spin, omega, forcing, self.inputs, opts)?
        };
        Ok(r.hbm().clone())
    }
}

/// The period-doubling screen of the map ([`doubling_screen`]): on a mechanism parameter's
/// plane the linear screen looks at the mechanism at both ends of the range.
fn screen(
    study: &Study,
    spec: &EnvelopeSpec,
    ax: &Axis,
    second: &Second,
    ratio: f64,
) -> std::result::Result<String, String> {
    let speed = spec.speed_is_second();
    let screened = match &spec.parameter {
        Some(par) if !speed => [par.from, par.to].iter().filter_map(|&p| mechanism_at(study, par, p).ok()).collect(),
        _ => vec![study.mechanism.clone()],
    };
    let speeds = match ax.fold {
        FoldPlane::Order if speed => vec![second.range.0, second.range.1],
        FoldPlane::Order | FoldPlane::Torque { .. } => vec![ax.omega],
        FoldPlane::Speed { .. } => vec![ax.range.0, ax.range.1],
    };
    doubling_screen(&screened, &study.spec.spin_joint, ax, &speeds, &second.harmonics, ratio)
}

/// The settings of a seed branch. Its points only supply starting points (each seed is solved
/// exactly on its curve by `singular_at`): guesses at a loose corrector tolerance with one-sided
/// derivatives, as the multi-order analysis's order branches (`study::hbm::branch`).
fn seed_options(study: &Study) -> ContinuationOptions {
    ContinuationOptions {
        stability: false,
        refine_folds: false,
        one_sided: true,
        corrector_tol: Some(crate::study::hbm::GUESS_TOL),
        deadline: study.spec.integration.deadline,
        ds_max: SEED_DS_MAX,
        ..ContinuationOptions::default()
    }
}

/// A boundary's test: its kind, its identical set (a unison loss) and its singularity.
type Test = (BoundaryKind, Option<String>, Singularity);

/// A map being walked: the plane's two parameters, the problems' families on a mechanism
/// parameter's plane (at the base frequency and at half of it), the curves followed so far and
/// the failures listed.
struct Map<'a> {
    spec: &'a EnvelopeSpec,
    ax: Axis,
    second: &'a Second,
    fam: Option<&'a MechanismFamily<'a>>,
    fam_half: Option<&'a MechanismFamily<'a>>,
    fopts: FoldCurveOptions,
    copts: ContinuationOptions,
    walked: Vec<Walked>,
    failures: Vec<String>,
}

impl Map<'_> {
    /// One seed value `s` of the second parameter: its branch on its problem (`hbm` at torque
    /// scale s, or the family's at p = s), and the boundaries through the branch's singular
    /// points (`tests`) and its period doublings (on `half`) that no curve walked so far covers.
    fn seed(&mut self, hbm: &mut Hbm, half: Option<&mut Hbm>, tests: &[Test], s: f64) {
        let mut own;
        let hk: &mut Hbm = match self.fam {
            None => hbm,
            Some(f) => match (f.build)(s) {
                Ok(h) => {
                    own = h;
                    &mut own
                }
                Err(e) => {
                    self.failures.push(format!("{}: seed branch at {}: {e}", self.spec.name, self.second.words(s)));
                    return;
                }
            },
        };
        let scale = self.fam.map_or(s, |f| f.scale);
        let Some(branch) = self.seed_branch(hk, scale, s) else { return };
        for (kind, set, test) in tests {
            for seed in seeds_on(hk, &self.ax, self.fam, *test, &branch, s) {
                if covered(hk, &self.ax, self.fam, &self.walked, *test, &seed) {
                    continue;
                }
                let origin = self.origin(*kind, &seed, s);
                let what = (*kind, set.clone(), *test);
                let (w, failed) = walk_boundary(hk, &self.ax, self.fam, &seed, what, &self.fopts, &origin);
                self.failures.extend(failed);
                self.walked.push(w);
            }
        }
        self.doublings(half, &branch, scale, s);
    }

    /// The seed branch at `s` on `hk` (set to torque scale `scale`), continued across the
    /// first parameter's range. A speed branch starts at the highest speed, where the torque is
    /// smallest against the centrifugal stiffness (∝ Ω²) and the one state there is the small
    /// one: from the lowest, it may start on a large state that never folds back (the Table 1
    /// set at 500 rpm). If it fails, from the other end; None (listed) if that fails too.
    fn seed_branch(&mut self, hk: &mut Hbm, scale: f64, s: f64) -> Option<crate::hbm::Branch> {
        let (ax, copts) = (&self.ax, &self.copts);
        let ends = match ax.fold {
            FoldPlane::Order | FoldPlane::Torque { .. } => ax.range,
            FoldPlane::Speed { .. } => (ax.range.1, ax.range.0),
        };
        let branch = hk
            .set_torque_scale(scale)
            .and_then(|()| hk.continue_in(ax.param, ends.0, ends.1, None, copts))
            .or_else(|e| hk.continue_in(ax.param, ends.1, ends.0, None, copts).map_err(|_| e));
        match branch {
            Ok(b) => Some(b),
            Err(e) => {
                let at = self.second.words(self.second.value(s));
                self.failures.push(format!("{}: seed branch at {at}: {e}", self.spec.name));
                None
            }
        }
    }

    /// Where a boundary of `kind` was seeded (at `seed` on the branch at `s`), for its failures.
    fn origin(&self, kind: BoundaryKind, seed: &FoldCurvePoint, s: f64) -> String {
        format!(
            "{}: {} boundary from {} at {}",
            self.spec.name,
            kind.words(),
            num(self.ax.value(seed.order, seed.omega, seed.scale), 8),
            self.second.words(self.second.value(s))
        )
    }

    /// The period doublings of the seed branch `branch` at `s`, on the problem of half the base
    /// frequency at the same scale (or the family's at the same p), each walked unless covered.
    fn doublings(&mut self, half: Option<&mut Hbm>, branch: &crate::hbm::Branch, scale: f64, s: f64) {
        let mut own_half;
        let h2: Option<&mut Hbm> = match (self.fam_half, half) {
            (_, None) => None,
            (None, Some(h2)) => Some(h2),
            (Some(f), Some(_)) => match (f.build)(s) {
                Ok(h) => {
                    own_half = h;
                    Some(&mut own_half)
                }
                Err(e) => {
                    let at = self.second.words(s);
                    self.failures.push(format!("{}: half-frequency problem at {at}: {e}", self.spec.name));
                    None
                }
            },
        };
        let Some(h2) = h2 else { return };
        if h2.set_torque_scale(scale).is_err() {
            return;
        }
        // The set's label of a non-unison doubling (its test the set's representative's block at
        // half the base frequency).
        let mut halves = vec![(None, Singularity::HalfPeriod)];
        halves.extend(h2.unison_loss_tests().into_iter().map(|(l, t)| (Some(l), t.halved())));
        let tests: Vec<Singularity> = halves.iter().map(|h| h.1).collect();
        for (test, seed) in doubling_seeds(h2, &self.ax, self.fam_half, branch, s, &tests) {
            if covered(h2, &self.ax, self.fam_half, &self.walked, test, &seed) {
                continue;
            }
            let kind = BoundaryKind::PeriodDoubling;
            let set = halves.iter().find(|h| h.1 == test).and_then(|h| h.0.clone());
            let origin = self.origin(kind, &seed, s);
            let (w, failed) =
                walk_boundary(h2, &self.ax, self.fam_half, &seed, (kind, set, test), &self.fopts, &origin);
            self.failures.extend(failed);
            self.walked.push(w);
        }
    }

    /// The boundaries walked, each with its crossing of the second parameter's top, its sections
    /// and its codimension-two points (a period-doubling curve's read on `half`, the problem of
    /// half the base frequency).
    fn boundaries(&self, hbm: &mut Hbm, mut half: Option<&mut Hbm>) -> (Vec<Boundary>, Vec<MapPoint>) {
        let (ax, second) = (&self.ax, self.second);
        let mut boundaries = Vec::new();
        let mut points = Vec::new();
        for (i, w) in self.walked.iter().enumerate() {
            // A period-doubling curve lives on the problem of half the base frequency.
            let (hbm, fam): (&mut Hbm, _) = match (w.test, half.as_deref_mut()) {
                (t, Some(h2)) if t.on_half_period() => (h2, self.fam_half),
                _ => (&mut *hbm, self.fam),
            };
            let at_top = crossings_at(hbm, ax, fam, w, second.range.1);
            points.extend(self.map_points(hbm, fam, i, w));
            let sections = self
                .spec
                .sections
                .iter()
                .map(|&v| Section {
                    value: v,
                    second_values: sections_at(hbm, ax, fam, second.range, w, v)
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
        (boundaries, points)
    }

    /// The codimension-two points of boundary `i` (walked as `w`), curve by curve: its cusps,
    /// where a unison-loss curve meets a fold, and its onsets (the second parameter's extrema).
    fn map_points(&self, hbm: &mut Hbm, fam: Option<&MechanismFamily<'_>>, i: usize, w: &Walked) -> Vec<MapPoint> {
        let (ax, second) = (&self.ax, self.second);
        // A point at (order, Ω, scale) and the second parameter's value there.
        let point = |kind, (order, omega, scale, parameter): (f64, f64, f64, f64)| MapPoint {
            kind,
            boundary: i,
            value: ax.value(order, omega, scale),
            second_value: second.value(parameter),
        };
        let mut points = Vec::new();
        for c in &w.curves {
            points.extend(c.cusps.iter().map(|p| point(MapPointKind::Cusp, (p.order, p.omega, p.scale, p.parameter))));
            if w.kind == BoundaryKind::UnisonLoss {
                let meets = meets_fold(hbm, ax, fam, w.test, c);
                let at = |p: &FoldCurvePoint| (p.order, p.omega, p.scale, p.parameter);
                points.extend(meets.iter().map(|p| point(MapPointKind::UnisonLossMeetsJump, at(p))));
            }
            let onset = match w.kind {
                BoundaryKind::Jump => MapPointKind::JumpOnset,
                BoundaryKind::UnisonLoss => MapPointKind::UnisonLossOnset,
                BoundaryKind::PeriodDoubling => MapPointKind::PeriodDoublingOnset,
            };
            points.extend(c.scale_extrema.iter().map(|p| point(onset, (p.order, p.omega, p.scale, p.parameter))));
        }
        points
    }
}

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
    let problem = Problem { study, spec, kane: &kane, inputs: &inputs, omega: ax.omega, general: false };
    let (mut routed, general) = problem.routed(forcing, opts)?;
    let problem = Problem { general, ..problem };
    let route = routed.route().to_string();
    // The problem of half the base frequency (the extra multiple at zero amplitude, twice the
    // harmonics), on which period doublings are followed.
    let ratio = routed.hbm().base_frequency(1.0) / routed.hbm().omega();
    let mut halved = second.harmonics.clone();
    halved.push(Harmonic { multiple: 0.5 * ratio, amplitude: 0.0, phase: 0.0 });
    let opts2 = HbmOptions { harmonics: 2 * spec.harmonics, ..opts };
    let build = |p: f64| problem.at(p, forcing, opts);
    let build_half = |p: f64| problem.at(p, (&halved[..], &[][..]), opts2);
    let (reference, speed) = (second.range.0.abs().max(second.range.1.abs()), spec.speed_is_second());
    let family = spec.parameter.as_ref().map(|_| MechanismFamily { build: &build, scale: 1.0, reference, speed });
    let family_half =
        spec.parameter.as_ref().map(|_| MechanismFamily { build: &build_half, scale: 1.0, reference, speed });
    let hbm = routed.hbm_mut();
    let mut tests = vec![(BoundaryKind::Jump, None, Singularity::Jacobian)];
    tests.extend(hbm.unison_loss_tests().into_iter().map(|(l, t)| (BoundaryKind::UnisonLoss, Some(l), t)));
    let screen = screen(study, spec, &ax, &second, ratio);
    // The half-frequency problem the period-doubling curves are evaluated on (on a mechanism
    // parameter's plane the one at its lower end, for the layout only).
    let mut half: Option<Hbm> = match (&screen, &spec.parameter) {
        (Err(_), _) => None,
        (Ok(_), None) => RoutedHbm::new(&kane, study.spin, ax.omega, (&halved[..], &[][..]), &inputs, opts2)
            .ok()
            .map(|r| r.hbm().clone()),
        (Ok(_), Some(_)) => build_half(second.range.0).ok(),
    };
    let mut map = Map {
        spec,
        ax,
        second: &second,
        fam: family.as_ref(),
        fam_half: family_half.as_ref(),
        fopts: FoldCurveOptions { range: ax.range, scales: second.range, ..FoldCurveOptions::default() },
        copts: seed_options(study),
        walked: Vec::new(),
        failures: Vec::new(),
    };
    for &s in &second.seeds {
        map.seed(hbm, half.as_mut(), &tests, s);
    }
    let found = map.boundaries(hbm, half.as_mut());
    let result = result(spec, &ax, &second, route, found, screen, start);
    Ok((result, map.failures))
}

/// The map's result from what was found on it (`route` the harmonic-balance route, `screen` the
/// period-doubling search's words, `start` when the map began).
fn result(
    spec: &EnvelopeSpec,
    ax: &Axis,
    second: &Second,
    route: String,
    (boundaries, points): (Vec<Boundary>, Vec<MapPoint>),
    screen: std::result::Result<String, String>,
    start: std::time::Instant,
) -> EnvelopeResult {
    EnvelopeResult {
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
    }
}
