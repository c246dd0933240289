//! The linear response of a study: the order-domain frequency response normalised by the locked
//! twin (paper eq. 22, Fig. 2), per damping variant, with each element's response (the Campbell
//! diagram is in `campbell`).

mod analysis;
mod spec;
pub use spec::*;

use super::table::Table;
use super::{Output, Study};
use crate::error::{Error, Result};
use crate::linear::{Damping, LinearError, LinearModel, OrderResponse, ResponseSpec, Spin};
use crate::model::excitation::rpm_to_rad_s;
use crate::model::mechanism::Mechanism;
use crate::plot::{LineStyle, Panel, Series};
use nalgebra::DVector;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// A variant label as a file-name part: characters other than letters, digits, `.` and `-`
/// become `_`.
pub(crate) fn slug(label: &str) -> String {
    label.chars().map(|c| if c.is_ascii_alphanumeric() || c == '.' || c == '-' { c } else { '_' }).collect()
}

/// A variant's legend entry with the unit of what it sets: the label as written when it names
/// the unit, the label and the unit when it ends with the one damping it sets (`c_p = 5e-4` →
/// `c_p = 5e-4 N·m·s/rad`: the paper study's labels, which also name its CSV files and so stay
/// as they are), else the label and the dampings with their units in brackets.
fn legend(study: &Study, v: &Variant) -> String {
    let unit = |joint: &str| {
        let slide =
            study.mechanism.joint_index(joint).is_some_and(|j| study.mechanism.joints[j].kind.slide_axis().is_some());
        if slide { "N·s/m" } else { "N·m·s/rad" }
    };
    if v.dampers.is_empty() || v.dampers.iter().any(|(j, _)| v.label.contains(unit(j))) {
        return v.label.clone();
    }
    let last = v.label.rsplit([' ', '=']).next().and_then(|t| t.parse::<f64>().ok());
    match (&v.dampers[..], last) {
        ([(j, c)], Some(x)) if (x - c).abs() <= 1e-9 * c.abs() => format!("{} {}", v.label, unit(j)),
        _ => {
            let set: Vec<String> =
                v.dampers.iter().map(|(j, c)| format!("{j}: {} {}", crate::plot::num(*c, 4), unit(j))).collect();
            format!("{} ({})", v.label, set.join(", "))
        }
    }
}

/// Linear results of one variant, for tests and reports.
#[derive(Debug, Clone, serde::Serialize, schemars::JsonSchema)]
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
    /// The smallest ratio: (its order, the ratio).
    pub min: (f64, f64),
    /// The largest ratio: (its order, the ratio).
    pub max: (f64, f64),
    /// First order above n_t where the ratio exceeds 1.
    pub crossing: Option<f64>,
    /// High-order limit of the ratio.
    pub asymptote: f64,
    /// Each reported element's response per unit torque at each order.
    pub elements: Vec<ElementFrf>,
    /// With gravity: its order-1 response (not per unit torque), see [`GravityResponse`].
    pub gravity: Option<GravityResponse>,
}

/// The steady order-1 response that gravity forces at the nominal rotation, spin free, in the
/// linear model (`linear::gravity`: exact to first order; the gravity × deflection terms are
/// neglected).
#[derive(Debug, Clone, serde::Serialize, schemars::JsonSchema)]
pub struct GravityResponse {
    /// |α̂| of the watched body at order 1, rad/s².
    pub accel: f64,
    /// The locked twin's |α̂| at order 1, rad/s².
    pub locked: f64,
    /// Each reported element's |q̂| at order 1 (rad; m for a slide), as `elements`.
    pub elements: Vec<f64>,
}

