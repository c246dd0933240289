//! The analysis's figures: per amplitude, the branches (solid where stable, dashed where not,
//! with their folds and bifurcations named) over the overlaid order sweeps and their jumps (the
//! paper's Figs. 3 and 4), the elements along each branch, and the branches under a free
//! oscillation's backbone.

use super::{HbmBranch, HbmParameter, HbmSpec, axis, cases, jump_lag, jump_orders};
use crate::error::Result;
use crate::plot::{LineStyle, Panel, PointLabel, Series, num};
use crate::signal::OrderTrace;
use crate::study::sweep::{SweepRun, order_name};
use crate::study::{Direction, Study};
use std::path::{Path, PathBuf};

/// Whether two amplitudes are the same case (NaN, a torque or engine branch's, equals NaN).
fn same(a: f64, b: f64) -> bool {
    a == b || (a.is_nan() && b.is_nan())
}

/// `<name>.svg`: per amplitude, the branches over the overlaid sweeps ([`response_panel`]).
pub(super) fn response_figure(
    study: &Study,
    spec: &HbmSpec,
    branches: &[HbmBranch],
    overlay: &[&SweepRun],
    dir: &Path,
) -> Result<PathBuf> {
    let panels: Vec<Panel> =
        cases(spec).into_iter().map(|amp| response_panel(study, spec, branches, overlay, amp)).collect();
    let svg = dir.join(format!("{}.svg", spec.name));
    crate::plot::write_svg(&svg, &panels, 640, 460)?;
    Ok(svg)
}

/// The panel of amplitude `amp`: the overlaid sweeps dotted, each branch's drawn curve per
/// reported multiple ([`push_segments`]) with its folds and bifurcations named, where the
/// sweeps jump, and the folds marked on the axis.
fn response_panel(study: &Study, spec: &HbmSpec, branches: &[HbmBranch], overlay: &[&SweepRun], amp: f64) -> Panel {
    let ax = axis(spec);
    let mut series = sweep_series(overlay, amp);
    let mut labelled = [false; 2];
    let mut labels: Vec<PointLabel> = Vec::new();
    for br in branches.iter().filter(|b| same(b.amplitude, amp)) {
        for k in 0..spec.multiples.len() {
            push_segments(&mut series, br, k, k == 0, &mut labelled);
        }
        // Each fold and bifurcation marked on the main-order curve where it happens and named
        // with its parameter value to five digits (as the README quotes the folds); the
        // branches from both ends of the range find the same ones, named once.
        let points = br.folds.iter().map(|&f| (f, "fold".to_string())).chain(br.bifurcations.iter().cloned());
        for (at, kind) in points {
            let y = value_at_turn(br, at);
            let seen = labels.iter().any(|l| (l.x - at).abs() < 1e-3 * ax.range.1.abs().max(1.0));
            if y.is_finite() && y > 0.0 && !seen {
                labels.push(PointLabel { x: at, y, text: format!("{kind} {}", num(at, 5)), marker: true });
            }
        }
    }
    labels.extend(sweep_jumps(study, overlay, amp));
    let mut markers: Vec<(f64, String)> = branches
        .iter()
        .filter(|b| same(b.amplitude, amp))
        .flat_map(|b| b.folds.iter().map(|&f| (f, String::new())))
        .collect();
    markers.sort_by(|a, b| a.0.total_cmp(&b.0));
    markers.dedup_by(|a, b| (a.0 - b.0).abs() < 1e-3);
    let title = match spec.parameter {
        HbmParameter::Order => format!("Harmonic balance, {}, {} rpm", forcing_text(spec, amp), spec.rpm),
        HbmParameter::Speed { order, .. } => match &spec.engine {
            Some(e) => format!("Harmonic balance, engine {e}, n = {order}"),
            None => format!("Harmonic balance, {}, n = {order}", forcing_text(spec, amp)),
        },
        HbmParameter::Torque { order, .. } => format!("Harmonic balance, n = {order}, {} rpm", spec.rpm),
    };
    Panel {
        title,
        x_label: ax.label.into(),
        y_label: format!("{} angular acceleration, rad/s²", study.spec.response_body),
        log_y: true,
        x_range: Some(ax.range),
        markers,
        series,
        labels,
        ..Panel::default()
    }
}

/// The overlaid sweeps of amplitude `amp`, dotted: every tracked multiple, up and down.
fn sweep_series(overlay: &[&SweepRun], amp: f64) -> Vec<Series> {
    let mut series = Vec::new();
    for r in overlay.iter().filter(|r| r.amplitude == amp) {
        for (k, t) in r.traces.iter().enumerate() {
            let dir = if r.direction == Direction::Up { "up" } else { "down" };
            series.push(Series {
                label: format!("sweep {dir}, {}", order_name(t.multiple)),
                x: t.order.clone(),
                y: t.amplitude.clone(),
                color: 2 + 2 * k + usize::from(r.direction == Direction::Down),
                style: LineStyle::Dotted,
            });
        }
    }
    series
}

