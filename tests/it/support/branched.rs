//! A branched drivetrain of coaxial discs on torsion shafts with a closed form (for
//! tests/it/campbell_crossings.rs and tests/it/modal_damping.rs, included there with `#[path]`): a hub
//! spun by the engine, with shaft a to disc a and on to disc c by shaft c (a chain), and shaft b
//! to disc b. Every centre of mass on the axis, so no centrifugal effect: with the hub held the
//! natural frequencies do not depend on speed.

#![allow(dead_code)]

use kanedyn::io::{ReadPolicy, Source};
use kanedyn::model::mechanism::Mechanism;

// Inertias (kg·m²) and shaft stiffnesses (N·m/rad).
pub const J_A: f64 = 0.8;
pub const J_B: f64 = 0.3;
pub const J_C: f64 = 0.5;
pub const K_A: f64 = 4.0e4;
pub const K_B: f64 = 2.5e4;
pub const K_C: f64 = 1.5e4;

/// The drivetrain with `speeds` (`JointRates` or `AbsoluteAngularVelocities`) and, when
/// `dampers`, viscous dampers on shafts a (3 N·m·s/rad) and c (1 N·m·s/rad).
pub fn drivetrain(speeds: &str, dampers: bool) -> Mechanism {
    let (ca, cc) = if dampers { (", damper: 3.0", ", damper: 1.0") } else { ("", "") };
    let text = format!(
        r#"Mechanism(
    name: "branched",
    speeds: {speeds},
    bodies: [
        Body(name: "hub", mass: 20.0, inertia: 1.2),
        Body(name: "disc_a", mass: 10.0, inertia: {J_A}),
        Body(name: "disc_b", mass: 5.0, inertia: {J_B}),
        Body(name: "disc_c", mass: 8.0, inertia: {J_C}),
    ],
    joints: [
        Joint(name: "spin", parent: "ground", child: "hub"),
        Joint(name: "shaft_a", parent: "hub", child: "disc_a", spring: (stiffness: {K_A}, free_angle: 0.0){ca}),
        Joint(name: "shaft_b", parent: "hub", child: "disc_b", spring: (stiffness: {K_B}, free_angle: 0.0)),
        Joint(name: "shaft_c", parent: "disc_a", child: "disc_c", spring: (stiffness: {K_C}, free_angle: 0.0){cc}),
    ],
)"#
    );
    Mechanism::from_source(&Source::from_text("branched.ron", &text), &ReadPolicy::unrestricted()).unwrap()
}

/// Undamped natural frequencies with the hub held, rad/s, ascending: branch b alone,
/// `ω² = k_b/J_b`; the chain a–c, `J_a J_c ω⁴ − (J_a k_c + J_c (k_a + k_c)) ω² + k_a k_c = 0`.
pub fn closed_form_rad_s() -> Vec<f64> {
    let (a, b, c) = (J_A * J_C, -(J_A * K_C + J_C * (K_A + K_C)), K_A * K_C);
    let disc = (b * b - 4.0 * a * c).sqrt();
    let mut w2 = [K_B / J_B, (-b - disc) / (2.0 * a), (-b + disc) / (2.0 * a)];
    w2.sort_by(f64::total_cmp);
    w2.iter().map(|w| w.sqrt()).collect()
}
