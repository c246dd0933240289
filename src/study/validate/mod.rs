//! Validation of a study against its mechanism, before any work: every number finite and in
//! range, every name safe as a file name, every count bounded, and every order-tracking band
//! inside the usable spectrum of its window (the check the short-time FFT of `signal` would
//! otherwise make at run time, with no file or line). The estimated work is checked in `plan`.

use super::{AnalysisSpec, HbmParameter, StudySpec};
use crate::error::Result;
use crate::io::Source;
use crate::model::excitation::rpm_to_rad_s;
use crate::model::loads::ForceFrame;
use crate::model::mechanism::Mechanism;
use std::f64::consts::PI;

mod inputs;
pub mod limits;
mod outputs;
pub use inputs::MAX_TRANSIENT_S;
use inputs::{check_excite, check_transient};

pub use limits::*;

/// Why analyses about a steady spin (linear response, Campbell, multi-order, harmonic balance)
/// cannot be run on this mechanism, if they cannot: they need the spin angle to be cyclic. (The
/// linear ones take gravity and world-frame forces as an order-1 forcing all the same; `check`
/// says which.)
pub fn steady_spin_obstacle(mech: &Mechanism, spin: usize) -> Option<String> {
    let g = mech.loads.gravity;
    if g.x != 0.0 || g.y != 0.0 {
        return Some(format!(
            "mechanism `{}` has gravity ({}, {}) m/s²: the spinning state is then periodic at order 1, \
             not steady, which this analysis needs (OrderSweep, Transient, a HarmonicBalance continued in \
             Speed or Torque, LinearResponse, Campbell and MultiOrder's linear part take gravity); \
             set gravity to (0.0, 0.0)",
            mech.name, g.x, g.y
        ));
    }
    if mech.loads.point_forces.iter().any(|f| f.frame == ForceFrame::World) {
        return Some(format!(
            "mechanism `{}` has a world-frame point force: the spinning state is then not steady; \
             give the force in the body frame",
            mech.name
        ));
    }
    if let Some(s) = mech.joints[spin].spring {
        return Some(format!(
            "the spin joint `{}` has a spring ({} N·m/rad): a spinning rotor cannot wind a spring to ground",
            mech.joints[spin].name, s.stiffness
        ));
    }
    None
}

/// A number for a message: plain when moderate, in exponent form when huge or tiny.
fn g(v: f64) -> String {
    if v != 0.0 && !(1e-3..1e6).contains(&v.abs()) { format!("{v:e}") } else { format!("{v}") }
}

/// A finite, positive value.
fn pos(v: f64) -> bool {
    v.is_finite() && v > 0.0
}

