//! Period doublings on the map: whether the linearised mechanism lets the map hold one at all
//! (a multiplier −1 grows from a parametric resonance of the Mathieu kind, o ≈ k·e/2), and the
//! seeds of the period-doubling curves on a seed branch (sign changes of the half-period tests on
//! the problem of half the base frequency, between the branch's points and interpolated states).

use super::plane::Axis;
use crate::hbm::{FoldCurvePoint, FoldPlane, Hbm, HbmSolution, MechanismFamily, Singularity};
use crate::model::excitation::Harmonic;
use crate::plot::num;

/// Sub-intervals per step of a seed branch at which [`doubling_seeds`] tests for a period
/// doubling: a tongue is often narrower than the seed branch's step (0.05 wide in n at 2000 N·m
/// on the paper's rotor against steps of 0.1), and the states between points come from the
/// branch's Hermite interpolation, without a solve.
const DOUBLING_SUBSTEPS: usize = 10;

/// The period doublings of the seed branch `branch` (on the problem at the base frequency, at
/// scale `s`, or at p = `s` of a mechanism family), each solved on the problem of half the base
/// frequency `h2` (at that s or p; `family` the half-frequency problems' family) with its test: where
/// the sign of a test's determinant (the odd-harmonic block, or its part of an identical set's
/// representative) changes between two of the branch's points or interpolated states.
pub(super) fn doubling_seeds(
    h2: &mut Hbm,
    ax: &Axis,
    family: Option<&MechanismFamily<'_>>,
    branch: &crate::hbm::Branch,
    s: f64,
    tests: &[Singularity],
) -> Vec<(Singularity, FoldCurvePoint)> {
    let mut states: Vec<HbmSolution> = Vec::new();
    for i in 0..branch.points.len() {
        states.push(branch.points[i].solution.clone());
        if i + 1 < branch.points.len() {
            states.extend(
                (1..DOUBLING_SUBSTEPS).filter_map(|j| branch.interpolate(i, j as f64 / DOUBLING_SUBSTEPS as f64)),
            );
        }
    }
    let doubled: Vec<HbmSolution> = states.iter().filter_map(|p| h2.on_doubled_period(p, p.order).ok()).collect();
    let signs: Vec<Vec<f64>> = doubled.iter().map(|d| h2.singularity_signs(d, tests)).collect();
    let mut seeds = Vec::new();
    for (k, &test) in tests.iter().enumerate() {
        for (i, w) in signs.windows(2).enumerate() {
            if w[0][k] * w[1][k] < 0.0
                && let Ok(p) = h2.singular_at_with(ax.fold, family, test, s, &doubled[i])
            {
                seeds.push((test, p));
            }
        }
    }
    seeds
}

/// How far (as a factor either way) a period-doubling tongue is looked for from the linear
/// parametric resonance it grows from: the amplitude shifts an absorber's tuning (a circular
/// path's order falls by 15 % at a 90° swing) and a tongue widens with the pump.
const DOUBLING_MARGIN: f64 = 1.3;

/// Whether the map can hold a period doubling, from the linearised mechanism (free spin, no
/// damping) at the map's mean speeds: a multiplier −1 over the base period T_b grows from the
/// parametric resonance of a mode of eigen-order o with a pump of order e (a harmonic of the
/// response, the excitation's own orders first) where o ≈ k·e/2 for k = 1 (the principal
/// Mathieu tongue) or 3, and only where k·e/e_b is odd (e_b the base order: an even multiple
/// makes the mode's motion repeat over T_b, a +1 tongue). Ok(words) when some resonance lies
/// within [`DOUBLING_MARGIN`] of the map's orders (and when the linear model fails: then the
/// search runs), Err(words) when none does and the search is skipped. `mechanisms`: the study's
/// mechanism, or on a mechanism parameter's plane the mechanism at both ends of its range;
/// `speeds`: the map's (rad/s); each eigen-order's range spans every pair of the two.
pub(super) fn doubling_screen(
    mechanisms: &[crate::model::mechanism::Mechanism],
    spin_joint: &str,
    ax: &Axis,
    speeds: &[f64],
    harmonics: &[Harmonic],
    ratio: f64,
) -> std::result::Result<String, String> {
    use crate::linear::{Damping, LinearModel, ModeKind, Spin};
    let searched = "searched along the seed branches".to_string();
    // The base order's range (the eigen-orders are taken at each of `speeds`, rad/s).
    let n = match ax.fold {
        FoldPlane::Order => ax.range,
        FoldPlane::Speed { order } | FoldPlane::Torque { order } => (order, order),
    };
    let cases = mechanisms.iter().flat_map(|m| speeds.iter().map(move |&omega| (m, omega)));
    let mut orders: Vec<(f64, f64)> = Vec::new();
    for (i, (mech, omega)) in cases.enumerate() {
        let modal =
            LinearModel::new(mech, spin_joint, omega, None).and_then(|m| m.modes(Spin::Free, Damping::Undamped));
        let Ok(modal) = modal else { return Ok(searched) };
        let vib = modal.modes.iter().filter(|m| m.kind == ModeKind::Vibration && m.order.is_finite());
        for (j, o) in vib.map(|m| m.order).enumerate() {
            if i == 0 {
                orders.push((o, o));
            } else if let Some(r) = orders.get_mut(j) {
                *r = (r.0.min(o), r.1.max(o));
            }
        }
    }
    for h in harmonics.iter().filter(|h| h.amplitude != 0.0) {
        let m = (h.multiple / ratio).round() as i64;
        for k in [1_i64, 3] {
            if (k * m) % 2 == 0 {
                continue;
            }
            let lo = 0.5 * k as f64 * h.multiple * n.0.min(n.1) / DOUBLING_MARGIN;
            let hi = 0.5 * k as f64 * h.multiple * n.0.max(n.1) * DOUBLING_MARGIN;
            if let Some(o) = orders.iter().find(|o| o.1 >= lo && o.0 <= hi) {
                return Ok(format!(
                    "{searched}: the linear eigen-order {} is near {k}/2 of the excitation's order {}",
                    num(o.0, 5),
                    num(h.multiple * 0.5 * (n.0 + n.1), 5)
                ));
            }
        }
    }
    Err(format!(
        "not searched: no linear eigen-order lies within a factor {DOUBLING_MARGIN} of k/2 of an excitation order \
         (k = 1, 3, the parametric resonances that double the period)"
    ))
}
