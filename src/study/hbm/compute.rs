//! The branches of a harmonic-balance analysis: per amplitude, the branch continued from each
//! end of the range (pseudo-arclength continuation, `hbm::continuation`), with its stability,
//! folds and bifurcations, the curve drawn between its points (Hermite interpolation), why it
//! stopped short, and the states it crosses at the requested values; the switched branches
//! (`switch.rs`) after the upward one.

use super::switch::{SwitchedRow, switched};
use super::{
    Axis, CURVE_SUBDIVISION, HbmBranch, HbmOrbit, HbmParameter, HbmSpec, axis, body_accel, branch_in, cases, forcing,
};
use crate::hbm::{BifurcationClass, Branch, BranchEnd, HbmSolution, Parameter, PointHook, RoutedHbm};
use crate::model::excitation::{Harmonic, rpm_to_rad_s};
use crate::model::mechanism::Mechanism;
use crate::study::Study;
use crate::study::elements::from_hbm;
use crate::study::sim::Progress;

/// Share of a path's travel at which a stalled branch counts as having reached the end of the
/// path: the corrector fails there because the periodic state approaches the path's end, where
/// the motion stiffens without bound (the path examples' 500 N·m branches stall at 90–91 % of
/// their travel; 0.8 leaves room for coarser harmonics).
const AT_TRAVEL_END: f64 = 0.8;

/// Why a branch ending at `sol` stalled, when it is the end of an absorber's path: the joint and
/// the share of its travel its peak reaches (at least [`AT_TRAVEL_END`]).
fn travel_end(mech: &Mechanism, sol: &HbmSolution) -> Option<String> {
    (0..mech.ndof())
        .filter_map(|k| {
            let joint = &mech.joints[mech.joint_of(k)];
            let travel = joint.kind.travel();
            let share = sol.peak_amplitude(k) / travel;
            (travel.is_finite() && share >= AT_TRAVEL_END).then_some((share, joint.name.clone(), travel))
        })
        .max_by(|a, b| a.0.total_cmp(&b.0))
        .map(|(share, name, travel)| {
            format!(
                "absorber `{name}` reaches {:.0} % of its travel ({travel:.4e} m): the steady state leaves its path",
                100.0 * share
            )
        })
}

/// What every branch of one analysis shares: the continued parameter on its axis, the problem's
/// mean speed and the factor from the axis unit to the solver's (rad/s per rpm on a speed
/// branch), the response body's path, and the progress lines.
struct Continued<'a> {
    study: &'a Study,
    spec: &'a HbmSpec,
    ax: Axis,
    parameter: Parameter,
    omega: f64,
    scale: f64,
    path: Vec<(usize, f64)>,
    progress: Option<&'a Progress>,
}

/// [`super::compute`] with a progress line per branch on a terminal (points and the parameter
/// reached).
pub(super) fn compute_with(
    study: &Study,
    spec: &HbmSpec,
    progress: Option<&Progress>,
) -> (Vec<HbmBranch>, Vec<String>) {
    // One case per amplitude (order and speed), or one with T_n = 1 N·m scaled (torque).
    let (omega, scale) = match spec.parameter {
        HbmParameter::Speed { rpm_min, .. } => (rpm_to_rad_s(rpm_min), rpm_to_rad_s(1.0)),
        _ => (rpm_to_rad_s(spec.rpm), 1.0),
    };
    let run = Continued {
        study,
        spec,
        ax: axis(spec),
        parameter: spec.parameter.continued(),
        omega,
        scale,
        path: study.mechanism.rotation_rates(study.body),
        progress,
    };
    let mut branches = Vec::new();
    let mut failures = Vec::new();
    for amp in cases(spec) {
        let (harmonics, per_omega2) = forcing(spec, amp);
        // From above, the continuation follows the branch that comes down from high values; from
        // below, the one that comes up from low values. Where the response is S-shaped and a fold
        // lies outside the range, each reaches sheets the other cannot.
        let (lo, hi) = run.ax.range;
        for (from, to) in [(hi, lo), (lo, hi)] {
            let what = if amp.is_nan() { String::new() } else { format!(" {amp} N·m") };
            let case = (amp, &harmonics[..], &per_omega2[..]);
            let Some((hbm, b, wall_s)) = run.continued(case, (from, to), &what, &mut failures) else { continue };
            // The unison branch, then (`switch`, once per amplitude: on the upward
            // continuation) the non-unison branches switched at its branch points.
            let mut rows = Vec::new();
            if spec.switch && from == lo {
                let range = (lo * scale, hi * scale);
                rows = switched(study, spec, (omega, &harmonics, &per_omega2), &b, range, &mut failures, &what);
            }
            rows.insert(0, (hbm, b, wall_s, None, false));
            for row in rows {
                branches.push(run.branch(row, amp, from, &what, &mut failures));
            }
        }
    }
    failures.extend(not_finite(spec, &branches));
    (branches, failures)
}

