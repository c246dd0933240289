//! Issue 29, items 1 and 8: Gunter & Chen's Example 8.1, a branched marine gearbox with the
//! intermediate shafts as springs between two meshes, modelled naturally
//! (examples/marine_driveline.ron, study examples/marine_gearbox.ron), and the linear analyses of
//! geared mechanisms whose rigid rotation is a combination of joints through the gear ratios.
//!
//! References written here: the plant's mass and stiffness matrices reduced by hand in the
//! absolute angles of the six inertias (propeller, bull gear, LP and HP first-reduction gears,
//! LP and HP turbines; each pinion's angle eliminated through its ratio), its free modes from a
//! symmetric eigen-solve, and the forced response `(−ω²M + iωC + K) x = F` with
//! `C = C_dampers + Σ 2ζω_r M φ_r φ_rᵀ M`. Published values: free modes 177.7, 220.2 and 1282.6
//! cpm; the vibratory propeller-shaft torque under the fifth-order propeller torque peaks near
//! 4.72e5 N·m at 35.59 rpm (the book's Fig. 8.10-5, and OpenTorsion's reproduction of it).

use crate::support::scratch;
use approx::assert_relative_eq;
use kanedyn::linear::{Damping, LinearModel, Spin};
use kanedyn::model::mechanism::Mechanism;
use kanedyn::study::{RunOptions, Study, run};
use nalgebra::{Complex, DMatrix, DVector, SymmetricEigen};
use std::f64::consts::PI;
use std::path::Path;

/// The book's unit conversion, lb·in·s² (and lb·in/rad, lb·in·s/rad) to SI, as in the example.
const F: f64 = 0.11298;
const R2: f64 = 9.4094;
const R_LP: f64 = 40.0424 / 9.4094;
const R_HP: f64 = 78.2365 / 9.4094;
const K_PS: f64 = 826e6 * F;
const ZETA: f64 = 0.00398;

fn mechanism() -> Mechanism {
    Mechanism::from_file(Path::new("examples/marine_driveline.ron")).unwrap_or_else(|e| panic!("{e}"))
}

/// The plant's five shafts as `(name as kanedyn labels it, v, k)`: strain energy ½k(v·θ)² in the
/// absolute angles (propeller, bull, LP gear, LP turbine, HP gear, HP turbine); a pinion's angle
/// enters through its ratio.
fn shafts() -> Vec<(&'static str, DVector<f64>, f64)> {
    let spring = |name, i: usize, a: f64, j: usize, b: f64, k: f64| {
        let mut v = DVector::zeros(6);
        v[i] += a;
        v[j] -= b;
        (name, v, k)
    };
    vec![
        spring("propeller_shaft", 1, 1.0, 0, 1.0, K_PS),
        // The second-reduction pinion turns at −R2 × the bull gear; the intermediate shaft joins
        // it to the first-reduction gear (a mesh of ratio 1 in the model).
        spring("mesh lp_gear_1/lp_pinion_2", 1, -R2, 2, 1.0, 203.94e6 * F),
        spring("mesh hp_gear_1/hp_pinion_2", 1, -R2, 4, 1.0, 24.17e6 * F),
        // The first-reduction pinion turns at −R × its gear; the turbine shaft joins it to the
        // turbine.
        spring("lp_turbine_shaft", 2, -R_LP, 3, 1.0, 30.51e6 * F),
        spring("hp_turbine_shaft", 4, -R_HP, 5, 1.0, 14.26e6 * F),
    ]
}

/// (M, K, C_dampers) in the absolute angles (propeller, bull, LP gear, LP turbine, HP gear, HP
/// turbine), from the book's table.
fn hand_matrices() -> (DMatrix<f64>, DMatrix<f64>, DMatrix<f64>) {
    let inertia = [2.454e6, 0.826e6, 1.283e4, 1.509e4, 2.723e4, 2.612e2].map(|i| i * F);
    let m = DMatrix::from_diagonal(&DVector::from_row_slice(&inertia));
    let mut k = DMatrix::zeros(6, 6);
    for (_, v, stiffness) in shafts() {
        k += stiffness * &v * v.transpose();
    }
    let c = DMatrix::from_diagonal(&DVector::from_row_slice(&[3.86e6 * F, 0.0, 0.0, 108.77 * F, 0.0, 42.738 * F]));
    (m, k, c)
}

