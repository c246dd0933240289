//! The resonance table of a Campbell diagram: every crossing of an order line with a mode,
//! located by bisection on the eigen-orders. Reference: a branched drivetrain of coaxial discs on
//! torsion shafts with the spin held, whose natural frequencies do not depend on speed and follow
//! in closed form (tests/it/support/branched.rs), so order n crosses mode i at exactly
//! `rpm = 60 f_i / n`; and the truck driveline, whose modes veer, against itself on two grids and
//! against untracked eigen-solves at each crossing.

use crate::support::branched;
use approx::{abs_diff_eq, assert_abs_diff_eq};

use branched::{J_B, J_C, K_A, K_B, K_C, closed_form_rad_s, drivetrain};
use kanedyn::linear::{Damping, Spin, campbell};
use std::f64::consts::PI;

/// Natural frequencies with the hub held, Hz, ascending ([`closed_form_rad_s`]).
fn closed_form_hz() -> Vec<f64> {
    closed_form_rad_s().iter().map(|w| w / (2.0 * PI)).collect()
}

#[test]
fn every_order_line_crossing_is_listed_where_the_closed_form_puts_it() {
    let mech = drivetrain("JointRates", false);
    let f = closed_form_hz();
    println!("closed-form frequencies {f:?} Hz");
    let (rpm_min, rpm_max) = (100.0, 6000.0);
    let rpm: Vec<f64> = (0..60).map(|i| rpm_min + (rpm_max - rpm_min) * i as f64 / 59.0).collect();
    let orders = [1.0, 2.0, 3.0, 6.0, 12.0];
    let c = campbell(&mech, "spin", &rpm, &orders, Spin::Held, Damping::Undamped, None, None).unwrap();

    // Modes in frequency order at every speed, each equal to the closed form to 1e-9 (the
    // operating point and the eigen-solver work near rounding here).
    assert_eq!(c.tracks.len(), 3);
    for (t, tr) in c.tracks.iter().enumerate() {
        for (i, &fi) in tr.frequency_hz.iter().enumerate() {
            assert!(abs_diff_eq!(fi, f[t], epsilon = 1e-9 * f[t]), "mode {t} at {} rpm: {fi} vs {}", rpm[i], f[t]);
            if t > 0 {
                assert!(c.tracks[t - 1].frequency_hz[i] < fi);
            }
        }
    }
    // Labels by where the potential energy is: the branch-b mode twists shaft b only; a chain
    // mode has disc angles x_c/x_a = k_c/(k_c − ω²J_c) (second row of (K − ω²M)x = 0), so its
    // strain energies are ½k_a x_a² in shaft a and ½k_c (x_c − x_a)² in shaft c.
    let wb = (K_B / J_B).sqrt() / (2.0 * PI);
    for (t, &fi) in f.iter().enumerate() {
        let expect = if (fi - wb).abs() < 1e-9 * wb {
            "shaft_b"
        } else {
            let w2 = (2.0 * PI * fi).powi(2);
            let ratio = K_C / (K_C - w2 * J_C);
            if K_A > K_C * (ratio - 1.0).powi(2) { "shaft_a" } else { "shaft_c" }
        };
        assert_eq!(c.tracks[t].label, expect, "mode {t} at {fi} Hz");
    }

    // Every crossing inside the range, and nothing else.
    let mut expected = Vec::new();
    for (t, &fi) in f.iter().enumerate() {
        for &n in &orders {
            let r = 60.0 * fi / n;
            if r > rpm_min && r <= rpm_max {
                expected.push((n, t, r));
            }
        }
    }
    assert_eq!(c.crossings.len(), expected.len(), "{:?}", c.crossings);
    for (n, t, r) in expected {
        let x = c.crossings.iter().find(|x| x.order == n && x.track == t).expect("crossing listed");
        let e = (x.rpm - r).abs() / r;
        println!("order {n} × mode {} ({}): {:.6} rpm vs {r:.6} ({e:.1e})", t + 1, x.label, x.rpm);
        // Issue 13 asks for 1e-6; the bisection stops at 1e-9 and the eigen-orders are exact to
        // ~1e-10 here (measured ≤ 4.3e-10).
        assert!(e <= 1e-6, "order {n}, mode {t}: {} vs {r}", x.rpm);
        assert_abs_diff_eq!(x.frequency_hz, f[t], epsilon = 1e-6 * f[t]);
    }
    assert!(c.crossings.windows(2).all(|w| w[0].rpm <= w[1].rpm), "listed by speed");
}

