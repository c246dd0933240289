//! The linear frequency response as written in the study file.

use crate::study::ExciteAt;
use serde::{Deserialize, Serialize};

/// Joint dampers replaced for one variant of a linear analysis (e.g. the pivot damping c_p).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Variant {
    /// Legend and file label.
    pub label: String,
    /// `(joint, damping in N·m·s/rad)` pairs.
    pub dampers: Vec<(String, f64)>,
}

/// The linear frequency response of the response body's angular acceleration under a torque on
/// the spin joint, `|α̂(n)| / |α̂_locked(n)|`, over an order range.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LinearResponseSpec {
    /// Name (file prefix).
    pub name: String,
    /// Mean speed, rpm.
    pub rpm: f64,
    /// Lower end of the order range (in units of the tuning order n_t when `relative`).
    pub from: f64,
    /// Upper end of the order range.
    pub to: f64,
    /// Number of orders evaluated (default 1201).
    #[serde(default = "default_points")]
    pub points: usize,
    /// Give `from`/`to` and plot in units of the tuning order n_t: the undamped eigen-order of the
    /// first locked joint's mode with the spin held (eq. 15 for the CPVA). Default true.
    #[serde(default = "crate::study::spec::default_true")]
    pub relative: bool,
    /// Damping variants (default: the mechanism as it is).
    #[serde(default)]
    pub variants: Vec<Variant>,
    /// Modal damping: `All(ζ)` or `PerMode([ζ1, ζ2, …])` (lowest frequency first; modes of the
    /// mechanism with the spin free, and of its locked twin). Default: the dampers as built.
    #[serde(default)]
    pub modal_damping: Option<crate::linear::ModalDamping>,
    /// How `modal_damping` meets the joint dampers: `Replace` (absent: the ratios are the whole
    /// damping, and damper variants do not apply) or `Add` (the ratios come on top of the
    /// dampers, of each variant's). Only with `modal_damping`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub modal_combination: Option<crate::linear::ModalCombination>,
    /// The joints the oscillating torque acts at, each with its share and phase lead (default:
    /// the spin joint alone). The mean torque stays on the spin joint.
    #[serde(default)]
    pub excite: Vec<ExciteAt>,
}

impl LinearResponseSpec {
    /// The modal damping in force with its combination (absent combination: `Replace`).
    pub fn modal(&self) -> Option<(&crate::linear::ModalDamping, crate::linear::ModalCombination)> {
        self.modal_damping.as_ref().map(|z| (z, self.modal_combination.unwrap_or_default()))
    }
}

fn default_points() -> usize {
    1201
}
