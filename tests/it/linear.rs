//! Linear analysis (src/linear.rs) against the paper's closed forms: the linearised equations (13),
//! the tuning order (15) with its damping (16), the rotor eigen-order (17) with Ĩ (18), the
//! normalised frequency response of eq. (22) (Fig. 2: zero at n_t, pole at n_r, the crossing
//! of 1 and the high-order asymptote, derived in the comments below), Campbell data of a
//! shaft-spring rotor against the roots of its 2×2 characteristic polynomial, and the
//! multi-order response of Table 1 against a hand-written 2-DOF model.

use approx::{assert_abs_diff_eq, assert_relative_eq, relative_eq};
use kanedyn::cpva::{CpvaParams, inertia_ratio, rotor_order, tuning_order};
use kanedyn::linear::{
    C64, Damping, LinearError, LinearModel, ModeKind, OrderResponse, ResponseSpec, SpeedCase, Spin, campbell,
    forcing_jacobians, multi_order_response, with_speeds,
};
use kanedyn::model::excitation::{Harmonic, rpm_to_rad_s};
use kanedyn::model::joint::Spring;
use kanedyn::model::mechanism::{Mechanism, MechanismSpec};
use kanedyn::model::speeds::Speeds;
use nalgebra::DMatrix;
use std::f64::consts::PI;

const RPM: f64 = 1000.0;

fn omega() -> f64 {
    rpm_to_rad_s(RPM)
}

/// Closed-form constants of eq. (15), (17), (18) from the canonical parameters' geometry.
struct Closed {
    n_t: f64,
    i_tilde: f64,
    n_r: f64,
    /// `a = I_A + m_p R²`, `b = m_p R L`, `c = I_B + m_p L²` (eq. 7, totals over the pendulums).
    a: f64,
    b: f64,
    c: f64,
}

fn closed(p: &CpvaParams) -> Closed {
    let (m, r, l, ib) = (p.pendulum_mass, p.pivot_radius, p.l(), p.i_b());
    let n_t = tuning_order(m, r, l, ib);
    let i_tilde = inertia_ratio(p.i_a(), m, r, ib, l);
    Closed { n_t, i_tilde, n_r: rotor_order(n_t, i_tilde), a: p.i_a() + m * r * r, b: m * r * l, c: ib + m * l * l }
}