/// Checks one study against its mechanism; the first problem found is returned with its file,
/// line:column and field path.
pub(crate) fn check(spec: &StudySpec, mech: &Mechanism, spin: usize, src: &Source) -> Result<()> {
    // The study name was checked before its mechanism was read (`Study::from_source`).
    let i = spec.integration;
    check_rtol(i.rtol).map_err(|m| src.error("integration.rtol", m))?;
    if !(pos(i.atol) && i.atol <= 1.0) {
        return Err(src.error("integration.atol", "absolute tolerance must be finite, positive and at most 1"));
    }
    check_sample_hz(i.sample_hz).map_err(|m| src.error("integration.sample_hz", m))?;
    if i.max_steps == 0 {
        return Err(src.error("integration.max_steps", "must be at least 1"));
    }
    let o = spec.order_tracking;
    if !pos(o.window_s) {
        return Err(src.error("order_tracking.window_s", "window must be finite and positive (s)"));
    }
    if !pos(o.hop_s) {
        return Err(src.error("order_tracking.hop_s", "hop must be finite and positive (s)"));
    }
    if o.hop_s * i.sample_hz < 1.0 {
        return Err(src.error("order_tracking.hop_s", "hop is shorter than one sample (raise hop_s or sample_hz)"));
    }
    if o.half_width_bins > 64 {
        return Err(
            src.error("order_tracking.half_width_bins", "at most 64 bins each side (2 is the 5-bin convention)")
        );
    }
    if spec.analyses.is_empty() {
        return Err(src.error("analyses", "no analyses: nothing to run"));
    }
    if spec.analyses.len() > MAX_ANALYSES {
        return Err(src.error("analyses", format!("{} analyses; at most {MAX_ANALYSES}", spec.analyses.len())));
    }
    if spec.lock.len() > MAX_LIST {
        return Err(src.error("lock", format!("{} locked joints; at most {MAX_LIST}", spec.lock.len())));
    }
    let mut names = std::collections::HashSet::new();
    for (k, a) in spec.analyses.iter().enumerate() {
        let at = |field: &str| format!("analyses[{k}].{field}");
        let name = a.name();
        if let Err(m) = check_file_name(name) {
            return Err(src.error(&at("name"), m));
        }
        if !names.insert(name.to_string()) {
            return Err(src.error(&at("name"), format!("duplicate analysis name `{name}`")));
        }
        // A harmonic balance at a fixed order takes gravity and world-frame forces (its base
        // period is then whole revolutions); a spring on the spin joint it cannot. The linear
        // analyses take them as an order-1 forcing of the steady rotation (`linear::gravity`):
        // LinearResponse, Campbell (modes unchanged at that order) and MultiOrder's linear part.
        let periodic_hbm = matches!(a, AnalysisSpec::HarmonicBalance(h) if h.parameter != HbmParameter::Order)
            && mech.joints[spin].spring.is_none();
        let linear =
            matches!(a, AnalysisSpec::LinearResponse(_) | AnalysisSpec::Campbell(_) | AnalysisSpec::MultiOrder(_));
        if !matches!(a, AnalysisSpec::OrderSweep(_) | AnalysisSpec::Transient(_) | AnalysisSpec::Compare(_))
            && !periodic_hbm
            && let Some(why) = steady_spin_obstacle(mech, spin)
        {
            let spring = mech.joints[spin].spring.is_some();
            if !linear || spring {
                return Err(src.error(&format!("analyses[{k}]"), format!("{} `{name}`: {why}", a.kind())));
            }
            if let AnalysisSpec::MultiOrder(m) = a {
                // Only the linear part: the steady time runs and the order-continued harmonic
                // balance assume a steady spin.
                let g = mech.loads.gravity;
                let what = if g.x != 0.0 || g.y != 0.0 {
                    format!("gravity ({}, {}) m/s²", g.x, g.y)
                } else {
                    "a world-frame point force".to_string()
                };
                for (on, field, part) in [
                    (m.time_domain, "time_domain", "steady time runs"),
                    (m.hbm, "hbm", "harmonic balance continued in order"),
                ] {
                    if on {
                        return Err(src.error(
                            &at(field),
                            format!(
                                "MultiOrder `{name}`: mechanism `{}` has {what}, which makes the spinning state \
                                 periodic at order 1; the {part} of this analysis need a steady spin. Only its \
                                 linear part takes gravity (and reports the order-1 response it forces): set \
                                 `{field}: false`, or use a HarmonicBalance continued in Speed or Torque",
                                mech.name
                            ),
                        ));
                    }
                }
            }
        }
        match a {
            AnalysisSpec::OrderSweep(s) => {
                check_excite(src, spec, mech, &at("excite"), &s.excite)?;
                rpm(src, &at("rpm"), s.rpm)?;
                order_range(src, &at("order_min"), s.order_min, s.order_max)?;
                if !pos(s.duration_s) {
                    return Err(src.error(&at("duration_s"), "duration must be finite and positive (s)"));
                }
                if s.duration_s < 2.0 * o.window_s {
                    return Err(src.error(
                        &at("duration_s"),
                        format!("a sweep shorter than two tracking windows ({} s) gives no trace", 2.0 * o.window_s),
                    ));
                }
                torques(src, &at("amplitudes"), &s.amplitudes, true)?;
                if s.directions.is_empty() || s.directions.len() > 2 || s.directions.first() == s.directions.get(1) {
                    return Err(src.error(&at("directions"), "give Up, Down or both, each once"));
                }
                common(src, &at(""), &s.multiples, s.ramp_s, s.mean_torque)?;
                if s.ramp_s > s.duration_s - 2.0 * o.window_s {
                    return Err(src.error(
                        &at("ramp_s"),
                        format!(
                            "the ramp-in ({} s) must end two tracking windows ({} s) before the sweep does ({} s), \
                             or no window sees the full torque",
                            g(s.ramp_s),
                            g(2.0 * o.window_s),
                            g(s.duration_s)
                        ),
                    ));
                }
                let omega = rpm_to_rad_s(s.rpm);
                tracking(src, &at("multiples"), spec, o.window_s, o.half_width_bins, omega, s.order_min, &s.multiples)?;
                tracking(src, &at("multiples"), spec, o.window_s, o.half_width_bins, omega, s.order_max, &s.multiples)?;
            }
            AnalysisSpec::MultiOrder(m) => {
                check_excite(src, spec, mech, &at("excite"), &m.excite)?;
                order(src, &at("order"), m.order)?;
                if m.speeds.is_empty() || m.speeds.len() > MAX_LIST {
                    return Err(src.error(&at("speeds"), format!("give 1 to {MAX_LIST} operating speeds")));
                }
                common(src, &at(""), &m.multiples, m.ramp_s, m.mean_torque)?;
                if !(pos(m.steady_tol) && m.steady_tol <= 1.0) {
                    return Err(src.error(&at("steady_tol"), "must be finite, positive and at most 1"));
                }
                if !pos(m.window_s) {
                    return Err(src.error(&at("window_s"), "window must be finite and positive (s)"));
                }
                if !(m.min_time_s.is_finite() && m.min_time_s >= 0.0) {
                    return Err(src.error(&at("min_time_s"), "must be finite and non-negative (s)"));
                }
                if !(m.max_time_s.is_finite() && m.max_time_s >= m.ramp_s + 2.0 * m.window_s) {
                    return Err(src.error(&at("max_time_s"), "must be finite and at least ramp_s + 2·window_s (s)"));
                }
                if m.min_time_s > m.max_time_s {
                    return Err(src.error(&at("min_time_s"), "must not exceed max_time_s"));
                }
                for (j, p) in m.speeds.iter().enumerate() {
                    let sp = format!("analyses[{k}].speeds[{j}]");
                    rpm(src, &format!("{sp}.rpm"), p.rpm)?;
                    if p.harmonics.is_empty() || p.harmonics.len() > MAX_LIST {
                        return Err(src.error(&format!("{sp}.harmonics"), format!("give 1 to {MAX_LIST} harmonics")));
                    }
                    for (h, hm) in p.harmonics.iter().enumerate() {
                        let hp = format!("{sp}.harmonics[{h}]");
                        order(src, &format!("{hp}.multiple"), hm.multiple)?;
                        torque(src, &format!("{hp}.amplitude"), hm.amplitude)?;
                        if !(hm.phase.is_finite() && hm.phase.abs() <= 1e3) {
                            return Err(src.error(&format!("{hp}.phase"), "phase must be finite, |α| ≤ 1000 rad"));
                        }
                    }
                    if m.time_domain {
                        let omega = rpm_to_rad_s(p.rpm);
                        tracking(src, &format!("{sp}.rpm"), spec, m.window_s, 2, omega, m.order, &m.multiples)?;
                    }
                }
            }
            AnalysisSpec::LinearResponse(l) => {
                check_excite(src, spec, mech, &at("excite"), &l.excite)?;
                rpm(src, &at("rpm"), l.rpm)?;
                if !(pos(l.from) && l.to.is_finite() && l.from < l.to && l.to <= MAX_ORDER) {
                    return Err(src.error(&at("from"), format!("need 0 < from < to ≤ {MAX_ORDER}")));
                }
                if l.points < 2 || l.points > MAX_POINTS {
                    return Err(src.error(&at("points"), format!("need 2 to {MAX_POINTS} points")));
                }
                if let Some(z) = &l.modal_damping {
                    modal_ratios(src, &at("modal_damping"), z)?;
                    if l.variants.iter().any(|v| !v.dampers.is_empty()) {
                        return Err(src.error(
                            &at("modal_damping"),
                            "modal damping replaces the dampers, so variants that set dampers do not apply",
                        ));
                    }
                }
                if l.relative && spec.lock.is_empty() {
                    return Err(src.error(
                        &at("relative"),
                        "orders relative to n_t need a locked joint (`lock`) to define the tuning order",
                    ));
                }
                if l.variants.len() > 32 {
                    return Err(src.error(&at("variants"), "at most 32 variants"));
                }
                let mut files = std::collections::HashSet::new();
                for (j, v) in l.variants.iter().enumerate() {
                    let vp = format!("analyses[{k}].variants[{j}]");
                    if v.label.is_empty() || v.label.chars().count() > MAX_NAME_CHARS {
                        return Err(src.error(
                            &format!("{vp}.label"),
                            format!("label must have 1 to {MAX_NAME_CHARS} characters"),
                        ));
                    }
                    if !files.insert(super::linear::slug(&v.label)) {
                        return Err(src.error(
                            &format!("{vp}.label"),
                            format!("label `{}` gives the same file name as an earlier variant's", v.label),
                        ));
                    }
                    if v.dampers.len() > MAX_LIST {
                        return Err(src.error(&format!("{vp}.dampers"), format!("at most {MAX_LIST} dampers")));
                    }
                    for (d, (joint, c)) in v.dampers.iter().enumerate() {
                        let dp = format!("{vp}.dampers[{d}]");
                        if mech.joint_index(joint).is_none() {
                            return Err(src.error(&dp, format!("unknown joint `{joint}`")));
                        }
                        if !(c.is_finite() && *c >= 0.0) {
                            return Err(src.error(&dp, format!("damping must be finite and non-negative, got {c}")));
                        }
                    }
                }
            }
            AnalysisSpec::DesignStudy(d) => {
                super::design::check(src, spec, mech, k, d)?;
                // The analysis a design study runs must be valid by itself: checked by these rules
                // on a study holding it alone, errors moved to their place inside this entry.
                let alone = StudySpec { analyses: vec![d.analysis.as_ref().clone()], ..spec.clone() };
                if let Err(e) = check(&alone, mech, spin, src) {
                    return Err(match e {
                        crate::error::Error::Input { location, message }
                            if location.path.starts_with("analyses[0]") =>
                        {
                            let rest = &location.path["analyses[0]".len()..];
                            src.error(&format!("analyses[{k}].analysis{rest}"), message)
                        }
                        other => other,
                    });
                }
                super::design::check_parameters(src, mech, spin, k, d)?;
            }
            AnalysisSpec::HarmonicBalance(h) => {
                check_excite(src, spec, mech, &at("excite"), &h.excite)?;
                check_hbm(src, spec, k, h)?
            }
            AnalysisSpec::Transient(t) => check_transient(src, spec, mech, spin, k, t)?,
            AnalysisSpec::FreeOscillation(f) => check_free(src, mech, spin, k, f)?,
            AnalysisSpec::Compare(c) => check_compare(src, k, c)?,
            AnalysisSpec::Campbell(c) => {
                if !(c.rpm_min.is_finite() && c.rpm_min >= 0.0 && c.rpm_max.is_finite() && c.rpm_max > c.rpm_min) {
                    return Err(src.error(&at("rpm_min"), "need 0 ≤ rpm_min < rpm_max"));
                }
                rpm(src, &at("rpm_max"), c.rpm_max)?;
                if c.points < 2 || c.points > MAX_POINTS {
                    return Err(src.error(&at("points"), format!("need 2 to {MAX_POINTS} points")));
                }
                if c.orders.len() > 64 {
                    return Err(src.error(&at("orders"), "at most 64 order lines"));
                }
                if let Some(z) = &c.modal_damping {
                    modal_ratios(src, &at("modal_damping"), z)?;
                }
                for (j, &n) in c.orders.iter().enumerate() {
                    order(src, &format!("analyses[{k}].orders[{j}]"), n)?;
                }
            }
        }
    }
    outputs::check_unique(spec, src)
}

