//! A transient's outputs: the time series, the order–rpm map in long form and the order cuts as
//! CSV tables, the map as a colour map and the speed and cuts as line plots (SVG), and its
//! summary section.

use super::{TransientResult, cut_orders};
use crate::error::Result;
use crate::plot::{Heatmap, LineStyle, Panel, Series};
use crate::study::table::{Table, fmt_num};
use crate::study::{SpeedProfile, Study, TransientSpec, cell};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The transient's CSV tables: the time series (when asked for), the map in long form (one row
/// per block and order) and the order cuts side by side.
pub(crate) fn tables(study: &Study, spec: &TransientSpec, r: &TransientResult) -> Vec<Table> {
    let mut out = Vec::new();
    let mech = &study.mechanism;
    if spec.write_time_series {
        let mut t = Table::new(format!("{}_series", spec.name));
        t.push("time_s", "s", r.time_s.clone());
        t.push("spin_rpm", "rpm", r.spin_rpm.clone());
        t.push(format!("{}_accel_rad_s2", study.spec.response_body), "rad/s²", r.response.clone());
        for (&j, (q, qd)) in study.elements.iter().zip(&r.element_series) {
            let joint = &mech.joints[j];
            let u = joint.kind.coordinate_unit();
            let (qu, ru) = if u == "m" { ("m", "m/s") } else { ("rad", "rad/s") };
            t.push(format!("{}_q_{}", joint.name, qu), u, q.clone());
            t.push(format!("{}_qdot_{}", joint.name, ru.replace('/', "_")), ru, qd.clone());
        }
        if !r.drive_torque.is_empty() {
            t.push("drive_torque_Nm", "N·m", r.drive_torque.clone());
        }
        for (name, [rad, tan, mom]) in &r.reaction_series {
            t.push(format!("{name}_force_radial_N"), "N", rad.clone());
            t.push(format!("{name}_force_tangential_N"), "N", tan.clone());
            t.push(format!("{name}_moment_Nm"), "N·m", mom.clone());
            if let Some((_, mesh)) = r.mesh_series.iter().find(|(n, _)| n == name) {
                t.push(format!("{name}_mesh_torque_Nm"), "N·m", mesh.clone());
            }
        }
        out.push(t);
    }
    if let Some(m) = &r.map {
        let mut t = Table::new(format!("{}_map", spec.name));
        let cells = m.rpm.len() * m.orders.len();
        let (mut time, mut rpm, mut order, mut amp) = (
            Vec::with_capacity(cells),
            Vec::with_capacity(cells),
            Vec::with_capacity(cells),
            Vec::with_capacity(cells),
        );
        for (b, row) in m.amplitude.iter().enumerate() {
            for (o, &a) in m.orders.iter().zip(row) {
                time.push(m.time_s[b]);
                rpm.push(m.rpm[b]);
                order.push(*o);
                amp.push(a);
            }
        }
        t.push("time_s", "s", time);
        t.push("rpm", "rpm", rpm);
        t.push("order", "1", order);
        t.push(format!("{}_accel_rad_s2", study.spec.response_body), "rad/s²", amp);
        out.push(t);
        let mut c = Table::new(format!("{}_cuts", spec.name));
        c.push("time_s", "s", m.time_s.clone());
        c.push("rpm", "rpm", m.rpm.clone());
        // The engine's order torques at each block's speed: what excites the cuts beside them.
        for (order, torques) in engine_torques(spec, &m.rpm) {
            c.push(format!("engine_T_order{}_Nm", fmt_num(order)), "N·m", torques);
        }
        for cut in &r.cuts {
            c.push(
                format!("{}_{}x_{}", cut.signal, fmt_num(cut.order), unit_tag(cut.unit)),
                cut.unit,
                cut.amplitude.clone(),
            );
        }
        out.push(c);
    }
    out
}

/// With an engine: each of its orders that carries torque (as the cuts take them) with its
/// amplitude T_k at each of `rpm`, N·m, before any joint's share. Empty without an engine.
fn engine_torques(spec: &TransientSpec, rpm: &[f64]) -> Vec<(f64, Vec<f64>)> {
    let Some(series) = spec.engine.as_ref().and_then(|e| e.series.as_ref()) else { return Vec::new() };
    let at = |order: f64, r: f64| {
        // Base order ½: multiple j of the series is order j/2.
        let h = series.harmonics(crate::model::excitation::rpm_to_rad_s(r), 0.5);
        h.iter().find(|x| (0.5 * x.multiple - order).abs() <= 1e-9).map_or(f64::NAN, |x| x.amplitude)
    };
    super::engine_orders(spec).into_iter().map(|o| (o, rpm.iter().map(|&r| at(o, r)).collect())).collect()
}

/// A unit for a CSV header: `rad/s²` → `rad_s2`.
fn unit_tag(u: &str) -> String {
    u.replace("/s²", "_s2").replace('/', "_").replace('·', "")
}

