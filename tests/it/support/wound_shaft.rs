//! The paper's absorber on an elastic shaft behind a spinning hub (examples/shaft_cpva.ron) with
//! a rotor loss that winds the shaft up: shared by the honest-peaks and Neimark–Sacker stories.

/// The shaft-CPVA of examples/shaft_cpva.ron with a rotor loss large enough to wind the shaft
/// up visibly: c = 2 N·m·s/rad at 1000 rpm is 209 N·m through a 5e4 N·m/rad shaft, 4.2e-3 rad.
pub const WOUND: &str = r#"Mechanism(
    name: "wound_shaft_cpva",
    speeds: AbsoluteAngularVelocities,
    bodies: [
        Body(name: "hub", mass: 20.0, inertia: 0.5),
        Body(name: "rotor", part: "catalog:bodies/flywheel_rotor.ron"),
        Body(name: "pendulum", part: "catalog:bodies/cpva_pendulum.ron"),
    ],
    joints: [
        Joint(name: "spin", parent: "ground", child: "hub"),
        Joint(name: "shaft", parent: "hub", child: "rotor", spring: (stiffness: 5.0e4), damper: 2.0),
        Joint(name: "pivot", part: "catalog:joints/cpva_pivot.ron", parent: "rotor", child: "pendulum", at: (0.17, 0.0)),
    ],
    loads: [GroundDamper(body: "rotor", c: 2.0)],
)"#;