/// A free oscillation: a speed, a joint with a coordinate other than the spin joint, and
/// release amplitudes inside the joint's travel.
fn check_free(src: &Source, mech: &Mechanism, spin: usize, k: usize, f: &super::FreeOscillationSpec) -> Result<()> {
    let at = |field: &str| format!("analyses[{k}].{field}");
    rpm(src, &at("rpm"), f.rpm)?;
    let j = mech.joint_index(&f.joint).ok_or_else(|| {
        let names: Vec<&str> = mech.joints.iter().map(|j| j.name.as_str()).collect();
        src.error(&at("joint"), format!("unknown joint `{}` (joints: {})", f.joint, names.join(", ")))
    })?;
    if j == spin || mech.coordinate(j).is_none() {
        return Err(src.error(&at("joint"), format!("joint `{}` is the spin joint or has no coordinate", f.joint)));
    }
    if f.amplitudes.is_empty() || f.amplitudes.len() > MAX_LIST {
        return Err(src.error(&at("amplitudes"), format!("need 1 to {MAX_LIST} amplitudes")));
    }
    let kind = mech.joints[j].kind;
    let travel = kind.travel();
    for (i, &a) in f.amplitudes.iter().enumerate() {
        if !(a.is_finite() && a != 0.0 && a.abs() < travel) {
            return Err(src.error(
                &format!("analyses[{k}].amplitudes[{i}]"),
                format!(
                    "amplitude must be finite, non-zero and inside the joint's travel (|a| < {} {}), got {a}",
                    g(travel),
                    kind.coordinate_unit()
                ),
            ));
        }
    }
    if !(1..=1000).contains(&f.periods) {
        return Err(src.error(&at("periods"), "need 1 to 1000 periods"));
    }
    Ok(())
}

