//! The linear response of a study: the order-domain frequency response normalised by the locked
//! twin (paper eq. 22, Fig. 2), per damping variant, with each element's response (the Campbell
//! diagram is in `campbell`).

mod analysis;
mod figure;
mod spec;
mod summary;
pub use spec::*;

use super::table::Table;
use super::{Output, Study};
use crate::error::{Error, Result};
use crate::linear::{Damping, LinearError, LinearModel, OrderResponse, ResponseSpec, Spin};
use crate::model::excitation::rpm_to_rad_s;
use crate::model::mechanism::Mechanism;
use nalgebra::DVector;
use std::path::{Path, PathBuf};

/// A variant label as a file-name part: ASCII letters, digits, `.` and `-` stay; every run of
/// other characters (spaces, `=`, `_`, `/`, non-ASCII) becomes one `_`, and none is left at
/// either end: `c_p = 5e-4` → `c_p_5e-4`, `locked (rigid)` → `locked_rigid`. The result is safe
/// on every file system and shell (no separators, quotes or `=`), and two labels that give the
/// same name are refused at load (the analysis's `check`).
pub(crate) fn slug(label: &str) -> String {
    let keep = |c: char| c.is_ascii_alphanumeric() || c == '.' || c == '-';
    let mut out = String::with_capacity(label.len());
    for c in label.chars() {
        if keep(c) {
            out.push(c);
        } else if !out.is_empty() && !out.ends_with('_') {
            out.push('_');
        }
    }
    if out.ends_with('_') {
        out.pop();
    }
    out
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
    /// |(k + iωc)·q̂| per N·m at each order: the torque its spring and damper transmit, and the
    /// compliant mesh driving it, if any ([`crate::linear::ElementLaw`]; N·m per N·m, N per N·m
    /// for a slide). With modal damping in place of the dampers, the springs' alone.
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
    let modes = mode_rows(study, spec, &model)?;
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
    let sweep = Sweep { study, spec, omega, n_t, rspec, orders };
    let mut results = Vec::new();
    let mut failures = Vec::new();
    for (vi, v) in variants.iter().enumerate() {
        sweep.watch(mech, format!("before variant `{}` ({} of {})", v.label, vi + 1, variants.len()))?;
        results.push(sweep.variant(v, &mut failures)?);
    }
    let result = LinearResult { name: spec.name.clone(), n_t, free_orders, modes, variants: results };
    Ok((result, failures))
}

/// The modal table of the mechanism as built: eigen-orders, damping ratios and the joint that
/// dominates each mode, with the spin held (absorber alone) and free (coupled), undamped and
/// damped. With modal damping the damped rows are those of the damping in force in the response
/// (the modal matrix of the spin-free modes, alone or with the dampers), not the dampers'.
fn mode_rows(study: &Study, spec: &LinearResponseSpec, model: &LinearModel) -> Result<Vec<ModeRow>> {
    let mech = &study.mechanism;
    let damped_model = match spec.modal() {
        Some((z, how)) => model.with_modal_damping_combined(Spin::Free, z, how).map_err(lin(mech))?,
        None => model.clone(),
    };
    let mut modes = Vec::new();
    for (spin, spin_held) in [(Spin::Held, true), (Spin::Free, false)] {
        for (damping, damped) in [(Damping::Undamped, false), (Damping::Damped, true)] {
            let model = if damped { &damped_model } else { model };
            for m in &model.modes(spin, damping).map_err(lin(mech))?.modes {
                let (order, damping_ratio, label) = (m.order, m.damping_ratio, m.label.clone());
                modes.push(ModeRow { spin_held, damped, order, damping_ratio, label });
            }
        }
    }
    Ok(modes)
}

/// Orders per watchdog check: the response is checked between variants and every `CHUNK` orders.
const CHUNK: usize = 4096;

/// What every variant's response shares: the operating speed (rad/s), the tuning order, the
/// response's inputs and body, and the order grid.
struct Sweep<'a> {
    study: &'a Study,
    spec: &'a LinearResponseSpec,
    omega: f64,
    n_t: Option<f64>,
    rspec: ResponseSpec,
    orders: Vec<f64>,
}

