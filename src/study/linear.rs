//! The linear analyses of a study: the order-domain frequency response normalised by the locked
//! twin (paper eq. 22, Fig. 2) and the Campbell diagram.

use super::{CampbellSpec, LinearResponseSpec, Output, Results, Study, write_csv};
use crate::error::{Error, Result};
use crate::linear::{Campbell, Damping, LinearError, LinearModel, OrderResponse, ResponseSpec, Spin, campbell};
use crate::model::excitation::rpm_to_rad_s;
use crate::model::mechanism::Mechanism;
use crate::plot::{LineStyle, Panel, Series};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// A variant label as a file-name part: characters other than letters, digits, `.` and `-`
/// become `_`.
pub(crate) fn slug(label: &str) -> String {
    label.chars().map(|c| if c.is_ascii_alphanumeric() || c == '.' || c == '-' { c } else { '_' }).collect()
}

/// Linear results of one variant, for tests and reports.
#[derive(Debug, Clone, serde::Serialize)]
pub struct ResponseVariant {
    /// The variant's label.
    pub label: String,
    /// Orders evaluated.
    pub orders: Vec<f64>,
    /// |α̂| per unit torque at each order, rad/s² per N·m.
    pub response: Vec<f64>,
    /// The locked twin's |α̂| per unit torque at each order, rad/s² per N·m.
    pub locked: Vec<f64>,
    /// |α̂| / |α̂_locked| at each order.
    pub ratio: Vec<f64>,
    /// Smallest ratio and its order.
    pub min: (f64, f64),
    /// Largest ratio and its order.
    pub max: (f64, f64),
    /// First order above n_t where the ratio exceeds 1.
    pub crossing: Option<f64>,
    /// High-order limit of the ratio.
    pub asymptote: f64,
}

/// A linear frequency-response analysis.
#[derive(Debug, Clone, serde::Serialize)]
pub struct LinearResult {
    /// Analysis name.
    pub name: String,
    /// Tuning order n_t (held spin, undamped), if the study locks a joint.
    pub n_t: Option<f64>,
    /// Undamped eigen-orders with the spin free, with their mode labels.
    pub free_orders: Vec<(f64, String)>,
    /// The modes of the mechanism as built, spin held and free, undamped and damped.
    pub modes: Vec<ModeRow>,
    /// One entry per damping variant.
    pub variants: Vec<ResponseVariant>,
}

/// One mode of the modal table of a linear response analysis.
#[derive(Debug, Clone, serde::Serialize)]
pub struct ModeRow {
    /// Spin held (the absorbers alone) rather than free (coupled with the rotor).
    pub spin_held: bool,
    /// With the dampers (else undamped).
    pub damped: bool,
    /// Eigen-order (natural frequency over the spin speed).
    pub order: f64,
    /// Damping ratio.
    pub damping_ratio: f64,
    /// The joint that dominates the mode.
    pub label: String,
}

fn lin(mech: &Mechanism) -> impl Fn(LinearError) -> Error + '_ {
    move |e| Error::Model { mechanism: mech.name.clone(), message: format!("linear analysis: {e}") }
}

/// The mechanism with the variant's joint dampers (names checked when the study was read).
fn with_dampers(mech: &Mechanism, dampers: &[(String, f64)]) -> Mechanism {
    let mut m = mech.clone();
    for (joint, c) in dampers {
        if let Some(k) = m.joint_index(joint) {
            m.joints[k].damper = *c;
        }
    }
    m
}

/// Undamped eigen-order of the first locked joint's mode with the spin held (eq. 15 for a CPVA).
fn tuning_order(study: &Study, omega: f64) -> Result<Option<f64>> {
    let Some(first) = study.spec.lock.first() else { return Ok(None) };
    let mech = &study.mechanism;
    let model = LinearModel::new(mech, &study.spec.spin_joint, omega, None).map_err(lin(mech))?;
    let modal = model.modes(Spin::Held, Damping::Undamped).map_err(lin(mech))?;
    Ok(modal.modes.iter().filter(|m| &m.label == first).map(|m| m.order).min_by(f64::total_cmp))
}

