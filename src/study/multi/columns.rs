//! The MultiOrder CSV: one row per speed, its columns gathered source by source (engine
//! torques, order amplitudes, the linear response, the steady time window, the harmonic-balance
//! states), each source's element columns through `push_element_columns`.

use super::report::fmt_mult;
use super::{MultiOrderResult, SpeedResult, Steady, engine_orders};
use crate::model::joint::Joint;
use crate::study::elements::{ElementResponse, push_element_columns};
use crate::study::table::Table;
use crate::study::{MultiOrderSpec, Study};

/// The CSV table: one row per speed, per multiple the nonlinear, locked and ratio columns and
/// the linear ones as asked for, then the steadiness columns.
pub(crate) fn table(study: &Study, spec: &MultiOrderSpec, result: &MultiOrderResult) -> Table {
    let mut table = Table::new(spec.name.clone());
    table.push("rpm", "rpm", result.speeds.iter().map(|s| s.rpm).collect());
    // The engine's order torques at each speed: what drives every response column after them.
    for o in engine_orders(result) {
        let col = result.speeds.iter().map(|s| s.engine_torque(o)).collect();
        table.push(format!("engine_T_order{}_Nm", fmt_mult(o)), "N·m", col);
    }
    order_columns(&mut table, study, spec, result);
    if spec.linear {
        linear_element_columns(&mut table, study, spec, result);
    }
    if spec.time_domain {
        steady_columns(&mut table, study, spec, result);
    }
    if spec.hbm {
        hbm_columns(&mut table, study, spec, result);
    }
    table
}

/// One column per speed of `f`.
fn per_speed(result: &MultiOrderResult, f: &dyn Fn(&SpeedResult) -> f64) -> Vec<f64> {
    result.speeds.iter().map(f).collect()
}

/// The time-domain and linear amplitudes of each multiple, with the locked twin's and their
/// ratio, then gravity's order-1 line.
fn order_columns(table: &mut Table, study: &Study, spec: &MultiOrderSpec, result: &MultiOrderResult) {
    let has_locked = study.locked.is_some();
    for (k, m) in spec.multiples.iter().enumerate() {
        let tag = fmt_mult(*m);
        if spec.time_domain {
            table.push(format!("amp_{tag}x_rad_s2"), "rad/s²", per_speed(result, &|s| s.amplitude(k)));
            if has_locked {
                table.push(format!("locked_{tag}x_rad_s2"), "rad/s²", per_speed(result, &|s| s.locked_amplitude(k)));
                table.push(format!("ratio_{tag}x"), "1", per_speed(result, &|s| s.ratio(k)));
            }
        }
        if spec.linear {
            table.push(format!("linear_{tag}x_rad_s2"), "rad/s²", per_speed(result, &|s| s.linear_amplitude(k, false)));
            if has_locked {
                let col = per_speed(result, &|s| s.linear_amplitude(k, true));
                table.push(format!("linear_locked_{tag}x_rad_s2"), "rad/s²", col);
            }
        }
    }
    // Gravity's order-1 line (order 1 of the rotation, whatever the base order).
    if spec.linear && study.mechanism.loads.needs_world_orientation() {
        table.push(
            "linear_gravity_order1_rad_s2",
            "rad/s²",
            per_speed(result, &|s| s.linear_gravity.unwrap_or(f64::NAN)),
        );
        if has_locked {
            table.push(
                "linear_locked_gravity_order1_rad_s2",
                "rad/s²",
                per_speed(result, &|s| s.linear_gravity_locked.unwrap_or(f64::NAN)),
            );
        }
    }
}

/// An element's columns from whichever speeds `pick` finds it at (NaN elsewhere), skipped when
/// no speed has it; its torque columns when any found response carries a torque.
fn push_found_element(
    table: &mut Table,
    joint: &Joint,
    multiples: &[f64],
    prefix: &str,
    result: &MultiOrderResult,
    pick: &dyn Fn(&SpeedResult) -> Option<ElementResponse>,
) {
    if !result.speeds.iter().any(|s| pick(s).is_some()) {
        return;
    }
    let el = |f: &dyn Fn(&ElementResponse) -> f64| per_speed(result, &|s| pick(s).map_or(f64::NAN, |x| f(&x)));
    let torque = result.speeds.iter().filter_map(pick).any(|x| x.torque.is_some());
    push_element_columns(table, joint, multiples, torque, prefix, &el);
}

