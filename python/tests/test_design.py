"""Design studies from Python: the case table equals the CSV the study writes, a 50-case study on a
2-worker Dask LocalCluster equals the local rayon run bit for bit with its one failed case
reported and the other 49 kept, cases run by index, pickling, and located errors."""

import csv
import math
import os
import pickle

import numpy as np
import pytest

import kanedyn

from conftest import EXAMPLES

distributed = pytest.importorskip("distributed", reason="dask[distributed] is installed by run-tests.sh")

# 50 torque amplitudes T_n (N·m) for a harmonic balance of the paper's CPVA through n_t: 49 from
# 10 to 200 N·m, and at index 17 one of 1e6 N·m, where Newton's method diverges from both ends
# of the range (the README's "diverges" failure): the case forced to fail.
TORQUES = [10.0 + 190.0 * k / 48 for k in range(49)]
TORQUES.insert(17, 1e6)
FAILED = 17

STUDY = f"""Study(
    name: "design_py",
    mechanism: "cpva.ron",
    lock: ["pivot"],
    analyses: [
        DesignStudy(
            name: "torques",
            parameters: [(name: "T_n", quantity: TorqueAmplitude, values: [{", ".join(repr(t) for t in TORQUES)}])],
            analysis: HarmonicBalance(name: "h", rpm: 1000.0, order_min: 2.9, order_max: 3.3, amplitudes: [40.0]),
        ),
    ],
)
"""


def bits(a):
    """The float64 array's bit patterns (NaNs compared by payload too)."""
    return np.ascontiguousarray(a, dtype=np.float64).view(np.uint64)


@pytest.fixture(scope="module")
def study():
    # Named as a file of the examples folder, so that its mechanism resolves from there.
    return kanedyn.Study.from_str(STUDY, str(EXAMPLES / "design_py.ron"))


@pytest.fixture(scope="module")
def local(study, tmp_path_factory):
    out = tmp_path_factory.mktemp("design_out")
    return study.run(out=out), out / "design_py"


@pytest.fixture(scope="module")
def client():
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0") as cluster:
        with distributed.Client(cluster) as c:
            yield c