/// Writes the tables, the map and the cuts and returns the summary section.
pub(super) fn render(
    study: &Study,
    spec: &TransientSpec,
    r: &TransientResult,
    dir: &Path,
) -> Result<(String, Vec<PathBuf>)> {
    let mut files = Vec::new();
    for t in tables(study, spec, r) {
        files.push(t.write_csv(dir)?);
    }
    let body = &study.spec.response_body;
    if let Some(m) = &r.map {
        let heat = Heatmap {
            title: format!("{}: order–rpm map of the {body} acceleration", spec.name),
            x_label: "spin speed, rpm".into(),
            y_label: "order".into(),
            z_label: "rad/s²".into(),
            x: m.rpm.clone(),
            y: m.orders.clone(),
            z: m.amplitude.clone(),
            db_range: 60.0,
            y_markers: cut_orders(spec).iter().map(|&o| (o, fmt_num(o))).collect(),
        };
        if increasing(&m.rpm) {
            let svg = dir.join(format!("{}_map.svg", spec.name));
            crate::plot::write_heatmap_svg(&svg, &heat, 760, 460)?;
            files.push(svg);
        }
    }
    let mut panels = vec![Panel {
        title: format!("{}: spin speed", spec.name),
        x_label: "time, s".into(),
        y_label: "speed, rpm".into(),
        series: vec![Series {
            label: "spin joint".into(),
            x: thin(&r.time_s),
            y: thin(&r.spin_rpm),
            ..Series::default()
        }],
        ..Panel::default()
    }];
    let signals: Vec<&str> = {
        let mut s: Vec<&str> = r.cuts.iter().map(|c| c.signal.as_str()).collect();
        s.dedup();
        s
    };
    for sig in signals {
        let series = r
            .cuts
            .iter()
            .filter(|c| c.signal == sig)
            .enumerate()
            .map(|(k, c)| Series {
                label: format!("order {}", fmt_num(c.order)),
                x: r.block_rpm.clone(),
                y: c.amplitude.clone(),
                color: k,
                style: LineStyle::Solid,
            })
            .collect();
        let unit = r.cuts.iter().find(|c| c.signal == sig).map_or("", |c| c.unit);
        panels.push(Panel {
            title: format!("{sig}: order cuts"),
            x_label: "spin speed, rpm".into(),
            y_label: format!("amplitude, {unit}"),
            log_y: true,
            series,
            ..Panel::default()
        });
    }
    let svg = dir.join(format!("{}.svg", spec.name));
    crate::plot::write_svg(&svg, &panels, 560, 400)?;
    files.push(svg);
    Ok((summary(study, spec, r), files))
}

/// Every k-th value, at most 2000: a line plot of 10⁵ samples would weigh megabytes and show no
/// more than its pixels.
fn thin(v: &[f64]) -> Vec<f64> {
    let step = v.len().div_ceil(2000).max(1);
    v.iter().step_by(step).copied().collect()
}

fn increasing(v: &[f64]) -> bool {
    v.windows(2).all(|w| w[1] > w[0])
}

fn summary(study: &Study, spec: &TransientSpec, r: &TransientResult) -> String {
    let mut md = String::new();
    let profile = profile_words(spec);
    let _ = writeln!(md, "## Transient `{}`: {} s, {profile}\n", spec.name, fmt_num(spec.duration_s));
    let _ = writeln!(
        md,
        "Rigid-rotation inertia of the spin joint's load J = {} kg·m²; speed {} → {} rpm as reached; {} steps, {} right-hand sides.\n",
        cell(r.rigid_inertia_kg_m2, 6),
        cell(r.rpm_start, 2),
        cell(r.rpm_end, 2),
        r.sim.stats.accepted,
        r.sim.rhs_evals()
    );
    md += &engine_section(spec, r);
    let target = spec.speed.rpm_range().1;
    if !matches!(spec.speed, SpeedProfile::Free { .. })
        && r.sim.error.is_none()
        && (r.rpm_end - target).abs() > 0.05 * target.max(1.0)
    {
        let _ = writeln!(
            md,
            "**The speed did not follow the ramp**: it ended at {} rpm against {} rpm. Power drawn by a resonance \
             held the mean speed back (the Sommerfeld effect of a torque-limited drive); a speed governor \
             (`governor_s`) or a prescribed speed takes the run through.\n",
            cell(r.rpm_end, 1),
            fmt_num(target)
        );
    }
    if let Some(note) = &r.map_note {
        let _ = writeln!(md, "Note: {note}. The time series, peaks and reactions do not depend on it.\n");
    }
    if r.map.is_some() {
        let _ = writeln!(
            md,
            "Order–rpm map of the `{}` acceleration: blocks of {} revolutions (order resolution {}), speed resolution {} rpm (the widest spread of speeds inside one block).\n",
            study.spec.response_body,
            spec.map.revs_per_block,
            fmt_num(r.map_order_resolution),
            cell(r.map_speed_resolution_rpm, 2)
        );
    }
    md += &cut_table(r);
    md += &reaction_table(r);
    md += &peak_table(r);
    md
}

