//! The Campbell analysis of a study: natural frequencies over a speed range tracked by mode
//! shape, the engine-order lines and the resonance table of their crossings (`linear::campbell`),
//! written as CSV, SVG and a summary section.

mod analysis;
mod spec;
pub use spec::*;

use super::linear::lin;
use super::table::Table;
use super::table::fmt_num;
use super::{Output, Study};
use crate::error::Result;
use crate::linear::{Campbell, CampbellOptions, Damping, Spin, campbell_with};
use crate::plot::{LineStyle, Panel, PointLabel, Series};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The Campbell CSV tables: the speeds with, per tracked mode, its frequency and damping ratio,
/// then the order lines; and the resonance table `<name>_crossings` (order, mode number, rpm, Hz).
pub(crate) fn campbell_tables(spec: &CampbellSpec, c: &Campbell) -> Vec<Table> {
    let mut t = Table::new(spec.name.clone());
    t.push("rpm", "rpm", c.rpm.clone());
    for (k, tr) in c.tracks.iter().enumerate() {
        t.push(format!("mode{}_{}_hz", k + 1, tr.label), "Hz", tr.frequency_hz.clone());
        t.push(format!("mode{}_{}_damping_ratio", k + 1, tr.label), "1", tr.damping_ratio.clone());
    }
    for l in &c.order_lines {
        t.push(format!("order_{}_hz", l.order), "Hz", l.frequency_hz.clone());
    }
    // Each tracked mode's place in frequency order at each speed (1 = lowest): read the table
    // sorted by frequency speed by speed through these.
    for (k, tr) in c.tracks.iter().enumerate() {
        t.push(format!("mode{}_{}_rank", k + 1, tr.label), "1", tr.rank.iter().map(|&r| r as f64).collect());
    }
    let mut x = Table::new(format!("{}_crossings", spec.name));
    let col = |f: &dyn Fn(&crate::linear::Crossing) -> f64| c.crossings.iter().map(f).collect::<Vec<f64>>();
    x.push("order", "1", col(&|x| x.order));
    x.push("mode", "1", col(&|x| (x.track + 1) as f64));
    x.push("rpm", "rpm", col(&|x| x.rpm));
    x.push("frequency_hz", "Hz", col(&|x| x.frequency_hz));
    x.push("rank", "1", col(&|x| x.rank as f64));
    vec![t, x]
}

/// Runs the Campbell analysis ([`compute_campbell`]) and writes its outputs
/// ([`render_campbell`]).
pub(crate) fn run_campbell(study: &Study, spec: &CampbellSpec, dir: &Path) -> Result<Output> {
    let (c, failures) = compute_campbell(study, spec)?;
    let (mut markdown, files) = render_campbell(spec, &c, dir)?;
    let g = study.mechanism.loads.gravity;
    if study.mechanism.loads.needs_world_orientation() {
        // After the heading: what gravity does to these modes.
        let note = format!(
            "The mechanism has gravity ({}, {}) m/s² (or a world-frame force): at the nominal rotation it is an \
             order-1 forcing, not a change of the linear system, so these modes about the steady rotation are \
             those without it; its parametric effect (gravity × deflection) is second order and neglected. Its \
             forced response is in LinearResponse and MultiOrder.\n\n",
            g.x, g.y
        );
        let at = markdown.find("\n\n").map_or(markdown.len(), |i| i + 2);
        markdown.insert_str(at, &note);
    }
    Ok(Output { markdown, files, failures, results: Box::new(c) })
}

/// The natural frequencies over the speed range, tracked by mode shape, with the order lines.
pub(crate) fn compute_campbell(study: &Study, spec: &CampbellSpec) -> Result<(Campbell, Vec<String>)> {
    let mech = &study.mechanism;
    let steps = spec.points.max(2);
    let rpm: Vec<f64> =
        (0..steps).map(|i| spec.rpm_min + (spec.rpm_max - spec.rpm_min) * i as f64 / (steps - 1) as f64).collect();
    let spin = if spec.spin_held { Spin::Held } else { Spin::Free };
    let damping = if spec.damped { Damping::Damped } else { Damping::Undamped };
    let modal = spec.modal();
    let opts = CampbellOptions { spin, damping, modal, guess: None, deadline: study.spec.integration.deadline };
    // In a named shaft's speed: computed at the spin speeds rpm/r with the spin orders n·r (the
    // same frequencies), then read back in the shaft's speed and orders.
    let r = spec.speed_ratio(mech, study.spin).unwrap_or(1.0);
    let spin_rpm: Vec<f64> = rpm.iter().map(|v| v / r).collect();
    let spin_orders: Vec<f64> = spec.orders.iter().map(|n| n * r).collect();
    let mut c = campbell_with(mech, &study.spec.spin_joint, &spin_rpm, &spin_orders, &opts).map_err(lin(mech))?;
    if r != 1.0 {
        c.rpm.clone_from(&rpm);
        for (line, &n) in c.order_lines.iter_mut().zip(&spec.orders) {
            line.order = n;
        }
        for x in &mut c.crossings {
            x.rpm *= r;
            // The shaft's own order as written (n·r / r may not round back to n).
            let k = spin_orders.iter().position(|&o| o == x.order);
            x.order = k.map_or(x.order / r, |k| spec.orders[k]);
        }
    }
    let mut failures = Vec::new();
    for (k, t) in c.tracks.iter().enumerate() {
        if let Some(i) = t.frequency_hz.iter().position(|f| !f.is_finite()) {
            failures.push(format!(
                "{} mode {} (`{}`): the frequency is not finite at {} rpm (left empty)",
                spec.name,
                k + 1,
                t.label,
                c.rpm[i]
            ));
        }
    }
    Ok((c, failures))
}

