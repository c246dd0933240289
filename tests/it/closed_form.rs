//! The numeric Kane engine against the closed-form equations (7) of the paper, generalized to N
//! synchronous pendulums, and the published formulas (15), (17), (18).

use approx::{abs_diff_eq, assert_abs_diff_eq, assert_relative_eq, relative_eq};
use kanedyn::cpva::{CpvaParams, inertia_ratio, rotor_order, tuning_order};
use kanedyn::kane::Kane;
use kanedyn::model::excitation::Excitation;
use kanedyn::model::mechanism::Mechanism;
use kanedyn::model::speeds::Speeds;
use nalgebra::{DMatrix, DVector};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

/// A constant rotor torque keeps the comparison about the mechanics (the excitation signal is
/// tested on its own).
const TORQUE: f64 = 123.4;

fn max_abs(m: &DMatrix<f64>) -> f64 {
    m.iter().fold(0.0, |a, &b| a.max(b.abs()))
}

/// Random states covering large spin angles (cyclic coordinate), all pendulum angles and speeds
/// up to ±300 rad/s (≈ 2900 rpm).
fn random_state(rng: &mut StdRng, n: usize) -> (Vec<f64>, Vec<f64>) {
    let mut q = vec![rng.random_range(-3000.0..3000.0)];
    q.extend((1..n).map(|_| rng.random_range(-std::f64::consts::PI..std::f64::consts::PI)));
    let u = (0..n).map(|_| rng.random_range(-300.0..300.0)).collect();
    (q, u)
}

#[test]
fn numeric_m_and_f_equal_eq7_for_1_2_4_pendulums() {
    let mut rng = StdRng::seed_from_u64(7);
    let mut worst: f64 = 0.0;
    for n_pend in [1, 2, 4] {
        let p = CpvaParams::canonical().with_pendulums(n_pend);
        let mech = p.mechanism(Some(Excitation::constant(TORQUE))).unwrap();
        let cf = p.closed_form();
        let mut kane = Kane::new(&mech).unwrap();
        for _ in 0..200 {
            let (q, u) = random_state(&mut rng, n_pend + 1);
            let (m_cf, f_cf) = cf.mass_matrix_and_forcing(&q, &u, TORQUE);
            let (m, f) = kane.mass_matrix_and_forcing(0.0, &q, &u);
            let em = max_abs(&(m - &m_cf)) / max_abs(&m_cf);
            let ef = (f - &f_cf).amax() / f_cf.amax();
            worst = worst.max(em).max(ef);
            assert!(em <= 1e-12, "N = {n_pend}: M differs by {em:e} (relative) at q = {q:?}");
            assert!(ef <= 1e-12, "N = {n_pend}: F differs by {ef:e} (relative) at q = {q:?}, u = {u:?}");
            // The slice accessor (row-major) gives the same numbers.
            let (mr, fr) = kane.mass_matrix_and_forcing_rows(0.0, &q, &u);
            let k = n_pend + 1;
            for r in 0..k {
                assert_abs_diff_eq!(fr[r], f_cf[r], epsilon = 1e-12 * f_cf.amax());
                for c in 0..k {
                    assert_abs_diff_eq!(mr[r * k + c], m_cf[(r, c)], epsilon = 1e-12 * max_abs(&m_cf));
                }
            }
        }
    }
    println!("largest relative difference to eq. (7): {worst:e}");
}

#[test]
fn world_frame_and_root_frame_evaluations_agree() {
    // Expressing vectors in the rotor frame (skipping the spin angle's trigonometry) must not
    // change M or F: both are built from dot products.
    let mech = CpvaParams::canonical().with_pendulums(3).mechanism(Some(Excitation::constant(TORQUE))).unwrap();
    let mut a = Kane::new(&mech).unwrap();
    let mut b = Kane::new_world_frame(&mech).unwrap();
    let mut rng = StdRng::seed_from_u64(11);
    for _ in 0..100 {
        let (q, u) = random_state(&mut rng, 4);
        let (ma, fa) = a.mass_matrix_and_forcing(0.0, &q, &u);
        let (ma, fa) = (ma.clone(), fa.clone());
        let (mb, fb) = b.mass_matrix_and_forcing(0.0, &q, &u);
        assert!(max_abs(&(ma - mb)) / max_abs(mb) < 1e-12);
        assert!((fa - fb).amax() / fb.amax() < 1e-11);
    }
}