/// A failure for each branch with a solution that is not finite (left empty in the CSV).
fn not_finite(spec: &HbmSpec, branches: &[HbmBranch]) -> Vec<String> {
    branches
        .iter()
        .filter(|br| br.accel.iter().flatten().chain(&br.relative_angle).any(|v| !v.is_finite()))
        .map(|br| format!("{} branch from {}: a solution is not finite (left empty in the CSV)", spec.name, br.from))
        .collect()
}

impl Continued<'_> {
    /// The branch of one case (`(amplitude, harmonics, per Ω²)`) continued from `from` to `to`
    /// (axis unit) with its wall time, or None with the failure listed (`what` names the
    /// amplitude): not run once the watchdog has passed, or the continuation's error.
    fn continued(
        &self,
        (amp, harmonics, per_omega2): (f64, &[Harmonic], &[Harmonic]),
        (from, to): (f64, f64),
        what: &str,
        failures: &mut Vec<String>,
    ) -> Option<(RoutedHbm, Branch, f64)> {
        let (study, spec) = (self.study, self.spec);
        if let Some(d) = study.spec.integration.deadline.filter(|d| d.passed()) {
            failures.push(format!(
                "{}{what}, continued from {from}: not run: {} (stopped by the watchdog)",
                spec.name,
                crate::deadline::Deadline::overran(d.budget_s)
            ));
            return None;
        }
        let bar = self.progress.map(|pr| pr.spinner(&format!("{}{what} from {from}", spec.name)));
        let hook = bar.clone().map(|bar| {
            let (to_unit, unit) = (self.ax.to_unit, self.ax.unit);
            PointHook(std::sync::Arc::new(move |k: usize, p: f64| {
                bar.set_message(format!("{k} points, at {:.5} {unit}", p * to_unit));
                bar.tick();
            }))
        });
        let solved = branch_in(
            study,
            self.omega,
            (harmonics, per_omega2),
            &spec.excite,
            spec.harmonics,
            self.parameter,
            from * self.scale,
            to * self.scale,
            spec.max_step,
            hook,
            spec.route,
        );
        if let Some(bar) = &bar {
            bar.finish_and_clear();
        }
        match solved {
            Ok(x) => Some(x),
            Err(e) => {
                let what = if amp.is_nan() { String::new() } else { format!(" at {amp} N·m") };
                failures.push(format!("{}{what}, continued from {from}: {e}", spec.name));
                None
            }
        }
    }

    /// One branch as the study reports it, from a row of the continuation (the unison branch or
    /// a switched one) of amplitude `amp` continued from `from`; its stop short of the range and
    /// the watchdog's are listed in `failures`.
    fn branch(
        &self,
        (mut hbm, b, wall_s, switched_at, period_doubled): SwitchedRow,
        amp: f64,
        from: f64,
        what: &str,
        failures: &mut Vec<String>,
    ) -> HbmBranch {
        let (study, spec, ax, path) = (self.study, self.spec, &self.ax, &self.path);
        let from = switched_at.map_or(from, |v: f64| v * ax.to_unit);
        let stopped_short = self.stopped_short(&b, from, what, failures);
        let (curve_parameter, curve_accel, curve_stable) = self.drawn_curve(&b);
        let orbits = orbits_on(study, spec, &mut hbm, &b, (path, self.scale));
        let p = &b.points;
        HbmBranch {
            orbits,
            stopped_short,
            analysis: spec.name.clone(),
            curve_parameter,
            curve_accel,
            curve_stable,
            amplitude: amp,
            order: p.iter().map(|x| x.order).collect(),
            parameter: p.iter().map(|x| x.parameter * ax.to_unit).collect(),
            accel: spec
                .multiples
                .iter()
                .map(|&m| p.iter().map(|x| body_accel(&x.solution, path, m)).collect())
                .collect(),
            relative_angle: p.iter().map(|x| x.solution.max_peak_amplitude()).collect(),
            elements: p
                .iter()
                .map(|x| from_hbm(&study.mechanism, &study.elements, &x.solution, &spec.multiples))
                .collect(),
            stable: p.iter().map(|x| x.stable).collect(),
            coupling_tail: p.iter().map(|x| x.solution.coupling_tail).collect(),
            max_multiplier: p
                .iter()
                .map(|x| x.solution.stability.as_ref().map_or(f64::NAN, |st| st.max_modulus))
                .collect(),
            folds: b.folds.iter().map(|f| f.parameter * ax.to_unit).collect(),
            unison_lost: unison_lost(&study.mechanism, &b, ax.to_unit),
            bifurcations: b
                .bifurcations
                .iter()
                .map(|x| (x.parameter * ax.to_unit, x.class.words().to_string()))
                .collect(),
            wall_s,
            route: hbm.route().name().to_string(),
            route_detail: hbm.route().to_string(),
            end: format!("{:?}", b.end),
            from,
            switched_at: switched_at.map(|v| v * ax.to_unit),
            goes: switched_at.map(|_| super::switch::goes(&b, ax.to_unit, period_doubled)),
            period_doubled,
        }
    }

    /// Why and where branch `b` (continued from `from`) stopped short of its range, in words;
    /// a stall or the point cap short of the range, and the watchdog's stop, also listed in
    /// `failures`.
    fn stopped_short(&self, b: &Branch, from: f64, what: &str, failures: &mut Vec<String>) -> Option<String> {
        let (study, spec, ax) = (self.study, self.spec, &self.ax);
        let p = &b.points;
        // A branch that could not go on says why and where in the summary (its points are
        // kept). Where the last state takes an absorber to the end of its path (within
        // `AT_TRAVEL_END`), the stall is the mechanism's own limit and stays a note; any other
        // stall is also a failure (below).
        let at_travel_end = p.last().and_then(|last| travel_end(&study.mechanism, &last.solution));
        let stopped = match b.end {
            BranchEnd::StepTooSmall if at_travel_end.is_some() => at_travel_end.as_deref(),
            BranchEnd::StepTooSmall => Some("the corrector failed at every step down to the smallest"),
            BranchEnd::MaxPoints => Some("it reached the largest number of points"),
            BranchEnd::Watchdog => Some("the analysis overran its time budget (stopped by the watchdog)"),
            BranchEnd::ReachedTarget | BranchEnd::LeftRange | BranchEnd::Unison => None,
        };
        // Where the branch got to: ` at order = 3.1765350 after 669 points`.
        let reached = p.last().map_or(String::new(), |last| {
            format!(" at {} = {:.7}{} after {} points", ax.column, last.parameter * ax.to_unit, ax.suffix(), p.len())
        });
        if b.end == BranchEnd::Watchdog {
            let budget = study.spec.integration.deadline.map_or(f64::NAN, |d| d.budget_s);
            let at = &reached;
            failures.push(format!(
                "{}{what}, continued from {from}: stopped by the watchdog{at}: {} (the points reached are kept)",
                spec.name,
                crate::deadline::Deadline::overran(budget)
            ));
        }
        let stopped_short = match (stopped, p.last()) {
            (Some(reason), Some(_)) => Some(format!("stopped because {reason},{reached}")),
            _ => None,
        };
        // A branch that stalled (or hit its point cap) short of its range is a failure of the
        // analysis: the jump or fold the user asked about may lie beyond it. (The watchdog's
        // stop is listed above.)
        if matches!(b.end, BranchEnd::StepTooSmall | BranchEnd::MaxPoints)
            && at_travel_end.is_none()
            && let Some(why) = &stopped_short
        {
            failures.push(format!("{}{what}, continued from {from}: {why} (the points reached are kept)", spec.name));
        }
        stopped_short
    }

    /// Branch `b`'s drawn curve: its points with [`CURVE_SUBDIVISION`] − 1 Hermite-interpolated
    /// states between each two (an interpolated state takes its nearer point's stability): the
    /// parameter in the axis unit, the acceleration per reported multiple, the stability.
    fn drawn_curve(&self, b: &Branch) -> (Vec<f64>, Vec<Vec<f64>>, Vec<Option<bool>>) {
        let (spec, p) = (self.spec, &b.points);
        let (mut curve_parameter, mut curve_stable) = (Vec::new(), Vec::new());
        let mut curve_accel = vec![Vec::new(); spec.multiples.len()];
        let mut add = |sol: &HbmSolution, stable: Option<bool>| {
            curve_parameter.push(self.parameter.value(sol) * self.ax.to_unit);
            for (acc, &m) in curve_accel.iter_mut().zip(&spec.multiples) {
                acc.push(body_accel(sol, &self.path, m));
            }
            curve_stable.push(stable);
        };
        for i in 0..p.len() {
            add(&p[i].solution, p[i].stable);
            if i + 1 == p.len() {
                break;
            }
            for j in 1..CURVE_SUBDIVISION {
                let sigma = j as f64 / CURVE_SUBDIVISION as f64;
                if let Some(sol) = b.interpolate(i, sigma) {
                    add(&sol, if sigma < 0.5 { p[i].stable } else { p[i + 1].stable });
                }
            }
        }
        (curve_parameter, curve_accel, curve_stable)
    }
}