/// One element's linear response per unit excitation torque over the orders of a variant.
#[derive(Debug, Clone, serde::Serialize, schemars::JsonSchema)]
pub struct ElementFrf {
    /// The joint.
    pub joint: String,
    /// Unit of its coordinate (rad or m).
    pub unit: &'static str,
    /// |q̂| per N·m at each order (rad or m per N·m).
    pub amplitude: Vec<f64>,
    /// |(k + iωc)·q̂| per N·m at each order: the torque its spring and damper transmit (N·m per
    /// N·m; N per N·m for a slide). Under modal damping, the spring's alone.
    pub torque: Vec<f64>,
}

/// A linear frequency-response analysis.
#[derive(Debug, Clone, serde::Serialize, schemars::JsonSchema)]
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
#[derive(Debug, Clone, serde::Serialize, schemars::JsonSchema)]
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

pub(crate) fn lin(mech: &Mechanism) -> impl Fn(LinearError) -> Error + '_ {
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
    Ok(Output { markdown, files, failures, results: Box::new(result) })
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
    // With modal damping the damped rows are those of the damping in force in the response (the
    // modal matrix of the spin-free modes, alone or with the dampers), not the dampers'.
    let modal = spec.modal();
    let damped_model = match modal {
        Some((z, how)) => model.with_modal_damping_combined(Spin::Free, z, how).map_err(lin(mech))?,
        None => model.clone(),
    };
    for (spin, spin_held) in [(Spin::Held, true), (Spin::Free, false)] {
        for (damping, damped) in [(Damping::Undamped, false), (Damping::Damped, true)] {
            let model = if damped { &damped_model } else { &model };
            for m in &model.modes(spin, damping).map_err(lin(mech))?.modes {
                let (order, damping_ratio, label) = (m.order, m.damping_ratio, m.label.clone());
                modes.push(ModeRow { spin_held, damped, order, damping_ratio, label });
            }
        }
    }
    let free_orders: Vec<(f64, String)> = free.modes.iter().map(|m| (m.order, m.label.clone())).collect();
    let rspec = ResponseSpec {
        spin_joint: study.spec.spin_joint.clone(),
        inputs: study.inputs(&crate::study::excite_at_rpm(&spec.excite, spec.rpm)),
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
    // The watchdog: checked between variants and every `CHUNK` orders.
    const CHUNK: usize = 4096;
    let deadline = study.spec.integration.deadline;
    let watch = |m: &crate::model::mechanism::Mechanism, reached: String| -> Result<()> {
        match deadline.filter(|d| d.passed()) {
            Some(d) => Err(lin(m)(LinearError::Watchdog { reached, budget_s: d.budget_s })),
            None => Ok(()),
        }
    };
    for (vi, v) in variants.iter().enumerate() {
        watch(mech, format!("before variant `{}` ({} of {})", v.label, vi + 1, variants.len()))?;
        let m = with_dampers(mech, &v.dampers);
        let mut resp = OrderResponse::new(&m, &rspec, omega, None).map_err(lin(&m))?;
        // Modal damping replaces (or adds to) the dampers of both the mechanism and its locked
        // twin, modes with the spin free as the response is taken.
        if let Some((z, how)) = modal {
            resp.model = resp.model.with_modal_damping_combined(Spin::Free, z, how).map_err(lin(&m))?;
            resp.locked = resp.locked.with_modal_damping_combined(Spin::Free, z, how).map_err(lin(&m))?;
        }
        let mut pts = Vec::with_capacity(orders.len());
        for (c, chunk) in orders.chunks(CHUNK).enumerate() {
            watch(&m, format!("in variant `{}` at order {} of {}", v.label, c * CHUNK, orders.len()))?;
            pts.extend(resp.sweep(chunk).map_err(lin(&m))?);
        }
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
        // Gravity's order-1 line (with modal damping, through the modally damped model).
        let gravity = if resp.model.has_gravity() {
            let q = resp.gravity_coordinates().map_err(lin(&m))?;
            Some(GravityResponse {
                accel: resp.gravity_response().map_err(lin(&m))?.norm(),
                locked: resp.gravity_locked_response().map_err(lin(&m))?.norm(),
                elements: study.elements.iter().filter_map(|&j| m.coordinate(j)).map(|c| q[c].norm()).collect(),
            })
        } else {
            None
        };
        if let Some(g) = &gravity
            && !(g.accel.is_finite() && g.locked.is_finite() && g.elements.iter().all(|v| v.is_finite()))
        {
            failures.push(format!("{} variant `{}`: the gravity response is not finite", spec.name, v.label));
        }
        if let Some(i) = pts.iter().position(|p| !(p.response.is_finite() && p.locked.is_finite())) {
            failures.push(format!(
                "{} variant `{}`: the response is not finite at order {} (left empty in the CSV)",
                spec.name, v.label, orders[i]
            ));
        }
        // One solve per order for every element's coordinate.
        let mut states: Vec<Option<DVector<crate::linear::C64>>> = Vec::with_capacity(orders.len());
        for (c, chunk) in orders.chunks(CHUNK).enumerate() {
            watch(&m, format!("in variant `{}` at element order {} of {}", v.label, c * CHUNK, orders.len()))?;
            states.extend(chunk.iter().map(|&n| resp.coordinate_responses(n).ok()));
        }
        let mut elements = Vec::with_capacity(study.elements.len());
        for &j in &study.elements {
            let joint = &m.joints[j];
            let Some(c) = m.coordinate(j) else { continue };
            let k = joint.spring.map_or(0.0, |s| s.stiffness);
            let replaced = matches!(modal, Some((_, crate::linear::ModalCombination::Replace)));
            let damper = if replaced { 0.0 } else { joint.damper };
            let (amplitude, torque) = orders
                .iter()
                .zip(&states)
                .map(|(&n, q)| match q {
                    Some(q) => (q[c].norm(), (crate::linear::C64::new(k, n * omega * damper) * q[c]).norm()),
                    None => (f64::NAN, f64::NAN),
                })
                .unzip();
            elements.push(ElementFrf {
                joint: joint.name.clone(),
                unit: joint.kind.coordinate_unit(),
                amplitude,
                torque,
            });
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
            elements,
            gravity,
        });
    }
    let result = LinearResult { name: spec.name.clone(), n_t, free_orders, modes, variants: results };
    Ok((result, failures))
}

