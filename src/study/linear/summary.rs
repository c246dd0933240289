//! The linear response's summary section: the tuning and eigen-orders, the modal table (spin
//! held and free, undamped and with the damping in force), gravity's order-1 response, per
//! variant the extremes of the ratio with the first amplification above n_t and the high-order
//! asymptote (or, without a locked twin, the extremes per unit torque), and the elements.

use super::{LinearResponseSpec, LinearResult, ModeRow, ResponseVariant};
use crate::study::Study;
use std::fmt::Write as _;

/// The section.
pub(super) fn summary(study: &Study, spec: &LinearResponseSpec, result: &LinearResult) -> String {
    let results = &result.variants;
    let mut md = String::new();
    let _ = writeln!(md, "## Linear frequency response `{}`: {} rpm (eq. 22)\n", spec.name, spec.rpm);
    md += &orders_list(study, spec, result);
    md += &modes(spec, result);
    md += &gravity_table(study, spec, results);
    if study.spec.lock.is_empty() {
        md += &extremes_table(results);
    } else {
        md += &ratio_table(result);
    }
    md += &element_table(results);
    md
}

/// The tuning order n_t, every absorber's own eigen-order with the spin held, the free
/// eigen-orders, the modal damping and the excitation shares set by laws in speed, one line each.
fn orders_list(study: &Study, spec: &LinearResponseSpec, result: &LinearResult) -> String {
    let (n_t, free_orders) = (result.n_t, &result.free_orders);
    let mut md = String::new();
    if let Some(nt) = n_t {
        let _ = writeln!(md, "- tuning order n_t (spin held, undamped) of `{}` = {nt:.10}", study.spec.lock[0]);
    }
    // Every absorber's own tuning order: each mode with the spin held, named by its joint.
    let held: Vec<&ModeRow> = result.modes.iter().filter(|m| m.spin_held && !m.damped).collect();
    if held.len() > 1 || n_t.is_none() {
        for m in held {
            let _ = writeln!(md, "- eigen-order with the spin held (undamped) {:.10} (mode `{}`)", m.order, m.label);
        }
    }
    for (o, l) in free_orders {
        let _ = writeln!(md, "- free undamped eigen-order {o:.10} (mode `{l}`)");
    }
    if let Some((z, how)) = spec.modal() {
        let _ = writeln!(md, "- modal damping: {} ({})", z.describe(), how.describe());
    }
    for (e, at) in spec.excite.iter().zip(crate::study::excite_at_rpm(&spec.excite, spec.rpm)) {
        if !e.law.is_constant() {
            let _ = writeln!(
                md,
                "- excitation share at `{}` at {} rpm: {:.6} ({} × {:.6} by its law in speed)",
                e.joint,
                spec.rpm,
                at.scale,
                e.scale,
                e.law.factor(spec.rpm).unwrap_or(f64::NAN)
            );
        }
    }
    md
}

/// The modes at the operating speed: the modal table with what its damped rows carry.
fn modes(spec: &LinearResponseSpec, result: &LinearResult) -> String {
    let modal = spec.modal();
    let mut modal_md =
        String::from("| spin | damping | eigen-order | damping ratio | dominant joint |\n|---|---|---|---|---|\n");
    for m in &result.modes {
        let _ = writeln!(
            modal_md,
            "| {} | {} | {:.10} | {:.3e} | `{}` |",
            if m.spin_held { "held" } else { "free" },
            match (m.damped, modal) {
                (false, _) => "undamped",
                (true, None) => "damped",
                (true, Some((_, crate::linear::ModalCombination::Replace))) => "modal",
                (true, Some((_, crate::linear::ModalCombination::Add))) => "dampers + modal",
            },
            m.order,
            m.damping_ratio,
            m.label
        );
    }
    let mut md = String::new();
    match modal {
        None => {
            let _ = writeln!(md, "\nModes at {} rpm (mechanism as built):\n\n{modal_md}", spec.rpm);
        }
        Some((z, how)) => {
            let _ = writeln!(
                md,
                "\nModes at {} rpm (mechanism as built; the damped rows carry the damping in force: {}, {}, \
                 modes with the spin free, so their ratios are the given ζ where the dampers and the \
                 velocity coupling add nothing):\n\n{modal_md}",
                spec.rpm,
                z.describe(),
                how.describe()
            );
        }
    }
    md
}

/// Without a locked twin: the extremes per unit torque on the order grid, per variant.
fn extremes_table(results: &[ResponseVariant]) -> String {
    let mut md = String::new();
    let _ = writeln!(
        md,
        "No joint is locked, so the response is not normalised by a locked twin: ratios, n_t and \
         the first amplification do not apply. Extremes on the order grid:\n"
    );
    let _ = writeln!(md, "| variant | min (rad/s² per N·m) | at n | max (rad/s² per N·m) | at n |");
    let _ = writeln!(md, "|---|---|---|---|---|");
    for r in results {
        let pick = |better: fn(f64, f64) -> bool| {
            r.orders.iter().zip(&r.response).fold((f64::NAN, f64::NAN), |best, (&n, &a)| {
                if best.1.is_nan() || better(a, best.1) { (n, a) } else { best }
            })
        };
        let (lo, hi) = (pick(|a, b| a < b), pick(|a, b| a > b));
        let _ = writeln!(md, "| {} | {:.6e} | {:.5} | {:.6e} | {:.5} |", r.label, lo.1, lo.0, hi.1, hi.0);
    }
    md.push('\n');
    md
}