/// The speed profile in words: free, a run driven by the feed-forward torque (and a governor),
/// or a prescribed speed.
fn profile_words(spec: &TransientSpec) -> String {
    match spec.speed {
        SpeedProfile::Free { rpm } => format!("spin free from {} rpm", fmt_num(rpm)),
        SpeedProfile::Torque { rpm_from, rpm_to, .. } => {
            format!(
                "run {} → {} rpm driven by the feed-forward torque J·α + losses{}",
                fmt_num(rpm_from),
                fmt_num(rpm_to),
                match spec.speed {
                    SpeedProfile::Torque { governor_s: Some(tau), .. } =>
                        format!(" and a speed governor (τ = {} s)", fmt_num(tau)),
                    _ => String::new(),
                }
            )
        }
        SpeedProfile::Prescribed { rpm_from, rpm_to, .. } => {
            format!("spin speed prescribed {} → {} rpm", fmt_num(rpm_from), fmt_num(rpm_to))
        }
    }
}

/// With an engine: what it applies and its order torques at the run's first and last speed.
fn engine_section(spec: &TransientSpec, r: &TransientResult) -> String {
    let mut md = String::new();
    let Some(e) = &spec.engine else { return md };
    let orders = e.series.as_ref().map(|s| s.orders()).unwrap_or_default();
    let list = |o: &[f64]| o.iter().map(|v| fmt_num(*v)).collect::<Vec<_>>().join(", ");
    let _ = writeln!(
        md,
        "Engine `{}`: its oscillating torque at the spin joint's angle and rate of each instant, orders {} (amplitudes following the speed); its mean torque is not applied.\n",
        e.file,
        list(&orders)
    );
    // T_k at the run's first and last speed; every block's in the cuts CSV.
    let ends = [r.rpm_start, r.rpm_end];
    let torques = engine_torques(spec, &ends);
    if !torques.is_empty() {
        let _ = writeln!(
            md,
            "Its order torques T_k (N·m) at the run's first and last speed (at every block's speed in `{}_cuts.csv`, \
             columns `engine_T_order<k>_Nm`):\n",
            spec.name
        );
        let head: String = torques.iter().map(|(o, _)| format!(" T order {} |", fmt_num(*o))).collect();
        let _ = writeln!(md, "| rpm |{head}\n|---|{}", "---|".repeat(torques.len()));
        for (i, rpm) in ends.iter().enumerate() {
            let cells: String = torques.iter().map(|(_, t)| format!(" {} |", cell(t[i], 4))).collect();
            let _ = writeln!(md, "| {} |{cells}", cell(*rpm, 1));
        }
        md.push('\n');
    }
    md
}

/// The order cuts' peaks: signal, order, peak amplitude and the speed of its block.
fn cut_table(r: &TransientResult) -> String {
    let mut md = String::new();
    if r.cuts.is_empty() {
        return md;
    }
    md += "| signal | order | peak amplitude | unit | at (rpm) |\n|---|---|---|---|---|\n";
    for c in &r.cuts {
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {} |",
            c.signal,
            fmt_num(c.order),
            cell(c.peak, 6),
            c.unit,
            cell(c.peak_rpm, 1)
        );
    }
    md.push('\n');
    md
}

/// The joints' reactions after the first second, smallest and largest (with the gear mesh's
/// torque where a listed joint is driven by a gear).
fn reaction_table(r: &TransientResult) -> String {
    let mut md = String::new();
    if r.reaction_ranges.is_empty() {
        return md;
    }
    md += "Joint reactions (what the parent exerts on the child; radial: outward from the parent's origin), \
           smallest and largest after the first second:\n\n";
    // The mesh column appears only when a listed joint is driven by a gear.
    let mesh = r.reaction_ranges.iter().any(|x| x.mesh_torque_nm.is_some());
    md += if mesh {
        "| joint | radial force (N) | tangential force (N) | moment (N·m) | gear mesh torque (N·m) |\n|---|---|---|---|---|\n"
    } else {
        "| joint | radial force (N) | tangential force (N) | moment (N·m) |\n|---|---|---|---|\n"
    };
    let pair = |(a, b): (f64, f64)| format!("{} … {}", cell(a, 3), cell(b, 3));
    for x in &r.reaction_ranges {
        let _ = write!(md, "| {} | {} | {} | {} |", x.joint, pair(x.radial_n), pair(x.tangential_n), pair(x.moment_nm));
        if mesh {
            let _ = write!(md, " {} |", x.mesh_torque_nm.map_or_else(|| "—".to_string(), pair));
        }
        md.push('\n');
    }
    md.push('\n');
    md
}

/// The elements' largest excursions, with when and at what speed.
fn peak_table(r: &TransientResult) -> String {
    let mut md = String::new();
    if r.elements.is_empty() {
        return md;
    }
    md += "| element | largest excursion | unit | at time (s) | at speed (rpm) |\n|---|---|---|---|---|\n";
    for e in &r.elements {
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {} |",
            e.joint,
            cell(e.peak, 6),
            e.unit,
            cell(e.at_time_s, 3),
            cell(e.at_rpm, 1)
        );
    }
    md.push('\n');
    md
}
