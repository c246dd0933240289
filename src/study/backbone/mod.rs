//! The free-oscillation analysis: the backbone curve of one joint (an absorber), its free
//! oscillation order against amplitude with every damper removed, the spin held or free.
//!
//! Every joint damper and damper to ground is set to zero and the mechanism's own joint torques
//! are removed, so the motion is conservative. Two routes give the order at each release
//! amplitude A (the joint's coordinate at an instant where it is at rest: its unit, rad, or m of
//! arc length for a path joint):
//!
//! - **Continuation** (the result, `orders`): free periodic orbits by harmonic balance with a
//!   phase condition, natural continuation in the amplitude from the linear mode
//!   ([`crate::hbm::Hbm::backbone`], whose module docs give the formulation). The mean rotor
//!   speed is fixed at Ω: the equations are invariant under the time scaling t → ct, so the
//!   order ω/Ω does not depend on the speed chosen.
//! - **Time integration** (the check, `time_orders`): the joint released from rest at A, DOP853
//!   at rtol 1e-12. The period is the mean spacing of the upward zero crossings of the
//!   coordinate over `periods` full periods, each crossing located between two samples by the
//!   cubic Hermite interpolant of (q, q̇) (error O(h⁴) in the sample step, with 128 samples per
//!   linear period); the order is `2π·periods / Δq_s`, Δq_s the spin angle turned between the
//!   first and the last crossing (Hermite-interpolated too): ω over the rotor's mean speed.
//!
//! With the spin **held** the spin joint's rate is prescribed constant (the partitioned
//! equations of `time::drive_laws`: `A_rr q̈_r = G_r − A_rs q̈_s` with q̈_s = 0); every other
//! joint starts at q = 0 relative to its parent. The small-amplitude limit is the linear
//! analysis's held-spin undamped mode with the largest share of the joint's coordinate: the
//! circle's order falls with amplitude as `π / (2 K(sin(φ₀/2)))` (a softening path), a
//! tautochronic path keeps it constant.
//!
//! With the spin **free** no torque acts on the rotor, so the angular momentum about the spin
//! axis is conserved (the time route reports its largest relative drift). The time route
//! releases the rotor at Ω and every other joint at rest where the continuation's orbit has it
//! at its turning point (at zero without an orbit): for one absorber, or identical absorbers in
//! unison, that is the same orbit, so the two routes agree point for point. The small-amplitude
//! limit is the free-spin undamped mode that moves the rotor (the one a rotor torque excites;
//! identical absorbers' non-unison modes leave it at rest) with the largest share of the joint:
//! for the paper's absorber n_r of its eq. (17).

mod analysis;
mod spec;
pub use spec::*;

use super::table::{Table, fmt_num};
use super::{Output, Study};
use crate::error::{Error, Result};
use crate::hbm::{Hbm, HbmOptions};
use crate::kane::Kane;
use crate::linear::{Damping, LinearModel, Spin};
use crate::model::excitation::rpm_to_rad_s;
use crate::model::mechanism::Mechanism;
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

/// Relative share below which a coordinate does not move in a mode (the rotor in a non-unison
/// mode of identical absorbers: zero to rounding).
const STILL: f64 = 1e-9;

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
    /// The spin speed, rpm: held there, or the rotor's mean speed with the spin free.
    pub rpm: f64,
    /// Whether the rotor was held or free.
    pub spin: FreeSpin,
    /// The linear (small-amplitude) order of the joint's mode, undamped, with the spin held or
    /// free.
    pub linear_order: f64,
    /// Harmonics kept by the continuation.
    pub harmonics: usize,
    /// Release amplitudes, in `unit`.
    pub amplitudes: Vec<f64>,
    /// The free-oscillation order at each amplitude by continuation of free periodic orbits
    /// (NaN where the continuation did not reach it).
    pub orders: Vec<f64>,
    /// The same by time integration (NaN where the run failed or the joint did not oscillate
    /// through zero `periods` times, e.g. a pendulum going over the top).
    pub time_orders: Vec<f64>,
    /// |orders − time_orders| at each amplitude: the two routes' disagreement.
    pub route_difference: Vec<f64>,
    /// The largest excursion on the other side of zero in the time run, in `unit` (equal to the
    /// amplitude for a path symmetric in its coordinate): the largest sample, so low by up to
    /// (2π/128)²/2 ≈ 1.2e-3 relative at the linear sample spacing.
    pub far_side: Vec<f64>,
    /// With the spin free, the largest relative change of the angular momentum about the spin
    /// axis over the time run, `max |H(t) − H(0)| / |H(0)|` at the samples (NaN with the spin
    /// held, where the holding torque changes it).
    pub momentum_drift: Vec<f64>,
}

