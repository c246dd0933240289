//! Modal damping, the usual damping input of torsional practice: instead of the mechanism's
//! viscous dampers, a damping ratio ζ_i for each vibration mode (or one for all). With the
//! undamped second-order form `M q̈ + G q̇ + K q = τ` in the coordinates (G: the velocity terms
//! that remain without dampers, such as the rotor–pendulum coupling at speed), the undamped
//! modes `K φ_i = ω_i² M φ_i` of the symmetric parts of M and K are mass-normalised
//! (`Φᵀ M Φ = I`), and the damping matrix is the classical
//! `C = M Φ diag(2 ζ_i ω_i) Φᵀ M`,
//! which gives mode i exactly the ratio ζ_i when G vanishes (a drivetrain of shafts) and to first
//! order otherwise. Modes of zero frequency (the free spin) get no damping. The speeds' matrix
//! follows from `C_q = −Wᵀ F_u W`: `F_u = −W⁻ᵀ (G + C) W⁻¹`.
//!
//! Torsional practice gives damping both ways at once (a propeller's or a damper's own viscous
//! loss, and a modal ratio for the shafting's material damping), so the modal matrix may also be
//! added to the mechanism's dampers instead of replacing them ([`ModalCombination::Add`]): then
//! `F_u = −W⁻ᵀ (G + C_dampers + C) W⁻¹`, the modes and their ω_i still those of M and K.

use super::{Damping, LinResult, LinearError, LinearModel, Spin};
use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};

/// Damping ratios per vibration mode, in order of undamped natural frequency.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum ModalDamping {
    /// One ratio for every vibration mode.
    All(f64),
    /// One ratio per vibration mode, lowest frequency first (as many as there are modes).
    PerMode(Vec<f64>),
}

impl ModalDamping {
    /// The ratio of mode `i` (0-based, by frequency), if given.
    fn ratio(&self, i: usize) -> Option<f64> {
        match self {
            ModalDamping::All(z) => Some(*z),
            ModalDamping::PerMode(v) => v.get(i).copied(),
        }
    }

    /// In words, for a report.
    pub fn describe(&self) -> String {
        match self {
            ModalDamping::All(z) => format!("ζ = {z} for every vibration mode"),
            ModalDamping::PerMode(v) => {
                let list: Vec<String> = v.iter().map(|z| z.to_string()).collect();
                format!("ζ = {} for the vibration modes in order of frequency", list.join(", "))
            }
        }
    }
}

/// How modal damping meets the mechanism's own dampers.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum ModalCombination {
    /// The modal matrix replaces the dampers (the ratios are the whole damping).
    #[default]
    Replace,
    /// The modal matrix adds to the dampers (the ratios are extra, e.g. material damping).
    Add,
}

impl ModalCombination {
    /// In words, for a report: where the modal ratios stand against the joint dampers.
    pub fn describe(self) -> &'static str {
        match self {
            ModalCombination::Replace => "in place of the mechanism's dampers",
            ModalCombination::Add => "added to the mechanism's dampers",
        }
    }
}

impl LinearModel {
    /// The same linear model with the mechanism's dampers replaced by modal damping `zeta` (see
    /// the module doc), the modes taken with the spin `spin` (held: the spin coordinate is left
    /// out; free: it is kept, and its zero-frequency mode gets no damping). Errors when a ratio is
    /// missing for a vibration mode, or the mass matrix is not positive definite.
    pub fn with_modal_damping(&self, spin: Spin, zeta: &ModalDamping) -> LinResult<LinearModel> {
        self.with_modal_damping_combined(spin, zeta, ModalCombination::Replace)
    }

    /// [`LinearModel::with_modal_damping`] with the modal matrix replacing the mechanism's
    /// dampers or added to them (`combine`).
    pub fn with_modal_damping_combined(
        &self,
        spin: Spin,
        zeta: &ModalDamping,
        combine: ModalCombination,
    ) -> LinResult<LinearModel> {
        let n = self.ndof();
        let second = self.second_order(Damping::Undamped);
        // The velocity matrix the modal one adds to: G alone, or G with the dampers.
        let base_c = match combine {
            ModalCombination::Replace => second.c.clone(),
            ModalCombination::Add => self.second_order(Damping::Damped).c,
        };
        let s = self.op.spin_coordinate;
        let kept: Vec<usize> = (0..n).filter(|&j| spin == Spin::Free || j != s).collect();
        let pick = |m: &DMatrix<f64>| DMatrix::from_fn(kept.len(), kept.len(), |i, j| m[(kept[i], kept[j])]);
        let m = pick(&second.m);
        let k = pick(&second.k);
        let k = (&k + k.transpose()) * 0.5;
        // M = L Lᵀ; the symmetric problem L⁻¹ K L⁻ᵀ v = ω² v; φ = L⁻ᵀ v is mass-normalised.
        let chol = m.clone().cholesky().ok_or_else(|| LinearError::MassMatrix { mechanism: self.mech.name.clone() })?;
        let l = chol.l();
        let l_inv =
            l.clone().try_inverse().ok_or_else(|| LinearError::MassMatrix { mechanism: self.mech.name.clone() })?;
        let a = &l_inv * &k * l_inv.transpose();
        let eig = super::bounded::symmetric_eigen((&a + a.transpose()) * 0.5)?;
        let mut order: Vec<usize> = (0..kept.len()).collect();
        order.sort_by(|&i, &j| eig.eigenvalues[i].total_cmp(&eig.eigenvalues[j]));
        let scale = eig.eigenvalues.iter().fold(0.0f64, |a, &b| a.max(b.abs())).max(f64::MIN_POSITIVE);
        let mut c = DMatrix::zeros(kept.len(), kept.len());
        let mut mode = 0;
        for &i in &order {
            let w2 = eig.eigenvalues[i];
            // Zero-frequency (rigid) modes take no damping and no ratio from the list.
            if w2 <= 1e-12 * scale {
                continue;
            }
            let z = zeta.ratio(mode).ok_or_else(|| {
                LinearError::Invalid(format!(
                    "modal damping: no ratio for vibration mode {} (of {})",
                    mode + 1,
                    kept.len()
                ))
            })?;
            mode += 1;
            let phi = l_inv.transpose() * eig.eigenvectors.column(i);
            let mphi = &m * phi;
            c += (2.0 * z * w2.sqrt()) * &mphi * mphi.transpose();
        }
        let mut c_full = base_c;
        for (a, &i) in kept.iter().enumerate() {
            for (b, &j) in kept.iter().enumerate() {
                c_full[(i, j)] += c[(a, b)];
            }
        }
        let mut out = self.clone();
        out.f_u = -(self.w_inv.transpose() * c_full * &self.w_inv);
        Ok(out)
    }
}