/// Where the overlaid up and down sweeps of amplitude `amp` jump (the summary's "sweep jumps"),
/// labelled on their main-order traces.
fn sweep_jumps(study: &Study, overlay: &[&SweepRun], amp: f64) -> Vec<PointLabel> {
    let mut labels = Vec::new();
    let Some((up, down)) = jump_orders(overlay, amp, jump_lag(study)) else { return labels };
    for (dir, at) in [(Direction::Up, up), (Direction::Down, down)] {
        let trace = overlay.iter().find(|r| r.amplitude == amp && r.direction == dir).and_then(|r| r.trace(1.0));
        if let (Some(at), Some(trace)) = (at, trace) {
            let y = trace_value(trace, at);
            if y.is_finite() && y > 0.0 {
                let name = if dir == Direction::Up { "up-sweep" } else { "down-sweep" };
                labels.push(PointLabel { x: at, y, text: format!("{name} jumps at {}", num(at, 4)), marker: true });
            }
        }
    }
    labels
}

/// The forcing of case `amp` in words: `T_n = … N·m`, or where the case has no one amplitude
/// (NaN: continued in torque, or an engine's orders) what stands for it, never a NaN.
fn forcing_text(spec: &HbmSpec, amp: f64) -> String {
    if amp.is_finite() {
        return format!("T_n = {amp} N·m");
    }
    match (&spec.engine, spec.parameter) {
        (Some(e), _) => format!("engine {e}"),
        (None, HbmParameter::Torque { order, .. }) => format!("T_n continued at n = {order}"),
        (None, _) => "T_n not given".into(),
    }
}

/// `<name>_elements.svg`: the elements along each branch, their main-order amplitude (first
/// reported multiple), one panel per amplitude, the branch from each end solid and dashed.
pub(super) fn elements_figure(spec: &HbmSpec, branches: &[HbmBranch], dir: &Path) -> Result<PathBuf> {
    let ax = axis(spec);
    let panels: Vec<Panel> = cases(spec)
        .into_iter()
        .map(|amp| {
            let mut series = Vec::new();
            for (b, br) in branches.iter().filter(|b| same(b.amplitude, amp)).enumerate() {
                let names: Vec<&str> =
                    br.elements.first().map(|p| p.iter().map(|e| e.joint.as_str()).collect()).unwrap_or_default();
                for (e, name) in names.iter().enumerate() {
                    let y = br
                        .elements
                        .iter()
                        .map(|p| p.get(e).and_then(|el| el.amplitude.first().copied()).unwrap_or(f64::NAN))
                        .collect();
                    series.push(Series {
                        label: if b == 0 { (*name).to_string() } else { String::new() },
                        x: br.parameter.clone(),
                        y,
                        color: e,
                        style: if b == 0 { LineStyle::Solid } else { LineStyle::Dashed },
                    });
                }
            }
            Panel {
                title: format!("Elements at the {}, {}", order_name(spec.multiples[0]), forcing_text(spec, amp)),
                x_label: ax.label.into(),
                y_label: "amplitude, rad (m for slides)".into(),
                log_y: true,
                x_range: Some(ax.range),
                series,
                ..Panel::default()
            }
        })
        .collect();
    let svg = dir.join(format!("{}_elements.svg", spec.name));
    crate::plot::write_svg(&svg, &panels, 640, 460)?;
    Ok(svg)
}