def test_the_case_table_equals_the_csv_file(local):
    result, folder = local
    table = result.designs["torques"]
    with open(folder / "torques.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 50
    assert list(table) == list(rows[0])
    for name, column in table.items():
        cells = [r[name] for r in rows]
        if name in ("status", "error"):
            assert list(column) == cells
        else:
            # Each cell is Rust's shortest round-trip text of the same f64 (empty for NaN).
            parsed = np.array([float(c) if c else math.nan for c in cells])
            assert np.array_equal(np.isnan(column), np.isnan(parsed)), name
            given = ~np.isnan(parsed)
            assert np.array_equal(bits(column[given]), bits(parsed[given])), name
    assert result.units["torques"]["T_n_Nm"] == "N·m"
    findings = result.analysis("torques")["findings"]
    assert {k: findings[k] for k in ("cases", "ok", "partial", "failed")} == {
        "cases": 50,
        "ok": 49,
        "partial": 0,
        "failed": 1,
    }
    # The quantiles are numpy's (its default method is the same definition 7, computed apart).
    for q in findings["quantiles"]:
        column = table[q["name"]]
        values = column[np.isfinite(column)]
        assert q["values"] == len(values)
        if len(values):
            expected = np.quantile(values, [0.0, 0.05, 0.5, 0.95, 1.0])
            got = [q[k] for k in ("min", "p05", "p50", "p95", "max")]
            assert np.allclose(got, expected, rtol=1e-15, atol=0.0), q["name"]


def test_fifty_cases_on_two_dask_workers_equal_the_local_run_bit_for_bit(study, local, client):
    from kanedyn import dask as kdask

    assert len(client.scheduler_info()["workers"]) == 2
    remote = kdask.run(study, client, progress=False)["torques"]
    here = local[0].designs["torques"]
    assert list(remote) == list(here)
    for name, column in here.items():
        if column.dtype.kind == "f":
            assert np.array_equal(bits(remote[name]), bits(column)), name
        else:
            assert list(remote[name]) == list(column), name
    # The forced failure is reported with its reason; the other 49 cases keep their results.
    status = remote["status"]
    assert status[FAILED] == "failed" and "Newton did not converge" in remote["error"][FAILED]
    assert remote["T_n_Nm"][FAILED] == 1e6
    assert np.isnan(remote["peak_accel_1x_rad_s2"][FAILED])
    ok = np.arange(50) != FAILED
    assert (status[ok] == "ok").all()
    assert np.isfinite(remote["peak_accel_1x_rad_s2"][ok]).all()
    assert np.isfinite(remote["pivot_peak_rad"][ok]).all()
    # The rotor's peak acceleration grows with the torque (the branch's peak at least doubles
    # from 10 to 200 N·m: a check that the cases differ, not a pinned number).
    peaks = remote["peak_accel_1x_rad_s2"][ok]
    assert peaks[-1] > 2 * peaks[0]


def test_cases_run_by_index_equal_their_rows(study, local):
    here = local[0].designs["torques"]
    rows = study.run_cases("torques", [49, 0, FAILED], parallel=False)
    assert [r["case"] for r in rows] == [49, 0, FAILED]
    for r in rows:
        i = r["case"]
        assert r["status"] == here["status"][i]
        assert bits([r["values"][0]])[0] == bits(here["T_n_Nm"])[i]
        assert bits([r["results"][0]])[0] == bits(here["peak_accel_1x_rad_s2"])[i]
    assert study.case_count("torques") == 50
    assert np.array_equal(study.case_values("torques")[:, 0], np.array(TORQUES))
    with pytest.raises(kanedyn.ArgumentError, match="no design study `nope`"):
        study.run_cases("nope")
    with pytest.raises(kanedyn.ModelError, match="no case 50"):
        study.run_cases("torques", [50])


def test_the_default_local_cluster_runs_the_example(tmp_path):
    from kanedyn import dask as kdask

    ex = kanedyn.Study.from_file(EXAMPLES / "design_study.ron")
    here = ex.run().designs
    remote = kdask.run(ex, names=["tuning"], progress=False)
    for name, column in here["tuning"].items():
        if column.dtype.kind == "f":
            assert np.array_equal(bits(remote["tuning"][name]), bits(column)), name
    with pytest.raises(kanedyn.ArgumentError, match="no design study"):
        kdask.run(kanedyn.Study.from_file(EXAMPLES / "cpva_linear.ron"), progress=False)


def test_mechanisms_and_studies_pickle(study, monkeypatch, tmp_path):
    for m in [
        kanedyn.Mechanism.from_file(EXAMPLES / "cpva.ron"),
        kanedyn.Mechanism.from_str((EXAMPLES / "cpva4.ron").read_text(), str(EXAMPLES / "cpva4.ron")),
    ]:
        copy = pickle.loads(pickle.dumps(m))
        assert copy.check() == m.check()
        n = m.ndof
        q, u = np.linspace(-0.3, 0.4, n), np.linspace(90.0, 110.0, n)
        for a, b in zip(m.eom(q, u, 0.3), copy.eom(q, u, 0.3)):
            assert np.array_equal(bits(a), bits(b))
    with pytest.raises(TypeError, match="pickle the study"):
        pickle.dumps(study.mechanism)
    copy = pickle.loads(pickle.dumps(study))
    assert (copy.name, copy.file, copy.analyses) == (study.name, study.file, study.analyses)
    # A relative file name is pickled absolute: another working folder finds the same files.
    relative = kanedyn.Mechanism.from_file(os.path.relpath(EXAMPLES / "cpva.ron"))
    monkeypatch.chdir(tmp_path)
    moved = pickle.loads(pickle.dumps(relative))
    assert os.path.normpath(moved.file) == str(EXAMPLES / "cpva.ron") and moved.check()["bodies"] == relative.check()["bodies"]
    a, b = study.run_cases("torques", [3]), copy.run_cases("torques", [3])
    assert bits(a[0]["results"]).tolist() == bits(b[0]["results"]).tolist()


def test_bad_design_input_is_a_located_input_error():
    bad = STUDY.replace('quantity: TorqueAmplitude', 'quantity: JointDamping("pivt")')
    with pytest.raises(kanedyn.InputError) as e:
        kanedyn.Study.from_str(bad, str(EXAMPLES / "design_py.ron"))
    err = e.value
    assert err.field == "analyses[0].parameters[0].quantity"
    line = bad.splitlines()[err.line - 1]
    assert line[err.column - 1 :].startswith('JointDamping("pivt")')
    assert "unknown joint `pivt` (joints: spin, pivot)" in str(err)


def test_a_chunk_lost_on_the_workers_is_reported_row_by_row(tmp_path, client):
    """Workers rebuild the study from its text and read the mechanism from the file system; with
    the mechanism file gone, every task fails there, and each case becomes a failed row naming
    the reason (nothing raised, the table complete)."""
    from kanedyn import dask as kdask

    (tmp_path / "rotor.ron").write_text(
        'Mechanism(name: "rotor", speeds: AbsoluteAngularVelocities, bodies: ['
        'Body(name: "rotor", mass: 110.0, inertia: 3.4435), '
        'Body(name: "pendulum", mass: 6.0, com: (0.0152, 0.0), inertia: 2.16e-4)], joints: ['
        'Joint(name: "spin", parent: "ground", child: "rotor", at: (0.0, 0.0)), '
        'Joint(name: "pivot", parent: "rotor", child: "pendulum", at: (0.17, 0.0), damper: 5e-4)], '
        'loads: [GroundDamper(body: "rotor", c: 5e-3)])'
    )
    (tmp_path / "s.ron").write_text(
        STUDY.replace('"cpva.ron"', '"rotor.ron"').replace(", ".join(repr(t) for t in TORQUES), "10.0, 20.0, 30.0")
    )
    study = kanedyn.Study.from_file(tmp_path / "s.ron")
    local = study.run_cases("torques")
    assert [r["status"] for r in local] == ["ok"] * 3
    (tmp_path / "rotor.ron").unlink()
    t = kdask.run(study, client, progress=False, chunk_size=2)["torques"]
    assert list(t["status"]) == ["failed"] * 3
    assert np.array_equal(t["T_n_Nm"], [10.0, 20.0, 30.0])
    assert np.isnan(t["peak_accel_1x_rad_s2"]).all()
    assert "the Dask task for cases 0..1 failed" in t["error"][0] and "InputError" in t["error"][0] and "cannot read" in t["error"][0]
    assert "the Dask task for cases 2..2 failed" in t["error"][2]


def test_a_scheduler_address_takes_the_cases_to_that_cluster(client):
    """Given as an address, the scheduler is connected to for this run and let go after; the
    cluster stays up for its owner."""
    from kanedyn import dask as kdask

    ex = kanedyn.Study.from_file(EXAMPLES / "design_study.ron")
    here = kdask.table(ex, "tuning", ex.run_cases("tuning"))
    remote = kdask.run(ex, client.scheduler.address, names=["tuning"], progress=False)["tuning"]
    for name, column in here.items():
        if column.dtype.kind == "f":
            assert np.array_equal(bits(remote[name]), bits(column)), name
    assert len(client.scheduler_info()["workers"]) == 2


MISTUNED = """Study(
    name: "mistuned_py",
    mechanism: "cpva4.ron",
    analyses: [
        DesignStudy(
            name: "spread",
            parameters: [%s],
            sampling: MonteCarlo(n: 24, seed: 2026),
            operating: (2.95, 3.25),
            analysis: HarmonicBalance(name: "h", rpm: 1000.0, order_min: 2.9, order_max: 3.3, amplitudes: [500.0]),
        ),
    ],
)
""" % ", ".join(
    f'(name: "n_t{i}", quantity: TuningOrder("pivot_{i}"), from: 3.0789, to: 3.1411, '
    "distribution: Normal(mean: 3.11, sd: 0.010367))"
    for i in range(1, 5)
)


def test_a_mistuning_spread_on_two_dask_workers_equals_the_local_run_bit_for_bit(client, tmp_path):
    from kanedyn import dask as kdask

    study = kanedyn.Study.from_str(MISTUNED, str(EXAMPLES / "mistuned_py.ron"))
    here = study.run(out=tmp_path)
    local = here.designs["spread"]
    remote = kdask.run(study, client, progress=False)["spread"]
    for name, column in local.items():
        if column.dtype.kind == "f":
            assert np.array_equal(bits(remote[name]), bits(column)), name
        else:
            assert list(remote[name]) == list(column), name
    # Every draw lies in the band; the fractions count the rows that jump or part in range.
    for i in range(1, 5):
        assert ((local[f"n_t{i}"] >= 3.0789) & (local[f"n_t{i}"] <= 3.1411)).all()
    findings = here.analysis("spread")["findings"]
    parted = local["unison_losses_in_range"] > 0
    assert findings["unison_loss_fraction"] == parted.mean()
    assert findings["jump_fraction"] == (local["jumps_in_range"] > 0).mean()
