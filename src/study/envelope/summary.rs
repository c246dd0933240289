//! The map's summary section: what was mapped and how, the boundaries with their ranges and
//! ends, the sections, the codimension-two points and what the regions mean.

use super::{BoundaryKind, EnvelopeResult, TORQUE_COLUMN};
use crate::plot::num;
use std::fmt::Write as _;

/// Its summary section: what was mapped ([`intro`]), the boundaries ([`boundary_table`]), the
/// sections, the codimension-two points ([`point_table`]) and the regions' meaning.
pub(super) fn markdown(r: &EnvelopeResult) -> String {
    let mut md = format!("## Operating envelope `{}`\n\n", r.name);
    md += &intro(r);
    let _ = writeln!(md, "Period doublings: {}.\n", r.period_doubling_search);
    if r.boundaries.is_empty() {
        md += "No boundary crosses the map: one steady state everywhere (no jump, no loss of unison, no period \
               doubling on the seed branches).\n\n";
        return md;
    }
    md += &boundary_table(r);
    let sections: Vec<String> = r
        .boundaries
        .iter()
        .enumerate()
        .flat_map(|(i, b)| {
            b.sections.iter().map(move |sec| {
                let at: Vec<String> = sec.second_values.iter().map(|&v| r.second_words(v, 9)).collect();
                format!(
                    "boundary {} at {}: {}",
                    i + 1,
                    r.value_words(sec.value, 9),
                    if at.is_empty() { "none".into() } else { at.join(", ") }
                )
            })
        })
        .collect();
    if !sections.is_empty() {
        let _ = writeln!(md, "Sections (solved exactly there): {}.\n", sections.join("; "));
    }
    md += &point_table(r);
    md += "Regions: one steady state outside the jump boundaries; inside one, three steady states coexist and the \
           response jumps at its edges";
    if r.boundaries.iter().any(|b| b.kind == BoundaryKind::UnisonLoss) {
        md += "; inside a unison-loss boundary the identical absorbers' unison motion is unstable (a non-unison \
               motion takes over)";
    }
    if r.boundaries.iter().any(|b| b.kind == BoundaryKind::PeriodDoubling) {
        md += "; inside a period-doubling boundary the response is unstable against a motion of twice its period \
               (a swing at half the order takes over: see `switch: true` on a harmonic balance)";
    }
    md += ".\n\n";
    md
}

/// What was mapped, over what ranges, by which route, from which seeds, in how long, and what
/// the CSV's kinds mean.
fn intro(r: &EnvelopeResult) -> String {
    let mut md = String::new();
    let _ = writeln!(
        md,
        "{}{} over {} {}–{}{} and {} {}–{}, route {}: {} from {} seed branches ({}) in {} s. \
         Each boundary is a curve of folds, of +1 branch points or of period doublings (−1) followed in the \
         plane by two-parameter continuation; figure `{}.svg`, points in `{}.csv` (kind 1: jump boundary, \
         2: unison-loss boundary, 3: period-doubling boundary, 10: cusp, 11: jump onset, 12: unison-loss \
         onset, 13: period-doubling onset, 14: unison loss meets jump).\n",
        if r.speed_is_second() {
            format!("At {}", r.fixed)
        } else if r.parameter == "order" {
            format!("At {} rpm", num(r.held, 6))
        } else {
            format!("At order {}", num(r.held, 6))
        },
        if r.fixed.is_empty() || r.speed_is_second() { String::new() } else { format!(" and {}", r.fixed) },
        match r.parameter.as_str() {
            "order" => "orders",
            TORQUE_COLUMN => "torques",
            _ => "speeds",
        },
        num(r.range[0], 6),
        num(r.range[1], 6),
        r.first_unit(),
        r.second_label,
        num(r.second_range[0], 6),
        num(r.second_range[1], 6),
        r.route,
        crate::study::digest::count(r.boundaries.len(), "boundary", "boundaries"),
        r.seeds.len(),
        r.seeds.iter().map(|t| r.second_words(*t, 4)).collect::<Vec<_>>().join(", "),
        num(r.time_s, 2),
        r.name,
        r.name
    );
    md
}

/// One row per boundary: its kind, points, range of the second parameter, crossings of the
/// second parameter's top and why its ends stopped.
fn boundary_table(r: &EnvelopeResult) -> String {
    let mut md = String::new();
    let _ = writeln!(
        md,
        "| boundary | kind | points | range of the {} | {} at its largest | ends |\n|---|---|---|---|---|---|",
        r.second_label,
        match r.parameter.as_str() {
            "order" => "orders",
            TORQUE_COLUMN => "torques (N·m)",
            _ => "speeds (rpm)",
        }
    );
    for (i, b) in r.boundaries.iter().enumerate() {
        let extra = || r.points.iter().filter(|p| p.boundary == i).map(|p| p.second_value);
        let lo = b.second_values.iter().copied().chain(extra()).fold(f64::INFINITY, f64::min).max(r.second_range[0]);
        let hi =
            b.second_values.iter().copied().chain(extra()).fold(f64::NEG_INFINITY, f64::max).min(r.second_range[1]);
        let kind = match &b.set {
            Some(set) if b.kind == BoundaryKind::PeriodDoubling => format!("{}, out of unison ({set})", b.kind.words()),
            Some(set) => format!("{} ({set})", b.kind.words()),
            None => b.kind.words().to_string(),
        };
        let top: Vec<String> = b.at_second_max.iter().map(|n| num(*n, 8)).collect();
        let _ = writeln!(
            md,
            "| {} | {kind} | {} | {}–{} | {} | {}; {} |",
            i + 1,
            b.values.len(),
            num(lo, 5),
            num(hi, 5),
            if top.is_empty() { "none".into() } else { top.join(", ") },
            b.ends[0],
            b.ends[1]
        );
    }
    md.push('\n');
    md
}

/// The codimension-two points with what each means (empty without one).
fn point_table(r: &EnvelopeResult) -> String {
    let mut md = String::new();
    if r.points.is_empty() {
        return md;
    }
    let _ = writeln!(
        md,
        "Codimension-two points:\n\n| point | boundary | {} | {} | meaning |\n|---|---|---|---|---|",
        match r.parameter.as_str() {
            "order" => "order",
            TORQUE_COLUMN => "torque (N·m)",
            _ => "speed (rpm)",
        },
        r.second_label
    );
    for p in &r.points {
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {} |",
            p.kind.words(),
            p.boundary + 1,
            num(p.value, 8),
            num(p.second_value, 7),
            p.kind.meaning()
        );
    }
    md.push('\n');
    md
}