/// A comparison: 1 to 8 mechanisms with distinct file-name labels, and analyses of the kinds a
/// comparison runs (each is checked against each mechanism when the mechanisms are read).
fn check_compare(src: &Source, k: usize, c: &super::CompareSpec) -> Result<()> {
    let at = |field: &str| format!("analyses[{k}].{field}");
    let most = super::compare::MAX_MECHANISMS;
    if c.mechanisms.is_empty() || c.mechanisms.len() > most {
        return Err(src.error(&at("mechanisms"), format!("need 1 to {most} mechanisms")));
    }
    let mut labels = std::collections::HashSet::new();
    for (v, m) in c.mechanisms.iter().enumerate() {
        let field = format!("analyses[{k}].mechanisms[{v}].label");
        check_file_name(&m.label).map_err(|e| src.error(&field, e))?;
        if !labels.insert(m.label.as_str()) {
            return Err(src.error(&field, format!("duplicate label `{}`", m.label)));
        }
    }
    if c.analyses.is_empty() || c.analyses.len() > MAX_ANALYSES {
        return Err(src.error(&at("analyses"), format!("need 1 to {MAX_ANALYSES} analyses")));
    }
    for (i, a) in c.analyses.iter().enumerate() {
        if !super::compare::allowed(a) {
            return Err(src.error(
                &format!("analyses[{k}].analyses[{i}]"),
                format!(
                    "a comparison runs OrderSweep, HarmonicBalance, FreeOscillation, LinearResponse, MultiOrder or \
                     Transient analyses, not {}",
                    a.kind()
                ),
            ));
        }
    }
    Ok(())
}