/// Runs the linear response analysis ([`compute_response`]) and writes its outputs
/// ([`render_response`]).
pub(crate) fn run_response(study: &Study, spec: &LinearResponseSpec, dir: &Path) -> Result<Output> {
    let (result, failures) = compute_response(study, spec)?;
    let (markdown, files) = render_response(study, spec, &result, dir)?;
    Ok(Output { markdown, files, failures, results: Results::Linear(result) })
}

/// The modes at the operating speed and, per damping variant, the order-domain response of
/// eq. (22) normalised by the locked twin, with its extremes, first amplification above n_t and
/// high-order asymptote.
pub(crate) fn compute_response(study: &Study, spec: &LinearResponseSpec) -> Result<(LinearResult, Vec<String>)> {
    let omega = rpm_to_rad_s(spec.rpm);
    let mech = &study.mechanism;
    let n_t = tuning_order(study, omega)?;
    let scale = if spec.relative {
        n_t.ok_or_else(|| Error::Model {
            mechanism: mech.name.clone(),
            message: format!("analysis `{}`: `relative` orders need a locked joint to define n_t", spec.name),
        })?
    } else {
        1.0
    };
    let model = LinearModel::new(mech, &study.spec.spin_joint, omega, None).map_err(lin(mech))?;
    let free = model.modes(Spin::Free, Damping::Undamped).map_err(lin(mech))?;
    // The modal table of the mechanism as built: eigen-orders, damping ratios and the joint that
    // dominates each mode, with the spin held (absorber alone) and free (coupled).
    let mut modes = Vec::new();
    for (spin, spin_held) in [(Spin::Held, true), (Spin::Free, false)] {
        for (damping, damped) in [(Damping::Undamped, false), (Damping::Damped, true)] {
            for m in &model.modes(spin, damping).map_err(lin(mech))?.modes {
                let (order, damping_ratio, label) = (m.order, m.damping_ratio, m.label.clone());
                modes.push(ModeRow { spin_held, damped, order, damping_ratio, label });
            }
        }
    }
    let free_orders: Vec<(f64, String)> = free.modes.iter().map(|m| (m.order, m.label.clone())).collect();
    let rspec = ResponseSpec {
        spin_joint: study.spec.spin_joint.clone(),
        input_joint: study.spec.spin_joint.clone(),
        body: study.spec.response_body.clone(),
        lock: study.spec.lock.clone(),
    };
    let steps = spec.points.max(2);
    let orders: Vec<f64> =
        (0..steps).map(|i| scale * (spec.from + (spec.to - spec.from) * i as f64 / (steps - 1) as f64)).collect();
    let default_variant = [super::Variant { label: "as built".into(), dampers: Vec::new() }];
    let variants = if spec.variants.is_empty() { &default_variant[..] } else { &spec.variants[..] };
    let mut results = Vec::new();
    let mut failures = Vec::new();
    for v in variants {
        let m = with_dampers(mech, &v.dampers);
        let resp = OrderResponse::new(&m, &rspec, omega, None).map_err(lin(&m))?;
        let pts = resp.sweep(&orders).map_err(lin(&m))?;
        let locked_max = pts.iter().map(|p| p.locked.abs()).fold(0.0, f64::max);
        let ratio: Vec<f64> = pts.iter().map(|p| super::ratio(p.response, p.locked, locked_max)).collect();
        // Extremes refined by the linear module's golden-section search around the grid's.
        let ext = resp.extremes(orders[0], orders[steps - 1], steps).map_err(lin(&m))?;
        let crossing = match n_t {
            Some(nt) if nt < orders[steps - 1] => {
                resp.first_amplification(nt.max(orders[0]), orders[steps - 1], steps).map_err(lin(&m))?
            }
            _ => None,
        };
        let asymptote = resp.asymptote().map_err(lin(&m))?;
        if let Some(i) = pts.iter().position(|p| !(p.response.is_finite() && p.locked.is_finite())) {
            failures.push(format!(
                "{} variant `{}`: the response is not finite at order {} (left empty in the CSV)",
                spec.name, v.label, orders[i]
            ));
        }
        results.push(ResponseVariant {
            label: v.label.clone(),
            orders: orders.clone(),
            response: pts.iter().map(|p| p.response).collect(),
            locked: pts.iter().map(|p| p.locked).collect(),
            ratio,
            min: (ext.min_order, ext.min_ratio),
            max: (ext.max_order, ext.max_ratio),
            crossing,
            asymptote,
        });
    }
    let result = LinearResult { name: spec.name.clone(), n_t, free_orders, modes, variants: results };
    Ok((result, failures))
}

