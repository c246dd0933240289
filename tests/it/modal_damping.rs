//! Modal damping: each vibration mode gets exactly the damping ratio asked for. Reference: a
//! branched drivetrain of coaxial discs on torsion shafts with the spin held (no velocity
//! coupling, so classical damping decouples the modes exactly), whose natural frequencies follow
//! in closed form: branch b alone, `ω² = k_b/J_b`; the chain a–c,
//! `J_a J_c ω⁴ − (J_a k_c + J_c (k_a + k_c)) ω² + k_a k_c = 0`.

use crate::support::branched;
use crate::support::scratch;
use approx::{abs_diff_eq, assert_abs_diff_eq};

use branched::{closed_form_rad_s, drivetrain};
use kanedyn::linear::{Damping, LinearModel, ModalDamping, Spin, campbell};
use kanedyn::model::excitation::rpm_to_rad_s;

#[test]
fn every_mode_gets_the_ratio_asked_for() {
    let mech = drivetrain("AbsoluteAngularVelocities", true);
    let model = LinearModel::new(&mech, "spin", rpm_to_rad_s(1500.0), None).unwrap();
    let w = closed_form_rad_s();
    for zeta in [ModalDamping::PerMode(vec![0.01, 0.03, 0.05]), ModalDamping::All(0.02)] {
        let damped = model.with_modal_damping(Spin::Held, &zeta).unwrap();
        let mut modes = damped.modes(Spin::Held, Damping::Damped).unwrap().modes;
        modes.sort_by(|a, b| a.natural_frequency_rad_s.total_cmp(&b.natural_frequency_rad_s));
        assert_eq!(modes.len(), 3);
        for (i, m) in modes.iter().enumerate() {
            let want = match &zeta {
                ModalDamping::PerMode(v) => v[i],
                ModalDamping::All(z) => *z,
            };
            println!(
                "{}: ω_n {:.9} vs {:.9} rad/s, ζ {:.12} vs {want}",
                m.label, m.natural_frequency_rad_s, w[i], m.damping_ratio
            );
            // Classical damping on an uncoupled drivetrain: exact up to the eigen-solver (1e-9).
            assert!(abs_diff_eq!(m.damping_ratio, want, epsilon = 1e-9), "mode {i}: ζ {} vs {want}", m.damping_ratio);
            assert_abs_diff_eq!(m.natural_frequency_rad_s, w[i], epsilon = 1e-9 * w[i]);
            // The damped frequency is ω_n √(1 − ζ²).
            assert_abs_diff_eq!(m.damped_frequency_rad_s, w[i] * (1.0 - want * want).sqrt(), epsilon = 1e-9 * w[i]);
        }
    }
    // The mechanism's own dampers are replaced, not added to: with all ratios 0 the damped model
    // is the undamped one.
    let none = model.with_modal_damping(Spin::Held, &ModalDamping::All(0.0)).unwrap();
    assert!((&none.f_u - &model.f_u_undamped).amax() <= 1e-9 * model.f_u.amax().max(1.0));
    // Too few ratios is an error that says which mode lacks one.
    let e = model.with_modal_damping(Spin::Held, &ModalDamping::PerMode(vec![0.01])).unwrap_err().to_string();
    assert!(e.contains("vibration mode 2"), "{e}");
}

/// A Campbell diagram with modal damping: at every speed each mode has its ratio and the damped
/// frequency ω_n √(1 − ζ²) of the closed form.
#[test]
fn a_campbell_diagram_takes_modal_damping() {
    let mech = drivetrain("AbsoluteAngularVelocities", true);
    let w = closed_form_rad_s();
    let rpm: Vec<f64> = (0..11).map(|i| 500.0 + 300.0 * i as f64).collect();
    let zeta = ModalDamping::PerMode(vec![0.02, 0.04, 0.06]);
    let c = campbell(&mech, "spin", &rpm, &[3.0], Spin::Held, Damping::Undamped, Some(&zeta), None).unwrap();
    for (t, (tr, z)) in c.tracks.iter().zip([0.02, 0.04, 0.06]).enumerate() {
        for (i, (&f, &d)) in tr.frequency_hz.iter().zip(&tr.damping_ratio).enumerate() {
            let want = w[t] * (1.0f64 - z * z).sqrt() / (2.0 * std::f64::consts::PI);
            assert!(abs_diff_eq!(d, z, epsilon = 1e-9), "mode {t} at {} rpm: ζ {d}", rpm[i]);
            assert!(abs_diff_eq!(f, want, epsilon = 1e-9 * want), "mode {t} at {} rpm: {f} Hz vs {want}", rpm[i]);
        }
    }
}

/// In a study: the summary states the modal damping, and damper variants beside it, a negative
/// ratio or an empty list are located errors.
#[test]
fn a_study_states_its_modal_damping_and_refuses_conflicts() {
    let tmp = scratch("modal");
    let dir = tmp.path().to_path_buf();
    let mech = std::fs::read_to_string("examples/cpva.ron").unwrap();
    // Its parts come from the shipped catalog.
    std::fs::write(dir.join("cpva.ron"), mech).unwrap();
    let study = |extra: &str| {
        format!(
            r#"Study(name: "m", mechanism: "cpva.ron", lock: ["pivot"],
    analyses: [LinearResponse(name: "lin", rpm: 1000.0, from: 0.9, to: 1.2, points: 31{extra})])"#
        )
    };
    std::fs::write(dir.join("ok.ron"), study(", modal_damping: All(0.01)")).unwrap();
    let s = kanedyn::study::Study::from_file(&dir.join("ok.ron")).unwrap_or_else(|e| panic!("{e}"));
    let opts = kanedyn::study::RunOptions { out: Some(dir.join("out")), progress: false };
    let report = kanedyn::study::run(&s, &opts).unwrap();
    assert!(report.failures.is_empty(), "{:?}", report.failures);
    assert!(report.summary.contains("- modal damping: ζ = 0.01 for every vibration mode"), "{}", report.summary);
    for (name, extra, words) in [
        ("neg.ron", ", modal_damping: All(-0.1)", "damping ratio -0.1 must lie in 0..=10"),
        ("empty.ron", ", modal_damping: PerMode([])", "give 1 to"),
        (
            "both.ron",
            r#", modal_damping: All(0.02), variants: [(label: "x", dampers: [("pivot", 1e-3)])]"#,
            "variants that set dampers do not apply",
        ),
    ] {
        std::fs::write(dir.join(name), study(extra)).unwrap();
        let e = kanedyn::study::Study::from_file(&dir.join(name)).unwrap_err().to_string();
        assert!(e.contains(&format!("{name}:2:")) && e.contains("modal_damping") && e.contains(words), "{e}");
    }
}