/// Each reported element in the linear response: its amplitude per order and peak, and its
/// spring-and-damper torque.
fn linear_element_columns(table: &mut Table, study: &Study, spec: &MultiOrderSpec, result: &MultiOrderResult) {
    for (e, &j) in study.elements.iter().enumerate() {
        let joint = &study.mechanism.joints[j];
        let pick = |s: &SpeedResult| s.linear_elements.get(e).filter(|x| x.joint == joint.name).cloned();
        push_found_element(table, joint, &spec.multiples, "linear_", result, &pick);
    }
}

/// The steadiness of each time run, then each reported element over the last window: its
/// amplitude per order and peak, and its spring-and-damper torque (N·m; N for a slide).
fn steady_columns(table: &mut Table, study: &Study, spec: &MultiOrderSpec, result: &MultiOrderResult) {
    let col = |f: &dyn Fn(&Steady) -> f64| per_speed(result, &|s| s.response.as_ref().map_or(f64::NAN, f));
    table.push("steady_change", "1", col(&|s| s.change));
    table.push("max_relative_angle_rad", "rad", col(&|s| s.max_relative_angle));
    table.push("simulated_s", "s", col(&|s| s.time_s));
    for (e, &j) in study.elements.iter().enumerate() {
        let el = |f: &dyn Fn(&ElementResponse) -> f64| {
            per_speed(result, &|s| s.response.as_ref().and_then(|r| r.elements.get(e)).map_or(f64::NAN, f))
        };
        let joint = &study.mechanism.joints[j];
        let torque = joint.spring.is_some() || joint.damper != 0.0;
        push_element_columns(table, joint, &spec.multiples, torque, "", &el);
    }
}

/// The harmonic-balance amplitudes of each multiple, the elements on the torque ramp's state (of
/// the mechanism and of the locked twin, by joint name: the twin lacks the locked joints), then
/// every state at each speed, numbered as `hbm` lists them: the upper state's elements where the
/// low branch folds before the full torques and no ramp state carries them.
fn hbm_columns(table: &mut Table, study: &Study, spec: &MultiOrderSpec, result: &MultiOrderResult) {
    let has_locked = study.locked.is_some();
    for (k, m) in spec.multiples.iter().enumerate() {
        let tag = fmt_mult(*m);
        table.push(format!("hbm_{tag}x_rad_s2"), "rad/s²", per_speed(result, &|s| s.hbm_amplitude(k, false)));
        if has_locked {
            table.push(format!("hbm_locked_{tag}x_rad_s2"), "rad/s²", per_speed(result, &|s| s.hbm_amplitude(k, true)));
            table.push(format!("hbm_ratio_{tag}x"), "1", per_speed(result, &|s| s.hbm_ratio(k)));
        }
    }
    for (prefix, locked) in [("hbm_", false), ("hbm_locked_", true)] {
        if locked && !has_locked {
            continue;
        }
        for &j in &study.elements {
            let joint = &study.mechanism.joints[j];
            let pick = |s: &SpeedResult| -> Option<ElementResponse> {
                let st = if locked { s.hbm_locked.as_ref() } else { s.hbm_ramp.as_ref() }?;
                st.elements.iter().find(|e| e.joint == joint.name).cloned()
            };
            push_found_element(table, joint, &spec.multiples, prefix, result, &pick);
        }
    }
    let states = result.speeds.iter().map(|s| s.hbm.len()).max().unwrap_or(0);
    for k in 0..states {
        let prefix = format!("hbm_state{}_", k + 1);
        let stable = |s: &SpeedResult| s.hbm.get(k).and_then(|h| h.stable).map_or(f64::NAN, f64::from);
        table.push(format!("{prefix}stable"), "1", per_speed(result, &stable));
        for &j in &study.elements {
            let joint = &study.mechanism.joints[j];
            let pick = |s: &SpeedResult| -> Option<ElementResponse> {
                s.hbm.get(k)?.elements.iter().find(|e| e.joint == joint.name).cloned()
            };
            push_found_element(table, joint, &spec.multiples, &prefix, result, &pick);
        }
    }
}