impl FreeOscillationResult {
    /// Each order over the linear order.
    pub fn order_ratios(&self) -> Vec<f64> {
        self.orders.iter().map(|o| o / self.linear_order).collect()
    }
}

/// The CSV table `<name>.csv`: amplitude, order (continuation), order over the linear order,
/// the time route's order and its difference, the far-side amplitude and the momentum drift.
pub(crate) fn table(r: &FreeOscillationResult) -> Table {
    let mut t = Table::new(r.name.clone());
    t.push(format!("amplitude_{}", r.unit), r.unit, r.amplitudes.clone());
    t.push("order", "1", r.orders.clone());
    t.push("order_over_linear", "1", r.order_ratios());
    t.push(format!("far_side_{}", r.unit), r.unit, r.far_side.clone());
    t.push("time_order", "1", r.time_orders.clone());
    t.push("route_difference", "1", r.route_difference.clone());
    if r.spin == FreeSpin::Free {
        t.push("momentum_drift", "1", r.momentum_drift.clone());
    }
    t
}

/// Runs the analysis: the continuation and one free run per amplitude, then the CSV, the figure
/// and the summary.
pub(crate) fn run(study: &Study, spec: &FreeOscillationSpec, dir: &Path) -> Result<Output> {
    let r = compute(study, spec)?;
    let mut failures = Vec::new();
    for ((a, o), t) in r.amplitudes.iter().zip(&r.orders).zip(&r.time_orders) {
        for (v, route) in [(o, "continuation"), (t, "time integration")] {
            if !v.is_finite() {
                failures.push(format!(
                    "{} at amplitude {} {}: no free oscillation by {route} (see the summary)",
                    spec.name,
                    fmt_num(*a),
                    r.unit
                ));
            }
        }
    }
    let mut files = vec![table(&r).write_csv(dir)?];
    let svg = dir.join(format!("{}.svg", spec.name));
    crate::plot::write_svg(&svg, &[panel(&[(r.joint.clone(), &r)])], 760, 520)?;
    files.push(svg);
    Ok(Output { markdown: markdown(&r), files, failures, results: Box::new(r) })
}

/// Words for the spin.
fn spin_words(spin: FreeSpin) -> &'static str {
    match spin {
        FreeSpin::Held => "held spin",
        FreeSpin::Free => "free rotor",
    }
}