impl Sweep<'_> {
    /// The watchdog: an error naming where the response got to (`reached`) once it has passed.
    fn watch(&self, m: &Mechanism, reached: String) -> Result<()> {
        match self.study.spec.integration.deadline.filter(|d| d.passed()) {
            Some(d) => Err(lin(m)(LinearError::Watchdog { reached, budget_s: d.budget_s })),
            None => Ok(()),
        }
    }

    /// One variant's response over the order grid (the mechanism with its dampers), with its
    /// extremes, first amplification, asymptote, gravity's line and elements; a response or a
    /// gravity line that is not finite is listed in `failures`.
    fn variant(&self, v: &Variant, failures: &mut Vec<String>) -> Result<ResponseVariant> {
        let (study, spec, orders) = (self.study, self.spec, &self.orders);
        let steps = orders.len();
        let modal = spec.modal();
        let m = with_dampers(&study.mechanism, &v.dampers);
        let mut resp = OrderResponse::new(&m, &self.rspec, self.omega, None).map_err(lin(&m))?;
        // Modal damping replaces (or adds to) the dampers of both the mechanism and its locked
        // twin, modes with the spin free as the response is taken.
        if let Some((z, how)) = modal {
            resp.model = resp.model.with_modal_damping_combined(Spin::Free, z, how).map_err(lin(&m))?;
            resp.locked = resp.locked.with_modal_damping_combined(Spin::Free, z, how).map_err(lin(&m))?;
        }
        let mut pts = Vec::with_capacity(orders.len());
        for (c, chunk) in orders.chunks(CHUNK).enumerate() {
            self.watch(&m, format!("in variant `{}` at order {} of {}", v.label, c * CHUNK, orders.len()))?;
            pts.extend(resp.sweep(chunk).map_err(lin(&m))?);
        }
        let locked_max = pts.iter().map(|p| p.locked.abs()).fold(0.0, f64::max);
        let ratio: Vec<f64> = pts.iter().map(|p| super::ratio(p.response, p.locked, locked_max)).collect();
        // Extremes refined by the linear module's golden-section search around the grid's.
        let ext = resp.extremes(orders[0], orders[steps - 1], steps).map_err(lin(&m))?;
        let crossing = match self.n_t {
            Some(nt) if nt < orders[steps - 1] => {
                resp.first_amplification(nt.max(orders[0]), orders[steps - 1], steps).map_err(lin(&m))?
            }
            _ => None,
        };
        let asymptote = resp.asymptote().map_err(lin(&m))?;
        let gravity = self.gravity(&m, &resp)?;
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
        let elements = self.elements(&m, &resp, &v.label)?;
        Ok(ResponseVariant {
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
        })
    }

    /// Gravity's order-1 line of mechanism `m` (with modal damping, through the modally damped
    /// model), None without gravity.
    fn gravity(&self, m: &Mechanism, resp: &OrderResponse) -> Result<Option<GravityResponse>> {
        if !resp.model.has_gravity() {
            return Ok(None);
        }
        let q = resp.gravity_coordinates().map_err(lin(m))?;
        Ok(Some(GravityResponse {
            accel: resp.gravity_response().map_err(lin(m))?.norm(),
            locked: resp.gravity_locked_response().map_err(lin(m))?.norm(),
            elements: self.study.elements.iter().filter_map(|&j| m.coordinate(j)).map(|c| q[c].norm()).collect(),
        }))
    }

    /// Every element's coordinate and spring-and-damper torque per N·m over the order grid, from
    /// one solve per order for all of them (the dampers left out where modal damping replaces
    /// them).
    fn elements(&self, m: &Mechanism, resp: &OrderResponse, label: &str) -> Result<Vec<ElementFrf>> {
        let (orders, omega) = (&self.orders, self.omega);
        let mut states: Vec<Option<DVector<crate::linear::C64>>> = Vec::with_capacity(orders.len());
        for (c, chunk) in orders.chunks(CHUNK).enumerate() {
            self.watch(m, format!("in variant `{label}` at element order {} of {}", c * CHUNK, orders.len()))?;
            states.extend(chunk.iter().map(|&n| resp.coordinate_responses(n).ok()));
        }
        let replaced = matches!(self.spec.modal(), Some((_, crate::linear::ModalCombination::Replace)));
        let mut elements = Vec::with_capacity(self.study.elements.len());
        for &j in &self.study.elements {
            let joint = &m.joints[j];
            let Some(c) = m.coordinate(j) else { continue };
            // The joint's spring and damper and the compliant mesh driving it (a shaft written as
            // a mesh between two gears has its stiffness there); none transmits nothing.
            let law = crate::linear::element_law(m, j, !replaced);
            let (amplitude, torque) = orders
                .iter()
                .zip(&states)
                .map(|(&n, q)| match q {
                    Some(q) => (q[c].norm(), law.as_ref().map_or(0.0, |l| l.phasor(q.as_slice(), n * omega).norm())),
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
        Ok(elements)
    }
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

/// Writes one CSV per variant ([`response_tables`]) and the figure (the paper's Fig. 2), and
/// returns the summary section with the files written.
pub(crate) fn render_response(
    study: &Study,
    spec: &LinearResponseSpec,
    result: &LinearResult,
    dir: &Path,
) -> Result<(String, Vec<PathBuf>)> {
    let mut files = Vec::new();
    for t in response_tables(study, spec, result) {
        files.push(t.write_csv(dir)?);
    }
    files.push(figure::response_figure(study, spec, result, dir)?);
    Ok((summary::summary(study, spec, result), files))
}

#[cfg(test)]
mod slug_tests {
    use super::slug;

    #[test]
    fn labels_become_readable_safe_file_name_parts() {
        for (label, name) in [
            ("c_p = 5e-4", "c_p_5e-4"),
            ("c_p=5e-4", "c_p_5e-4"),
            ("  locked (rigid) ", "locked_rigid"),
            ("ζ = 0.02", "0.02"),
            ("a/b\\c:d", "a_b_c_d"),
            ("plain-1.5", "plain-1.5"),
        ] {
            assert_eq!(slug(label), name, "{label:?}");
        }
    }
}