#[test]
fn joint_rate_speeds_transform_with_w() {
    // M_rates = Wᵀ M_abs W and F_rates = Wᵀ F_abs, with u_abs = W q̇.
    let mut rng = StdRng::seed_from_u64(3);
    for n_pend in [1, 2, 4] {
        let p = CpvaParams::canonical().with_pendulums(n_pend);
        let spec_abs = p.spec(Some(Excitation::constant(TORQUE)));
        let spec_rates = kanedyn::model::mechanism::MechanismSpec { speeds: Speeds::JointRates, ..spec_abs.clone() };
        let abs = Mechanism::from_spec(&spec_abs).unwrap();
        let rates = Mechanism::from_spec(&spec_rates).unwrap();
        let w = Speeds::AbsoluteAngularVelocities.w_matrix(&abs.parents());
        let mut ka = Kane::new(&abs).unwrap();
        let mut kr = Kane::new(&rates).unwrap();
        for _ in 0..100 {
            let (q, qd) = random_state(&mut rng, n_pend + 1);
            let u_abs: Vec<f64> = (&w * DVector::from_column_slice(&qd)).iter().copied().collect();
            let (ma, fa) = ka.mass_matrix_and_forcing(0.0, &q, &u_abs);
            let m_expect = w.transpose() * ma * &w;
            let f_expect = w.transpose() * fa;
            let (mr, fr) = kr.mass_matrix_and_forcing(0.0, &q, &qd);
            assert!(max_abs(&(mr - &m_expect)) / max_abs(&m_expect) <= 1e-12);
            assert!((fr - &f_expect).amax() / f_expect.amax() <= 1e-12);
        }
    }
}

#[test]
fn canonical_parameters_give_back_table_2() {
    let p = CpvaParams::canonical();
    let (r, l) = (p.pivot_radius, p.l());
    let nt = tuning_order(p.pendulum_mass, r, l, p.i_b());
    let it = inertia_ratio(p.i_a(), p.pendulum_mass, r, p.i_b(), l);
    assert_relative_eq!(nt, 3.11, max_relative = 1e-9);
    assert_relative_eq!(it, 2255.0, max_relative = 1e-9);
    // n_r from eq. (17) with the recovered n_t and Ĩ equals docs/design/conventions.md's tabulated value.
    assert_abs_diff_eq!(rotor_order(nt, it), 3.19088605122, epsilon = 1e-10);
    // The same numbers from the generic mechanism's bodies, not from the parameter struct.
    let mech = p.with_pendulums(4).mechanism(None).unwrap();
    let pend: Vec<_> = mech.bodies[1..].iter().map(|b| b.inertia).collect();
    let m_p: f64 = pend.iter().map(|i| i.mass).sum();
    let i_b: f64 = pend.iter().map(|i| i.i_com).sum();
    let l_mech = pend[0].com.norm();
    let r_mech = mech.joints[1].at.norm();
    let nt2 = tuning_order(m_p, r_mech, l_mech, i_b);
    let it2 = inertia_ratio(mech.bodies[0].inertia.i_com, m_p, r_mech, i_b, l_mech);
    assert_relative_eq!(nt2, 3.11, max_relative = 1e-9);
    assert_relative_eq!(it2, 2255.0, max_relative = 1e-9);
}

