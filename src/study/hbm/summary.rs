//! The analysis's summary section: the branches' table (points, route, stability, folds and
//! bifurcations, the overlaid sweeps' jumps, the cost), a note per switched branch, per branch
//! that stopped short and per branch whose couplings have not converged in H, and the states at
//! the requested values.

use super::{HbmBranch, HbmOptions, HbmOrbit, HbmParameter, HbmSpec, axis, findings};
use crate::study::Study;
use crate::study::sweep::SweepRun;
use std::fmt::Write as _;

/// The summary section of `branches` over the sweeps `overlay`.
pub(super) fn summary(study: &Study, spec: &HbmSpec, branches: &[HbmBranch], overlay: &[&SweepRun]) -> String {
    let ax = axis(spec);
    let mut md = branch_table(study, spec, branches, overlay);
    md += &branch_notes(spec, branches);
    md += &orbit_table(spec, branches, ax.column);
    md
}

/// The heading and the table of branches, one row each.
fn branch_table(study: &Study, spec: &HbmSpec, branches: &[HbmBranch], overlay: &[&SweepRun]) -> String {
    let ax = axis(spec);
    let refs: Vec<&HbmBranch> = branches.iter().collect();
    let mut md = String::new();
    let head = match spec.parameter {
        HbmParameter::Order => {
            format!("{} rpm, n from {} down to {} and back", spec.rpm, spec.order_max, spec.order_min)
        }
        HbmParameter::Speed { order, rpm_min, rpm_max } => {
            format!("n = {order}, speed from {rpm_max} down to {rpm_min} rpm and back")
        }
        HbmParameter::Torque { order, min, max } => {
            format!("n = {order}, {} rpm, T_n from {max} down to {min} N·m and back", spec.rpm)
        }
    };
    let _ = writeln!(md, "## Harmonic balance `{}`: {head}, H = {}\n", spec.name, spec.harmonics);
    let _ = writeln!(
        md,
        "| T_n (N·m) | continued from ({}) | points | route | stable / unstable | folds | other bifurcations | sweep jumps (up, down) | continuation time (ms) | per point (ms) | end |",
        ax.column
    );
    let _ = writeln!(md, "|---|---|---|---|---|---|---|---|---|---|---|");
    for (br, f) in branches.iter().zip(findings(study, &refs, overlay)) {
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {} / {} | {} | {} | {} | {:.1} | {:.3} | {} |",
            match (&spec.engine, br.amplitude.is_nan()) {
                (Some(_), _) => "engine".to_string(),
                (None, true) => "continued".to_string(),
                (None, false) => br.amplitude.to_string(),
            },
            // A switched branch starts at a located crossing: the list's precision, and what
            // it was.
            match br.switched_at {
                Some(at) if br.period_doubled => format!("{at:.5} (period doubling)"),
                Some(at) => format!("{at:.5} (branch point)"),
                None => br.from.to_string(),
            },
            f.points,
            br.route_detail,
            f.stable,
            f.unstable,
            list(&br.folds),
            if br.bifurcations.is_empty() {
                "none".into()
            } else {
                br.bifurcations.iter().map(|(o, k)| format!("{k} at {o:.5}")).collect::<Vec<_>>().join(", ")
            },
            f.sweep_jumps.map_or("–".into(), |(u, d)| format!(
                "{}, {}",
                u.map_or("none".into(), |v| format!("{v:.4}")),
                d.map_or("none".into(), |v| format!("{v:.4}"))
            )),
            1e3 * br.wall_s,
            // The cost per point, which the route and the mechanism's size set (the points
            // count the branch's shape).
            1e3 * br.wall_s / f.points.max(1) as f64,
            br.end
        );
    }
    md.push('\n');
    md
}

/// A note per branch: its couplings' convergence in H, where a switched branch goes, and why a
/// branch stopped short.
fn branch_notes(spec: &HbmSpec, branches: &[HbmBranch]) -> String {
    let mut md = String::new();
    for br in branches {
        if let Some(w) = coupling_warning(spec, br) {
            let _ = writeln!(md, "{w}");
        }
        if let (Some(at), Some(goes)) = (br.switched_at, &br.goes) {
            let what = if br.amplitude.is_nan() { String::new() } else { format!(" at {} N·m", br.amplitude) };
            let (st, un) = (
                br.stable.iter().filter(|s| **s == Some(true)).count(),
                br.stable.iter().filter(|s| **s == Some(false)).count(),
            );
            let (kind, point) =
                if br.period_doubled { ("period-doubled", "period doubling") } else { ("non-unison", "branch point") };
            let _ = writeln!(
                md,
                "- The {kind} branch{what} switched at the {point} {at:.7} ({st} stable, {un} unstable points) {goes}."
            );
        }
        if let Some(why) = &br.stopped_short {
            let what = if br.amplitude.is_nan() { String::new() } else { format!(" at {} N·m", br.amplitude) };
            let _ = writeln!(md, "- The branch{what} continued from {} {why}; its points are shown.", br.from);
        }
    }
    md
}

