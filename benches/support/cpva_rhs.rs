//! The right-hand-side set-up shared by benches/rhs.rs (criterion) and benches/rhs_count.rs (the
//! callgrind driver), so both measure the same thing: the generic Kane engine on
//! examples/cpva.ron and the hand-written closed form of eq. (7) with the same excitation, at
//! one state in the middle of a run.

use kanedyn::cpva::{ClosedForm, CpvaParams};
use kanedyn::kane::Kane;
use kanedyn::model::excitation::Excitation;
use kanedyn::model::mechanism::Mechanism;
use std::path::Path;

/// A state in the middle of a run, `[θ, φ, u1, u2]`: large spin angle, pendulum swinging.
pub const X: [f64; 4] = [1234.5, 0.4, 104.9, 108.2];
/// The time of evaluation, s (inside the excitation's ramp-free part).
pub const T: f64 = 12.345;

/// The two evaluators of the CPVA and the excitation they both evaluate.
pub struct CpvaRhs {
    /// The generic engine on examples/cpva.ron.
    pub kane: Kane,
    /// The rotor torque of examples/cpva.ron, evaluated by the closed form's caller.
    pub excitation: Excitation,
    /// Eq. (7) with the canonical parameters.
    pub closed: ClosedForm,
}

impl CpvaRhs {
    /// Reads examples/cpva.ron and builds both evaluators.
    pub fn new() -> Self {
        let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/cpva.ron");
        let mech = Mechanism::from_file(&file).expect("examples/cpva.ron");
        let excitation = mech.loads.joint_torques[0].excitation.clone();
        let kane = Kane::new(&mech).expect("engine");
        Self { kane, excitation, closed: CpvaParams::canonical().closed_form() }
    }
}
