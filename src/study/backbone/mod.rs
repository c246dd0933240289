//! The free-oscillation analysis: the backbone curve of one joint (an absorber), its free
//! oscillation order against amplitude at held spin with every damper removed.
//!
//! The spin joint's rate is prescribed constant (the partitioned equations of `time::drive_laws`:
//! `A_rr q̈_r = G_r − A_rs q̈_s` with q̈_s = 0), every joint damper and damper to ground is
//! set to zero and the mechanism's own joint torques are removed, so the motion is the
//! conservative free oscillation about the relative equilibrium. The joint is released from
//! rest at each amplitude A (its coordinate's unit: rad, or m of arc length for a path joint),
//! every other joint at q = 0 relative to its parent. The period is the mean spacing of the
//! upward zero crossings of the coordinate over `periods` full periods, each crossing located
//! between two samples by the cubic Hermite interpolant of (q, q̇) (error O(h⁴) in the sample
//! step, with 128 samples per linear period); the order is `2π / (T Ω)`.
//!
//! The small-amplitude limit is the linear analysis's held-spin undamped mode with the largest
//! share of the joint's coordinate: the circle's order falls with amplitude as
//! `π / (2 K(sin(φ₀/2)))` (a softening path), a tautochronic path keeps it constant.

mod analysis;
mod spec;
pub use spec::*;

use super::linear::lin;
use super::table::{Table, fmt_num};
use super::{Output, Study};
use crate::error::{Error, Result};
use crate::kane::Kane;
use crate::linear::{Damping, LinearModel, Spin};
use crate::model::excitation::rpm_to_rad_s;
use crate::plot::{LineStyle, Panel, Series};
use crate::time::drive_laws::{Drive, Prescribed};
use crate::time::integrate::{IntegrateOptions, integrate};
use serde::Serialize;
use std::f64::consts::PI;
use std::fmt::Write as _;
use std::path::Path;

/// Samples per linear period for locating the zero crossings.
const SAMPLES_PER_PERIOD: f64 = 128.0;

/// Integration tolerance: the runs are short and cheap, and the order should be resolved far
/// below any physical difference between paths.
const RTOL: f64 = 1e-12;

/// The slowest nonlinear oscillation the run waits for, as a fraction of the linear frequency:
/// a circle released at 170° still oscillates at about 0.4 of it.
const SLOWEST: f64 = 0.25;

/// The backbone of one joint.
#[derive(Debug, Clone, PartialEq, Serialize, schemars::JsonSchema)]
pub struct FreeOscillationResult {
    /// The analysis name.
    pub name: String,
    /// The joint released.
    pub joint: String,
    /// Unit of its coordinate (`rad` or `m`).
    pub unit: &'static str,
    /// The held spin speed, rpm.
    pub rpm: f64,
    /// The linear (small-amplitude) order of the joint's mode at held spin, undamped.
    pub linear_order: f64,
    /// Release amplitudes, in `unit`.
    pub amplitudes: Vec<f64>,
    /// The free-oscillation order at each amplitude (NaN where the run failed or the joint did
    /// not oscillate through zero `periods` times, e.g. a pendulum going over the top).
    pub orders: Vec<f64>,
    /// The largest excursion on the other side of zero, in `unit` (equal to the amplitude for a
    /// path symmetric in its coordinate): the largest sample, so low by up to
    /// (2π/128)²/2 ≈ 1.2e-3 relative at the linear sample spacing.
    pub far_side: Vec<f64>,
}

impl FreeOscillationResult {
    /// Each order over the linear order.
    pub fn order_ratios(&self) -> Vec<f64> {
        self.orders.iter().map(|o| o / self.linear_order).collect()
    }
}