fn check_hbm(src: &Source, spec: &StudySpec, k: usize, h: &super::HbmSpec) -> Result<()> {
    let at = |field: &str| format!("analyses[{k}].{field}");
    let order_range_given = !(h.order_min == 0.0 && h.order_max == 0.0);
    let (needs_rpm, needs_orders, needs_amplitudes) = match h.parameter {
        HbmParameter::Order => (true, true, true),
        HbmParameter::Speed { order: n, rpm_min, rpm_max } => {
            order(src, &at("parameter"), n)?;
            if !(pos(rpm_min) && rpm_min < rpm_max && rpm_max <= MAX_RPM) {
                return Err(src.error(&at("parameter"), format!("Speed needs 0 < rpm_min < rpm_max ≤ {MAX_RPM:e}")));
            }
            (false, false, true)
        }
        HbmParameter::Torque { order: n, min, max } => {
            order(src, &at("parameter"), n)?;
            if !(pos(min) && min < max && max <= MAX_TORQUE_NM) {
                return Err(src.error(&at("parameter"), format!("Torque needs 0 < min < max ≤ {MAX_TORQUE_NM:e} N·m")));
            }
            (true, false, false)
        }
    };
    let what = "a Speed or Torque continuation takes its range from `parameter`";
    if needs_rpm {
        rpm(src, &at("rpm"), h.rpm)?;
    } else if h.rpm != 0.0 {
        return Err(src.error(&at("rpm"), format!("{what}: leave `rpm` out")));
    }
    if needs_orders {
        order_range(src, &at("order_min"), h.order_min, h.order_max)?;
    } else if order_range_given {
        return Err(src.error(&at("order_min"), format!("{what}: leave the order range out")));
    }
    if !needs_orders && h.overlay.is_some() {
        return Err(src.error(&at("overlay"), "sweeps can only be overlaid on order branches"));
    }
    // An engine (resolved at load, where its fields are checked) gives the amplitudes.
    if needs_amplitudes && h.engine.is_none() {
        torques(src, &at("amplitudes"), &h.amplitudes, false)?;
    } else if !h.amplitudes.is_empty() {
        return Err(src.error(&at("amplitudes"), format!("{what}: leave `amplitudes` out")));
    }
    check_harmonics(h.harmonics).map_err(|m| src.error(&at("harmonics"), m))?;
    if let Some(d) = h.max_step {
        check_max_step(d).map_err(|m| src.error(&at("max_step"), m))?;
    }
    if h.multiples.is_empty() || h.multiples.len() > 64 {
        return Err(src.error(&at("multiples"), "give 1 to 64 harmonic multiples"));
    }
    for (j, &m) in h.multiples.iter().enumerate() {
        // A periodic solution holds the harmonics 1..=H of its base order only.
        if !(m >= 1.0 && m.fract() == 0.0 && m <= h.harmonics as f64) {
            return Err(src.error(
                &format!("analyses[{k}].multiples[{j}]"),
                format!("reported multiples must be whole numbers from 1 to harmonics = {}, got {m}", h.harmonics),
            ));
        }
    }
    if let Some(o) = &h.overlay {
        let earlier = spec.analyses[..k].iter().any(|a| matches!(a, AnalysisSpec::OrderSweep(s) if &s.name == o));
        if !earlier {
            return Err(src.error(&at("overlay"), format!("no OrderSweep named `{o}` before this analysis")));
        }
    }
    Ok(())
}

