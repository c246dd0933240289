"""`kanedyn.linearize`: the CPVA's eigen-orders against the paper's closed forms (eqs. 15, 17),
the order response against the CLI's `LinearResponse` CSV bit for bit and its asymptote against
the closed form, the matrices against eq. (13), and the errors."""

import numpy as np
import pytest

import kanedyn
from conftest import EXAMPLES, read_csv, same_bits


def cpva_closed_forms(m):
    """n_t (eq. 15), Ĩ (eq. 18) and n_r (eq. 17) from the masses and lengths `check()` reports."""
    info = m.check()
    body = {b["name"]: b for b in info["bodies"]}
    mp, L, IB = body["pendulum"]["mass"], body["pendulum"]["com"][0], body["pendulum"]["inertia"]
    IA, R = body["rotor"]["inertia"], info["joints"][1]["at"][0]
    nt2 = mp * R * L / (IB + mp * L * L)
    it = (IA + mp * R * R) / (IB + mp * L * L)
    return np.sqrt(nt2), it, np.sqrt(nt2 * (it + 2 * nt2 + 1) / (it - nt2 * nt2))


@pytest.fixture(scope="module")
def cpva():
    return kanedyn.Mechanism.from_file(EXAMPLES / "cpva.ron")


def test_eigen_orders_are_the_closed_forms(cpva):
    nt, it, nr = cpva_closed_forms(cpva)
    for rpm in (600.0, 1000.0, 1800.0):
        lin = kanedyn.linearize(cpva, "spin", rpm)
        held = lin.modes(spin="held", damped=False)
        free = lin.modes(spin="free", damped=False)
        assert held.labels == ["pivot"] and free.labels == ["pivot"]
        # Richardson-extrapolated Jacobians: 1e-9 relative (tests/it/study.rs holds the study to it).
        assert abs(held.orders[0] / nt - 1) < 1e-9, (rpm, held.orders[0], nt)
        assert abs(free.orders[0] / nr - 1) < 1e-9, (rpm, free.orders[0], nr)
        # Undamped: no damping; the frequency is the order times the speed.
        assert held.damping_ratios[0] == 0.0
        assert abs(free.frequencies_hz[0] - nr * rpm / 60) < 1e-9 * nr * rpm / 60
        assert [r["kind"] for r in free.rigid] == ["SpinAngle", "SpinSpeed"] and held.rigid == []
    # With the dampers the pendulum mode is lightly damped and the spin-speed mode decays at
    # about c_r / J (J the locked rotor inertia, 3.6495 kg·m²).
    damped = kanedyn.linearize(cpva, "spin", 1000.0).modes()
    assert 0 < damped.damping_ratios[0] < 1e-3 and damped.stable
    spin_speed = damped.rigid[1]["eigenvalue"]
    assert abs(spin_speed.real / (-5e-3 / 3.6495354086) - 1) < 1e-3 and spin_speed.imag == 0


def test_operating_point_and_matrices(cpva):
    lin = kanedyn.linearize(cpva, "spin", 1000.0)
    op = lin.operating_point
    # T_m = c_r Ω holds the speed (section 4.1); the pendulum sits on the radial line.
    assert op["mean_spin_torque"] == pytest.approx(5e-3 * lin.omega_rad_s, rel=1e-12)
    assert op["spin_joint"] == "spin" and abs(op["q"][1]) < 1e-12 and np.all(op["u"] == lin.omega_rad_s)
    M, C, K = lin.second_order(damped=False)
    # Eq. (13) in the joint coordinates: the pendulum's stiffness m R L Ω², nothing on θ.
    _, _, nr = cpva_closed_forms(cpva)
    info = cpva.check()
    mp, L, R = info["bodies"][1]["mass"], info["bodies"][1]["com"][0], info["joints"][1]["at"][0]
    assert K[1, 1] == pytest.approx(mp * R * L * lin.omega_rad_s**2, rel=1e-10)
    assert np.all(K[:, 0] == 0) and np.allclose(C, 0, atol=1e-12)
    assert np.allclose(M, M.T, rtol=0, atol=1e-15)
    Mf, A = lin.first_order()
    assert Mf.shape == A.shape == (4, 4) and np.array_equal(Mf[2:, 2:], lin.mass)
    assert lin.coordinate_names == ["spin", "pivot"] and lin.f_q.shape == lin.f_u.shape == lin.w_inv.shape == (2, 2)