/// The CSV table `<name>.csv`: amplitude, order, order over the linear order, far-side amplitude.
pub(crate) fn table(r: &FreeOscillationResult) -> Table {
    let mut t = Table::new(r.name.clone());
    t.push(format!("amplitude_{}", r.unit), r.unit, r.amplitudes.clone());
    t.push("order", "1", r.orders.clone());
    t.push("order_over_linear", "1", r.order_ratios());
    t.push(format!("far_side_{}", r.unit), r.unit, r.far_side.clone());
    t
}

/// Runs the analysis: one free run per amplitude, then the CSV, the figure and the summary.
pub(crate) fn run(study: &Study, spec: &FreeOscillationSpec, dir: &Path) -> Result<Output> {
    let r = compute(study, spec)?;
    let mut failures = Vec::new();
    for (a, o) in r.amplitudes.iter().zip(&r.orders) {
        if !o.is_finite() {
            failures.push(format!(
                "{} at amplitude {} {}: no free oscillation measured (see the summary)",
                spec.name,
                fmt_num(*a),
                r.unit
            ));
        }
    }
    let mut files = vec![table(&r).write_csv(dir)?];
    let svg = dir.join(format!("{}.svg", spec.name));
    crate::plot::write_svg(&svg, &[panel(&[(r.joint.clone(), &r)])], 760, 520)?;
    files.push(svg);
    Ok(Output { markdown: markdown(&r), files, failures, results: Box::new(r) })
}

/// The figure's panel: order against amplitude for each labelled result, with the linear orders
/// as dotted lines.
pub(crate) fn panel(results: &[(String, &FreeOscillationResult)]) -> Panel {
    let mut series = Vec::new();
    for (k, (label, r)) in results.iter().enumerate() {
        series.push(Series {
            label: label.clone(),
            x: r.amplitudes.clone(),
            y: r.orders.clone(),
            color: k,
            style: LineStyle::Solid,
        });
        let (lo, hi) = r.amplitudes.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
        series.push(Series {
            label: String::new(),
            x: vec![lo.min(0.0), hi],
            y: vec![r.linear_order; 2],
            color: k,
            style: LineStyle::Dotted,
        });
    }
    let unit = results.first().map_or("", |r| r.1.unit);
    let rpm = results.first().map_or(f64::NAN, |r| r.1.rpm);
    Panel {
        title: format!("Free oscillation at held spin ({} rpm, undamped); dotted: linear order", fmt_num(rpm)),
        x_label: format!("release amplitude, {unit}"),
        y_label: "order of the free oscillation".into(),
        series,
        ..Panel::default()
    }
}

/// The summary section.
pub(crate) fn markdown(r: &FreeOscillationResult) -> String {
    let mut md = String::new();
    let _ = writeln!(
        md,
        "## Free oscillation `{}`: joint `{}` at held spin, {} rpm, undamped\n",
        r.name,
        r.joint,
        fmt_num(r.rpm)
    );
    let _ = writeln!(md, "Linear order (held spin, undamped): {:.6}.\n", r.linear_order);
    let _ = writeln!(md, "| amplitude ({}) | order | order / linear | far side ({}) |", r.unit, r.unit);
    let _ = writeln!(md, "|---|---|---|---|");
    for (((a, o), q), f) in r.amplitudes.iter().zip(&r.orders).zip(r.order_ratios()).zip(&r.far_side) {
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} |",
            fmt_num(*a),
            super::cell(*o, 6),
            super::cell(q, 6),
            super::cell(*f, 6)
        );
    }
    let finite: Vec<f64> = r.order_ratios().into_iter().filter(|v| v.is_finite()).collect();
    if finite.len() >= 2 {
        let (lo, hi) = finite.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
        let _ = writeln!(
            md,
            "\nOver these amplitudes the order varies by {:.3e} of the linear order ({}).",
            hi - lo,
            if hi - lo <= 1e-6 { "amplitude-independent: tautochronic" } else { "amplitude-dependent" }
        );
    }
    md.push('\n');
    md
}

