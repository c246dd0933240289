"""Issue 25: the Python API is held to the command line's bounds, through the same Rust functions
(`kanedyn::study::validate::limits`). Each call below used to abort the interpreter ("memory
allocation of … bytes failed"), run for minutes, or be accepted; now each raises
`kanedyn.ArgumentError` within a second, and the CLI refuses the same number in a study file."""

import time

import numpy as np
import pytest

import kanedyn
from conftest import EXAMPLES

OMEGA = 1000.0 * np.pi / 30.0


@pytest.fixture(scope="module")
def cpva():
    return kanedyn.Mechanism.from_file(EXAMPLES / "cpva.ron")


def refused(call, *words):
    """Runs `call`, which must raise ArgumentError naming every word, in under a second."""
    start = time.perf_counter()
    with pytest.raises(kanedyn.ArgumentError) as e:
        call()
    took = time.perf_counter() - start
    assert took < 1.0, (took, str(e.value))
    for w in words:
        assert w in str(e.value), (w, str(e.value))
    return str(e.value)


def test_simulate_is_bounded(cpva):
    probes = [("BodyAccel", "rotor")]
    x0 = [0.0, 0.0, OMEGA, OMEGA]
    # Used to abort the interpreter allocating the samples.
    refused(lambda: kanedyn.simulate(cpva, x0, 0.0, 1.0, probes, sample_hz=1e12), "sample_hz:", "at most 1e7 Hz")
    # 1e7 Hz is the CLI's limit too, but a day at that rate is 13 TB of samples.
    refused(lambda: kanedyn.simulate(cpva, x0, 0.0, 86_400.0, probes, sample_hz=1e7), "sample_hz:", "MB of samples")
    # Used to run for minutes.
    refused(lambda: kanedyn.simulate(cpva, x0, 0.0, 1e300, probes), "t1:", "at most 86400 s")
    refused(lambda: kanedyn.simulate(cpva, x0, 0.0, 1.0, probes, rtol=1e-16), "rtol:", "1e-13..=0.1")
    # Just inside: a short run at the highest rate still runs.
    r = kanedyn.simulate(cpva, x0, 0.0, 1e-3, probes, sample_hz=1e7)
    assert r.completed and abs(len(r.time) - 10_001) <= 1


def test_hbm_branch_is_bounded(cpva):
    # Used to abort the interpreter allocating the Jacobian.
    refused(lambda: kanedyn.hbm_branch(cpva, "spin", 1000.0, 40.0, 3.3, 2.9, harmonics=10**9), "harmonics:", "1 to 64")
    refused(lambda: kanedyn.hbm_branch(cpva, "spin", 2e6, 40.0, 3.3, 2.9), "rpm:", "1e6")
    refused(lambda: kanedyn.hbm_branch(cpva, "spin", 1000.0, 1e10, 3.3, 2.9), "amplitude:", "1e9 N·m")
    refused(lambda: kanedyn.hbm_branch(cpva, "spin", 1000.0, 40.0, 3.3, 2e3), "order_to:", "at most 1000")


def test_linearize_and_order_response_are_bounded(cpva):
    # A negative speed used to be accepted.
    refused(lambda: kanedyn.linearize(cpva, "spin", -1.0), "rpm:", "0 ≤ rpm")
    lin = kanedyn.linearize(cpva, "spin", 1000.0)
    # 1e8 orders used to run for minutes; a broadcast view costs no memory here.
    refused(lambda: lin.order_response("spin", "rotor", np.broadcast_to(3.0, (10**8,))), "orders:", "1000000 points")
    refused(lambda: lin.order_response("spin", "rotor", [3.0, -1.0]), "orders[1]:", "positive")
    assert len(lin.order_response("spin", "rotor", [2.9, 3.0, 3.1])) == 3


def test_the_cli_refuses_the_same_numbers(tmp_path, cli_path):
    """The same bound, the same words: a study with the sample rate the Python call was refused."""
    import shutil
    import subprocess

    shutil.copytree(EXAMPLES, tmp_path / "ex")
    study = tmp_path / "ex" / "s.ron"
    study.write_text(
        'Study(name: "s", mechanism: "cpva.ron", integration: (sample_hz: 1e12),\n'
        ' analyses: [Campbell(name: "c", rpm_min: 0.0, rpm_max: 2000.0, points: 5)])\n'
    )
    out = subprocess.run([str(cli_path), "check", str(study)], capture_output=True, text=True)
    assert out.returncode != 0
    assert "sample rate must be finite, positive and at most 1e7 Hz, got 1e12" in out.stderr, out.stderr
    py = refused(lambda: kanedyn.simulate(kanedyn.Mechanism.from_file(EXAMPLES / "cpva.ron"), [0, 0, 1, 1], 0.0,
                                          1.0, [("BodyAccel", "rotor")], sample_hz=1e12))
    assert "sample rate must be finite, positive and at most 1e7 Hz, got 1e12" in py
