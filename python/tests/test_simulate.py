"""`kanedyn.simulate` against three independent routes.

1. The library's own run, bit for bit: a study's order sweep with `write_time_series: true` makes
   the CLI integrate the CPVA through `time::probe::simulate` and print every sample; the same
   mechanism, excitation, initial state and options from Python must give the same numbers.
2. The paper's closed form: the free, undamped rotor-CPVA vibrates at the rotor eigen-order n_r
   of eq. (17), from the masses and lengths of the mechanism file.
3. Conservation: an undamped, unloaded run keeps its kinetic energy and angular momentum
   (computed from `Mechanism.eom`'s mass matrix at the samples), and a run continued in two
   chunks agrees with one run to the integrator's tolerance.
"""

import shutil

import numpy as np
import pytest

import kanedyn
from conftest import EXAMPLES, read_csv, same_bits

CPVA = (EXAMPLES / "cpva.ron").read_text()

# The speed of 1000 rpm in rad/s, as the library converts it (the linear model's Ω).
OMEGA = kanedyn.linearize(kanedyn.Mechanism.from_file(EXAMPLES / "cpva.ron"), "spin", 1000.0).omega_rad_s


def free_cpva():
    """The paper's rotor-CPVA without dampers, torques or losses."""
    start, end = CPVA.index("    loads: ["), CPVA.index("\n    ],\n)") + len("\n    ],\n")
    text = CPVA[:start] + "    loads: [],\n" + CPVA[end:]
    text = text.replace('part: "catalog:joints/cpva_pivot.ron", parent', 'part: "catalog:joints/cpva_pivot.ron", damper: 0.0, parent')
    assert text != CPVA
    m = kanedyn.Mechanism.from_str(text, name=str(EXAMPLES / "cpva_free.ron"))
    info = m.check()
    assert info["joints"][1]["damper"] == 0.0 and info["loads"]["ground_dampers"] == info["loads"]["joint_torques"] == 0
    return m


def test_simulate_equals_the_cli_time_series_bit_for_bit(cli, tmp_path):
    # The study's sweep replaces the spin joint's torque by T_m + 40 sin(Ω∫n dt), n from 2.9 to
    # 3.3 over 8 s, ramped in over 1 s; the Python mechanism carries the same excitation itself.
    shutil.copy(EXAMPLES / "cpva.ron", tmp_path / "cpva.ron")
    mean = "0.5235987755982988"
    (tmp_path / "ts.ron").write_text(
        f"""Study(name: "ts", mechanism: "cpva.ron", analyses: [
    OrderSweep(name: "ts", rpm: 1000.0, order_min: 2.9, order_max: 3.3, duration_s: 8.0, amplitudes: [40.0],
               directions: [Up], multiples: [1.0], ramp_s: 1.0, mean_torque: {mean}, write_time_series: true),
])"""
    )
    ok, _, err = cli("run", tmp_path / "ts.ron", "--out", tmp_path / "out")
    assert ok, err
    want = read_csv(tmp_path / "out" / "ts" / "ts_40Nm_up_time_series.csv")
    assert list(want) == ["time_s", "rotor_angle_rad", "rotor_rate_rad_s", "rotor_accel_rad_s2", "spin_q_rad", "pivot_q_rad"]
    assert len(want["time_s"]) == 16001

    text = CPVA.replace("order: Fixed(3.0),", "order: Sweep(from: 2.9, to: 3.3, duration_s: 8.0),")
    text = text.replace("ramp_s: 2.0,", "ramp_s: 1.0,").replace("mean: 0.5235987755982988,", f"mean: {mean},")
    assert text.count("Sweep(") == 1 and "ramp_s: 1.0" in text
    m = kanedyn.Mechanism.from_str(text, name=str(tmp_path / "cpva_sweep.ron"))
    probes = [("BodyAngle", "rotor"), ("BodyRate", "rotor"), ("BodyAccel", "rotor"), ("JointAngle", "spin"), ("JointAngle", "pivot")]
    # The study's initial state: q = 0, every body turning at Ω (absolute speeds u = [Ω, Ω]).
    got = kanedyn.simulate(m, ([0.0, 0.0], [OMEGA, OMEGA]), 0.0, 8.0, probes, rtol=1e-9, atol=1e-9, sample_hz=2000.0, max_steps=50_000_000)
    assert got.completed and got.error is None and got.t_end == 8.0
    assert same_bits(got.time, want["time_s"])
    for (label, column) in zip(got.names, list(want)[1:]):
        assert same_bits(got[label], want[column]), f"{label} differs from {column}"
    # Something happened: the sweep passes the tuning order and the pendulum swings.
    assert np.abs(got["pivot.q"]).max() > 0.05