/// The backbone of `spec.joint` (see the module docs).
pub(crate) fn compute(study: &Study, spec: &FreeOscillationSpec) -> Result<FreeOscillationResult> {
    let model_err = |message: String| Error::Model { mechanism: study.mechanism.name.clone(), message };
    let mut mech = study.mechanism.clone();
    for j in &mut mech.joints {
        j.damper = 0.0;
    }
    mech.loads.ground_dampers.clear();
    mech.loads.joint_torques.clear();
    let joint = mech.joint_index(&spec.joint).ok_or_else(|| model_err(format!("unknown joint `{}`", spec.joint)))?;
    let coord = mech.coordinate(joint).ok_or_else(|| model_err(format!("joint `{}` has no coordinate", spec.joint)))?;
    let unit = mech.joints[joint].kind.coordinate_unit();
    let omega = rpm_to_rad_s(spec.rpm);
    let lm = LinearModel::new(&mech, &study.spec.spin_joint, omega, None).map_err(lin(&mech))?;
    let modes = lm.modes(Spin::Held, Damping::Undamped).map_err(lin(&mech))?;
    let share = |m: &crate::linear::Mode| {
        let big = m.shape_q.iter().map(|c| c.norm()).fold(0.0, f64::max);
        m.shape_q.get(coord).map_or(0.0, |c| c.norm() / big.max(f64::MIN_POSITIVE))
    };
    let linear_order = modes
        .modes
        .iter()
        .filter(|m| m.order.is_finite() && m.order > 0.0)
        .max_by(|a, b| share(a).total_cmp(&share(b)))
        .map(|m| m.order)
        .ok_or_else(|| model_err(format!("joint `{}` has no oscillating mode at held spin", spec.joint)))?;
    let mut orders = Vec::with_capacity(spec.amplitudes.len());
    let mut far_side = Vec::with_capacity(spec.amplitudes.len());
    let deadline = study.spec.integration.deadline;
    let watchdog = |done: usize| {
        deadline.filter(|d| d.passed()).map(|d| {
            model_err(format!(
                "stopped by the watchdog after {done} of {} amplitudes: {}",
                spec.amplitudes.len(),
                crate::deadline::Deadline::overran(d.budget_s)
            ))
        })
    };
    for (k, &a) in spec.amplitudes.iter().enumerate() {
        if let Some(e) = watchdog(k) {
            return Err(e);
        }
        let (o, f) = one_amplitude(&mech, study.spin, coord, omega, linear_order, a, spec.periods, deadline);
        orders.push(o);
        far_side.push(f);
    }
    // The last run may have been the one the watchdog stopped.
    if let Some(e) = watchdog(spec.amplitudes.len() - 1) {
        return Err(e);
    }
    Ok(FreeOscillationResult {
        name: spec.name.clone(),
        joint: spec.joint.clone(),
        unit,
        rpm: spec.rpm,
        linear_order,
        amplitudes: spec.amplitudes.clone(),
        orders,
        far_side,
    })
}