/// Natural frequencies (rad/s, ascending, the rigid rotation's 0 first) and mass-normalised
/// modes of (M, K).
fn hand_modes(m: &DMatrix<f64>, k: &DMatrix<f64>) -> (Vec<f64>, Vec<DVector<f64>>) {
    let l_inv = DMatrix::from_diagonal(&m.diagonal().map(|x| 1.0 / x.sqrt()));
    let eig = SymmetricEigen::new(&l_inv * k * &l_inv);
    let mut idx: Vec<usize> = (0..6).collect();
    idx.sort_by(|&a, &b| eig.eigenvalues[a].total_cmp(&eig.eigenvalues[b]));
    let w = idx.iter().map(|&i| eig.eigenvalues[i].max(0.0).sqrt()).collect();
    let phi = idx.iter().map(|&i| &l_inv * eig.eigenvectors.column(i)).collect();
    (w, phi)
}

/// Amplitude of the propeller-shaft torque (N·m) at propeller speed `rpm` under the fifth-order
/// propeller torque `0.1 T_o (rpm/85)²`, with the dampers and the modal ratio ζ on every mode.
fn hand_shaft_torque(rpm: f64) -> f64 {
    let x = hand_state(rpm, 0.1 * 22.24e6 * F * (rpm / 85.0).powi(2));
    K_PS * (x[1] - x[0]).norm()
}

/// The gearbox turns as a whole along z = (1, 0, −9.4094, 0, −9.4094, 0) in its coordinates
/// (bull gear, propeller-shaft twist, LP gear, LP turbine-shaft twist, HP gear, HP turbine-shaft
/// twist): the second-reduction pinions through their rigid gears, the first-reduction gears
/// through the intermediate shafts (meshes of ratio 1). Its free modes equal the book's to the
/// published digit and the hand-reduced matrices' to 1e-9 relative (the Jacobians are central
/// differences of linear springs, exact up to rounding), at any speed (nothing here depends on
/// the speed), and each is named by the shaft holding most of its strain energy in the hand
/// modes (an intermediate shaft is a mesh between two gears in the model).
#[test]
fn free_modes_equal_the_book_and_the_hand_reduced_matrices() {
    let mech = mechanism();
    let (m, k, _) = hand_matrices();
    let (hand, phi) = hand_modes(&m, &k);
    // The shaft holding most strain energy in each hand-built mode names it.
    let names: Vec<&str> = phi[1..]
        .iter()
        .map(|p| {
            let energy = |(_, v, k): &(&str, DVector<f64>, f64)| k * v.dot(p).powi(2);
            shafts().iter().max_by(|a, b| energy(a).total_cmp(&energy(b))).unwrap().0
        })
        .collect();
    println!("hand: {:?} cpm", hand.iter().map(|w| w * 30.0 / PI).collect::<Vec<_>>());
    assert!(hand[0] < 1e-6 * hand[1], "one rigid rotation: {hand:?}");
    for rpm in [20.0, 85.0] {
        let model = LinearModel::new(&mech, "bull", rpm * PI / 30.0, None).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(model.op.rotation, vec![1.0, 0.0, -R2, 0.0, -R2, 0.0]);
        let modal = model.modes(Spin::Free, Damping::Undamped).unwrap();
        assert_eq!(modal.modes.len(), 5);
        for ((mode, want), name) in modal.modes.iter().zip(&hand[1..]).zip(&names) {
            assert_relative_eq!(mode.natural_frequency_rad_s, *want, max_relative = 1e-9);
            assert_eq!(mode.label, *name);
        }
        // The SpinAngle mode is the rigid rotation itself.
        assert_eq!(modal.rigid[0].shape_q.iter().map(|c| c.re).collect::<Vec<_>>(), model.op.rotation);
        // The book's table, to its one decimal (cpm).
        for (mode, cpm) in modal.modes.iter().zip([177.7, 220.2, 1282.6]) {
            let got = mode.natural_frequency_rad_s * 30.0 / PI;
            println!("{rpm} rpm: {got:.4} cpm (book {cpm})");
            assert!((got - cpm).abs() <= 0.05, "{got} cpm against the book's {cpm}");
        }
    }
}

