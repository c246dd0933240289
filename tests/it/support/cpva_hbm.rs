//! The harmonic-balance problem of the canonical rotor-CPVA at 1000 rpm, shared by tests/it/hbm.rs,
//! tests/it/hbm_sensitivity.rs and the benches benches/hbm.rs, benches/hbm_branches.rs and
//! benches/hbm_sensitivity.rs (included there with `#[path]`), and the design parameters whose
//! sensitivities are checked.

use kanedyn::cpva::CpvaParams;
use kanedyn::hbm::{Hbm, HbmError, HbmOptions};
use kanedyn::kane::Kane;
use kanedyn::model::excitation::{Harmonic, rpm_to_rad_s};
use kanedyn::model::mechanism::Mechanism;

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

/// The design parameters varied: each sets one number of the mechanism.
#[derive(Clone, Copy, Debug)]
pub enum Design {
    /// The pivot's distance from the rotor axis, m.
    PivotRadius,
    /// The pendulum's centre-of-mass distance from its pivot, m.
    ComRadius,
    /// The pendulum's mass, kg.
    PendulumMass,
    /// The pivot's viscous damping, N·m·s/rad.
    PivotDamping,
}

impl Design {
    /// Every one of them.
    pub const ALL: [Design; 4] = [Design::PivotRadius, Design::ComRadius, Design::PendulumMass, Design::PivotDamping];

    /// Its value in `m`.
    pub fn get(self, m: &Mechanism) -> f64 {
        let (j, b) = (m.joint_index("pivot").unwrap(), m.body_index("pendulum").unwrap());
        match self {
            Design::PivotRadius => m.joints[j].at.norm(),
            Design::ComRadius => m.bodies[b].inertia.com.norm(),
            Design::PendulumMass => m.bodies[b].inertia.mass,
            Design::PivotDamping => m.joints[j].damper,
        }
    }

    /// Sets it to `v` in `m`.
    pub fn set(self, m: &mut Mechanism, v: f64) {
        let (j, b) = (m.joint_index("pivot").unwrap(), m.body_index("pendulum").unwrap());
        match self {
            Design::PivotRadius => {
                let at = m.joints[j].at;
                m.joints[j].at = at * (v / at.norm());
            }
            Design::ComRadius => {
                let com = m.bodies[b].inertia.com;
                m.bodies[b].inertia.com = com * (v / com.norm());
            }
            Design::PendulumMass => m.bodies[b].inertia.mass = v,
            Design::PivotDamping => m.joints[j].damper = v,
        }
    }
}

/// The canonical rotor with `design` set to `p`, excited by `torque` N·m at the main order.
pub fn problem(design: Design, p: f64, torque: f64) -> Result<Hbm, HbmError> {
    let mut mech = CpvaParams::canonical().mechanism(None).unwrap();
    design.set(&mut mech, p);
    let kane = Kane::new(&mech).map_err(|e| HbmError::Invalid(e.to_string()))?;
    Hbm::new(&kane, mech.joint_index("spin").unwrap(), omega(), &single(torque), HbmOptions::default())
}

/// Its value in the canonical rotor.
pub fn base_value(design: Design) -> f64 {
    design.get(&CpvaParams::canonical().mechanism(None).unwrap())
}