/// `<name>_backbone.svg`: per amplitude, each branch's largest peak relative angle of the
/// non-spin joints (the absorber's amplitude, rad) against the order, the branch from each end
/// of the range solid and dashed, with the backbone `bb` (its order against release amplitude,
/// the peak angle of the free orbit, from the linear order at zero) over them: the forced
/// response leans along it.
pub(super) fn backbone_figure(
    spec: &HbmSpec,
    branches: &[HbmBranch],
    bb: &crate::study::backbone::FreeOscillationResult,
    dir: &Path,
) -> Result<PathBuf> {
    let same = |a: f64, b: f64| a == b || (a.is_nan() && b.is_nan());
    let spin = match bb.spin {
        crate::hbm::FreeSpin::Held => "held spin",
        crate::hbm::FreeSpin::Free => "free rotor",
    };
    let panels: Vec<Panel> = cases(spec)
        .into_iter()
        .map(|amp| {
            let mut series = Vec::new();
            for (b, br) in branches.iter().filter(|b| same(b.amplitude, amp)).enumerate() {
                series.push(Series {
                    label: if b == 0 { format!("forced, {}", forcing_text(spec, amp)) } else { String::new() },
                    x: br.parameter.clone(),
                    y: br.relative_angle.clone(),
                    color: 0,
                    style: if b == 0 { LineStyle::Solid } else { LineStyle::Dashed },
                });
            }
            // The backbone leaves the axis at the linear order.
            series.push(Series {
                label: format!("backbone `{}` ({spin}, {})", bb.name, bb.joint),
                x: std::iter::once(bb.linear_order).chain(bb.orders.iter().copied()).collect(),
                y: std::iter::once(0.0).chain(bb.amplitudes.iter().copied()).collect(),
                color: 1,
                style: LineStyle::Dashed,
            });
            series.push(Series {
                label: String::new(),
                x: bb.orders.clone(),
                y: bb.amplitudes.clone(),
                color: 1,
                style: LineStyle::Points,
            });
            Panel {
                title: format!("Forced branches and the backbone, {}, {} rpm", forcing_text(spec, amp), spec.rpm),
                x_label: "excitation order n".into(),
                y_label: format!("largest peak joint angle, {}", bb.unit),
                x_range: Some((spec.order_min, spec.order_max)),
                series,
                ..Panel::default()
            }
        })
        .collect();
    let svg = dir.join(format!("{}_backbone.svg", spec.name));
    crate::plot::write_svg(&svg, &panels, 640, 460)?;
    Ok(svg)
}

/// Splits a branch's drawn curve into runs of equal stability, solid when stable, dashed when
/// not; only the first stable and first unstable segment of the main order get a legend entry.
fn push_segments(series: &mut Vec<Series>, br: &HbmBranch, k: usize, legend: bool, labelled: &mut [bool; 2]) {
    let len = br.curve_parameter.len();
    let mut i = 0;
    while i < len {
        let s = br.curve_stable[i] != Some(false);
        let mut j = i;
        while j + 1 < len && (br.curve_stable[j + 1] != Some(false)) == s {
            j += 1;
        }
        // Overlap one point so the segments join.
        let end = (j + 1).min(len - 1);
        let idx = usize::from(!s);
        series.push(Series {
            label: if let (Some(at), true, 0) = (br.switched_at, legend, i) {
                format!("{}, switched at {at:.5}", if br.period_doubled { "period-doubled" } else { "non-unison" })
            } else if labelled[idx] || !legend || br.switched_at.is_some() {
                String::new()
            } else {
                format!("HBM, {}", if s { "stable" } else { "unstable" })
            },
            x: br.curve_parameter[i..=end].to_vec(),
            y: br.curve_accel[k][i..=end].to_vec(),
            color: if br.switched_at.is_some() { k + 3 } else { k },
            // A switched (non-unison) branch: dotted where unstable, in its own colour.
            style: match (s, br.switched_at.is_some()) {
                (true, _) => LineStyle::Solid,
                (false, false) => LineStyle::Dashed,
                (false, true) => LineStyle::Dotted,
            },
        });
        // A switched branch has its own legend entry: the unison branches' stays to be drawn.
        if legend && br.switched_at.is_none() {
            labelled[idx] = true;
        }
        i = j + 1;
    }
}

/// The main-order amplitude on branch `br`'s drawn curve at its turning point nearest the
/// parameter value `at` (a fold turns the continuation back; a bifurcation elsewhere falls back
/// to the nearest point), NaN on an empty branch.
fn value_at_turn(br: &HbmBranch, at: f64) -> f64 {
    let (p, Some(y)) = (&br.curve_parameter, br.curve_accel.first()) else { return f64::NAN };
    let distance = |i: &usize| (p[*i] - at).abs();
    let turn = (1..p.len().saturating_sub(1))
        .filter(|&i| (p[i] - p[i - 1]) * (p[i + 1] - p[i]) <= 0.0)
        .filter(|i| distance(i) < 1e-2 * at.abs().max(1e-9))
        .min_by(|a, b| distance(a).total_cmp(&distance(b)));
    turn.or_else(|| (0..p.len()).min_by(|a, b| distance(a).total_cmp(&distance(b)))).map_or(f64::NAN, |i| y[i])
}

/// A sweep trace's amplitude at the order `at`: its sample nearest that order.
fn trace_value(t: &OrderTrace, at: f64) -> f64 {
    let before = t.order.iter().zip(&t.amplitude).filter(|(o, a)| o.is_finite() && a.is_finite());
    before.min_by(|a, b| (a.0 - at).abs().total_cmp(&(b.0 - at).abs())).map_or(f64::NAN, |(_, a)| *a)
}