/// The values of branch `b`'s continued parameter (times `to_unit`) where absorbers leave
/// unison: its branch points and its folds that [`parts_absorbers`], ascending.
fn unison_lost(mech: &Mechanism, b: &crate::hbm::Branch, to_unit: f64) -> Vec<f64> {
    let nb = b.points.first().map_or(0, |p| 2 * p.solution.harmonics + 1);
    let points = b.bifurcations.iter().filter(|x| x.class == BifurcationClass::BranchPoint).map(|x| x.parameter);
    let folds = b.folds.iter().filter(|f| parts_absorbers(mech, &f.critical, nb)).map(|f| f.parameter);
    let mut out: Vec<f64> = points.chain(folds).map(|v| v * to_unit).collect();
    out.sort_by(f64::total_cmp);
    out
}

/// Whether a critical motion (Fourier coefficients, `nb` per coordinate, in the layout of
/// [`HbmSolution::coefficients`]) moves the absorbers of some rotor apart rather than together:
/// for the absorbers hung on one body (two or more), the energy of their deviations from their
/// mean motion, `Σ_k ‖v_k − v̄‖²`, exceeds half their total `Σ_k ‖v_k‖²`. In unison every v_k is
/// the same (ratio 0); in a pure out-of-unison mode of identical absorbers the mean is zero
/// (ratio 1). A mistuned set sits near one or the other, which is why half separates them.
pub fn parts_absorbers(mech: &Mechanism, critical: &[f64], nb: usize) -> bool {
    if critical.is_empty() || nb == 0 {
        return false;
    }
    let absorbers = crate::model::absorber::absorbers(mech);
    let mut parents: Vec<Option<usize>> = Vec::new();
    let mut groups: Vec<Vec<usize>> = Vec::new();
    for a in &absorbers {
        let Some(j) = mech.joint_index(&a.joint) else { continue };
        let Some(k) = mech.coordinate(j).filter(|&k| (k + 1) * nb <= critical.len()) else { continue };
        let parent = mech.joints[j].parent;
        match parents.iter().position(|p| *p == parent) {
            Some(g) => groups[g].push(k),
            None => {
                parents.push(parent);
                groups.push(vec![k]);
            }
        }
    }
    groups.iter().filter(|g| g.len() >= 2).any(|g| {
        let slice = |k: usize| &critical[k * nb..(k + 1) * nb];
        let mean: Vec<f64> = (0..nb).map(|i| g.iter().map(|&k| slice(k)[i]).sum::<f64>() / g.len() as f64).collect();
        let total: f64 = g.iter().map(|&k| slice(k).iter().map(|v| v * v).sum::<f64>()).sum();
        let apart: f64 =
            g.iter().map(|&k| slice(k).iter().zip(&mean).map(|(v, m)| (v - m) * (v - m)).sum::<f64>()).sum();
        total > 0.0 && apart > 0.5 * total
    })
}