/// Modal damping added to the mechanism's own dampers (issue 29, item 2): the eigenvalues of the
/// drivetrain with its shaft dampers (3 N·m·s/rad on shaft a, 1 on shaft c) plus modal ratios
/// equal those of `λ² M + λ (C_d + C_m) + K` built here by hand in the disc angles with the hub
/// held: M = diag(J_a, J_b, J_c), K from the three shafts, C_d from the two dampers, and
/// C_m = M Φ diag(2 ζ_i ω_i) Φᵀ M from this test's own mass-normalised modes. Both sides solve
/// small well-conditioned eigenproblems: 1e-9 relative. With every ratio 0 the model is the
/// damped one unchanged; replacing instead of adding loses the dampers.
#[test]
fn modal_damping_adds_to_the_dampers_when_asked() {
    use branched::{J_A, J_B, J_C, K_A, K_B, K_C};
    use kanedyn::linear::ModalCombination;
    use nalgebra::{DMatrix, SymmetricEigen};
    let mech = drivetrain("JointRates", true);
    let model = LinearModel::new(&mech, "spin", rpm_to_rad_s(1500.0), None).unwrap();
    let ratios = [0.01, 0.03, 0.05];
    let zeta = ModalDamping::PerMode(ratios.to_vec());
    let added = model.with_modal_damping_combined(Spin::Held, &zeta, ModalCombination::Add).unwrap();
    let mut got: Vec<(f64, f64)> = added
        .modes(Spin::Held, Damping::Damped)
        .unwrap()
        .modes
        .iter()
        .map(|m| (m.eigenvalue.re, m.eigenvalue.im.abs()))
        .collect();
    got.sort_by(|a, b| a.1.total_cmp(&b.1));

    // By hand: coordinates (x_a, x_b, x_c), absolute disc angles with the hub held.
    let m = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(vec![J_A, J_B, J_C]));
    let k = DMatrix::from_row_slice(3, 3, &[K_A + K_C, 0.0, -K_C, 0.0, K_B, 0.0, -K_C, 0.0, K_C]);
    let c_d = DMatrix::from_row_slice(3, 3, &[3.0 + 1.0, 0.0, -1.0, 0.0, 0.0, 0.0, -1.0, 0.0, 1.0]);
    let m_half_inv = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(
        [J_A, J_B, J_C].iter().map(|j: &f64| 1.0 / j.sqrt()).collect(),
    ));
    let eig = SymmetricEigen::new(&m_half_inv * &k * &m_half_inv);
    let mut order: Vec<usize> = (0..3).collect();
    order.sort_by(|&i, &j| eig.eigenvalues[i].total_cmp(&eig.eigenvalues[j]));
    let mut c_m = DMatrix::zeros(3, 3);
    for (mode, &i) in order.iter().enumerate() {
        let phi = &m_half_inv * eig.eigenvectors.column(i);
        let mphi = &m * phi;
        c_m += (2.0 * ratios[mode] * eig.eigenvalues[i].sqrt()) * &mphi * mphi.transpose();
    }
    let m_inv = m.clone().try_inverse().unwrap();
    let mut a = DMatrix::zeros(6, 6);
    a.view_mut((0, 3), (3, 3)).copy_from(&DMatrix::identity(3, 3));
    a.view_mut((3, 0), (3, 3)).copy_from(&(-&m_inv * &k));
    a.view_mut((3, 3), (3, 3)).copy_from(&(-&m_inv * (&c_d + &c_m)));
    let mut want: Vec<(f64, f64)> =
        a.complex_eigenvalues().iter().filter(|l| l.im > 0.0).map(|l| (l.re, l.im)).collect();
    want.sort_by(|a, b| a.1.total_cmp(&b.1));
    assert_eq!(got.len(), want.len());
    for (g, w) in got.iter().zip(&want) {
        println!("λ = {:.9} ± {:.9}i vs {:.9} ± {:.9}i", g.0, g.1, w.0, w.1);
        let size = w.0.hypot(w.1);
        assert!(
            abs_diff_eq!(g.0, w.0, epsilon = 1e-9 * size) && abs_diff_eq!(g.1, w.1, epsilon = 1e-9 * size),
            "{g:?} vs {w:?}"
        );
    }
    // Ratios 0: the mechanism's damped model, unchanged.
    let zero = model.with_modal_damping_combined(Spin::Held, &ModalDamping::All(0.0), ModalCombination::Add).unwrap();
    assert!((&zero.f_u - &model.f_u).amax() <= 1e-9 * model.f_u.amax());
    // Replacing gives a different (lighter) damping of the mode that shaft a's damper works on.
    let replaced = model.with_modal_damping(Spin::Held, &zeta).unwrap();
    assert!((&replaced.f_u - &added.f_u).amax() > 1.0);
}