/// The linear response's CSV tables, one per variant: the order, and with a locked twin the
/// order over n_t (over 1 when the orders are absolute), both responses per unit torque and
/// their ratio; without one, the order and the response only (nothing to normalise by).
pub(crate) fn response_tables(study: &Study, spec: &LinearResponseSpec, r: &LinearResult) -> Vec<Table> {
    let normalised = !study.spec.lock.is_empty();
    let scale = if spec.relative { r.n_t.unwrap_or(1.0) } else { 1.0 };
    r.variants
        .iter()
        .map(|v| {
            let mut t = Table::new(format!("{}_{}", spec.name, slug(&v.label)));
            t.push("order", "1", v.orders.clone());
            if normalised {
                t.push("order_over_nt", "1", v.orders.iter().map(|n| n / scale).collect());
            }
            t.push("accel_per_torque_rad_s2_per_Nm", "rad/s² per N·m", v.response.clone());
            if normalised {
                t.push("locked_rad_s2_per_Nm", "rad/s² per N·m", v.locked.clone());
                t.push("ratio", "1", v.ratio.clone());
            }
            for e in &v.elements {
                let (q, tq, qu, tu) = if e.unit == "m" {
                    ("m_per_Nm", "torque_N_per_Nm", "m per N·m", "N per N·m")
                } else {
                    ("rad_per_Nm", "torque_Nm_per_Nm", "rad per N·m", "1")
                };
                t.push(format!("{}_{q}", e.joint), qu, e.amplitude.clone());
                t.push(format!("{}_{tq}", e.joint), tu, e.torque.clone());
            }
            t
        })
        .collect()
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
    // Without a locked twin the response is not normalised: ratios, n_t and the crossing of 1 do
    // not apply, and none is written (they would read 1 and NaN).
    let normalised = !study.spec.lock.is_empty();
    let scale = if spec.relative { n_t.unwrap_or(1.0) } else { 1.0 };
    let mut files = Vec::new();
    for t in response_tables(study, spec, result) {
        files.push(t.write_csv(dir)?);
    }
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
    let body = &study.spec.response_body;
    let legends: Vec<String> = results
        .iter()
        .map(|r| {
            spec.variants.iter().find(|v| v.label == r.label).map_or_else(|| r.label.clone(), |v| legend(study, v))
        })
        .collect();
    let mut series: Vec<Series> = results
        .iter()
        .enumerate()
        .map(|(k, r)| Series {
            label: legends[k].clone(),
            x: r.orders.iter().map(|n| n / scale).collect(),
            y: if normalised { r.ratio.clone() } else { r.response.clone() },
            color: k,
            style: LineStyle::Solid,
        })
        .collect();
    if normalised {
        series.push(Series {
            label: "unity".into(),
            x: vec![spec.from, spec.to],
            y: vec![1.0, 1.0],
            color: 7,
            style: LineStyle::Dotted,
        });
    }
    let panel = Panel {
        title: if normalised {
            format!("Linear response normalised by the locked twin, {} rpm", spec.rpm)
        } else {
            format!("Linear response, {} rpm", spec.rpm)
        },
        x_label: x_label.into(),
        y_label: if normalised {
            format!("{body} acceleration / locked")
        } else {
            format!("{body} acceleration per torque, rad/s² per N·m")
        },
        log_y: true,
        x_range: Some((spec.from, spec.to)),
        markers,
        series,
        ..Panel::default()
    };
    let mut panels = vec![panel];
    // The elements' amplitudes per N·m: one curve per element and variant.
    let element_series: Vec<Series> = results
        .iter()
        .enumerate()
        .flat_map(|(v, r)| {
            let legend = &legends[v];
            r.elements.iter().enumerate().map(move |(e, el)| Series {
                label: if results.len() > 1 { format!("{} ({legend})", el.joint) } else { el.joint.clone() },
                x: r.orders.iter().map(|n| n / scale).collect(),
                y: el.amplitude.clone(),
                color: e,
                style: [LineStyle::Solid, LineStyle::Dashed, LineStyle::Dotted][v % 3],
            })
        })
        .collect();
    if !element_series.is_empty() {
        panels.push(Panel {
            title: format!("Elements per N·m, {} rpm", spec.rpm),
            x_label: x_label.into(),
            y_label: "amplitude per torque, rad per N·m (m per N·m for slides)".into(),
            log_y: true,
            x_range: Some((spec.from, spec.to)),
            series: element_series,
            ..Panel::default()
        });
    }
    let svg = dir.join(format!("{}.svg", spec.name));
    crate::plot::write_svg(&svg, &panels, 640, 480)?;
    files.push(svg);

    let mut md = String::new();
    let _ = writeln!(md, "## Linear frequency response `{}`: {} rpm (eq. 22)\n", spec.name, spec.rpm);
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
    if let Some((z, how)) = modal {
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
    md += &gravity_table(study, spec, results);
    if !normalised {
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
        md += &element_table(results);
        return Ok((md, files));
    }
    let _ = writeln!(
        md,
        "\n| variant | min ratio | at n | at n/n_t | max ratio | at n | at n/n_t | first n > n_t with ratio > 1 | n/n_t | high-order asymptote |"
    );
    let _ = writeln!(md, "|---|---|---|---|---|---|---|---|---|---|");
    // n/n_t is printed only where n_t exists (a locked joint with a held-spin mode).
    let per_nt = |n: f64| n_t.map_or("–".to_string(), |nt| format!("{:.6}", n / nt));
    for r in results {
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
    md += &element_table(results);
    Ok((md, files))
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
                super::cell(na, 5),
                sci(t),
                super::cell(nt, 5)
            );
        }
    }
    md.push('\n');
    md
}
