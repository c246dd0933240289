//! The harmonic-balance problem of the canonical rotor-CPVA at 1000 rpm, shared by tests/it/hbm.rs
//! and the benches benches/hbm.rs and benches/hbm_branches.rs (included there with `#[path]`).

use kanedyn::cpva::CpvaParams;
use kanedyn::hbm::{Hbm, HbmOptions};
use kanedyn::kane::Kane;
use kanedyn::model::excitation::{Harmonic, rpm_to_rad_s};

/// Mean rotor speed, rpm.
pub const RPM: f64 = 1000.0;

/// Mean rotor speed Ω, rad/s.
pub fn omega() -> f64 {
    rpm_to_rad_s(RPM)
}

/// A single main-order harmonic of `amplitude` N·m, phase 0.
pub fn single(amplitude: f64) -> Vec<Harmonic> {
    vec![Harmonic { multiple: 1.0, amplitude, phase: 0.0 }]
}

/// The canonical CPVA (absolute speeds, no excitation in the file) with the engine torque
/// `harmonics` on the spin joint at Ω.
pub fn cpva_hbm(harmonics: &[Harmonic], opts: HbmOptions) -> Hbm {
    let mech = CpvaParams::canonical().mechanism(None).unwrap();
    let kane = Kane::new(&mech).unwrap();
    Hbm::new(&kane, mech.joint_index("spin").unwrap(), omega(), harmonics, opts).unwrap()
}