/// Writes one CSV per variant and the figure (the paper's Fig. 2), and returns the summary
/// section with the files written.
pub(crate) fn render_response(
    study: &Study,
    spec: &LinearResponseSpec,
    result: &LinearResult,
    dir: &Path,
) -> Result<(String, Vec<PathBuf>)> {
    let LinearResult { n_t, free_orders, variants: results, .. } = result;
    let n_t = *n_t;
    let scale = if spec.relative { n_t.unwrap_or(1.0) } else { 1.0 };
    let mut files = Vec::new();
    for r in results {
        let path = dir.join(format!("{}_{}.csv", spec.name, slug(&r.label)));
        let rel: Vec<f64> = r.orders.iter().map(|n| n / scale).collect();
        write_csv(
            &path,
            &["order", "order_over_nt", "accel_per_torque_rad_s2_per_Nm", "locked_rad_s2_per_Nm", "ratio"],
            &[&r.orders, &rel, &r.response, &r.locked, &r.ratio],
        )?;
        files.push(path);
    }
    let mut modal_md =
        String::from("| spin | damping | eigen-order | damping ratio | dominant joint |\n|---|---|---|---|---|\n");
    for m in &result.modes {
        let _ = writeln!(
            modal_md,
            "| {} | {} | {:.10} | {:.3e} | `{}` |",
            if m.spin_held { "held" } else { "free" },
            if m.damped { "damped" } else { "undamped" },
            m.order,
            m.damping_ratio,
            m.label
        );
    }
    let x_label = if spec.relative { "n / n_t" } else { "excitation order n" };
    let mut markers = Vec::new();
    if let Some(nt) = n_t {
        markers.push((nt / scale, "n_t".to_string()));
    }
    // The rotor eigen-order: the free mode nearest n_t (for a CPVA, eq. 17).
    if let (Some(nt), Some((nr, _))) = (
        n_t,
        free_orders.iter().min_by(|a, b| (a.0 - n_t.unwrap_or(0.0)).abs().total_cmp(&(b.0 - n_t.unwrap_or(0.0)).abs())),
    ) && (nr - nt).abs() > 1e-9
    {
        markers.push((nr / scale, "n_r".to_string()));
    }
    let panel = Panel {
        title: format!("Linear response normalised by the locked twin, {} rpm", spec.rpm),
        x_label: x_label.into(),
        y_label: format!("{} acceleration / locked", study.spec.response_body),
        log_y: true,
        x_range: Some((spec.from, spec.to)),
        markers,
        series: results
            .iter()
            .enumerate()
            .map(|(k, r)| Series {
                label: r.label.clone(),
                x: r.orders.iter().map(|n| n / scale).collect(),
                y: r.ratio.clone(),
                color: k,
                style: LineStyle::Solid,
            })
            .chain(std::iter::once(Series {
                label: "unity".into(),
                x: vec![spec.from, spec.to],
                y: vec![1.0, 1.0],
                color: 7,
                style: LineStyle::Dotted,
            }))
            .collect(),
        ..Panel::default()
    };
    let svg = dir.join(format!("{}.svg", spec.name));
    crate::plot::write_svg(&svg, &[panel], 760, 500)?;
    files.push(svg);

    let mut md = String::new();
    let _ = writeln!(md, "## Linear frequency response `{}`: {} rpm (eq. 22)\n", spec.name, spec.rpm);
    if let Some(nt) = n_t {
        let _ = writeln!(md, "- tuning order n_t (spin held, undamped) = {nt:.10}");
    }
    for (o, l) in free_orders {
        let _ = writeln!(md, "- free undamped eigen-order {o:.10} (mode `{l}`)");
    }
    let _ = writeln!(md, "\nModes at {} rpm (mechanism as built):\n\n{modal_md}", spec.rpm);
    let _ = writeln!(
        md,
        "\n| variant | min ratio | at n | at n/n_t | max ratio | at n | at n/n_t | first n > n_t with ratio > 1 | n/n_t | high-order asymptote |"
    );
    let _ = writeln!(md, "|---|---|---|---|---|---|---|---|---|---|");
    let nt = n_t.unwrap_or(f64::NAN);
    for r in results {
        let _ = writeln!(
            md,
            "| {} | {:.5} | {:.5} | {:.6} | {:.4} | {:.5} | {:.6} | {} | {} | {} |",
            r.label,
            r.min.1,
            r.min.0,
            r.min.0 / nt,
            r.max.1,
            r.max.0,
            r.max.0 / nt,
            r.crossing.map_or("–".into(), |c| format!("{c:.8}")),
            r.crossing.map_or("–".into(), |c| format!("{:.8}", c / nt)),
            if r.asymptote.is_finite() { format!("{:.8}", r.asymptote) } else { "– (both tend to 0)".into() }
        );
    }
    md.push('\n');
    Ok((md, files))
}

