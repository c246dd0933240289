"""`Mechanism.eom` equals `kanedyn eom`'s JSON bit for bit on five example mechanisms.

The five cover both speed definitions and the three evaluation forms of the engine: absolute
angular velocities on revolute trees (cpva, cpva4, shaft_cpva, with a spring), joint rates under
gravity (triple_pendulum), and mixed joint kinds, prismatic and fixed (joint_kinds). Each is
evaluated at two states away from zero with t > 0 (the examples' torques are time-dependent), with
its own loads and with joint torques replaced as `--joint-torque NAME=VALUE` does.
"""

import json
from collections.abc import Mapping
from types import MappingProxyType

import numpy as np
import pytest

import kanedyn
from conftest import EXAMPLES

# name: (states (q, u, t), joint-torque overrides in the order they are given)
CASES = {
    "cpva": (
        [([12.5, -0.4], [104.7, -20.0], 0.0), ([-3.1, 1.2], [98.0, 150.5], 1.37)],
        {"spin": 250.0},
    ),
    "cpva4": (
        [
            ([0.3, 0.5, -0.2, 0.9, -1.1], [104.7, 120.0, 80.0, 95.5, 110.25], 0.25),
            ([2.0, -0.7, 0.1, 0.0, 0.45], [-50.0, 10.0, -30.0, 0.0, 5.5], 2.5),
        ],
        {"spin": -80.5, "pivot_2": 0.01},
    ),
    "triple_pendulum": (
        [([0.4, -0.9, 1.3], [0.5, -2.0, 3.25], 0.0), ([-1.2, 0.2, 2.9], [-4.0, 1.5, 0.1], 3.0)],
        # The elbow has no torque of its own: the override adds one.
        {"elbow": 3.5},
    ),
    "joint_kinds": (
        [([0.8, 0.03, -0.6], [157.0, 0.4, 170.0], 0.1), ([-2.2, -0.02, 1.4], [60.0, -1.5, 20.0], 0.9)],
        # A torque on the welded joint has nothing to drive and is ignored by both tools.
        {"slide": 12.0, "weld": 5.0, "spin": 40.0},
    ),
    "shaft_cpva": (
        [([0.2, 0.01, -0.3], [104.7, 105.0, 90.0], 0.5), ([5.0, -0.02, 0.8], [80.0, 79.0, 120.0], 2.2)],
        {"spin": 300.0},
    ),
}

PARAMS = [
    pytest.param(name, i, with_torques, id=f"{name}-state{i}-{'torques' if with_torques else 'own-loads'}")
    for name, (states, _) in CASES.items()
    for i in range(len(states))
    for with_torques in (False, True)
]

# One Mechanism per file for the whole module, so later cases run on an evaluator that earlier
# cases (other states, other overrides) have already used: the CLI always starts fresh.
_LOADED = {}


def loaded(name):
    if name not in _LOADED:
        _LOADED[name] = kanedyn.Mechanism.from_file(EXAMPLES / f"{name}.ron")
    return _LOADED[name]


def cli_eom(cli, path, q, u, t, torques):
    args = ["eom", path, "--q", ",".join(map(repr, q)), "--u", ",".join(map(repr, u)), "--t", repr(t)]
    for name, value in (torques or {}).items():
        args += ["--joint-torque", f"{name}={value!r}"]
    ok, out, err = cli(*args)
    assert ok, err
    return json.loads(out)


def bits(a):
    """The float64 bit patterns, so that -0.0 ≠ 0.0 and nothing is compared with a tolerance."""
    a = np.asarray(a, dtype=np.float64)
    return np.ascontiguousarray(a).view(np.uint64)


def assert_same_bits(got, want, what):
    got, want = np.asarray(got), np.asarray(want, dtype=np.float64)
    assert got.dtype == np.float64, what
    assert got.shape == want.shape, f"{what}: shape {got.shape} != {want.shape}"
    diff = np.flatnonzero(bits(got).ravel() != bits(want).ravel())
    assert diff.size == 0, f"{what}: first difference at flat index {diff[0]}: {got.ravel()[diff[0]]!r} != {want.ravel()[diff[0]]!r}"


