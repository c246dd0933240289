"""`kanedyn.hbm_branch`: the paper study's harmonic-balance branches, bit for bit what the CLI
writes (CSV columns, folds and bifurcations in results.json), the mean torque against the
angular-momentum balance T_m = c_r Ω, and the errors."""

import json

import numpy as np
import pytest

import kanedyn
from conftest import EXAMPLES, read_csv, same_bits


@pytest.fixture(scope="module")
def cpva():
    return kanedyn.Mechanism.from_file(EXAMPLES / "cpva.ron")


# examples/cpva_paper.ron's HarmonicBalance `hbm`: 1000 rpm, orders 2.9–3.3, H = 10, each
# amplitude continued from both ends.
CASES = [(amp, frm, to, tag) for amp in (40.0, 500.0) for (frm, to, tag) in ((3.3, 2.9, "from_above"), (2.9, 3.3, "from_below"))]


@pytest.mark.parametrize("amplitude,order_from,order_to,tag", CASES)
def test_branch_equals_the_cli_bit_for_bit(cpva, cli_run, amplitude, order_from, order_to, tag):
    out = cli_run(EXAMPLES / "cpva_paper.ron")
    csv = read_csv(out / f"hbm_{amplitude:.0f}Nm_{tag}.csv")
    b = kanedyn.hbm_branch(cpva, "spin", 1000.0, amplitude, order_from, order_to)
    assert len(b) == len(csv["order"]) > 10
    assert same_bits(b.order, csv["order"])
    assert same_bits(b.accel[0], csv["accel_1x_rad_s2"]) and same_bits(b.accel[1], csv["accel_2x_rad_s2"])
    assert same_bits(b.relative_angle, csv["max_relative_angle_rad"])
    assert same_bits(b.stable, csv["stable"]) and same_bits(b.max_multiplier, csv["max_floquet_modulus"])
    # Folds and bifurcations as results.json has them.
    doc = json.loads((out / "results.json").read_text())
    hbm = next(a for a in doc["analyses"] if a["name"] == "hbm")
    branch = next(x for x in hbm["result"]["branches"] if x["amplitude"] == amplitude and x["from"] == order_from)
    assert [f["order"] for f in b.folds] == branch["folds"]
    assert [[x["order"], x["classification"]] for x in b.bifurcations] == branch["bifurcations"]
    assert b.end == branch["end"]


def test_mean_torque_balances_the_losses_and_the_folds_bracket_the_jumps(cpva):
    b = kanedyn.hbm_branch(cpva, "spin", 1000.0, 40.0, 3.3, 2.9)
    # Over one period the pendulum's damper is internal: T_m = c_r Ω exactly (the module docs of
    # kanedyn::hbm); to the Newton tolerance.
    omega = kanedyn.linearize(cpva, "spin", 1000.0).omega_rad_s
    assert np.abs(b.mean_torque / (5e-3 * omega) - 1).max() < 1e-8
    # At 40 N·m the response is S-shaped: two folds, the upper where an up-sweep jumps, the
    # lower where a down-sweep does (the paper's Figs. 3, 4); the middle sheet is unstable.
    assert sorted(f["kind"] for f in b.folds) == ["Maximum", "Minimum"]
    lo, hi = sorted(f["order"] for f in b.folds)
    assert 2.9 < lo < 3.0 < 3.15 < hi < 3.2
    between = (b.order > lo) & (b.order < hi)
    assert (b.stable[between] == 0).any() and (b.stable == 1).any()
    # The middle sheet loses stability exactly at the folds (a multiplier through +1).
    assert {x["kind"] for x in b.bifurcations} == {"PlusOne"}
    assert {x["classification"] for x in b.bifurcations} == {"fold"}
    assert b.accel.shape == (2, len(b)) and list(b.multiples) == [1.0, 2.0] and b.body == "rotor"
    # Stability off: no verdicts.
    quick = kanedyn.hbm_branch(cpva, "spin", 1000.0, 40.0, 3.3, 3.2, stability=False, multiples=[1.0])
    assert np.isnan(quick.stable).all() and np.isnan(quick.max_multiplier).all() and quick.accel.shape[0] == 1


def test_hbm_errors(cpva):
    with pytest.raises(kanedyn.ArgumentError, match="unknown joint `spn`"):
        kanedyn.hbm_branch(cpva, "spn", 1000.0, 40.0, 3.3, 2.9)
    with pytest.raises(kanedyn.ArgumentError, match="unknown body `rotr`"):
        kanedyn.hbm_branch(cpva, "spin", 1000.0, 40.0, 3.3, 2.9, body="rotr")
    with pytest.raises(kanedyn.ArgumentError, match="rpm must be a finite, positive number"):
        kanedyn.hbm_branch(cpva, "spin", 0.0, 40.0, 3.3, 2.9)
    with pytest.raises(kanedyn.ArgumentError, match="order_from and order_to must differ"):
        kanedyn.hbm_branch(cpva, "spin", 1000.0, 40.0, 3.0, 3.0)
    with pytest.raises(kanedyn.ArgumentError, match="multiples must be finite and positive"):
        kanedyn.hbm_branch(cpva, "spin", 1000.0, 40.0, 3.3, 2.9, multiples=[1.0, -2.0])
    gravity = kanedyn.Mechanism.from_file(EXAMPLES / "triple_pendulum.ron")
    with pytest.raises(kanedyn.ModelError, match="gravity or a world-frame force"):
        kanedyn.hbm_branch(gravity, gravity.coordinate_names[0], 100.0, 1.0, 3.3, 2.9)
