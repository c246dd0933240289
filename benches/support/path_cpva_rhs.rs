//! The right-hand-side set-up of the path-joint CPVAs, shared by benches/rhs.rs (criterion) and
//! benches/rhs_count.rs (the callgrind driver): the paper's rotor with its absorber on a path
//! joint, at the state of `cpva_rhs::X` written in the path's coordinate.
//!
//! - the epicycloid of examples/cpva_epicycloid.ron (ñ = 3.11, a translating body);
//! - the same file with the path replaced by the `Circle` of the canonical pendulum (pivot radius
//!   R = 0.17 m, L from eq. (15)): the body turns with its arm, so this is the revolute CPVA of
//!   examples/cpva.ron written in s = Lφ (the absorber's mass, inertia and the path damper
//!   c_p/L² are the pendulum's already).

use kanedyn::cpva::CpvaParams;
use kanedyn::kane::Kane;
use kanedyn::model::joint::JointKind;
use kanedyn::model::mechanism::Mechanism;
use kanedyn::model::path::PathShape;
use std::path::Path;

/// The revolute CPVA's state `[θ, φ, u1, u2] = [1234.5, 0.4, 104.9, 108.2]` in the path's
/// coordinate: `[θ, s, θ̇, ṡ]` with s = Lφ and ṡ = L (u2 − u1) (the path's speed is its own
/// rate). s = 6.1 mm is a third of the epicycloid's travel (18.2 mm).
pub fn path_state() -> [f64; 4] {
    let l = CpvaParams::canonical().l();
    [1234.5, l * 0.4, 104.9, l * (108.2 - 104.9)]
}

/// The engine on examples/cpva_epicycloid.ron.
pub fn epicycloid_cpva() -> Kane {
    Kane::new(&epicycloid_mechanism()).expect("engine")
}

/// The engine on the circle-path twin of the paper's pendulum (see the module doc).
pub fn circle_cpva() -> Kane {
    let mut mech = epicycloid_mechanism();
    let p = CpvaParams::canonical();
    let path = mech.joint_index("path").expect("the path joint of examples/cpva_epicycloid.ron");
    mech.joints[path].kind = JointKind::Path {
        shape: PathShape::Circle { radius: p.pivot_radius, length: p.l() },
        mount: 0.0,
        travel: None,
    };
    Kane::new(&mech).expect("engine")
}

fn epicycloid_mechanism() -> Mechanism {
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/cpva_epicycloid.ron");
    Mechanism::from_file(&file).expect("examples/cpva_epicycloid.ron")
}
