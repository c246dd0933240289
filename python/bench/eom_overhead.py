"""Python call overhead of `Mechanism.eom` over the Rust cost of the same evaluation.

    python/.venv/bin/python python/bench/eom_overhead.py [--calls N] [--repeats R]

For each example mechanism it times, per call, best of R repeats of N calls:
- `rust`: the evaluation alone (rhs, M and F, the overflow check), in a Rust loop
  (`Mechanism._time_rust_eom`), no Python in between;
- `python`: `m.eom(q, u, t)` from a Python loop, with NumPy arrays in and out;
- the same with lists as input, and with a joint-torque override.
The overhead is python − rust; the target (issue 16) is at most 2 µs.
"""

import argparse
import time
from pathlib import Path

import numpy as np

import kanedyn

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"

STATES = {
    "cpva": ([12.5, -0.4], [104.7, -20.0], 0.5, {"spin": 250.0}),
    "triple_pendulum": ([0.4, -0.9, 1.3], [0.5, -2.0, 3.25], 0.5, {"elbow": 3.5}),
    "shaft_cpva": ([0.2, 0.01, -0.3], [104.7, 105.0, 90.0], 0.5, {"spin": 300.0}),
    "joint_kinds": ([0.8, 0.03, -0.6], [157.0, 0.4, 170.0], 0.5, {"spin": 40.0}),
    "cpva4": ([0.3, 0.5, -0.2, 0.9, -1.1], [104.7, 120.0, 80.0, 95.5, 110.25], 0.5, {"spin": -80.5}),
}


def best_per_call(fn, calls, repeats):
    """Seconds per call: the best of `repeats` loops of `calls` calls (the least disturbed run)."""
    best = float("inf")
    for _ in range(repeats):
        start = time.perf_counter()
        for _ in range(calls):
            fn()
        best = min(best, (time.perf_counter() - start) / calls)
    return best


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--calls", type=int, default=100_000)
    ap.add_argument("--repeats", type=int, default=7)
    args = ap.parse_args()
    us = 1e6
    print(f"{'mechanism':<16} {'n':>2} {'rust':>8} {'python':>8} {'overhead':>9} {'lists':>8} {'torques':>8}  (µs/call)")
    worst = 0.0
    for name, (q, u, t, torques) in STATES.items():
        m = kanedyn.Mechanism.from_file(EXAMPLES / f"{name}.ron")
        qa, ua = np.array(q), np.array(u)
        m.eom(qa, ua, t)  # builds the cached evaluator
        m.eom(qa, ua, t, torques)
        rust = min(m._time_rust_eom(qa, ua, t, args.calls) for _ in range(args.repeats))
        py = best_per_call(lambda: m.eom(qa, ua, t), args.calls, args.repeats)
        lists = best_per_call(lambda: m.eom(q, u, t), args.calls, args.repeats)
        driven = best_per_call(lambda: m.eom(qa, ua, t, torques), args.calls, args.repeats)
        worst = max(worst, py - rust)
        print(
            f"{name:<16} {m.ndof:>2} {rust * us:>8.3f} {py * us:>8.3f} {(py - rust) * us:>9.3f} "
            f"{lists * us:>8.3f} {driven * us:>8.3f}"
        )
    print(f"largest overhead (NumPy arrays in): {worst * us:.3f} µs/call (target ≤ 2 µs)")


if __name__ == "__main__":
    main()