/// The summary's warning when a branch's coupling forces have not converged in H: the worst
/// point's share above H and where it is, or None.
fn coupling_warning(spec: &HbmSpec, br: &HbmBranch) -> Option<String> {
    let tol = HbmOptions::default().coupling_tol;
    let (i, worst) =
        br.coupling_tail.iter().copied().enumerate().max_by(|a, b| a.1.total_cmp(&b.1)).filter(|&(_, t)| t > tol)?;
    let count = br.coupling_tail.iter().filter(|&&t| t > tol).count();
    let ax = axis(spec);
    Some(format!(
        "> **Warning** (branch from {}): the joint couplings' harmonic content has not converged at H = {}: at \
         {count} of {} points more than {:.0} % of a coupling force's oscillating part lies above the balanced \
         harmonics (worst {:.1} % at {} = {:.4}); raise `harmonics` and compare.\n",
        br.from,
        spec.harmonics,
        br.coupling_tail.len(),
        100.0 * tol,
        100.0 * worst,
        ax.column,
        br.parameter.get(i).copied().unwrap_or(f64::NAN),
    ))
}

/// The summary's table of the states at the requested values (`orbits_at`): every distinct
/// state the branches of one amplitude cross there (the two directions of continuation often
/// cross the same one: states whose accelerations and largest angle agree to 1e-6 relative count
/// once), with its stability.
fn orbit_table(spec: &HbmSpec, branches: &[HbmBranch], column: &str) -> String {
    if spec.orbits_at.is_empty() {
        return String::new();
    }
    let mut md = format!(
        "States at the requested values of {column} (every periodic state the branches cross there, solved \
         at that value):\n\n| T_n (N·m) | {column} | states | stable / unstable | main-order acceleration \
         (rad/s²) and largest angle (rad) of each, stability |\n|---|---|---|---|---|\n"
    );
    let same = |a: &HbmOrbit, b: &HbmOrbit| {
        let close = |x: f64, y: f64| (x - y).abs() <= 1e-6 * x.abs().max(y.abs()).max(1e-12);
        a.accel.iter().zip(&b.accel).all(|(x, y)| close(*x, *y)) && close(a.relative_angle, b.relative_angle)
    };
    let mut amplitudes: Vec<f64> = Vec::new();
    for br in branches {
        if !amplitudes.iter().any(|a| a.to_bits() == br.amplitude.to_bits()) {
            amplitudes.push(br.amplitude);
        }
    }
    for amp in amplitudes {
        for &at in &spec.orbits_at {
            let mut found: Vec<&HbmOrbit> = Vec::new();
            for o in branches
                .iter()
                .filter(|b| b.amplitude.to_bits() == amp.to_bits())
                .flat_map(|b| &b.orbits)
                .filter(|o| o.at == at)
            {
                if !found.iter().any(|f| same(f, o)) {
                    found.push(o);
                }
            }
            found.sort_by(|a, b| a.relative_angle.total_cmp(&b.relative_angle));
            let stable = found.iter().filter(|o| o.stable == Some(true)).count();
            let unstable = found.iter().filter(|o| o.stable == Some(false)).count();
            let each: Vec<String> = found
                .iter()
                .map(|o| {
                    let st = match o.stable {
                        Some(true) => "stable",
                        Some(false) => "unstable",
                        None => "?",
                    };
                    format!("{:.5e}, {:.5}, {st}", o.accel.first().copied().unwrap_or(f64::NAN), o.relative_angle)
                })
                .collect();
            let amp = if amp.is_nan() { "–".to_string() } else { amp.to_string() };
            let _ = writeln!(md, "| {amp} | {at} | {} | {stable} / {unstable} | {} |", found.len(), each.join("; "));
        }
    }
    md.push('\n');
    md
}

pub(super) fn list(v: &[f64]) -> String {
    if v.is_empty() { "none".into() } else { v.iter().map(|x| format!("{x:.5}")).collect::<Vec<_>>().join(", ") }
}