def assert_equals_cli(result, cli_json, n):
    M, F, qdot, udot = result
    assert M.shape == (n, n) and F.shape == qdot.shape == udot.shape == (n,)
    assert_same_bits(M, cli_json["mass_matrix"], "M")
    assert_same_bits(F, cli_json["forcing"], "F")
    assert_same_bits(qdot, cli_json["qdot"], "qdot")
    assert_same_bits(udot, cli_json["udot"], "udot")


@pytest.mark.parametrize("name,i,with_torques", PARAMS)
def test_eom_equals_cli_bit_for_bit(cli, name, i, with_torques):
    states, overrides = CASES[name]
    q, u, t = states[i]
    torques = overrides if with_torques else None
    path = EXAMPLES / f"{name}.ron"
    want = cli_eom(cli, path, q, u, t, torques)
    mech = loaded(name)
    assert mech.ndof == len(q)
    got = mech.eom(np.array(q), np.array(u), t=t, joint_torques=torques)
    assert_equals_cli(got, want, len(q))
    # A fresh object (a fresh evaluator, as the CLI has) gives the same bits.
    assert_equals_cli(kanedyn.Mechanism.from_file(path).eom(q, u, t, torques), want, len(q))


def test_overrides_change_the_result(cli):
    # Guards the test above against overrides that are silently dropped on both sides.
    q, u, t = CASES["cpva"][0][0]
    own = kanedyn.Mechanism.from_file(EXAMPLES / "cpva.ron").eom(q, u, t)
    driven = kanedyn.Mechanism.from_file(EXAMPLES / "cpva.ron").eom(q, u, t, {"spin": 250.0})
    assert not np.array_equal(own[1], driven[1])
    assert np.array_equal(own[0], driven[0])


def test_from_str_equals_from_file():
    path = EXAMPLES / "cpva4.ron"
    q, u, t = CASES["cpva4"][0][0]
    # Parts resolve relative to the folder of `name`, as for the file itself.
    text = kanedyn.Mechanism.from_str(path.read_text(), name=str(path))
    ref = kanedyn.Mechanism.from_file(path)
    for a, b in zip(text.eom(q, u, t), ref.eom(q, u, t)):
        assert_same_bits(a, b, "from_str vs from_file")
    assert text.check() == ref.check()


def test_array_like_inputs_give_the_same_numbers():
    mech = kanedyn.Mechanism.from_file(EXAMPLES / "cpva.ron")
    q, u, t = [12.0, -1.0], [104.0, -20.0], 0.3
    ref = mech.eom(np.array(q), np.array(u), t)
    wide = np.array([12.0, 99.0, -1.0, 99.0])
    for qq, uu in [
        (q, u),
        (tuple(q), tuple(u)),
        ([12, -1], [104, -20]),  # ints
        (np.array(q, dtype=np.float32), np.array(u, dtype=np.int64)),  # exact in float64
        (wide[::2], np.array(u)),  # not contiguous
    ]:
        for a, b in zip(mech.eom(qq, uu, t), ref):
            assert_same_bits(a, b, f"{qq!r}, {uu!r}")


def test_outputs_are_fresh_float64_arrays():
    mech = kanedyn.Mechanism.from_file(EXAMPLES / "joint_kinds.ron")
    q, u, t = CASES["joint_kinds"][0][0]
    first = mech.eom(q, u, t)
    assert isinstance(first, tuple) and len(first) == 4
    for a in first:
        assert isinstance(a, np.ndarray) and a.dtype == np.float64 and a.flags.c_contiguous and a.flags.writeable
    keep = [a.copy() for a in first]
    for a in first:
        a[...] = 0.0  # the caller owns them: writing must not reach the next call
    for a, b in zip(mech.eom(q, u, t), keep):
        assert_same_bits(a, b, "second call")