/// The states branch `b` crosses at each of `spec.orbits_at` (in the axis unit; `scale` takes it
/// to the continued parameter), each solved there from its nearer branch point and its stability
/// computed; a crossing whose solve fails is left out (the branch's points stay).
fn orbits_on(
    study: &Study,
    spec: &HbmSpec,
    hbm: &mut crate::hbm::RoutedHbm,
    b: &crate::hbm::Branch,
    (path, scale): (&[(usize, f64)], f64),
) -> Vec<HbmOrbit> {
    let mut out = Vec::new();
    for &at in &spec.orbits_at {
        let value = at * scale;
        for guess in b.guesses_at(value) {
            let solved = match spec.parameter {
                HbmParameter::Order => hbm.solve(value, Some(guess)),
                HbmParameter::Speed { order, .. } => hbm.set_speed(value).and_then(|()| hbm.solve(order, Some(guess))),
                HbmParameter::Torque { order, .. } => {
                    hbm.set_torque_scale(value).and_then(|()| hbm.solve(order, Some(guess)))
                }
            };
            let Ok(mut sol) = solved else { continue };
            sol.stability = hbm.stability(&sol).ok();
            out.push(HbmOrbit {
                at,
                accel: spec.multiples.iter().map(|&m| body_accel(&sol, path, m)).collect(),
                relative_angle: sol.max_peak_amplitude(),
                stable: sol.stability.as_ref().map(|st| st.stable),
                max_multiplier: sol.stability.as_ref().map_or(f64::NAN, |st| st.max_modulus),
                elements: from_hbm(&study.mechanism, &study.elements, &sol, &spec.multiples),
            });
        }
    }
    out
}