/// The example study runs unchanged through Campbell and the linear multi-order response over
/// 10–100 rpm (0.1 rpm steps) and LinearResponse at 35.6 rpm: the propeller-shaft torque at
/// every tenth speed and at order 5 equals the hand-built response to 1e-10 relative (the
/// Jacobians of linear springs are exact up to rounding), and its largest value is the book's 4.72e5 N·m at
/// 35.59 rpm (within 1 %, and within one grid step of the speed).
#[test]
fn the_example_gives_the_books_propeller_shaft_torque() {
    let tmp = scratch("marine");
    let dir = tmp.path().to_path_buf();
    let study = Study::from_file(Path::new("examples/marine_gearbox.ron")).unwrap_or_else(|e| panic!("{e}"));
    let report = run(&study, &RunOptions { out: Some(dir.clone()), progress: false }).unwrap();
    assert!(report.failures.is_empty(), "{:?}", report.failures);
    // Campbell: the fifth order crosses the first mode at 177.71/5 rpm.
    let (m, k, _) = hand_matrices();
    let first = hand_modes(&m, &k).0[1];
    let crossing = report.campbell[0].crossings.iter().find(|c| c.order == 5.0 && c.rank == 1).expect("crossing");
    assert_relative_eq!(crossing.rpm, first * 30.0 / PI / 5.0, max_relative = 1e-8);
    // LinearResponse at 35.6 rpm on the same model: the propeller-shaft torque per N·m of
    // propeller torque at order 5, times the law's (35.6/85)² and 0.1·T_o, is the hand torque.
    let lin = &report.linear[0];
    let v = &lin.variants[0];
    let at5 = v.orders.iter().position(|&n| (n - 5.0).abs() < 1e-12).expect("order 5 on the grid");
    assert_eq!(v.elements[0].joint, "propeller_shaft");
    let per_nm = v.elements[0].torque[at5];
    let t = per_nm * 0.1 * 22.24e6 * F;
    let want = hand_shaft_torque(35.6);
    println!("LinearResponse at 35.6 rpm, order 5: {t:.6e} N·m, hand {want:.6e}");
    assert_relative_eq!(t, want, max_relative = 1e-10);
    let multi = &report.multi[0];
    assert_eq!(multi.speeds.len(), 901);
    let torque = |s: &kanedyn::study::SpeedResult| {
        let e = &s.linear_elements[0];
        assert_eq!(e.joint, "propeller_shaft");
        e.torque.as_ref().expect("a spring").peak
    };
    let mut worst: f64 = 0.0;
    for s in multi.speeds.iter().step_by(10) {
        let want = hand_shaft_torque(s.rpm);
        worst = worst.max((torque(s) - want).abs() / want);
    }
    println!("propeller-shaft torque against the hand-built response: worst {worst:.2e}");
    assert!(worst <= 1e-10, "{worst:e}");
    let top = multi.speeds.iter().max_by(|a, b| torque(a).total_cmp(&torque(b))).unwrap();
    println!("peak {:.5e} N·m at {} rpm", torque(top), top.rpm);
    assert!((torque(top) - 4.72e5).abs() <= 0.01 * 4.72e5, "{}", torque(top));
    assert!((top.rpm - 35.59).abs() <= 0.1, "{}", top.rpm);
    let summary = std::fs::read_to_string(dir.join("marine_gearbox/summary.md")).unwrap();
    assert!(summary.contains("| `propeller_shaft` | 4.71689e5 | 35.6 |"), "{summary}");
}