def test_bad_arguments_raise_argument_error():
    mech = kanedyn.Mechanism.from_file(EXAMPLES / "cpva.ron")
    cases = [
        (([0.0], [1.0, 2.0]), {}, "q needs 2 values"),
        (([0.0, 0.0], [1.0, 2.0, 3.0]), {}, "u needs 2 values"),
        (([0.0, float("nan")], [1.0, 2.0]), {}, "q[1] is not finite"),
        (([0.0, 0.0], [float("inf"), 2.0]), {}, "u[0] is not finite"),
        (([0.0, 0.0], [1.0, 2.0]), {"t": float("inf")}, "t must be finite"),
        (([0.0, 0.0], [1.0, 2.0]), {"joint_torques": {"spn": 3.0}}, "unknown joint `spn` (joints: spin, pivot)"),
        (([0.0, 0.0], [1.0, 2.0]), {"joint_torques": {"spin": float("nan")}}, "not finite"),
    ]
    for args, kwargs, words in cases:
        with pytest.raises(kanedyn.ArgumentError) as e:
            mech.eom(*args, **kwargs)
        assert words in str(e.value), str(e.value)
        assert isinstance(e.value, ValueError) and isinstance(e.value, kanedyn.KanedynError)
    # Not a vector of numbers at all: a clear exception, never a panic.
    for bad in ([[0.0, 0.0]], np.zeros((1, 2)), "ab", None, object()):
        with pytest.raises(kanedyn.ArgumentError, match="q must be a 1-D sequence of numbers"):
            mech.eom(bad, [1.0, 2.0])
    for bad in ({"spin": "x"}, {3: 1.0}, [("spin", 1.0)]):
        with pytest.raises(kanedyn.ArgumentError, match="joint_torques must"):
            mech.eom([0.0, 0.0], [1.0, 2.0], joint_torques=bad)
    # A failed call leaves the mechanism usable.
    mech.eom([0.0, 0.0], [1.0, 2.0])


def test_overflow_is_refused_with_the_cli_message(cli):
    # `kanedyn eom` refuses to print a non-finite number (tests/it/input_hardening.rs).
    path = EXAMPLES / "cpva.ron"
    want = cli.error("eom", path, "--q", "0,0", "--u", "1e200,0")
    with pytest.raises(kanedyn.EngineError) as e:
        kanedyn.Mechanism.from_file(path).eom([0.0, 0.0], [1e200, 0.0])
    assert str(e.value) == want
    assert "overflow" in want and "F[" in want


def test_the_cli_rejects_what_python_rejects(cli):
    # The argument errors above have their CLI counterparts (tests/it/cli.rs, input_hardening.rs).
    path = EXAMPLES / "cpva.ron"
    for args in (
        ["--q", "0", "--u", "1,2"],
        ["--q", "0,NaN", "--u", "1,2"],
        ["--q", "0,0", "--u", "inf,0"],
        ["--q", "0,0", "--u", "1,2", "--joint-torque", "spn=3"],
    ):
        cli.error("eom", path, *args)


def test_any_mapping_and_reentrant_calls():
    # A mapping whose `items()` runs Python code that calls `eom` on the same mechanism while the
    # outer call is under way: the inner call gets its own evaluator instead of waiting forever.
    mech = kanedyn.Mechanism.from_file(EXAMPLES / "cpva.ron")
    q, u, t = CASES["cpva"][0][0]
    inner = []

    class Torques(Mapping):
        def __getitem__(self, key):
            return {"spin": 250.0}[key]

        def __iter__(self):
            return iter(["spin"])

        def __len__(self):
            return 1

        def items(self):
            inner.append(mech.eom(q, u, t, {"spin": 250.0}))
            return super().items()

    outer = mech.eom(q, u, t, Torques())
    assert len(inner) == 1
    for a, b in zip(outer, inner[0]):
        assert_same_bits(a, b, "re-entrant call")
    for a, b in zip(outer, mech.eom(q, u, t, MappingProxyType({"spin": 250.0}))):
        assert_same_bits(a, b, "mapping proxy")