/// With a locked twin: per variant the extremes of the ratio, the first order above n_t where it
/// exceeds 1, and the high-order asymptote.
fn ratio_table(result: &LinearResult) -> String {
    let n_t = result.n_t;
    let mut md = String::new();
    let _ = writeln!(
        md,
        "\n| variant | min ratio | at n | at n/n_t | max ratio | at n | at n/n_t | first n > n_t with ratio > 1 | n/n_t | high-order asymptote |"
    );
    let _ = writeln!(md, "|---|---|---|---|---|---|---|---|---|---|");
    // n/n_t is printed only where n_t exists (a locked joint with a held-spin mode).
    let per_nt = |n: f64| n_t.map_or("–".to_string(), |nt| format!("{:.6}", n / nt));
    for r in &result.variants {
        let _ = writeln!(
            md,
            "| {} | {:.5} | {:.5} | {} | {:.4} | {:.5} | {} | {} | {} | {} |",
            r.label,
            r.min.1,
            r.min.0,
            per_nt(r.min.0),
            r.max.1,
            r.max.0,
            per_nt(r.max.0),
            r.crossing.map_or("–".into(), |c| format!("{c:.8}")),
            r.crossing.map_or("–".into(), |c| n_t.map_or("–".into(), |nt| format!("{:.8}", c / nt))),
            if r.asymptote.is_finite() { format!("{:.8}", r.asymptote) } else { "– (both tend to 0)".into() }
        );
    }
    md.push('\n');
    md
}

/// With gravity: its order-1 response per variant (the watched body, its locked twin and each
/// element), and what it is.
fn gravity_table(study: &Study, spec: &LinearResponseSpec, results: &[ResponseVariant]) -> String {
    let mut md = String::new();
    if results.iter().all(|r| r.gravity.is_none()) {
        return md;
    }
    let g = study.mechanism.loads.gravity;
    let _ = writeln!(
        md,
        "Gravity ({}, {}) m/s² forces the rotation at order 1 (exactly, at the nominal rotation); its steady \
         response at {} rpm through the same linear transfer (spin free; the gravity × deflection terms, second \
         order, are neglected; the per-N·m responses above do not change):\n",
        g.x, g.y, spec.rpm
    );
    let body = &study.spec.response_body;
    let names: Vec<String> = results
        .iter()
        .find_map(|r| {
            r.gravity.as_ref().map(|_| r.elements.iter().map(|e| format!(" `{}` order 1 |", e.joint)).collect())
        })
        .unwrap_or_default();
    let _ = writeln!(
        md,
        "| variant | `{body}` order 1 (rad/s²) | locked twin (rad/s²) |{}\n|---|---|---|{}",
        names.concat(),
        "---|".repeat(names.len())
    );
    for r in results {
        let Some(gr) = &r.gravity else { continue };
        let els: Vec<String> =
            gr.elements.iter().zip(&r.elements).map(|(a, e)| format!(" {} {} |", sci(*a), e.unit)).collect();
        let _ = writeln!(md, "| {} | {} | {} |{}", r.label, sci(gr.accel), sci(gr.locked), els.concat());
    }
    md.push('\n');
    md
}

/// A number in exponent form with six digits, or `undefined`.
fn sci(v: f64) -> String {
    if v.is_finite() { format!("{v:.6e}") } else { "undefined".into() }
}

/// The elements' largest response per unit torque over the order range, per variant.
fn element_table(results: &[ResponseVariant]) -> String {
    let mut md = String::new();
    if results.iter().all(|r| r.elements.is_empty()) {
        return md;
    }
    md += "Elements, per N·m of excitation (largest over the orders evaluated):\n\n";
    md += "| variant | element | amplitude per N·m | at n | spring + damper torque per N·m | at n |\n|---|---|---|---|---|---|\n";
    let top = |orders: &[f64], v: &[f64]| {
        orders.iter().zip(v).fold((f64::NAN, f64::NAN), |b, (&n, &a)| if b.1.is_nan() || a > b.1 { (n, a) } else { b })
    };
    for r in results {
        for e in &r.elements {
            let (na, a) = top(&r.orders, &e.amplitude);
            let (nt, t) = top(&r.orders, &e.torque);
            let _ = writeln!(
                md,
                "| {} | `{}` | {} {} | {} | {} | {} |",
                r.label,
                e.joint,
                sci(a),
                if e.unit == "m" { "m" } else { "rad" },
                crate::study::cell(na, 5),
                sci(t),
                crate::study::cell(nt, 5)
            );
        }
    }
    md.push('\n');
    md
}