/// A loop of meshes whose ratios disagree has no rigid rotation: a located error naming the mesh,
/// at load for a study's linear analysis; and a massless body on a joint with its own coordinate
/// is refused at its field (on a rigidly geared joint, as the example's pinions, it is accepted).
#[test]
fn a_gear_loop_without_rigid_rotation_and_a_massless_free_body_are_refused() {
    let tmp = scratch("marine-bad");
    let dir = tmp.path().to_path_buf();
    let loop_mech = r#"Mechanism(
    name: "loop",
    speeds: JointRates,
    bodies: [Body(name: "a", inertia: 1.0), Body(name: "b", inertia: 1.0), Body(name: "c", inertia: 1.0)],
    joints: [
        Joint(name: "a", parent: "ground", child: "a"),
        Joint(name: "b", parent: "ground", child: "b", at: (1.0, 0.0)),
        Joint(name: "c", parent: "ground", child: "c", at: (2.0, 0.0)),
    ],
    gears: [
        Gear(joint: "b", follows: "a", ratio: -2.0, mesh: (stiffness: 1e5)),
        Gear(joint: "c", follows: "b", ratio: -1.0, mesh: (stiffness: 1e5)),
        Gear(joint: "a", follows: "c", ratio: 1.0, mesh: (stiffness: 1e5)),
    ],
)"#;
    std::fs::write(dir.join("loop.ron"), loop_mech).unwrap();
    let mech = Mechanism::from_file(&dir.join("loop.ron")).unwrap();
    let err = LinearModel::new(&mech, "a", 10.0, None).unwrap_err().to_string();
    assert!(err.contains("ratios disagree"), "{err}");
    std::fs::write(
        dir.join("s.ron"),
        r#"Study(name: "s", mechanism: "loop.ron", spin_joint: "a", response_body: "a",
    analyses: [Campbell(name: "c", rpm_min: 0.0, rpm_max: 100.0, points: 3, orders: [1.0], spin_held: false)])"#,
    )
    .unwrap();
    let err = Study::from_file(&dir.join("s.ron")).unwrap_err().to_string();
    println!("{err}");
    assert!(err.contains("s.ron:2:16") && err.contains("analyses[0]") && err.contains("ratios disagree"), "{err}");

    let massless = loop_mech.replace(r#"Body(name: "b", inertia: 1.0)"#, r#"Body(name: "b", inertia: 0.0)"#);
    std::fs::write(dir.join("massless.ron"), massless).unwrap();
    let err = Mechanism::from_file(&dir.join("massless.ron")).unwrap_err().to_string();
    println!("{err}");
    assert!(err.contains("bodies[1]") && err.contains("no mass and no inertia"), "{err}");
}

/// The paper's CPVA flywheel driving a wheel through a compliant mesh (3.2 : 1, 2e5 N·m/rad) and
/// the wheel a vehicle through a drive shaft: the wheel keeps its own coordinate and turns with
/// the spin at −0.3125 × its rate.
const MESHED_CPVA: &str = r#"Mechanism(
    name: "meshed_cpva",
    speeds: JointRates,
    bodies: [
        Body(name: "rotor", part: "catalog:bodies/flywheel_rotor.ron"),
        Body(name: "pendulum", part: "catalog:bodies/cpva_pendulum.ron"),
        Body(name: "wheel", mass: 30.0, inertia: 0.8),
        Body(name: "vehicle", inertia: 3.0),
    ],
    joints: [
        Joint(name: "spin", parent: "ground", child: "rotor"),
        Joint(name: "pivot", part: "catalog:joints/cpva_pivot.ron", parent: "rotor", child: "pendulum", at: (0.17, 0.0)),
        Joint(name: "output", parent: "ground", child: "wheel", at: (0.6, 0.0)),
        Joint(name: "driveshaft", parent: "wheel", child: "vehicle", spring: (stiffness: 1.0e5), damper: 2.0),
    ],
    loads: [GroundDamper(body: "rotor", c: 5e-3), GroundDamper(body: "vehicle", c: 0.5)],
    gears: [Gear(joint: "output", follows: "spin", ratio: -0.3125, mesh: (stiffness: 2.0e5, damping: 5.0))],
)"#;