def test_the_free_cpva_vibrates_at_the_rotor_eigen_order_of_eq_17():
    m = free_cpva()
    info = m.check()
    body = {b["name"]: b for b in info["bodies"]}
    mp, L, IB = body["pendulum"]["mass"], body["pendulum"]["com"][0], body["pendulum"]["inertia"]
    IA, R = body["rotor"]["inertia"], info["joints"][1]["at"][0]
    nt2 = mp * R * L / (IB + mp * L * L)  # eq. (15)
    it = (IA + mp * R * R) / (IB + mp * L * L)  # eq. (18)
    nr = np.sqrt(nt2 * (it + 2 * nt2 + 1) / (it - nt2 * nt2))  # eq. (17)
    assert abs(np.sqrt(nt2) - 3.11) < 1e-9 and abs(it - 2255) < 1e-6  # the design table

    # A small pendulum deflection at 1000 rpm; every body turning at Ω.
    r = kanedyn.simulate(m, [0.0, 1e-4, OMEGA, OMEGA], 0.0, 2.0, [("JointAngle", "pivot"), ("BodyAngle", "rotor")],
                         rtol=1e-12, atol=1e-12, sample_hz=20000.0)
    phi, theta, t = r["pivot.q"], r["rotor.angle"], r.time
    down = np.where((phi[:-1] > 0) & (phi[1:] <= 0))[0]
    f = phi[down] / (phi[down] - phi[down + 1])
    tc = t[down] + f * (t[down + 1] - t[down])
    thc = theta[down] + f * (theta[down + 1] - theta[down])
    assert len(tc) > 100
    period = (tc[-1] - tc[0]) / (len(tc) - 1)
    mean_speed = (thc[-1] - thc[0]) / (tc[-1] - tc[0])  # over whole periods
    order = 2 * np.pi / period / mean_speed
    # Measured 1.4e-9: the amplitude shift of the frequency (∝ φ0², ~7e-10 here) and the
    # interpolated zero crossings at 20 kHz.
    assert abs(order / nr - 1) < 1e-8, (order, nr)


def test_an_undamped_run_keeps_its_energy_and_angular_momentum():
    m = free_cpva()
    probes = [("JointAngle", "spin"), ("JointAngle", "pivot"), ("BodyRate", "rotor"), ("BodyRate", "pendulum")]
    r = kanedyn.simulate(m, [0.0, 0.5, OMEGA, OMEGA], 0.0, 2.0, probes, rtol=1e-12, atol=1e-12)
    q, u = np.c_[r["spin.q"], r["pivot.q"]], np.c_[r["rotor.rate"], r["pendulum.rate"]]
    # The speeds are absolute angular velocities, so u = [ω_rotor, ω_pendulum]; with θ cyclic
    # the angular momentum about O is ∂T/∂θ̇ = Σ (M u).
    energy, momentum = [], []
    for qi, ui in zip(q[::10], u[::10]):
        M = m.eom(qi, ui)[0]
        energy.append(0.5 * ui @ M @ ui)
        momentum.append((M @ ui).sum())
    energy, momentum = np.array(energy), np.array(momentum)
    assert np.ptp(q[:, 1]) > 0.9  # a large, nonlinear swing
    # Measured 9e-13 and 5e-13 at rtol = atol = 1e-12.
    assert np.abs(energy / energy[0] - 1).max() < 1e-11
    assert np.abs(momentum / momentum[0] - 1).max() < 1e-11


def test_a_run_continued_in_two_chunks_agrees_with_one_run():
    m = kanedyn.Mechanism.from_file(EXAMPLES / "cpva.ron")
    probes = [("BodyAccel", "rotor"), ("JointAngle", "pivot"), ("JointRate", "spin"), ("LargestJointAngle", "spin")]
    kw = dict(rtol=1e-11, atol=1e-11)
    one = kanedyn.simulate(m, [0, 0, OMEGA, OMEGA], 0.0, 6.0, probes, **kw)
    a = kanedyn.simulate(m, [0, 0, OMEGA, OMEGA], 0.0, 3.0, probes, **kw)
    b = kanedyn.simulate(m, a.x_end, a.t_end, 6.0, probes, **kw)
    assert a.completed and b.completed and len(a.time) == len(b.time) == 6001
    # The second chunk's first sample is the first one's last.
    assert np.abs(np.r_[a.time, b.time[1:]] - one.time).max() < 1e-12
    for k, name in enumerate(one.names):
        joined = np.r_[a[k], b[k][1:]]
        # The two routes differ by their global errors: measured 5e-9 of the largest value.
        assert np.abs(joined - one[name]).max() < 5e-8 * np.abs(one[name]).max(), name
    assert np.abs(one["pivot.q"]).max() > 1e-3


