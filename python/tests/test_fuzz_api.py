"""Issue 25, item 7 (Python side): a seeded fuzzer over the Python API's numeric arguments.
Each call draws its numbers from ordinary and hostile values (0, negatives, 1e-300, 1e300, NaN,
inf, huge counts) and must either return or raise a `kanedyn.KanedynError` (an ArgumentError
for a bad argument) within a second: never abort the interpreter, never hang. The values are
chosen so that every valid call is short (at most 0.1 s of simulated time at 2 kHz), so a slow
call is a defect. `KANEDYN_FUZZ_SEED` and `KANEDYN_FUZZ_CALLS` replay or lengthen it (the
normal run makes 300 calls)."""

import os
import random
import time

import numpy as np

import kanedyn
from conftest import EXAMPLES

FLOATS = [0.0, -1.0, 1e-300, 1e300, float("nan"), float("inf"), -float("inf"), 1e-6, 1e6, 0.5, 3.0, 1000.0, 1e12]


def test_hostile_numbers_raise_or_return_quickly():
    rng = random.Random(int(os.environ.get("KANEDYN_FUZZ_SEED", "25")))
    calls = int(os.environ.get("KANEDYN_FUZZ_CALLS", "300"))
    m = kanedyn.Mechanism.from_file(EXAMPLES / "cpva.ron")
    lin = kanedyn.linearize(m, "spin", 1000.0)
    f = lambda usual: rng.choice(FLOATS) if rng.random() < 0.3 else usual  # noqa: E731
    outcomes = {"returned": 0, "ArgumentError": 0, "other KanedynError": 0}
    slowest = 0.0
    for i in range(calls):
        kind = rng.randrange(4)
        if kind == 0:
            t1 = rng.choice([0.01, 0.1, -1.0, 1e300, float("nan"), 1e-9])
            call = lambda: kanedyn.simulate(  # noqa: E731
                m, [0.0, f(0.1), f(104.7), 104.7], f(0.0), t1, [("BodyAccel", "rotor")],
                rtol=f(1e-9), atol=f(1e-9), sample_hz=rng.choice([2000.0, 1e12, 0.0, None, float("nan")]),
                max_steps=rng.choice([1, 1000, 100_000]))
        elif kind == 1:
            call = lambda: kanedyn.hbm_branch(  # noqa: E731
                m, "spin", f(1000.0), f(40.0), f(3.3), f(3.2), rng.choice([1, 3, 0, 65, 10**9]),
                multiples=[f(1.0)], max_step=f(0.1), stability=False)
        elif kind == 2:
            call = lambda: kanedyn.linearize(m, "spin", f(1000.0))  # noqa: E731
        else:
            n = rng.choice([1, 3, 10**7])
            orders = np.broadcast_to(f(3.0), (n,))
            call = lambda: lin.order_response("spin", "rotor", orders)  # noqa: E731
        start = time.perf_counter()
        try:
            call()
            outcomes["returned"] += 1
        except kanedyn.ArgumentError:
            outcomes["ArgumentError"] += 1
        except kanedyn.KanedynError:
            outcomes["other KanedynError"] += 1
        took = time.perf_counter() - start
        slowest = max(slowest, took)
        assert took < 1.0, (i, kind, took)
    print(f"{calls} calls: {outcomes}, slowest {slowest:.3f} s")
    assert outcomes["ArgumentError"] > 0 and outcomes["returned"] > 0