/// Modal damping ratios: 1 to `MAX_LIST` of them, each finite in 0..=10.
fn modal_ratios(src: &Source, path: &str, z: &crate::linear::ModalDamping) -> Result<()> {
    let ratios = match z {
        crate::linear::ModalDamping::All(v) => std::slice::from_ref(v),
        crate::linear::ModalDamping::PerMode(v) => v.as_slice(),
    };
    if ratios.is_empty() || ratios.len() > MAX_LIST {
        return Err(src.error(path, format!("give 1 to {MAX_LIST} damping ratios")));
    }
    if let Some(bad) = ratios.iter().find(|z| !(z.is_finite() && (0.0..=10.0).contains(*z))) {
        return Err(src.error(path, format!("damping ratio {bad} must lie in 0..=10")));
    }
    Ok(())
}

fn rpm(src: &Source, path: &str, v: f64) -> Result<()> {
    check_rpm(v, false).map_err(|m| src.error(path, m))
}

fn order(src: &Source, path: &str, v: f64) -> Result<()> {
    check_order(v).map_err(|m| src.error(path, m))
}

fn order_range(src: &Source, path: &str, lo: f64, hi: f64) -> Result<()> {
    if pos(lo) && hi.is_finite() && lo < hi && hi <= MAX_ORDER {
        Ok(())
    } else {
        Err(src.error(path, format!("need 0 < order_min < order_max ≤ {MAX_ORDER}")))
    }
}