def test_x0_forms_probe_keys_and_counters():
    m = kanedyn.Mechanism.from_file(EXAMPLES / "cpva.ron")
    probes = [("BodyAccel", "rotor"), ("JointRate", "pivot")]
    flat = kanedyn.simulate(m, [0.1, 0.2, OMEGA, OMEGA + 1.0], 0.0, 0.5, probes)
    pair = kanedyn.simulate(m, (np.array([0.1, 0.2]), [OMEGA, OMEGA + 1.0]), 0.0, 0.5, probes)
    for k in range(2):
        assert same_bits(flat[k], pair[k])
    assert same_bits(flat[0], flat["rotor.accel"]) and same_bits(flat[1], flat["JointRate", "pivot"])
    assert same_bits(flat[-1], flat["pivot.qdot"]) and list(flat.columns) == ["rotor.accel", "pivot.qdot"]
    assert flat.units == ["rad/s²", "rad/s"] and flat.probes == probes and len(flat) == 2
    # The pendulum's relative rate at t = 0 is u2 − u1 = 1 rad/s.
    assert flat["pivot.qdot"][0] == (OMEGA + 1.0) - OMEGA
    assert flat.samples == len(flat.time) == 1001 and flat.accepted > 0 and flat.rhs_evals > flat.accepted
    # One right-hand side per sample for the acceleration.
    assert flat.sample_rhs_evals == 1001
    # Without samples, only the end state.
    none = kanedyn.simulate(m, [0.1, 0.2, OMEGA, OMEGA], 0.0, 0.5, [("JointAngle", "pivot")], sample_hz=None)
    assert len(none.time) == 0 and none.x_end is not None and none.x_end.shape == (4,)


def test_a_run_that_stops_early_keeps_its_samples():
    m = kanedyn.Mechanism.from_file(EXAMPLES / "cpva.ron")
    r = kanedyn.simulate(m, [0, 0, OMEGA, OMEGA], 0.0, 5.0, [("JointAngle", "pivot")], max_steps=300)
    assert not r.completed and r.x_end is None
    assert "step limit of 300" in r.error
    assert 0.0 < r.t_end < 5.0 and len(r.time) > 10 and r.time[-1] <= r.t_end
    assert r.accepted + r.rejected == 300


def test_bad_arguments_raise_argument_errors():
    m = kanedyn.Mechanism.from_file(EXAMPLES / "cpva.ron")
    x0 = [0, 0, OMEGA, OMEGA]
    cases = [
        (dict(x0=[0, 0, 1]), "x0 must be [q; u] (4 values) or a pair (q0, u0) of 2 values each (coordinates: spin, pivot)"),
        (dict(x0=[0, float("nan"), 1, 1]), "x0: q[1] is not finite"),
        (dict(probes=[("BodyAccel", "rotr")]), "probes[0]: mechanism `cpva`: probe BodyAccel: unknown body `rotr` (known bodys: rotor, pendulum)"),
        (dict(probes=[("Accel", "rotor")]), "probes[0]: unknown probe kind `Accel` (kinds: BodyAngle, BodyRate, BodyAccel, JointAngle, JointRate, LargestJointAngle, JointForceRadial, JointForceTangential, JointMoment, GearMeshTorque)"),
        (dict(probes=["rotor"]), "probes[0] must be a pair (kind, name)"),
        (dict(t1=0.0), "t1 must be after t0, got t0 = 0 s, t1 = 0 s"),
        (dict(rtol=-1.0), "rtol must be a finite, positive number, got -1"),
        (dict(sample_hz=0.0), "sample_hz must be a finite, positive number, got 0"),
        (dict(joint_torques={"spn": 1.0}), "joint_torques: unknown joint `spn` (joints: spin, pivot)"),
    ]
    for change, message in cases:
        args = dict(x0=x0, t0=0.0, t1=1.0, probes=[("BodyAccel", "rotor")]) | change
        with pytest.raises(kanedyn.ArgumentError) as e:
            kanedyn.simulate(m, args.pop("x0"), args.pop("t0"), args.pop("t1"), args.pop("probes"), **args)
        assert message in str(e.value), (change, str(e.value))


def test_joint_torques_replace_the_excitation():
    m = kanedyn.Mechanism.from_file(EXAMPLES / "cpva.ron")
    # A constant 50 N·m on the spin joint: at t = 0 (q = 0, rigid spin) the rotor's acceleration
    # is what the equations of motion give for that torque.
    r = kanedyn.simulate(m, [0, 0, OMEGA, OMEGA], 0.0, 0.01, [("BodyAccel", "rotor")], joint_torques={"spin": 50.0})
    udot = m.eom([0, 0], [OMEGA, OMEGA], joint_torques={"spin": 50.0})[3]
    assert r["rotor.accel"][0] == udot[0]
    assert r["rotor.accel"][0] > 10.0  # 50 N·m on about 3.6 kg·m²