def test_order_response_equals_the_cli_csv_bit_for_bit(cpva, cli_run):
    # examples/cpva_linear.ron: 1000 rpm, pivot locked in the twin, variant c_p = 5e-4 (the file's
    # own pivot damper).
    csv = read_csv(cli_run(EXAMPLES / "cpva_linear.ron") / "figure2_c_p_5e-4.csv")
    lin = kanedyn.linearize(cpva, "spin", 1000.0)
    r = lin.order_response("spin", "rotor", csv["order"], lock=["pivot"])
    assert same_bits(r.orders, csv["order"]) and len(r) == 1201
    assert same_bits(r.response, csv["accel_per_torque_rad_s2_per_Nm"])
    assert same_bits(r.locked, csv["locked_rad_s2_per_Nm"])
    # The CSV leaves a ratio to a silent twin empty; here the twin always answers.
    assert not np.isnan(csv["ratio"]).any() and same_bits(r.ratio, csv["ratio"])
    # NumPy's |z| and Rust's hypot may differ in the last bit.
    assert np.allclose(np.abs(r.response_complex), r.response, rtol=4e-16, atol=0)
    # The asymptote of the normalised response, (Ĩ + 1 + 2n_t²)/(Ĩ − n_t⁴) (tests/it/study.rs).
    nt, it, _ = cpva_closed_forms(cpva)
    assert abs(r.asymptote / ((it + 1 + 2 * nt**2) / (it - nt**4)) - 1) < 1e-9
    # Without a lock: the same response, no twin.
    alone = lin.order_response("spin", "rotor", csv["order"][:5])
    assert alone.locked is None and alone.ratio is None and alone.asymptote is None
    assert same_bits(alone.response, r.response[:5])


def test_linear_errors(cpva):
    with pytest.raises(kanedyn.ArgumentError, match=r"unknown joint `spn` \(known: spin, pivot\)"):
        kanedyn.linearize(cpva, "spn", 1000.0)
    with pytest.raises(kanedyn.ArgumentError, match="rpm must be finite"):
        kanedyn.linearize(cpva, "spin", float("inf"))
    lin = kanedyn.linearize(cpva, "spin", 1000.0)
    with pytest.raises(kanedyn.ArgumentError, match='spin must be "free" or "held"'):
        lin.modes(spin="sideways")
    with pytest.raises(kanedyn.ArgumentError, match="carries the input torque and cannot be locked"):
        lin.order_response("spin", "rotor", [3.0], lock=["spin"])
    with pytest.raises(kanedyn.ArgumentError, match="unknown body `rotr`"):
        lin.order_response("spin", "rotr", [3.0])
    # Gravity on bodies that turn with the spin joint forces the rotation at order 1 (accepted);
    # the weight of a body that does not turn with it (a pendulum hung from the ground) is refused.
    spun = kanedyn.Mechanism.from_file(EXAMPLES / "triple_pendulum.ron")
    kanedyn.linearize(spun, spun.coordinate_names[0], 100.0)
    hung = kanedyn.Mechanism.from_str(
        'Mechanism(name: "hung", gravity: (0.0, -9.81), bodies: [Body(name: "rotor", mass: 1.0, inertia: 0.1), '
        'Body(name: "bob", mass: 1.0, com: (0.0, -0.1), inertia: 0.001)], joints: [Joint(name: "spin", '
        'kind: Revolute, parent: "ground", child: "rotor"), Joint(name: "hang", kind: Revolute, parent: "ground", '
        'child: "bob", at: (1.0, 0.0))])'
    )
    with pytest.raises(kanedyn.ModelError, match="gravity or a world-frame force") as e:
        kanedyn.linearize(hung, "spin", 100.0)
    assert e.value.mechanism == hung.name