/// Harmonic balance on a train whose wheel turns with the spin through a compliant mesh (issue
/// 29, item 1): each coordinate carries its share of the mean rotation (`q = z Ω t + p(t)`, z =
/// (1, 0, −0.3125, 0)), so the mesh deflection stays periodic. Checked by a periodic-orbit
/// solver written here, on both sides of the absorber's jump (n = 3.0 inside the folds, the
/// low branch; n = 3.3 beyond them): one period of DOP853 at 1e-12 from the harmonic-balance
/// state returns to it advanced by z Ω P (to 1e-7: H = 10 against the integrator), and the
/// Floquet multipliers of harmonic balance equal the eigenvalues of the time flow's monodromy
/// (central differences of whole periods, taken to p = q − z q_s, the trivial +1 dropped) to 1e-5
/// (the differenced monodromy's own accuracy is about 1e-6). The stability step takes 1024
/// samples: the mesh mode (263 Hz) turns five times per period of 50 Hz, and the default 256
/// samples resolve its multiplier to 1.5e-4 only (measured), the others to 2e-8.
#[test]
fn harmonic_balance_of_a_meshed_train_is_a_periodic_orbit_of_the_time_equations() {
    use kanedyn::hbm::{Hbm, HbmOptions};
    use kanedyn::kane::Kane;
    use kanedyn::model::excitation::{Excitation, Harmonic, Order};
    use kanedyn::time::integrate::{IntegrateOptions, integrate};
    let tmp = scratch("meshed-hbm");
    let dir = tmp.path().to_path_buf();
    std::fs::write(dir.join("m.ron"), MESHED_CPVA).unwrap();
    let mech = Mechanism::from_file(&dir.join("m.ron")).unwrap();
    let spin = mech.joint_index("spin").unwrap();
    let (rpm, torque) = (1000.0, 40.0);
    let omega = rpm * PI / 30.0;
    let harmonics = vec![Harmonic { multiple: 1.0, amplitude: torque, phase: 0.0 }];
    let hopts = HbmOptions { stability_samples: 1024, ..HbmOptions::default() };
    let mut hbm = Hbm::new(&Kane::new(&mech).unwrap(), spin, omega, &harmonics, hopts).unwrap();
    let opts = IntegrateOptions { rtol: 1e-12, atol: 1e-12, ..IntegrateOptions::default() };
    for order in [3.0, 3.3] {
        let sol = hbm.solve(order, None).unwrap();
        assert_eq!(sol.rotation, vec![1.0, 0.0, -0.3125, 0.0]);
        let mu = hbm.stability(&sol).unwrap().multipliers;
        let period = 2.0 * PI / sol.base_frequency;
        let mut kane = Kane::new(&mech).unwrap();
        let exc = Excitation {
            mean: sol.mean_torque,
            rpm,
            order: Order::Fixed(order),
            harmonics: harmonics.clone(),
            ramp_s: 0.0,
        };
        kane.set_joint_torque(spin, exc);
        let mut flow =
            |x: &[f64]| integrate(|t, x, dx| kane.rhs(t, x, dx), x, 0.0, period, &opts, |_| {}).unwrap().x_end;
        let x0 = hbm.state_at(&sol, 0.0);
        let n = mech.ndof();
        let shift: Vec<f64> = (0..2 * n).map(|i| if i < n { sol.rotation[i] * omega * period } else { 0.0 }).collect();
        let end = flow(&x0);
        let gap = (0..2 * n).map(|i| (end[i] - x0[i] - shift[i]).abs()).fold(0.0, f64::max);
        println!("n = {order}: one period from the HBM state misses it by {gap:.2e}");
        assert!(gap <= 1e-7, "{gap:e}");
        // The monodromy by central differences, in p = q − z q_s, without the spin angle.
        let d = 2 * n;
        let phi = crate::support::shooting::differenced_monodromy(&mut flow, &x0);
        let mut p = DMatrix::identity(d, d);
        for k in 0..n {
            p[(k, 0)] = sol.rotation[k];
        }
        let p_inv = p.clone().try_inverse().unwrap();
        let reduced = (&p_inv * &phi * &p).remove_row(0).remove_column(0);
        let shooting = reduced.complex_eigenvalues();
        let worst = mu
            .iter()
            .map(|m| shooting.iter().map(|s| (s - m).norm()).fold(f64::INFINITY, f64::min))
            .fold(0.0, f64::max);
        println!("n = {order}: HBM multipliers {mu:?}\n  shooting {shooting:?}\n  worst {worst:.2e}");
        assert_eq!(mu.len(), d - 1);
        assert!(worst <= 1e-5, "{worst:e}");
    }
}