/// The figure's panel: order against amplitude for each labelled result (continuation, with the
/// time route's points as markers), with the linear orders as dotted lines.
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
        series.push(Series {
            label: if k == 0 { "time integration".into() } else { String::new() },
            x: r.amplitudes.clone(),
            y: r.time_orders.clone(),
            color: k,
            style: LineStyle::Points,
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
    // A Compare stopped before any member's free oscillation has no speed to name.
    let speed = results.first().map_or_else(|| "no member reached".into(), |r| format!("{} rpm", fmt_num(r.1.rpm)));
    let spin = results.first().map_or(FreeSpin::Held, |r| r.1.spin);
    Panel {
        title: format!("Free oscillation, {} ({}, undamped); dotted: linear order", spin_words(spin), speed),
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
        "## Free oscillation `{}`: joint `{}`, {}, {} rpm, undamped\n",
        r.name,
        r.joint,
        spin_words(r.spin),
        fmt_num(r.rpm)
    );
    let _ = writeln!(
        md,
        "Linear order ({}, undamped): {:.8}. Orders by continuation of free periodic orbits (harmonic \
         balance with a phase condition, H = {}), checked by time integration.\n",
        spin_words(r.spin),
        r.linear_order,
        r.harmonics
    );
    let _ = writeln!(
        md,
        "| amplitude ({}) | order | order / linear | time route | difference | far side ({}) |",
        r.unit, r.unit
    );
    let _ = writeln!(md, "|---|---|---|---|---|---|");
    for (k, a) in r.amplitudes.iter().enumerate() {
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {} | {} |",
            fmt_num(*a),
            super::cell(r.orders[k], 8),
            super::cell(r.order_ratios()[k], 8),
            super::cell(r.time_orders[k], 8),
            if r.route_difference[k].is_finite() { format!("{:.1e}", r.route_difference[k]) } else { "–".into() },
            super::cell(r.far_side[k], 6)
        );
    }
    if r.spin == FreeSpin::Free {
        let drift = r.momentum_drift.iter().copied().filter(|v| v.is_finite()).fold(0.0, f64::max);
        let _ = writeln!(md, "\nAngular momentum conserved in the time runs to {drift:.1e} (relative).");
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

/// The linear mode the backbone starts from: its order and its real shape per coordinate
/// relative to the joint's coordinate (= 1). Held spin: the held mode with the largest share of
/// the joint, the shape the joint alone (the others start at rest, as the time route's do).
/// Free spin: among the free modes that move the rotor, the one with the largest share of the
/// joint.
fn linear_mode(
    mech: &Mechanism,
    spin_joint: &str,
    spin: FreeSpin,
    coord: usize,
    omega: f64,
) -> std::result::Result<(f64, Vec<f64>), String> {
    let lm = LinearModel::new(mech, spin_joint, omega, None).map_err(|e| e.to_string())?;
    let which = if spin == FreeSpin::Free { Spin::Free } else { Spin::Held };
    let modes = lm.modes(which, Damping::Undamped).map_err(|e| e.to_string())?;
    let s = mech.joint_index(spin_joint).and_then(|j| mech.coordinate(j)).ok_or("the spin joint has no coordinate")?;
    let share = |m: &crate::linear::Mode, c: usize| {
        let big = m.shape_q.iter().map(|c| c.norm()).fold(0.0, f64::max);
        m.shape_q.get(c).map_or(0.0, |v| v.norm() / big.max(f64::MIN_POSITIVE))
    };
    let mode = modes
        .modes
        .iter()
        .filter(|m| m.order.is_finite() && m.order > 0.0)
        .filter(|m| spin == FreeSpin::Held || (share(m, s) > STILL && share(m, coord) > STILL))
        .max_by(|a, b| share(a, coord).total_cmp(&share(b, coord)))
        .ok_or_else(|| match spin {
            FreeSpin::Held => "no oscillating mode at held spin".to_string(),
            FreeSpin::Free => "no mode with a free rotor that moves both it and the rotor".to_string(),
        })?;
    let shape = match spin {
        FreeSpin::Held => (0..mech.ndof()).map(|k| if k == coord { 1.0 } else { 0.0 }).collect(),
        FreeSpin::Free => mode.shape_q.iter().map(|v| (v / mode.shape_q[coord]).re).collect(),
    };
    Ok((mode.order, shape))
}

/// The largest release amplitude of a joint of kind `kind`: π for a pivot (the top, where the
/// pendulum stands still), the travel of a path; none for a slide.
pub(crate) fn top(kind: crate::model::joint::JointKind) -> f64 {
    if kind.rotates() { PI } else { kind.travel() }
}

/// The undamped, unforced mechanism of the free oscillation.
fn conservative(mech: &Mechanism) -> Mechanism {
    let mut mech = mech.clone();
    for j in &mut mech.joints {
        j.damper = 0.0;
    }
    mech.loads.ground_dampers.clear();
    mech.loads.joint_torques.clear();
    mech
}

/// The backbone of `spec.joint` (see the module docs).
pub(crate) fn compute(study: &Study, spec: &FreeOscillationSpec) -> Result<FreeOscillationResult> {
    let model_err = |message: String| Error::Model { mechanism: study.mechanism.name.clone(), message };
    let mech = conservative(&study.mechanism);
    let joint = mech.joint_index(&spec.joint).ok_or_else(|| model_err(format!("unknown joint `{}`", spec.joint)))?;
    let coord = mech.coordinate(joint).ok_or_else(|| model_err(format!("joint `{}` has no coordinate", spec.joint)))?;
    let unit = mech.joints[joint].kind.coordinate_unit();
    let omega = rpm_to_rad_s(spec.rpm);
    let (linear_order, shape) = linear_mode(&mech, &study.spec.spin_joint, spec.spin, coord, omega)
        .map_err(|m| model_err(format!("joint `{}`: {m}", spec.joint)))?;
    // Continuation: steps of at most a thirtieth of the way to the top (6° for a pivot), or of
    // a tenth of the coordinate's scale where it has no top (a slide).
    let kind = mech.joints[joint].kind;
    let max_step = if top(kind).is_finite() { top(kind) / 30.0 } else { 0.1 * kind.coordinate_scale() };
    let bopts = crate::hbm::BackboneOptions { max_step, start: max_step / 10.0, ..Default::default() };
    let kane = Kane::new(&mech)?;
    let hopts = HbmOptions { harmonics: spec.harmonics, stability_samples: 0, ..HbmOptions::default() };
    let orbits: Vec<Option<crate::hbm::FreeOrbit>> = match Hbm::new(&kane, study.spin, omega, &[], hopts) {
        Ok(mut hbm) => hbm
            .backbone(spec.spin, coord, linear_order, &shape, &spec.amplitudes, &bopts)
            .into_iter()
            .map(Result::ok)
            .collect(),
        Err(_) => vec![None; spec.amplitudes.len()],
    };
    let orders: Vec<f64> = orbits.iter().map(|o| o.as_ref().map_or(f64::NAN, |o| o.order)).collect();
    let mut time_orders = Vec::with_capacity(spec.amplitudes.len());
    let mut far_side = Vec::with_capacity(spec.amplitudes.len());
    let mut momentum_drift = Vec::with_capacity(spec.amplitudes.len());
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
        // The other joints start where the orbit has them at the release instant (free rotor).
        let start: Vec<f64> = match (&orbits[k], spec.spin) {
            (Some(o), FreeSpin::Free) => o.solution.coordinates_at(0.0).0,
            _ => vec![0.0; mech.ndof()],
        };
        let run = Release { spin: study.spin, spin_mode: spec.spin, coord, omega, linear_order };
        let (o, f, d) = run.one_amplitude(&mech, a, &start, spec.periods, deadline);
        time_orders.push(o);
        far_side.push(f);
        momentum_drift.push(d);
    }
    // The last run may have been the one the watchdog stopped.
    if let Some(e) = watchdog(spec.amplitudes.len() - 1) {
        return Err(e);
    }
    let route_difference = orders.iter().zip(&time_orders).map(|(a, b)| (a - b).abs()).collect();
    Ok(FreeOscillationResult {
        name: spec.name.clone(),
        joint: spec.joint.clone(),
        unit,
        rpm: spec.rpm,
        spin: spec.spin,
        linear_order,
        harmonics: spec.harmonics,
        amplitudes: spec.amplitudes.clone(),
        orders,
        time_orders,
        route_difference,
        far_side,
        momentum_drift,
    })
}

/// One free run's setting: the spin joint and its mode, the joint's coordinate, Ω (rad/s) and
/// the linear order (for the run's length and sampling).
struct Release {
    spin: usize,
    spin_mode: FreeSpin,
    coord: usize,
    omega: f64,
    linear_order: f64,
}

impl Release {
    /// One free run released at `a` (every other coordinate at `start`, at rest relative to its
    /// parent, the rotor at Ω): (order, far-side excursion, momentum drift), the first two NaN
    /// when no oscillation was measured (the run failed, left the path, or crossed zero fewer
    /// than `periods + 1` times).
    fn one_amplitude(
        &self,
        mech: &Mechanism,
        a: f64,
        start: &[f64],
        periods: usize,
        deadline: Option<crate::deadline::Deadline>,
    ) -> (f64, f64, f64) {
        let (spin, coord, omega) = (self.spin, self.coord, self.omega);
        let fail = (f64::NAN, f64::NAN, f64::NAN);
        let Ok(kane) = Kane::new(mech) else { return fail };
        let Ok(mut momentum) = Kane::new(mech) else { return fail };
        let held = Some(Prescribed { joint: spin, accel: 0.0, until_s: 0.0 });
        let prescribed = if self.spin_mode == FreeSpin::Held { held } else { None };
        let Ok(mut drive) = Drive::new(kane, spin, vec![], prescribed) else {
            return fail;
        };
        let Some(s) = mech.coordinate(spin) else { return fail };
        let n = mech.ndof();
        let mut x0 = Study::initial_state(mech, spin, omega);
        for (k, &p) in start.iter().enumerate().take(n) {
            if k != s {
                x0[k] = p;
            }
        }
        x0[coord] = a;
        // Angular momentum about the spin axis: the momentum conjugate to the spin angle,
        // (Wᵀ M u)_s with u = W q̇ (T = ½ uᵀ M u).
        let w = mech.speeds.w_matrix(&mech.speed_parents());
        let mut angular_momentum = |t: f64, x: &[f64]| {
            let (m, _) = momentum.mass_matrix_and_forcing_rows(t, &x[..n], &x[n..]);
            (0..n).map(|r| w[(r, s)] * (0..n).map(|c| m[r * n + c] * x[n + c]).sum::<f64>()).sum::<f64>()
        };
        let free = self.spin_mode == FreeSpin::Free;
        let h0 = if free { angular_momentum(0.0, &x0) } else { f64::NAN };
        let mut drift = 0.0f64;
        let f_lin = self.linear_order * omega / (2.0 * PI);
        let t1 = (periods as f64 + 2.0) / (SLOWEST * f_lin);
        let dt = 1.0 / (SAMPLES_PER_PERIOD * f_lin);
        let opts = IntegrateOptions {
            rtol: RTOL,
            atol: RTOL * a.abs().max(f64::MIN_POSITIVE),
            sample_rate_hz: Some(1.0 / dt),
            sample_derivatives: true,
            deadline,
            ..IntegrateOptions::default()
        };
        // The joint's and the spin's (t, q, q̇) at the previous sample, and the crossings found:
        // (time, spin angle).
        let mut prev: Option<(f64, f64, f64, f64, f64)> = None;
        let mut crossings: Vec<(f64, f64)> = Vec::with_capacity(periods + 1);
        let mut far = 0.0_f64;
        let run = integrate(
            |t, x, dx| drive.rhs(t, x, dx),
            &x0,
            0.0,
            t1,
            &opts,
            |smp| {
                if crossings.len() > periods {
                    return;
                }
                if free {
                    drift = drift.max((angular_momentum(smp.t, smp.x) - h0).abs() / h0.abs());
                }
                let d = |k: usize| smp.xdot.map_or(f64::NAN, |d| d[k]);
                let (q, qd, qs, qsd) = (smp.x[coord], d(coord), smp.x[s], d(s));
                if q.signum() != a.signum() {
                    far = far.max(q.abs());
                }
                if let Some((t0, q0, qd0, qs0, qsd0)) = prev
                    && q0 < 0.0
                    && q >= 0.0
                {
                    let tc = hermite_root(t0, q0, qd0, smp.t, q, qd);
                    crossings.push((tc, hermite(t0, qs0, qsd0, smp.t, qs, qsd, tc)));
                }
                prev = Some((smp.t, q, qd, qs, qsd));
            },
        );
        if run.is_err() || crossings.len() <= periods {
            return fail;
        }
        let turned = crossings[periods].1 - crossings[0].1;
        (2.0 * PI * periods as f64 / turned, far, if free { drift } else { f64::NAN })
    }
}

/// The cubic Hermite interpolant of (q0, qd0) at t0 and (q1, qd1) at t1, at t.
fn hermite(t0: f64, q0: f64, qd0: f64, t1: f64, q1: f64, qd1: f64, t: f64) -> f64 {
    let h = t1 - t0;
    let s = (t - t0) / h;
    let (s2, s3) = (s * s, s * s * s);
    (2.0 * s3 - 3.0 * s2 + 1.0) * q0 + (s3 - 2.0 * s2 + s) * h * qd0 + (-2.0 * s3 + 3.0 * s2) * q1 + (s3 - s2) * h * qd1
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