/// Ranks by frequency when two modes cross: with the hub held, a pendulum on it (eigen-order
/// n_t, so its frequency n_t·Ω/2π grows with speed) and a disc on a shaft from it (a constant
/// √(k/J)/2π) are uncoupled, so their frequencies cross at Ω* = √(k/J)/n_t without veering. Each
/// track keeps its own shape (and label) through the crossing while the ranks swap there.
#[test]
fn ranks_swap_where_two_tracks_cross() {
    let (m, l, ic, r): (f64, f64, f64, f64) = (6.0, 0.015209365076836064, 0.000216, 0.17);
    let (k, j): (f64, f64) = (2.0e3, 0.5);
    let text = format!(
        r#"Mechanism(
    name: "crossing",
    bodies: [
        Body(name: "hub", mass: 20.0, inertia: 1.0),
        Body(name: "disc", mass: 10.0, inertia: {j}),
        Body(name: "pendulum", mass: {m}, com: ({l}, 0.0), inertia: {ic}),
    ],
    joints: [
        Joint(name: "spin", parent: "ground", child: "hub"),
        Joint(name: "shaft", parent: "hub", child: "disc", spring: (stiffness: {k})),
        Joint(name: "pivot", parent: "hub", child: "pendulum", at: ({r}, 0.0)),
    ],
)"#
    );
    let mech = kanedyn::model::mechanism::Mechanism::from_source(
        &kanedyn::io::Source::from_text("crossing.ron", &text),
        &kanedyn::io::ReadPolicy::unrestricted(),
    )
    .unwrap();
    // n_t² = m R L / (I_c + m L²) (the paper's eq. 15 with the pendulum's own inertia).
    let nt = (m * r * l / (ic + m * l * l)).sqrt();
    let cross_rpm = (k / j).sqrt() / nt * 60.0 / (2.0 * PI);
    let rpm: Vec<f64> = (1..=40).map(|i| 50.0 * i as f64).collect();
    assert!(cross_rpm > rpm[0] && cross_rpm < rpm[39], "{cross_rpm}");
    let c = campbell(&mech, "spin", &rpm, &[], Spin::Held, Damping::Undamped, None, None).unwrap();
    let pendulum = c.tracks.iter().position(|t| t.label == "pivot").unwrap();
    let disc = c.tracks.iter().position(|t| t.label == "shaft").unwrap();
    for (i, &s) in rpm.iter().enumerate() {
        let fp = nt * s / 60.0;
        // The pendulum track follows its shape: its frequency is n_t·rpm/60 at every speed.
        assert_abs_diff_eq!(c.tracks[pendulum].frequency_hz[i], fp, epsilon = 1e-6 * fp);
        assert!(c.tracks[pendulum].labels[i] == "pivot" && c.tracks[disc].labels[i] == "shaft");
        let (rp, rd) = if s < cross_rpm { (1, 2) } else { (2, 1) };
        assert_eq!((c.tracks[pendulum].rank[i], c.tracks[disc].rank[i]), (rp, rd), "at {s} rpm");
    }
    println!("pendulum n_t = {nt:.4}, crossing at {cross_rpm:.2} rpm: ranks swap there");
}

/// Issue 29, item 4: the resonance table does not depend on the speed grid. On the truck
/// driveline (spin free, absorber free), whose modes veer, the crossings at 41 and at 401 speeds
/// over 0–2000 rpm are the same list to 1e-3 rpm (the grid used to move four of them onto grid
/// speeds where tracking swapped two modes), and every crossing is a true one: at its speed a
/// mode of the linearisation there, found afresh without any tracking, has the line's frequency
/// n·rpm/60 to 1e-6 relative (the bisection stops at 1e-9 of the speed; the eigen-solver and the
/// equilibrium add ~1e-10).
#[test]
fn truck_crossings_do_not_depend_on_the_grid() {
    use kanedyn::linear::LinearModel;
    use kanedyn::model::excitation::rpm_to_rad_s;
    use kanedyn::model::mechanism::Mechanism;
    let mech = Mechanism::from_file(std::path::Path::new("examples/truck_driveline.ron")).unwrap();
    let orders = [1.5, 3.0, 4.5, 6.0];
    let run = |points: usize| {
        let rpm: Vec<f64> = (0..points).map(|i| 2000.0 * i as f64 / (points - 1) as f64).collect();
        campbell(&mech, "input", &rpm, &orders, Spin::Free, Damping::Undamped, None, None).unwrap()
    };
    let (coarse, fine) = (run(41), run(401));
    let list = |c: &kanedyn::linear::Campbell| c.crossings.iter().map(|x| (x.order, x.rpm)).collect::<Vec<_>>();
    let (a, b) = (list(&coarse), list(&fine));
    println!("41 speeds: {a:?}\n401 speeds: {b:?}");
    assert_eq!(a.len(), b.len(), "different numbers of crossings");
    assert!(a.len() >= 8, "only {} crossings", a.len());
    for ((na, ra), (nb, rb)) in a.iter().zip(&b) {
        assert_eq!(na, nb);
        assert!(abs_diff_eq!(ra, rb, epsilon = 1e-3), "order {na}: {ra} rpm vs {rb} rpm");
    }
    for x in &coarse.crossings {
        let model = LinearModel::new(&mech, "input", rpm_to_rad_s(x.rpm), None).unwrap();
        let modes = model.modes(Spin::Free, Damping::Undamped).unwrap();
        let line = x.order * x.rpm / 60.0;
        let nearest = modes.modes.iter().map(|m| (m.frequency_hz - line).abs()).fold(f64::INFINITY, f64::min);
        assert!(
            nearest <= 1e-6 * line,
            "order {} at {} rpm: no mode at {line} Hz (nearest off by {nearest})",
            x.order,
            x.rpm
        );
    }
}
