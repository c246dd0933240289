//! The analysis's CSV tables (one per branch: the continued parameter, the accelerations, the
//! largest angle, stability and the elements) and what the summary counts per branch.

use super::{HbmBranch, HbmSpec, axis, jump_lag, jump_orders};
use crate::model::mechanism::Mechanism;
use crate::study::Study;
use crate::study::elements::ElementResponse;
use crate::study::sweep::SweepRun;
use crate::study::table::Table;

/// One CSV table per branch: the continued parameter, the acceleration per reported multiple,
/// the largest relative angle, stability (1 stable, 0 unstable, empty unknown) and the largest
/// Floquet multiplier modulus at each solved point.
pub(crate) fn tables(mech: &Mechanism, spec: &HbmSpec, branches: &[&HbmBranch]) -> Vec<Table> {
    let ax = axis(spec);
    branches
        .iter()
        .map(|br| {
            // A switched branch is named by its branch point (`hb_500Nm_switched_3.08137`).
            let dir_tag = match br.switched_at {
                Some(at) => format!("switched_{at:.5}"),
                None if br.from > ax.range.0 => "from_above".into(),
                None => "from_below".into(),
            };
            let mut table = if br.amplitude.is_nan() {
                Table::new(format!("{}_{dir_tag}", spec.name))
            } else {
                Table::new(format!("{}_{}Nm_{dir_tag}", spec.name, crate::study::sweep::fmt_num(br.amplitude)))
            };
            table.push(ax.column, ax.unit, br.parameter.clone());
            for (k, m) in spec.multiples.iter().enumerate() {
                table.push(format!("accel_{m}x_rad_s2"), "rad/s²", br.accel[k].clone());
            }
            table.push("max_relative_angle_rad", "rad", br.relative_angle.clone());
            let stable = br.stable.iter().map(|s| s.map_or(f64::NAN, |s| if s { 1.0 } else { 0.0 })).collect();
            table.push("stable", "1", stable);
            table.push("max_floquet_modulus", "1", br.max_multiplier.clone());
            // Each reported element at every point, after the branch's own columns.
            for (e, first) in br.elements.first().map_or(&[][..], Vec::as_slice).iter().enumerate() {
                let el = |f: &dyn Fn(&ElementResponse) -> f64| {
                    br.elements.iter().map(|pt| pt.get(e).map_or(f64::NAN, f)).collect::<Vec<f64>>()
                };
                if let Some(joint) = mech.joints.iter().find(|j| j.name == first.joint) {
                    crate::study::elements::push_element_columns(
                        &mut table,
                        joint,
                        &spec.multiples,
                        first.torque.is_some(),
                        "",
                        &el,
                    );
                }
            }
            table
        })
        .collect()
}

/// What the summary counts per branch (also in `results.json`).
#[derive(Debug, Clone, PartialEq, serde::Serialize, schemars::JsonSchema)]
pub struct BranchFindings {
    /// Solved points.
    pub points: usize,
    /// Points found stable.
    pub stable: usize,
    /// Points found unstable.
    pub unstable: usize,
    /// The orders where the overlaid up and down sweeps of the same amplitude jump (None: no
    /// overlay with both directions; an inner None: that sweep does not jump).
    pub sweep_jumps: Option<(Option<f64>, Option<f64>)>,
}

/// The summary's readings of each branch, in order ([`BranchFindings`]); `overlay` is the sweeps
/// drawn under the branches ([`overlay_of`]), whose jumps are read next to them.
pub(crate) fn findings(study: &Study, branches: &[&HbmBranch], overlay: &[&SweepRun]) -> Vec<BranchFindings> {
    let lag = jump_lag(study);
    branches
        .iter()
        .map(|br| BranchFindings {
            points: br.order.len(),
            stable: br.stable.iter().filter(|s| **s == Some(true)).count(),
            unstable: br.stable.iter().filter(|s| **s == Some(false)).count(),
            sweep_jumps: jump_orders(overlay, br.amplitude, lag),
        })
        .collect()
}