/// One free run released at `a`: (order, far-side excursion), NaN when no oscillation was
/// measured (the run failed, left the path, or crossed zero fewer than `periods + 1` times).
#[allow(clippy::too_many_arguments)]
fn one_amplitude(
    mech: &crate::model::mechanism::Mechanism,
    spin: usize,
    coord: usize,
    omega: f64,
    linear_order: f64,
    a: f64,
    periods: usize,
    deadline: Option<crate::deadline::Deadline>,
) -> (f64, f64) {
    let fail = (f64::NAN, f64::NAN);
    let Ok(kane) = Kane::new(mech) else { return fail };
    let Ok(mut drive) = Drive::new(kane, spin, vec![], Some(Prescribed { joint: spin, accel: 0.0, until_s: 0.0 }))
    else {
        return fail;
    };
    let mut x0 = Study::initial_state(mech, spin, omega);
    x0[coord] = a;
    let f_lin = linear_order * omega / (2.0 * PI);
    let t1 = (periods as f64 + 2.0) / (SLOWEST * f_lin);
    let dt = 1.0 / (SAMPLES_PER_PERIOD * f_lin);
    let opts = IntegrateOptions {
        rtol: RTOL,
        atol: RTOL * a.abs().max(f64::MIN_POSITIVE),
        sample_rate_hz: Some(1.0 / dt),
        sample_derivatives: true,
        deadline: deadline.map(|d| (d.at, d.budget_s)),
        ..IntegrateOptions::default()
    };
    // The state (q, q̇) of the joint at the previous sample, and the crossings found.
    let mut prev: Option<(f64, f64, f64)> = None;
    let mut crossings: Vec<f64> = Vec::with_capacity(periods + 1);
    let mut far = 0.0_f64;
    let run = integrate(
        |t, x, dx| drive.rhs(t, x, dx),
        &x0,
        0.0,
        t1,
        &opts,
        |s| {
            if crossings.len() > periods {
                return;
            }
            let (q, qd) = (s.x[coord], s.xdot.map_or(f64::NAN, |d| d[coord]));
            if q.signum() != a.signum() {
                far = far.max(q.abs());
            }
            if let Some((t0, q0, qd0)) = prev
                && q0 < 0.0
                && q >= 0.0
            {
                crossings.push(hermite_root(t0, q0, qd0, s.t, q, qd));
            }
            prev = Some((s.t, q, qd));
        },
    );
    if run.is_err() || crossings.len() <= periods {
        return fail;
    }
    let period = (crossings[periods] - crossings[0]) / periods as f64;
    (2.0 * PI / (period * omega), far)
}

/// The root in (t0, t1) of the cubic Hermite interpolant of values q0 < 0 ≤ q1 with slopes
/// qd0, qd1, by bisection-safeguarded Newton.
fn hermite_root(t0: f64, q0: f64, qd0: f64, t1: f64, q1: f64, qd1: f64) -> f64 {
    let h = t1 - t0;
    let (m0, m1) = (qd0 * h, qd1 * h);
    let p = |s: f64| {
        let (s2, s3) = (s * s, s * s * s);
        (2.0 * s3 - 3.0 * s2 + 1.0) * q0 + (s3 - 2.0 * s2 + s) * m0 + (-2.0 * s3 + 3.0 * s2) * q1 + (s3 - s2) * m1
    };
    let dp = |s: f64| {
        let s2 = s * s;
        (6.0 * s2 - 6.0 * s) * q0
            + (3.0 * s2 - 4.0 * s + 1.0) * m0
            + (-6.0 * s2 + 6.0 * s) * q1
            + (3.0 * s2 - 2.0 * s) * m1
    };
    let (mut lo, mut hi) = (0.0, 1.0);
    let mut s = q0 / (q0 - q1);
    for _ in 0..60 {
        let v = p(s);
        if v < 0.0 {
            lo = s;
        } else {
            hi = s;
        }
        let d = dp(s);
        let next = if d != 0.0 { s - v / d } else { f64::NAN };
        let next = if next > lo && next < hi { next } else { 0.5 * (lo + hi) };
        if (next - s).abs() <= 1e-16 {
            s = next;
            break;
        }
        s = next;
    }
    t0 + s * h
}

#[cfg(test)]
mod tests {
    use super::hermite_root;
    use approx::assert_abs_diff_eq;

    /// The crossing of a cubic is exact when the data are a cubic's: q(t) = (t − 0.3)³ + (t − 0.3).
    #[test]
    fn hermite_root_of_a_cubic_is_exact() {
        let q = |t: f64| (t - 0.3).powi(3) + (t - 0.3);
        let qd = |t: f64| 3.0 * (t - 0.3).powi(2) + 1.0;
        let r = hermite_root(0.1, q(0.1), qd(0.1), 0.5, q(0.5), qd(0.5));
        assert_abs_diff_eq!(r, 0.3, epsilon = 1e-15);
    }
}