#[test]
fn synchronous_pendulums_equal_one() {
    // N pendulums moving in unison (same φ, same absolute speed) give the rotor the same
    // acceleration as one pendulum of the total mass.
    let mut rng = StdRng::seed_from_u64(5);
    let one = CpvaParams::canonical().mechanism(Some(Excitation::constant(TORQUE))).unwrap();
    let mut k1 = Kane::new(&one).unwrap();
    for n_pend in [2, 3, 4, 6] {
        let many =
            CpvaParams::canonical().with_pendulums(n_pend).mechanism(Some(Excitation::constant(TORQUE))).unwrap();
        let mut kn = Kane::new(&many).unwrap();
        for _ in 0..100 {
            let (q, u) = random_state(&mut rng, 2);
            let x1 = [q[0], q[1], u[0], u[1]];
            let mut d1 = [0.0; 4];
            k1.rhs(0.0, &x1, &mut d1).unwrap();
            let n = n_pend + 1;
            let mut xn = vec![q[0]; 2 * n];
            xn[1..n].iter_mut().for_each(|v| *v = q[1]);
            xn[n] = u[0];
            xn[n + 1..].iter_mut().for_each(|v| *v = u[1]);
            let mut dn = vec![0.0; 2 * n];
            kn.rhs(0.0, &xn, &mut dn).unwrap();
            let scale = d1[2].abs().max(1.0);
            assert!(
                abs_diff_eq!(dn[n], d1[2], epsilon = 1e-12 * scale),
                "N = {n_pend}: rotor u̇ {} vs {}",
                dn[n],
                d1[2]
            );
            for i in 1..n {
                assert_abs_diff_eq!(dn[n + i], d1[3], epsilon = 1e-11 * d1[3].abs().max(1.0));
            }
        }
    }
}

#[test]
fn closed_form_rhs_matches_engine_rhs() {
    let p = CpvaParams::canonical();
    let mech = p.mechanism(Some(Excitation::constant(TORQUE))).unwrap();
    let mut k = Kane::new(&mech).unwrap();
    let cf = p.closed_form();
    let mut rng = StdRng::seed_from_u64(9);
    for _ in 0..100 {
        let (q, u) = random_state(&mut rng, 2);
        let x = [q[0], q[1], u[0], u[1]];
        let (mut a, mut b) = ([0.0; 4], [0.0; 4]);
        k.rhs(0.0, &x, &mut a).unwrap();
        cf.rhs1(TORQUE, &x, &mut b);
        for i in 0..4 {
            assert!(
                abs_diff_eq!(a[i], b[i], epsilon = 1e-11 * b[i].abs().max(1.0)),
                "component {i}: {} vs {}",
                a[i],
                b[i]
            );
        }
    }
}

#[test]
fn locked_twin_is_one_rigid_rotor() {
    // Locking every pivot at φ = 0 leaves one body with the locked inertia of docs/design/conventions.md,
    // I_A + I_B + m_p (R + L)², and the rotor's damping only.
    for n_pend in [1, 4] {
        let p = CpvaParams::canonical().with_pendulums(n_pend);
        let mut mech = p.mechanism(Some(Excitation::constant(TORQUE))).unwrap();
        for i in 0..n_pend {
            mech = mech.lock(&p.pivot_name(i), 0.0).unwrap();
        }
        assert_eq!(mech.ndof(), 1);
        let mut k = Kane::new(&mech).unwrap();
        let m = k.mass_matrix(&[0.7])[(0, 0)];
        assert!(relative_eq!(m, p.locked_inertia(), max_relative = 1e-13), "N = {n_pend}: {m}");
        let mut xd = [0.0; 2];
        k.rhs(0.0, &[0.0, 100.0], &mut xd).unwrap();
        let expect = (TORQUE - p.c_r * 100.0) / p.locked_inertia();
        assert_abs_diff_eq!(xd[1], expect, epsilon = 1e-12 * expect.abs());
    }
    let mech = CpvaParams::canonical().mechanism(None).unwrap();
    assert!(mech.lock("spin", 0.0).is_err(), "locking to ground must be refused");
    assert!(mech.lock("nope", 0.0).is_err());
}