/// Runs the Campbell analysis ([`compute_campbell`]) and writes its outputs
/// ([`render_campbell`]).
pub(crate) fn run_campbell(study: &Study, spec: &CampbellSpec, dir: &Path) -> Result<Output> {
    let (c, failures) = compute_campbell(study, spec)?;
    let (markdown, files) = render_campbell(spec, &c, dir)?;
    Ok(Output { markdown, files, failures, results: Results::Campbell(c) })
}

/// The natural frequencies over the speed range, tracked by mode shape, with the order lines.
pub(crate) fn compute_campbell(study: &Study, spec: &CampbellSpec) -> Result<(Campbell, Vec<String>)> {
    let mech = &study.mechanism;
    let steps = spec.points.max(2);
    let rpm: Vec<f64> =
        (0..steps).map(|i| spec.rpm_min + (spec.rpm_max - spec.rpm_min) * i as f64 / (steps - 1) as f64).collect();
    let spin = if spec.spin_held { Spin::Held } else { Spin::Free };
    let damping = if spec.damped { Damping::Damped } else { Damping::Undamped };
    let c = campbell(mech, &study.spec.spin_joint, &rpm, &spec.orders, spin, damping, None).map_err(lin(mech))?;
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

/// Writes the Campbell CSV and figure, and returns the summary section with the files written.
pub(crate) fn render_campbell(spec: &CampbellSpec, c: &Campbell, dir: &Path) -> Result<(String, Vec<PathBuf>)> {
    let steps = c.rpm.len();
    let mut header = vec!["rpm".to_string()];
    let mut cols: Vec<Vec<f64>> = vec![c.rpm.clone()];
    for (k, t) in c.tracks.iter().enumerate() {
        header.push(format!("mode{}_{}_hz", k + 1, t.label));
        cols.push(t.frequency_hz.clone());
        header.push(format!("mode{}_{}_damping_ratio", k + 1, t.label));
        cols.push(t.damping_ratio.clone());
    }
    for l in &c.order_lines {
        header.push(format!("order_{}_hz", l.order));
        cols.push(l.frequency_hz.clone());
    }
    let csv = dir.join(format!("{}.csv", spec.name));
    let h: Vec<&str> = header.iter().map(String::as_str).collect();
    let cc: Vec<&[f64]> = cols.iter().map(Vec::as_slice).collect();
    write_csv(&csv, &h, &cc)?;
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
    for l in &c.order_lines {
        series.push(Series {
            label: format!("order {}", l.order),
            x: c.rpm.clone(),
            y: l.frequency_hz.clone(),
            color: 7,
            style: LineStyle::Dotted,
        });
    }
    let top = series.iter().flat_map(|s| s.y.iter().copied()).filter(|v| v.is_finite()).fold(0.0, f64::max);
    let panel = Panel {
        title: format!("Campbell diagram ({})", if spec.spin_held { "spin held" } else { "spin free" }),
        x_label: "spin speed, rpm".into(),
        y_label: "frequency, Hz".into(),
        x_range: Some((spec.rpm_min, spec.rpm_max)),
        y_range: Some((0.0, 1.05 * top.max(f64::MIN_POSITIVE))),
        series,
        ..Panel::default()
    };
    let svg = dir.join(format!("{}.svg", spec.name));
    crate::plot::write_svg(&svg, &[panel], 760, 520)?;

    let mut md = String::new();
    let _ = writeln!(
        md,
        "## Campbell diagram `{}`: {}–{} rpm, spin {}\n",
        spec.name,
        spec.rpm_min,
        spec.rpm_max,
        if spec.spin_held { "held" } else { "free" }
    );
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
    Ok((md, vec![csv, svg]))
}