fn torque(src: &Source, path: &str, v: f64) -> Result<()> {
    check_torque(v).map_err(|m| src.error(path, m))
}

fn torques(src: &Source, path: &str, v: &[f64], allow_zero: bool) -> Result<()> {
    if v.is_empty() || v.len() > MAX_LIST {
        return Err(src.error(path, format!("give 1 to {MAX_LIST} amplitudes (N·m)")));
    }
    for (j, &a) in v.iter().enumerate() {
        torque(src, &format!("{path}[{j}]"), a)?;
        if !allow_zero && a == 0.0 {
            return Err(src.error(&format!("{path}[{j}]"), "a zero amplitude has no periodic response to continue"));
        }
    }
    let mut seen = v.to_vec();
    seen.sort_by(f64::total_cmp);
    if seen.windows(2).any(|w| w[0] == w[1]) {
        return Err(src.error(path, "an amplitude is given twice (its runs would write the same files)"));
    }
    Ok(())
}

/// Checks shared by the time-domain analyses; `prefix` ends with a dot.
fn common(src: &Source, prefix: &str, multiples: &[f64], ramp_s: f64, mean: Option<f64>) -> Result<()> {
    let field = |f: &str| format!("{prefix}{f}");
    if multiples.is_empty() || multiples.len() > 64 {
        return Err(src.error(&field("multiples"), "give 1 to 64 harmonic multiples (1 = main order)"));
    }
    for (j, &m) in multiples.iter().enumerate() {
        order(src, &field(&format!("multiples[{j}]")), m)?;
    }
    if !(ramp_s.is_finite() && ramp_s >= 0.0) {
        return Err(src.error(&field("ramp_s"), "ramp must be a finite, non-negative duration (s)"));
    }
    if let Some(m) = mean {
        torque(src, &field("mean_torque"), m)?;
    }
    Ok(())
}

/// The short-time FFT of a window of `window_s` at the study's sample rate must hold the band of
/// `2·half + 1` bins around each tracked line `m·n·Ω/2π` inside bins 1..N/2 − 1 (no DC, no
/// Nyquist; see `signal`'s calibration). Checked at one order `n` (the band moves linearly with
/// n, so the two ends of a sweep bound it).
#[allow(clippy::too_many_arguments)]
fn tracking(
    src: &Source,
    path: &str,
    spec: &StudySpec,
    window_s: f64,
    half: usize,
    omega: f64,
    n: f64,
    multiples: &[f64],
) -> Result<()> {
    let fs = spec.integration.sample_hz;
    let samples = (window_s * fs).round();
    if samples < MIN_WINDOW_SAMPLES {
        return Err(src.error(
            path,
            format!(
                "a tracking window of {window_s} s at {fs} Hz holds {samples} samples; at least {MIN_WINDOW_SAMPLES} \
                 (lengthen the window or raise integration.sample_hz)"
            ),
        ));
    }
    if samples > MAX_WINDOW_SAMPLES {
        return Err(src.error(
            path,
            format!(
                "a tracking window of {window_s} s at {fs} Hz holds {samples:e} samples; at most {MAX_WINDOW_SAMPLES:e}"
            ),
        ));
    }
    let last = (samples / 2.0).floor() - 1.0;
    for &m in multiples {
        let f = m * n * omega / (2.0 * PI);
        let centre = (f * window_s).round();
        let (lo, hi) = (centre - half as f64, centre + half as f64);
        if lo < 1.0 || hi > last {
            let advice = if lo < 1.0 {
                "lengthen the tracking window or lower half_width_bins"
            } else {
                "raise integration.sample_hz (the line is at or beyond Nyquist) or lower half_width_bins"
            };
            return Err(src.error(
                path,
                format!(
                    "the {m}× line at order {n} ({f:.4} Hz) needs bins {lo}..={hi} of a {window_s} s window at {fs} Hz, \
                     but only bins 1..={last} are usable: {advice}"
                ),
            ));
        }
    }
    Ok(())
}