/// A Campbell diagram in the high-pressure turbine's own speed and orders (`speed_of` its
/// first-reduction pinion, which turns at 78.2365/9.4094 × 9.4094 = 78.2365 times the
/// propeller): order 1 of the turbine crosses each mode where the turbine's rpm equals the mode's
/// frequency in cpm (the hand modes, to 1e-8 relative); a joint that does not turn with the
/// spin (a shaft's twist) is refused at `speed_of`.
#[test]
fn a_campbell_diagram_in_a_turbines_speed() {
    let tmp = scratch("marine-turbine");
    let dir = tmp.path().to_path_buf();
    std::fs::copy("examples/marine_driveline.ron", dir.join("m.ron")).unwrap();
    let study = |speed_of: &str| {
        format!(
            r#"Study(name: "t", mechanism: "m.ron", spin_joint: "bull", response_body: "propeller",
    analyses: [Campbell(name: "c", rpm_min: 100.0, rpm_max: 2500.0, points: 25, orders: [1.0], spin_held: false,
                        speed_of: "{speed_of}")])"#
        )
    };
    std::fs::write(dir.join("s.ron"), study("hp_pinion_1")).unwrap();
    let s = Study::from_file(&dir.join("s.ron")).unwrap_or_else(|e| panic!("{e}"));
    let report = run(&s, &RunOptions { out: Some(dir.join("out")), progress: false }).unwrap();
    assert!(report.failures.is_empty(), "{:?}", report.failures);
    let (m, k, _) = hand_matrices();
    // The four modes below 2500 cpm (the fifth is at 2883).
    let cpm: Vec<f64> = hand_modes(&m, &k).0[1..5].iter().map(|w| w * 30.0 / PI).collect();
    let c = &report.campbell[0];
    assert_eq!(c.rpm.first(), Some(&100.0));
    let found: Vec<f64> = c.crossings.iter().map(|x| x.rpm).collect();
    println!("turbine-speed crossings of order 1: {found:?}; modes {cpm:?} cpm");
    assert_eq!(found.len(), 4);
    for (x, want) in c.crossings.iter().zip(&cpm) {
        assert_eq!(x.order, 1.0);
        assert_relative_eq!(x.rpm, *want, max_relative = 1e-8);
    }
    std::fs::write(dir.join("bad.ron"), study("hp_turbine_shaft")).unwrap();
    let err = Study::from_file(&dir.join("bad.ron")).unwrap_err().to_string();
    assert!(err.contains("speed_of") && err.contains("hp_turbine_shaft"), "{err}");
}

/// The complex amplitudes of the six absolute angles (propeller, bull, LP gear, LP turbine, HP
/// gear, HP turbine) under a propeller torque of amplitude `torque` (N·m) at order 5 of `rpm`,
/// with the dampers and the modal ratio ζ on every mode, from the hand-reduced matrices.
fn hand_state(rpm: f64, torque: f64) -> DVector<Complex<f64>> {
    let (m, k, c_d) = hand_matrices();
    let (w, phi) = hand_modes(&m, &k);
    let mut c = c_d;
    for (wr, p) in w.iter().zip(&phi).skip(1) {
        let mp = &m * p;
        c += 2.0 * ZETA * wr * &mp * mp.transpose();
    }
    let omega = 5.0 * rpm * PI / 30.0;
    let to_c = |a: &DMatrix<f64>| a.map(|x| Complex::new(x, 0.0));
    let z = to_c(&(&k - omega * omega * &m)) + to_c(&c) * Complex::new(0.0, omega);
    let mut force = DVector::from_element(6, Complex::new(0.0, 0.0));
    force[0] = Complex::new(torque, 0.0);
    z.lu().solve(&force).expect("regular with damping")
}