/// A crossing's speed as marked on the figure: whole rpm, which is finer than the figure can
/// show and as fine as a speed is read off a dial (the resonance table gives three decimals).
pub(crate) fn rpm_label(rpm: f64) -> String {
    format!("{rpm:.0} rpm")
}

/// Writes the Campbell CSV and figure, and returns the summary section with the files written.
pub(crate) fn render_campbell(spec: &CampbellSpec, c: &Campbell, dir: &Path) -> Result<(String, Vec<PathBuf>)> {
    let steps = c.rpm.len();
    let written: Vec<PathBuf> = campbell_tables(spec, c).iter().map(|t| t.write_csv(dir)).collect::<Result<_>>()?;
    let mut series: Vec<Series> = c
        .tracks
        .iter()
        .enumerate()
        .map(|(k, t)| Series {
            label: format!("mode {} ({})", k + 1, t.label),
            x: c.rpm.clone(),
            y: t.frequency_hz.clone(),
            color: k,
            style: LineStyle::Solid,
        })
        .collect();
    // The order lines are named at their ends ("3n", as in the tables), not in the legend, which
    // keeps to the modes; every crossing is marked with its speed.
    let mut labels = Vec::new();
    for l in &c.order_lines {
        series.push(Series {
            label: String::new(),
            x: c.rpm.clone(),
            y: l.frequency_hz.clone(),
            color: 7,
            style: LineStyle::Dotted,
        });
    }
    let top = series.iter().flat_map(|s| s.y.iter().copied()).filter(|v| v.is_finite()).fold(0.0, f64::max);
    for l in &c.order_lines {
        if let Some((&r, &f)) = c.rpm.iter().zip(&l.frequency_hz).rev().find(|(_, f)| f.is_finite()) {
            labels.push(PointLabel { x: r, y: f, text: format!("{}n", fmt_num(l.order)), marker: false });
        }
    }
    for x in &c.crossings {
        labels.push(PointLabel { x: x.rpm, y: x.frequency_hz, text: rpm_label(x.rpm), marker: true });
    }
    let panel = Panel {
        title: format!("Campbell diagram ({})", if spec.spin_held { "spin held" } else { "spin free" }),
        x_label: spec.speed_of.as_ref().map_or("spin speed, rpm".into(), |j| format!("speed of `{j}`, rpm")),
        y_label: "frequency, Hz".into(),
        x_range: Some((spec.rpm_min, spec.rpm_max)),
        y_range: Some((0.0, 1.05 * top.max(f64::MIN_POSITIVE))),
        series,
        labels,
        ..Panel::default()
    };
    let svg = dir.join(format!("{}.svg", spec.name));
    crate::plot::write_svg(&svg, &[panel], 760, 520)?;

    let mut md = String::new();
    let _ = writeln!(
        md,
        "## Campbell diagram `{}`: {}–{} rpm{}, spin {}\n",
        spec.name,
        spec.rpm_min,
        spec.rpm_max,
        spec.speed_of.as_ref().map_or(String::new(), |j| format!(" of `{j}` (speeds and orders are its own)")),
        if spec.spin_held { "held" } else { "free" }
    );
    if let Some((z, how)) = spec.modal() {
        let _ = writeln!(md, "Modal damping: {} ({}; damped frequencies).\n", z.describe(), how.describe());
    }
    let _ = writeln!(
        md,
        "| mode | label | f at {} rpm (Hz) | f at {} rpm (Hz) | order there | order line? |",
        spec.rpm_min, spec.rpm_max
    );
    let _ = writeln!(md, "|---|---|---|---|---|---|");
    for (k, t) in c.tracks.iter().enumerate() {
        let (f0, f1) = (t.frequency_hz[0], t.frequency_hz[steps - 1]);
        let order = |f: f64, r: f64| if r > 0.0 { f / (r / 60.0) } else { f64::NAN };
        // A mode is an order line when its order is the same at every non-zero speed (1e-6).
        let orders: Vec<f64> =
            c.rpm.iter().zip(&t.frequency_hz).filter(|(r, _)| **r > 0.0).map(|(&r, &f)| order(f, r)).collect();
        let straight = orders.iter().all(|o| (o - orders[0]).abs() <= 1e-6 * orders[0].abs());
        let _ = writeln!(
            md,
            "| {} | {} | {:.4} | {:.4} | {:.6} | {} |",
            k + 1,
            t.label,
            f0,
            f1,
            order(f1, spec.rpm_max),
            if straight { "yes" } else { "no" }
        );
    }
    md.push('\n');
    // The resonance table: where each order line crosses each mode.
    if c.crossings.is_empty() {
        let _ = writeln!(md, "No order line crosses a mode between {} and {} rpm.\n", spec.rpm_min, spec.rpm_max);
    } else {
        let _ = writeln!(md, "Resonance speeds (order lines crossing modes, located to 1e-9 in speed):\n");
        let _ = writeln!(
            md,
            "| speed (rpm) | order | mode | label | frequency (Hz) | rank there |\n|---|---|---|---|---|---|"
        );
        for x in &c.crossings {
            let _ = writeln!(
                md,
                "| {:.3} | {} | {} | {} | {:.4} | {} |",
                x.rpm,
                x.order,
                x.track + 1,
                x.label,
                x.frequency_hz,
                x.rank
            );
        }
        md.push('\n');
    }
    let mut files = written;
    files.insert(1, svg);
    Ok((md, files))
}