fn params(n: usize, c_p: f64, c_r: f64) -> CpvaParams {
    CpvaParams { c_p, c_r, ..CpvaParams::canonical().with_pendulums(n) }
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

fn max_abs(m: &DMatrix<f64>) -> f64 {
    m.iter().fold(0.0, |a, &b| a.max(b.abs()))
}

fn cpva_spec(n: usize) -> ResponseSpec {
    let p = params(n, 0.0, 0.0);
    ResponseSpec {
        spin_joint: "spin".into(),
        inputs: vec![kanedyn::linear::Input::unit("spin")],
        body: "rotor".into(),
        lock: (0..n).map(|i| p.pivot_name(i)).collect(),
    }
}

#[test]
fn operating_point_and_jacobians_equal_eq13() {
    // Eq. (13) in the paper's speeds at φ = 0: M = [[a, b], [b, c]], F_q = [[0, bΩ²], [0, −bΩ²]]
    // (columns θ, φ), F_u = [[−c_r − c_p, c_p], [c_p, −c_p]], and T_m = c_r Ω balances the loss.
    // Tolerance 1e-12 relative: Richardson's O(h⁶) remainder and rounding are both far below.
    let p = CpvaParams::canonical();
    let k = closed(&p);
    let w = omega();
    let lin = LinearModel::new(&p.mechanism(None).unwrap(), "spin", w, None).unwrap();
    let m_cf = DMatrix::from_row_slice(2, 2, &[k.a, k.b, k.b, k.c]);
    let fq_cf = DMatrix::from_row_slice(2, 2, &[0.0, k.b * w * w, 0.0, -k.b * w * w]);
    let fu_cf = DMatrix::from_row_slice(2, 2, &[-p.c_r - p.c_p, p.c_p, p.c_p, -p.c_p]);
    let em = max_abs(&(&lin.mass - &m_cf)) / max_abs(&m_cf);
    let eq = max_abs(&(&lin.f_q - &fq_cf)) / max_abs(&fq_cf);
    let eu = max_abs(&(&lin.f_u - &fu_cf)) / max_abs(&fu_cf);
    println!("eq. (13): M {em:e}, F_q {eq:e}, F_u {eu:e}; T_m = {} (c_r Ω = {})", lin.op.mean_spin_torque, p.c_r * w);
    assert!(em < 1e-12 && eq < 1e-12 && eu < 1e-12, "M {em:e}, F_q {eq:e}, F_u {eu:e}");
    assert_relative_eq!(lin.op.mean_spin_torque, p.c_r * w, max_relative = 1e-12);
    assert!(lin.op.residual < 1e-9);
    assert_eq!(lin.op.u, vec![w, w]);
    assert!(max_abs(&lin.f_u_undamped) < 1e-12 * max_abs(&fu_cf));
    // The input vector of a unit spin torque and the first-order form of eq. (19).
    let a_hat = lin.input("spin").unwrap();
    assert_eq!(a_hat.as_slice(), &[0.0, 0.0, 1.0, 0.0]);
    let fo = lin.first_order(Damping::Damped);
    // θ̇ = u1, φ̇ = u2 − u1: the block −W⁻¹ is [[−1, 0], [1, −1]].
    assert_eq!((fo.a[(0, 2)], fo.a[(0, 3)], fo.a[(1, 2)], fo.a[(1, 3)]), (-1.0, 0.0, 1.0, -1.0));
    assert_eq!(fo.m.view((2, 2), (2, 2)), lin.mass.view((0, 0), (2, 2)));
    // Second order in (θ, φ): M_q = Wᵀ M W is the joint-rate mass matrix, K = diag(0, bΩ²).
    let so = lin.second_order(Damping::Undamped);
    let jl = k.a + k.c + 2.0 * k.b;
    assert_relative_eq!(so.m[(0, 0)], jl, max_relative = 1e-12);
    assert_relative_eq!(so.m[(0, 1)], k.c + k.b, max_relative = 1e-12);
    assert_relative_eq!(so.m[(1, 1)], k.c, max_relative = 1e-12);
    assert_relative_eq!(so.k[(1, 1)], k.b * w * w, max_relative = 1e-12);
    assert_abs_diff_eq!(so.k[(0, 0)], 0.0, epsilon = 1e-9);
    assert_abs_diff_eq!(so.k[(0, 1)], 0.0, epsilon = 1e-9);
}

#[test]
fn jacobians_equal_analytic_derivatives_of_eq7_off_equilibrium() {
    // At arbitrary states (not an equilibrium) the Richardson Jacobians of the engine's F against
    // the analytic derivatives of eq. (7) for two pendulums: ∂F0/∂φ_i = b u_i² cos φ_i,
    // ∂F0/∂u_i = 2 b u_i sin φ_i + c_p, ∂F_i/∂φ_i = −b u1² cos φ_i, ∂F_i/∂u1 = −2 b u1 sin φ_i + c_p,
    // ∂F0/∂u1 = −Σc_p − c_r, ∂F_i/∂u_i = −c_p (per pendulum b, c_p). Tolerance 1e-10 relative
    // to the largest entry (rounding of F's largest terms over the h/4 step).
    let p = CpvaParams::canonical().with_pendulums(2);
    let cf = p.closed_form();
    let mut kane = kanedyn::kane::Kane::new(&p.mechanism(None).unwrap()).unwrap();
    let mut worst: f64 = 0.0;
    for (q, u) in [(vec![12.3, 0.4, -1.1], vec![110.0, 95.0, 130.0]), (vec![-3.0, 2.5, 0.05], vec![-40.0, 60.0, -20.0])]
    {
        let (fq, fu) = forcing_jacobians(&mut kane, &q, &u);
        let mut fq_cf = DMatrix::zeros(3, 3);
        let mut fu_cf = DMatrix::zeros(3, 3);
        fu_cf[(0, 0)] = -cf.c_r - 2.0 * cf.c_p;
        for i in 1..3 {
            let (s, c) = q[i].sin_cos();
            fq_cf[(0, i)] = cf.b * u[i] * u[i] * c;
            fq_cf[(i, i)] = -cf.b * u[0] * u[0] * c;
            fu_cf[(0, i)] = 2.0 * cf.b * u[i] * s + cf.c_p;
            fu_cf[(i, 0)] = -2.0 * cf.b * u[0] * s + cf.c_p;
            fu_cf[(i, i)] = -cf.c_p;
        }
        let eq = max_abs(&(fq - &fq_cf)) / max_abs(&fq_cf);
        let eu = max_abs(&(fu - &fu_cf)) / max_abs(&fu_cf);
        worst = worst.max(eq).max(eu);
    }
    println!("Richardson Jacobians vs analytic eq. (7): {worst:e}");
    assert!(worst < 1e-10, "{worst:e}");
}

#[test]
fn eigen_orders_equal_n_t_held_and_n_r_free_for_1_and_4_pendulums() {
    // Undamped: held spin → every pendulum mode at n_t (eq. 15); free spin → the unison mode at
    // n_r (eq. 17) and, for N = 4, three non-unison modes at n_t (the rotor feels no net torque
    // from them). Tolerance 1e-9 relative (brief); measured ≈ 1e-13.
    let mut worst: f64 = 0.0;
    for n in [1, 4] {
        let p = CpvaParams::canonical().with_pendulums(n);
        let k = closed(&p);
        let lin = LinearModel::new(&p.mechanism(None).unwrap(), "spin", omega(), None).unwrap();
        let held = lin.modes(Spin::Held, Damping::Undamped).unwrap();
        assert!(held.rigid.is_empty());
        assert_eq!(held.modes.len(), n);
        for m in &held.modes {
            worst = worst.max(rel(m.order, k.n_t));
            assert!(relative_eq!(m.order, k.n_t, max_relative = 1e-9), "N = {n} held: {} vs n_t {}", m.order, k.n_t);
            assert!(m.label.starts_with("pivot"), "held modes are pendulum modes: {}", m.label);
            assert_abs_diff_eq!(m.damping_ratio, 0.0, epsilon = 1e-9);
        }
        let free = lin.modes(Spin::Free, Damping::Undamped).unwrap();
        assert_eq!(free.rigid.len(), 2);
        assert_eq!(free.rigid[0].kind, ModeKind::SpinAngle);
        assert_eq!(free.rigid[1].kind, ModeKind::SpinSpeed);
        assert!(free.rigid[1].eigenvalue.norm() < 1e-8 * omega(), "undamped spin-speed mode at 0");
        // The spin-speed mode turns everything together: equal absolute rates.
        let sq = &free.rigid[1].shape_qdot;
        assert!((sq[0] - C64::new(1.0, 0.0)).norm() < 1e-9 && sq[1..].iter().all(|x| x.norm() < 1e-9));
        assert_eq!(free.modes.len(), n);
        let orders: Vec<f64> = free.modes.iter().map(|m| m.order).collect();
        for (i, m) in free.modes.iter().enumerate() {
            let expect = if i + 1 < n { k.n_t } else { k.n_r };
            worst = worst.max(rel(m.order, expect));
            assert!(
                relative_eq!(m.order, expect, max_relative = 1e-9),
                "N = {n} free: orders {orders:?}, n_t {}, n_r {}",
                k.n_t,
                k.n_r
            );
        }
        // The rotor mode moves the rotor (its coordinate share is far larger than in a
        // non-unison mode, where it is 0) although the pendulum's swing dominates it: φ/θ =
        // n²(1 + n_t²)/(n_t² − n²) ≈ −213 at n_r for N = 1.
        let top = free.modes.last().unwrap();
        if n == 1 {
            let ratio = top.shape_q[1] / top.shape_q[0];
            let nr2 = k.n_r * k.n_r;
            let expect = nr2 * (1.0 + k.n_t * k.n_t) / (k.n_t * k.n_t - nr2);
            assert!((ratio - C64::new(expect, 0.0)).norm() < 1e-7 * expect.abs(), "{ratio} vs {expect}");
        } else {
            assert!(free.modes[0].coordinate_share[0] < 1e-12 && top.coordinate_share[0] > 1e-6);
        }
        println!(
            "N = {n}: held orders {:?}, free orders {orders:?}",
            held.modes.iter().map(|m| m.order).collect::<Vec<_>>()
        );
    }
    println!("largest relative error of n_t, n_r: {worst:e}");
}

#[test]
fn damped_pendulum_mode_has_the_damping_of_eq16() {
    // Held spin, eq. (14): φ̈ + c̃_p φ̇ + n_t²Ω² φ = 0 with c̃_p = c_p / (I_B + m L²) (eq. 16):
    // ω_n = n_t Ω, ζ = c̃_p / (2 n_t Ω). Free spin with c_r: the spin-speed mode decays at
    // λ ≈ −c_r / J (J the locked inertia; exact for c_p → 0 since the pendulum rides along).
    let p = params(1, 5e-2, 5e-3);
    let k = closed(&p);
    let w = omega();
    let lin = LinearModel::new(&p.mechanism(None).unwrap(), "spin", w, None).unwrap();
    let held = lin.modes(Spin::Held, Damping::Damped).unwrap();
    let m = &held.modes[0];
    let zeta = p.c_p / k.c / (2.0 * k.n_t * w);
    println!("held: ω_n {} vs {}, ζ {} vs {zeta}", m.natural_frequency_rad_s, k.n_t * w, m.damping_ratio);
    assert_relative_eq!(m.natural_frequency_rad_s, k.n_t * w, max_relative = 1e-9);
    assert_relative_eq!(m.damping_ratio, zeta, max_relative = 1e-9);
    let free = LinearModel::new(&params(1, 0.0, 5e-3).mechanism(None).unwrap(), "spin", w, None)
        .unwrap()
        .modes(Spin::Free, Damping::Damped)
        .unwrap();
    let l = free.rigid[1].eigenvalue;
    assert!(relative_eq!(l.re, -p.c_r / p.locked_inertia(), max_relative = 1e-9) && l.im == 0.0, "{l}");
}

#[test]
fn relative_equilibrium_off_the_radial_line() {
    // A pivot spring k_s relaxed at φ_f = 0.3 rad pulls the pendulum off the radial line: the
    // equilibrium solves k_s(φ − φ_f) + bΩ² sin φ = 0 (bisection below), the held mode has
    // c ω² = bΩ² cos φ₀ + k_s, the mean torque is still c_r Ω (the spring torque is internal),
    // and the free linearisation gains the gyroscopic terms ∂F0/∂u2 = 2bΩ sin φ₀,
    // ∂F1/∂u1 = −2bΩ sin φ₀ (plus c_p). Tolerances: equilibrium 1e-12 rad, frequency 1e-9.
    let p = CpvaParams::canonical();
    let k = closed(&p);
    let w = omega();
    let ks = 0.2 * k.b * w * w;
    let phi_f = 0.3;
    let mut spec = p.spec(None);
    spec.joints[1].spring = Some(Spring { stiffness: ks, free_angle: phi_f });
    let mech = Mechanism::from_spec(&spec).unwrap();
    let lin = LinearModel::new(&mech, "spin", w, None).unwrap();
    let (mut lo, mut hi) = (0.0, phi_f);
    for _ in 0..200 {
        let mid: f64 = 0.5 * (lo + hi);
        if ks * (mid - phi_f) + k.b * w * w * mid.sin() > 0.0 {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    let phi0 = 0.5 * (lo + hi);
    println!(
        "φ₀ = {} (bisection {phi0}), {} Newton iterations, residual {:e}",
        lin.op.q[1], lin.op.iterations, lin.op.residual
    );
    assert_abs_diff_eq!(lin.op.q[1], phi0, epsilon = 1e-12);
    assert_relative_eq!(lin.op.mean_spin_torque, p.c_r * w, max_relative = 1e-9);
    let held = lin.modes(Spin::Held, Damping::Undamped).unwrap();
    let wn = ((k.b * w * w * phi0.cos() + ks) / k.c).sqrt();
    assert_relative_eq!(held.modes[0].natural_frequency_rad_s, wn, max_relative = 1e-9);
    let (s0, c_p) = (phi0.sin(), p.c_p);
    assert_relative_eq!(lin.f_u[(0, 1)], 2.0 * k.b * w * s0 + c_p, max_relative = 1e-10);
    assert_relative_eq!(lin.f_u[(1, 0)], -2.0 * k.b * w * s0 + c_p, max_relative = 1e-10);
}

#[test]
fn results_do_not_depend_on_the_speeds() {
    // Joint rates (u = [θ̇, φ̇]) instead of the paper's absolute speeds: same eigenvalues and
    // the same rotor acceleration response (a physical quantity). 1e-10 relative.
    let p = params(1, 5e-4, 5e-3);
    let abs = p.mechanism(None).unwrap();
    assert_eq!(abs.speeds, Speeds::AbsoluteAngularVelocities);
    let rates = with_speeds(&abs, Speeds::JointRates);
    let spec = cpva_spec(1);
    let ra = OrderResponse::new(&abs, &spec, omega(), None).unwrap();
    let rr = OrderResponse::new(&rates, &spec, omega(), None).unwrap();
    assert_eq!(rr.model.op.u, vec![omega(), 0.0]);
    let mut worst: f64 = 0.0;
    for spin in [Spin::Held, Spin::Free] {
        let ma = ra.model.modes(spin, Damping::Damped).unwrap();
        let mr = rr.model.modes(spin, Damping::Damped).unwrap();
        for (a, b) in ma.modes.iter().chain(&ma.rigid).zip(mr.modes.iter().chain(&mr.rigid)) {
            let e = (a.eigenvalue - b.eigenvalue).norm() / a.eigenvalue.norm().max(1e-300);
            worst = worst.max(if a.eigenvalue.norm() == 0.0 { 0.0 } else { e });
            assert!(a.kind == b.kind && a.label == b.label);
            for (x, y) in a.coordinate_share.iter().zip(&b.coordinate_share) {
                assert_abs_diff_eq!(x, y, epsilon = 1e-9);
            }
        }
    }
    for n in [1.0, 2.9, 3.11, 3.19, 3.5, 6.0] {
        let (a, b) = (ra.response(n).unwrap(), rr.response(n).unwrap());
        worst = worst.max((a - b).norm() / a.norm());
        let (a, b) = (ra.point(n).unwrap().ratio, rr.point(n).unwrap().ratio);
        worst = worst.max(rel(b, a));
    }
    println!("speeds choice: largest relative difference {worst:e}");
    assert!(worst < 1e-10, "{worst:e}");
}

/// Eq. (22) for the undamped CPVA in closed form: with P = Ĩ + 1 + 2n_t² (the locked inertia
/// over c) the rotor's effective inertia at order n is `c·(P + (1 + n_t²)² n² / (n_t² − n²))`,
/// so the normalised response is `P / |P + (1 + n_t²)² n² / (n_t² − n²)|`: zero at n_t, pole at
/// n_r (eq. 17), equal to 1 above n_t where the effective inertia is −P, i.e.
/// `(n/n_t)² = 2P / (2Ĩ + 1 + 2n_t² − n_t⁴)`, and → P / (Ĩ − n_t⁴) as n → ∞.
fn ratio_closed(k: &Closed, n: f64) -> f64 {
    let nt2 = k.n_t * k.n_t;
    let p = k.i_tilde + 1.0 + 2.0 * nt2;
    p / (p + (1.0 + nt2).powi(2) * n * n / (nt2 - n * n)).abs()
}

#[test]
fn normalised_response_matches_the_closed_forms() {
    // c_p = c_r = 0. The crossing by bisection to 1e-13 must equal the closed form to 1e-10;
    // the asymptote to 1e-12; the sweep values to 1e-10; the zero at n_t below 1e-10 and the
    // pole at n_r above 1e6 at n_r(1 ± 1e-8).
    for n_p in [1, 4] {
        let p = params(n_p, 0.0, 0.0);
        let k = closed(&p);
        let r = OrderResponse::new(&p.mechanism(None).unwrap(), &cpva_spec(n_p), omega(), None).unwrap();
        let nt2 = k.n_t * k.n_t;
        let cross_cf =
            k.n_t * (2.0 * (k.i_tilde + 1.0 + 2.0 * nt2) / (2.0 * k.i_tilde + 1.0 + 2.0 * nt2 - nt2 * nt2)).sqrt();
        let asym_cf = (k.i_tilde + 1.0 + 2.0 * nt2) / (k.i_tilde - nt2 * nt2);
        let cross = r.first_amplification(k.n_t, 1.1 * k.n_t, 400).unwrap().unwrap();
        let asym = r.asymptote().unwrap();
        let far = r.point(1e4).unwrap().ratio;
        let mut worst_sweep: f64 = 0.0;
        let orders: Vec<f64> = (0..=80).map(|i| 2.0 + 2.0 * i as f64 / 80.0).collect();
        for pt in r.sweep(&orders).unwrap() {
            if (pt.order - k.n_t).abs() > 1e-3 && (pt.order - k.n_r).abs() > 1e-3 {
                worst_sweep = worst_sweep.max(rel(pt.ratio, ratio_closed(&k, pt.order)));
            }
        }
        // Locked rotor: |α̂| = 1/J_L exactly without damping.
        let lk = r.point(3.0).unwrap().locked;
        assert_relative_eq!(lk, 1.0 / p.locked_inertia(), max_relative = 1e-12);
        let zero = r.point(k.n_t).unwrap().ratio;
        let pole = r.point(k.n_r * (1.0 + 1e-8)).unwrap().ratio.min(r.point(k.n_r * (1.0 - 1e-8)).unwrap().ratio);
        println!(
            "N = {n_p}: crossing {cross} (n/n_t {}) vs {cross_cf}: {:e}; asymptote {asym} vs {asym_cf}: {:e}, at n = 1e4 {far}; sweep {worst_sweep:e}; ratio at n_t {zero:e}, at n_r(1±1e-8) {pole:e}",
            cross / k.n_t,
            rel(cross, cross_cf),
            rel(asym, asym_cf)
        );
        assert_relative_eq!(cross, cross_cf, max_relative = 1e-10);
        assert_relative_eq!(asym, asym_cf, max_relative = 1e-12);
        assert!(relative_eq!(far, asym_cf, max_relative = 1e-6), "n = 1e4 approaches the asymptote as 1/n²");
        assert!(worst_sweep < 1e-10, "{worst_sweep:e}");
        assert!(zero < 1e-10, "{zero:e}");
        assert!(pole > 1e6, "{pole:e}");
    }
}

#[test]
fn figure2_extremes_for_three_pendulum_dampings() {
    // Fig. 2 of the paper: 1000 rpm, c_r = 5e-3, c_p = 5e-4, 5e-3, 5e-2. The minimum sits at
    // ≈ n_t, the maximum at ≈ n_r, above 1 beyond a crossing just above n_t (the paper reads
    // ≈ 1.015 n_t). Checks: the smallest-damping minimum within 1e-3 of n_t and maximum within
    // 1e-3 of n_r; extremes move away (min up, max down) as c_p grows. The crossing of 1 is
    // Den Hartog's invariant point: the locked rotor is the c_p → ∞ limit, so every c_p curve
    // passes where the undamped ratio is 1; with c_r = 5e-3 (not 0) it stays within 1e-6 of the
    // undamped closed form.
    let k = closed(&CpvaParams::canonical());
    let nt2 = k.n_t * k.n_t;
    let cross_cf =
        k.n_t * (2.0 * (k.i_tilde + 1.0 + 2.0 * nt2) / (2.0 * k.i_tilde + 1.0 + 2.0 * nt2 - nt2 * nt2)).sqrt();
    let mut prev: Option<(f64, f64)> = None;
    for c_p in [5e-4, 5e-3, 5e-2] {
        let p = params(1, c_p, 5e-3);
        let r = OrderResponse::new(&p.mechanism(None).unwrap(), &cpva_spec(1), omega(), None).unwrap();
        let e = r.extremes(0.9 * k.n_t, 1.2 * k.n_t, 3000).unwrap();
        let cross = r.first_amplification(e.min_order, 1.2 * k.n_t, 3000).unwrap().unwrap();
        println!(
            "c_p = {c_p:e}: min {:.6e} at n/n_t = {:.6}, max {:.6} at n/n_t = {:.6} (n_r/n_t = {:.6}), crossing n/n_t = {:.9}, asymptote {:.6}",
            e.min_ratio,
            e.min_order / k.n_t,
            e.max_ratio,
            e.max_order / k.n_t,
            k.n_r / k.n_t,
            cross / k.n_t,
            r.asymptote().unwrap()
        );
        assert!(relative_eq!(cross, cross_cf, max_relative = 1e-6), "crossing {cross} vs {cross_cf}");
        if c_p == 5e-4 {
            assert_relative_eq!(e.min_order, k.n_t, max_relative = 1e-3);
            assert_relative_eq!(e.max_order, k.n_r, max_relative = 1e-3);
        }
        if let Some((mn, mx)) = prev {
            assert!(e.min_ratio > mn && e.max_ratio < mx);
        }
        prev = Some((e.min_ratio, e.max_ratio));
    }
}

/// A hub spinning at Ω (held), a shaft spring k to the rotor, and the canonical pendulum on the
/// rotor: `ground –spin→ hub –shaft(k)→ rotor –pivot→ pendulum`.
fn shaft_mechanism(k_shaft: f64) -> Mechanism {
    let p = params(1, 0.0, 0.0);
    let mut spec: MechanismSpec = p.spec(None);
    spec.loads.clear();
    let mut hub = spec.bodies[0].clone();
    hub.name = Some("hub".into());
    hub.inertia = Some(0.5);
    spec.bodies.insert(0, hub);
    spec.joints[0].child = Some("hub".into());
    spec.joints.insert(
        1,
        kanedyn::model::joint::JointSpec {
            name: Some("shaft".into()),
            parent: Some("hub".into()),
            child: Some("rotor".into()),
            spring: Some(Spring { stiffness: k_shaft, free_angle: 0.0 }),
            ..Default::default()
        },
    );
    Mechanism::from_spec(&spec).unwrap()
}

#[test]
fn campbell_of_cpva_is_straight_order_lines_and_of_shaft_rotor_is_not() {
    // CPVA, free: the one vibration mode sits at n_r at every speed (f = n_r·rpm/60), held at
    // n_t. Tolerance 1e-9 relative.
    let p = CpvaParams::canonical();
    let k = closed(&p);
    let rpm = [200.0, 600.0, 1000.0, 1800.0];
    let mech = p.mechanism(None).unwrap();
    for (spin, order) in [(Spin::Free, k.n_r), (Spin::Held, k.n_t)] {
        let c = campbell(&mech, "spin", &rpm, &[1.5, 3.0], spin, Damping::Undamped, None, None).unwrap();
        assert_eq!(c.tracks.len(), 1);
        for (f, r) in c.tracks[0].frequency_hz.iter().zip(&rpm) {
            assert!(relative_eq!(*f, order * r / 60.0, max_relative = 1e-9), "{f} Hz at {r} rpm");
        }
        assert_eq!(c.order_lines[1].frequency_hz[2], 3.0 * 1000.0 / 60.0);
    }
    // Shaft rotor: in joint rates (ψ shaft twist, φ pendulum) M = [[J_L, c+b], [c+b, c]],
    // K = diag(k, bΩ²) with J_L = a + c + 2b; ω² are the roots of
    // (M11 c − (c+b)²) x² − (k c + bΩ² M11) x + k bΩ² = 0. At Ω = 0 the pendulum is free
    // (ω = 0) and the shaft mode is sqrt(k c / (J_L c − (c+b)²)) = sqrt(k / (a − b²/c)), the
    // rotor without the pendulum's swinging inertia (not the locked J_L: the brief's "J_total"
    // holds only for the locked pendulum, checked last). Tolerance 1e-9.
    let k_shaft = 2.0e5;
    let shaft = shaft_mechanism(k_shaft);
    let rpm = [0.0, 300.0, 1000.0, 3000.0, 6000.0];
    let c = campbell(&shaft, "spin", &rpm, &[3.0], Spin::Held, Damping::Undamped, None, None).unwrap();
    assert_eq!(c.tracks.len(), 2);
    let jl = k.a + k.c + 2.0 * k.b;
    let mut worst: f64 = 0.0;
    for (i, &r) in rpm.iter().enumerate() {
        let w = rpm_to_rad_s(r);
        let (qa, qb, qc) = (jl * k.c - (k.c + k.b).powi(2), k_shaft * k.c + k.b * w * w * jl, k_shaft * k.b * w * w);
        let disc = (qb * qb - 4.0 * qa * qc).sqrt();
        let x_hi = (qb + disc) / (2.0 * qa);
        let x_lo = qc / (qa * x_hi); // product of the roots: avoids cancellation
        let mut f: Vec<f64> = c.tracks.iter().map(|t| t.frequency_hz[i]).collect();
        f.sort_by(f64::total_cmp);
        let (lo, hi) = (x_lo.sqrt() / (2.0 * PI), x_hi.sqrt() / (2.0 * PI));
        worst = worst.max(rel(f[1], hi));
        if r > 0.0 {
            worst = worst.max(rel(f[0], lo));
        } else {
            assert!(f[0] < 1e-6, "pendulum frequency at rest: {}", f[0]);
        }
        // The tracks follow the two branches, which veer (the pendulum and the shaft couple
        // through M) and never cross: track 0 is the lower one at every speed, and the two
        // label the two joints.
        assert!(c.tracks[0].frequency_hz[i] < c.tracks[1].frequency_hz[i], "at {r} rpm");
        let mut labels: Vec<&str> = c.tracks.iter().map(|t| t.labels[i].as_str()).collect();
        labels.sort();
        assert_eq!(labels, ["pivot", "shaft"], "at {r} rpm");
        println!(
            "{r} rpm: pendulum {} Hz ({lo}), shaft {} Hz ({hi}); labels {:?}",
            f[0],
            f[1],
            c.tracks.iter().map(|t| &t.labels[i]).collect::<Vec<_>>()
        );
    }
    assert!(worst < 1e-9, "{worst:e}");
    let at_rest = (k_shaft / (k.a - k.b * k.b / k.c)).sqrt() / (2.0 * PI);
    // The branch that is the shaft mode at rest (the upper one).
    let shaft_track = c.tracks.iter().find(|t| t.labels[0] == "shaft").expect("a track labelled by the shaft joint");
    assert_relative_eq!(shaft_track.frequency_hz[0], at_rest, max_relative = 1e-9);
    let pend = c.tracks.iter().find(|t| t.labels[0] == "pivot").expect("a track labelled by the pivot");
    // Not order lines: frequency per rpm changes with speed for both tracks.
    let per_rpm = |t: &kanedyn::linear::CampbellTrack, i: usize| t.frequency_hz[i] / rpm[i];
    assert!(rel(per_rpm(shaft_track, 1), per_rpm(shaft_track, 4)) > 0.1);
    assert!(rel(per_rpm(pend, 1), per_rpm(pend, 4)) > 1e-3);
    // Locked pendulum at rest: sqrt(k / J_L).
    let locked = shaft.lock("pivot", 0.0).unwrap();
    let m = LinearModel::new(&locked, "spin", 0.0, None).unwrap().modes(Spin::Held, Damping::Undamped).unwrap();
    assert_relative_eq!(m.modes[0].natural_frequency_rad_s, (k_shaft / jl).sqrt(), max_relative = 1e-9);
}

/// The paper's Table 1 (n = 3, α_n = 0, α_2n = −0.32 rad).
fn table1() -> Vec<SpeedCase> {
    let rpm = [600.0, 800.0, 1000.0, 1200.0, 1400.0, 1600.0, 1800.0];
    let tn = [670.0, 945.0, 1600.0, 1600.0, 1600.0, 1600.0, 1500.0];
    let t2n = [430.0, 570.0, 900.0, 900.0, 838.0, 627.0, 406.0];
    (0..7)
        .map(|i| SpeedCase {
            rpm: rpm[i],
            harmonics: vec![
                Harmonic { multiple: 1.0, amplitude: tn[i], phase: 0.0 },
                Harmonic { multiple: 2.0, amplitude: t2n[i], phase: -0.32 },
            ],
        })
        .collect()
}

#[test]
fn multi_order_response_of_table1_matches_a_hand_written_2dof_model() {
    // Canonical damping. Independent model in joint rates (θ, φ): M = [[J_L, c+b], [c+b, c]],
    // C = diag(c_r, c_p), K = diag(0, bΩ²), α̂ = −ω² θ̂ for a unit torque on θ; locked:
    // α̂ = iω·iω / (−ω² J_L + iω c_r). Amplitudes to 1e-10 relative, phases to 1e-9 rad.
    let p = CpvaParams::canonical();
    let k = closed(&p);
    let jl = k.a + k.c + 2.0 * k.b;
    let res = multi_order_response(&p.mechanism(None).unwrap(), &cpva_spec(1), 3.0, &table1(), None).unwrap();
    let mut worst: f64 = 0.0;
    for sr in &res {
        let w0 = sr.omega;
        assert_relative_eq!(sr.mean_torque, p.c_r * w0, max_relative = 1e-12);
        for h in &sr.harmonics {
            let w = h.order * w0;
            let iw = C64::new(0.0, w);
            let m = [[jl, k.c + k.b], [k.c + k.b, k.c]];
            let z = |i: usize, j: usize| {
                let c = if i != j {
                    0.0
                } else if i == 0 {
                    p.c_r
                } else {
                    p.c_p
                };
                let kk = if i == 1 && j == 1 { k.b * w0 * w0 } else { 0.0 };
                iw * iw * m[i][j] + iw * c + kk
            };
            let det = z(0, 0) * z(1, 1) - z(0, 1) * z(1, 0);
            let theta = z(1, 1) / det;
            // T sin(ψ + α_k) → |H| T sin(ψ + α_k + arg H).
            let alpha = iw * iw * theta * h.torque;
            let alpha_l = iw * iw / (iw * iw * jl + iw * p.c_r) * h.torque;
            let alpha_k = if h.multiple == 1.0 { 0.0 } else { -0.32 };
            worst = worst.max(rel(h.amplitude, alpha.norm())).max(rel(h.locked_amplitude, alpha_l.norm()));
            let dphase = (h.phase - alpha_k - alpha.arg()).rem_euclid(2.0 * PI);
            let dphase = dphase.min(2.0 * PI - dphase);
            assert!(dphase < 1e-9, "phase {dphase:e}");
        }
        let pk = sr.peak.unwrap();
        let sum: f64 = sr.harmonics.iter().map(|h| h.amplitude).sum();
        assert!(pk <= sum * (1.0 + 1e-12) && pk >= sr.harmonics.iter().fold(0.0f64, |a, h| a.max(h.amplitude)));
        println!(
            "{} rpm: T_m {:.4} N·m; order 3: {:.4} rad/s² (locked {:.4}); order 6: {:.4} (locked {:.4}); peak {:.4} (locked {:.4})",
            sr.rpm,
            sr.mean_torque,
            sr.harmonics[0].amplitude,
            sr.harmonics[0].locked_amplitude,
            sr.harmonics[1].amplitude,
            sr.harmonics[1].locked_amplitude,
            pk,
            sr.locked_peak.unwrap()
        );
    }
    println!("multi-order: largest relative difference {worst:e}");
    assert!(worst < 1e-10, "{worst:e}");
    // The paper's observation in the linear model: order 3 reduced, order 6 amplified at all
    // speeds (the linear model has no jump to the upper branch at 600 rpm).
    for sr in &res {
        assert!(sr.harmonics[0].amplitude < sr.harmonics[0].locked_amplitude);
        assert!(sr.harmonics[1].amplitude > sr.harmonics[1].locked_amplitude);
    }
}

#[test]
fn refuses_what_it_cannot_linearise() {
    let p = CpvaParams::canonical();
    let mut spec = p.spec(None);
    spec.gravity = (0.0, -9.81);
    // Gravity is no longer refused: it forces the steady rotation at order 1 (tests/it/gravity_linear.rs)
    // and leaves the linearisation as it is without it.
    let g = LinearModel::new(&Mechanism::from_spec(&spec).unwrap(), "spin", 100.0, None).unwrap();
    let plain = LinearModel::new(&p.mechanism(None).unwrap(), "spin", 100.0, None).unwrap();
    assert!(g.has_gravity() && g.f_q == plain.f_q && g.mass == plain.mass && g.op == plain.op);
    let mut spec = p.spec(None);
    spec.joints[0].spring = Some(Spring { stiffness: 1e3, free_angle: 0.0 });
    let s = Mechanism::from_spec(&spec).unwrap();
    let e = LinearModel::new(&s, "spin", 100.0, None).unwrap_err();
    assert!(matches!(e, LinearError::SpinSpring { .. }), "{e}");
    let m = p.mechanism(None).unwrap();
    assert!(matches!(LinearModel::new(&m, "pivot", 100.0, None), Err(LinearError::SpinNotRoot { .. })));
    let e = LinearModel::new(&m, "spn", 100.0, None).unwrap_err();
    assert!(e.to_string().contains("unknown joint `spn`") && e.to_string().contains("spin, pivot"), "{e}");
    assert!(matches!(LinearModel::new(&m, "spin", 100.0, Some(&[0.0])), Err(LinearError::Length { .. })));
    let spec = ResponseSpec { lock: vec!["spin".into()], ..cpva_spec(1) };
    assert!(matches!(OrderResponse::new(&m, &spec, 100.0, None), Err(LinearError::LockedInput { .. })));
    // The input vector is exact: it equals the difference of F with and without a unit torque.
    let lin = LinearModel::new(&m, "spin", 100.0, None).unwrap();
    let mut kane = kanedyn::kane::Kane::new(lin.mechanism()).unwrap();
    let (q, u) = (lin.op.q.clone(), lin.op.u.clone());
    let f0 = kane.forcing(0.0, &q, &u).clone();
    kane.set_joint_torque(1, kanedyn::model::excitation::Excitation::constant(1.0));
    let f1 = kane.forcing(0.0, &q, &u).clone();
    assert!((f1 - f0 - lin.generalized_torque(1)).amax() < 1e-12);
}

#[test]
fn a_locked_away_body_is_watched_through_the_body_that_absorbed_it() {
    // Watching the pendulum with its pivot locked: the reference is the rotor that absorbed it
    // (same rigid body), so the locked responses agree exactly.
    let p = CpvaParams::canonical();
    let m = p.mechanism(None).unwrap();
    let rotor = OrderResponse::new(&m, &cpva_spec(1), omega(), None).unwrap();
    let spec = ResponseSpec { body: "pendulum".into(), ..cpva_spec(1) };
    let pend = OrderResponse::new(&m, &spec, omega(), None).unwrap();
    for n in [1.5, 3.0, 6.0] {
        assert_eq!(pend.locked_response(n).unwrap(), rotor.locked_response(n).unwrap());
        assert_ne!(pend.response(n).unwrap(), rotor.response(n).unwrap());
    }
}

/// `LinearModel::fastest_rate` (eigenvalues only, the time runs' step bound) is the largest
/// `max(|eigenvalue|, |partner|)` over the rigid and vibration modes of `modes`, to the bit, for
/// both spin cases and damping choices on 1, 4 and 32 pendulums (damped and undamped pendulums
/// give complex and real eigenvalues, and the free spin a real one at zero).
#[test]
fn fastest_rate_is_the_largest_modulus_of_the_modes() {
    for n in [1, 4, 32] {
        for (c_p, c_r) in [(5e-4, 5e-3), (0.0, 0.0), (5e-2, 5e-3)] {
            let mech = params(n, c_p, c_r).mechanism(None).unwrap();
            let lin = LinearModel::new(&mech, "spin", omega(), None).unwrap();
            for spin in [Spin::Free, Spin::Held] {
                for damping in [Damping::Damped, Damping::Undamped] {
                    let modal = lin.modes(spin, damping).unwrap();
                    let from_modes = modal
                        .rigid
                        .iter()
                        .chain(&modal.modes)
                        .map(|m| m.eigenvalue.norm().max(m.partner.norm()))
                        .fold(0.0, f64::max);
                    let rate = lin.fastest_rate(spin, damping).unwrap();
                    assert_eq!(rate.to_bits(), from_modes.to_bits(), "{n} pendulums, {spin:?}, {damping:?}");
                }
            }
        }
    }
}