/// The mean torque of each shaft (kanedyn's name, N·m, kanedyn's sign: `k (q_child − q_parent)`
/// for a joint spring, `k (q_gear − q_pinion)` for an intermediate shaft, which is `−k v·x` with
/// the hand shafts' `v`) when the plant turns steadily at `rpm` against its dampers to ground,
/// driven at the bull gear: `K x = −C Ω z + T e_bull` with `zᵀ(−C Ω z + T e_bull) = 0`, solved
/// in the least-squares sense (K is singular along the rigid rotation z, which no shaft's `v`
/// sees).
fn hand_mean_torques(rpm: f64) -> Vec<(&'static str, f64)> {
    let (_, k, c) = hand_matrices();
    let omega = rpm * PI / 30.0;
    let z = DVector::from_row_slice(&[1.0, 1.0, -R2, R2 * R_LP, -R2, R2 * R_HP]);
    let mut f = -(&c * &z) * omega;
    f[1] -= z.dot(&f) / z[1];
    let x = k.svd(true, true).solve(&f, 1e-12).unwrap();
    shafts().into_iter().map(|(name, v, stiffness)| (name, -stiffness * v.dot(&x))).collect()
}

/// Issue 49, items 6 and 9: the example written naturally (every joint with a coordinate reported, the
/// default `elements`), the intermediate shafts being compliant meshes of ratio 1 between a
/// first-reduction gear and a second-reduction pinion. Each shaft's torque, the intermediate
/// ones included (reported on the gear the mesh drives, `lp_gear_1` and `hp_gear_1`), equals the
/// hand-reduced model's `k |v·x|`: per N·m in LinearResponse at 35.6 rpm over orders 4–6, and at
/// order 5 in MultiOrder at 10 speeds over 10–100 rpm, to 1e-9 relative (the Jacobians of
/// linear springs are exact up to rounding; the modal damping's eigenvectors and the solves
/// leave about 1e-12). The MultiOrder means equal the hand static deflection under the
/// dampers' drag to 1e-9 relative too; with one harmonic the alternating maximum (item 9,
/// `alt_max`) is the hand amplitude and the absolute one `|mean| + amplitude`, to 1e-9; the CSVs
/// carry the same numbers.
#[test]
fn every_shaft_torque_and_its_alternating_part_equal_the_hand_model() {
    let tmp = scratch("marine-shafts");
    let dir = tmp.path().to_path_buf();
    std::fs::copy("examples/marine_driveline.ron", dir.join("marine_driveline.ron")).unwrap();
    let text = std::fs::read_to_string("examples/marine_gearbox.ron").unwrap();
    let text = text
        .replace("    elements: [\"propeller_shaft\", \"lp_turbine_shaft\", \"hp_turbine_shaft\"],\n", "")
        .replace("points: 401,", "points: 21,")
        .replace("points: 901,", "points: 10,");
    assert!(!text.contains("elements:") && text.contains("points: 10,"), "{text}");
    std::fs::write(dir.join("s.ron"), text).unwrap();
    let study = Study::from_file(&dir.join("s.ron")).unwrap_or_else(|e| panic!("{e}"));
    let report = run(&study, &RunOptions { out: Some(dir.join("out")), progress: false }).unwrap();
    assert!(report.failures.is_empty(), "{:?}", report.failures);
    // kanedyn's element (the joint) of each hand shaft.
    let joint_of = |shaft: &'static str| -> &'static str {
        match shaft {
            "mesh lp_gear_1/lp_pinion_2" => "lp_gear_1",
            "mesh hp_gear_1/hp_pinion_2" => "hp_gear_1",
            other => other,
        }
    };
    let to = 0.1 * 22.24e6 * F;
    let hand = |rpm: f64, torque: f64| -> Vec<(&'static str, f64)> {
        let x = hand_state(rpm, torque);
        shafts()
            .into_iter()
            .map(|(name, v, k)| {
                (joint_of(name), k * v.iter().zip(x.iter()).map(|(a, b)| b * *a).sum::<Complex<f64>>().norm())
            })
            .collect()
    };
    let csv = |name: &str| -> (Vec<String>, Vec<Vec<f64>>) {
        let text = std::fs::read_to_string(dir.join("out/marine_gearbox").join(name)).unwrap();
        let mut lines = text.lines();
        let head = lines.next().unwrap().split(',').map(str::to_string).collect();
        (head, lines.map(|l| l.split(',').map(|x| x.parse().unwrap()).collect()).collect())
    };
    let column = |t: &(Vec<String>, Vec<Vec<f64>>), name: &str| -> Vec<f64> {
        let i = t.0.iter().position(|h| h == name).unwrap_or_else(|| panic!("no column {name} in {:?}", t.0));
        t.1.iter().map(|r| r[i]).collect()
    };

    // LinearResponse: per N·m of the propeller torque at order n of 35.6 rpm (the law's
    // (35.6/85)² included); the hand model at order 5 only, so at n the frequency is that of
    // order 5 at n/5 × 35.6 rpm, and the torque per N·m follows the law at 35.6 rpm.
    let v = &report.linear[0].variants[0];
    let table = csv("response_as_built.csv");
    let mut worst: f64 = 0.0;
    for (i, &n) in v.orders.iter().enumerate() {
        let law = (35.6_f64 / 85.0).powi(2);
        for (joint, want) in hand(35.6 * n / 5.0, law) {
            let e = v.elements.iter().find(|e| e.joint == joint).unwrap_or_else(|| panic!("{joint}"));
            let got = e.torque[i];
            worst = worst.max((got - want).abs() / want);
            assert_eq!(column(&table, &format!("{joint}_torque_Nm_per_Nm"))[i], got);
        }
    }
    println!("LinearResponse shaft torques per N·m against the hand model: worst {worst:.2e}");
    assert!(worst <= 1e-9, "{worst:e}");
    // Order 5 per N·m, times 0.1 T_o, for the record.
    let at5 = v.orders.iter().position(|&n| (n - 5.0).abs() < 1e-12).unwrap();
    for e in &v.elements {
        println!("  {}: {:.6e} N·m at order 5", e.joint, e.torque[at5] * to);
    }

    // MultiOrder at order 5: amplitude, peak (one line: the amplitude) and mean per shaft.
    let multi = &report.multi[0];
    let table = csv("propeller_torque.csv");
    let (mut worst, mut worst_mean, mut worst_alt): (f64, f64, f64) = (0.0, 0.0, 0.0);
    for (row, s) in multi.speeds.iter().enumerate() {
        let means = hand_mean_torques(s.rpm);
        for ((joint, want), (_, mean)) in hand(s.rpm, to * (s.rpm / 85.0).powi(2)).into_iter().zip(means) {
            let e = s.linear_elements.iter().find(|e| e.joint == joint).unwrap_or_else(|| panic!("{joint}"));
            let t = e.torque.as_ref().unwrap_or_else(|| panic!("{joint} has a torque"));
            worst = worst.max((t.amplitude[0] - want).abs() / want).max((t.peak - want).abs() / want);
            worst_mean = worst_mean.max((t.range.mean - mean).abs() / mean.abs());
            // Item 9: one harmonic about a mean, so the largest departure from the mean is the
            // amplitude and the largest |T| is |mean| + amplitude.
            worst_alt = worst_alt
                .max((t.range.alt_max - want).abs() / want)
                .max((t.range.max_abs - (mean.abs() + want)).abs() / (mean.abs() + want));
            for (tag, value) in [
                ("1x", t.amplitude[0]),
                ("mean", t.range.mean),
                ("max_abs", t.range.max_abs),
                ("alt_max", t.range.alt_max),
            ] {
                assert_eq!(column(&table, &format!("linear_{joint}_torque_{tag}_Nm"))[row], value);
            }
            if joint == "propeller_shaft" && s.rpm == 30.0 {
                println!(
                    "  propeller shaft at 30 rpm: mean {:.5e}, alt max {:.5e}, max abs {:.5e} N·m",
                    t.range.mean, t.range.alt_max, t.range.max_abs
                );
            }
        }
    }
    println!("alternating and absolute maxima against the hand model: worst {worst_alt:.2e}");
    assert!(worst_alt <= 1e-9, "{worst_alt:e}");
    println!("MultiOrder order-5 shaft torques against the hand model: worst {worst:.2e}, means {worst_mean:.2e}");
    assert!(worst <= 1e-9, "{worst:e}");
    assert!(worst_mean <= 1e-9, "{worst_mean:e}");
}
