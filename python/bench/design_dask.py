"""Throughput of a 1000-case harmonic-balance design study: a 2-worker Dask LocalCluster against
the local rayon run, on the same machine, in one session.

    python/.venv/bin/python python/bench/design_dask.py [--repeats R] [--cases-per-side N]

The study (written to a temporary file next to examples/cpva.ron's folder name, so its mechanism
resolves): the paper's rotor-CPVA, harmonic balance in order from 2.9 to 3.3 at 1000 rpm
(H = 10, Floquet stability of every point, two continuations per case), over a grid of the
pendulum's centre-of-mass radius L (which sets the tuning order n_t, eq. 15) and the torque
amplitude T_n: N × N cases (default 32 × 32 = 1024 ≥ 1000).

- local: `study.run_cases(name)`, rayon over the machine's cores (the CLI's way);
- dask: `kanedyn.dask.run(study, client)` on a `LocalCluster(n_workers=2, threads_per_worker=1)`
  started beforehand (its start-up is reported apart), study scattered, chunks of cases per task.

Runs alternate local, dask, local, dask, … R times; throughput is cases per second of wall time,
the ratio dask / local from the medians and from the best runs (target of issue 16: ≥ 0.8; on a
machine shared with other work the best runs are the least disturbed). Both tables are checked
equal bit for bit.
"""

import argparse
import statistics
import time
from pathlib import Path

import numpy as np

import kanedyn
from kanedyn import dask as kdask

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def study_text(n: int) -> str:
    return f"""Study(
    name: "bench_design",
    mechanism: "cpva.ron",
    lock: ["pivot"],
    analyses: [
        DesignStudy(
            name: "nt_torque",
            parameters: [
                (name: "L", quantity: BodyComRadius("pendulum"), from: 0.0145, to: 0.0160, points: {n}),
                (name: "T_n", quantity: TorqueAmplitude, from: 10.0, to: 200.0, points: {n}),
            ],
            analysis: HarmonicBalance(name: "h", rpm: 1000.0, order_min: 2.9, order_max: 3.3, amplitudes: [40.0]),
        ),
    ],
)
"""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--cases-per-side", type=int, default=32)
    args = ap.parse_args()
    from distributed import Client, LocalCluster

    study = kanedyn.Study.from_str(study_text(args.cases_per_side), str(EXAMPLES / "bench_design.ron"))
    name = "nt_torque"
    n = study.case_count(name)
    t0 = time.perf_counter()
    cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0")
    client = Client(cluster)
    startup = time.perf_counter() - t0
    local_s, dask_s = [], []
    local_rows = remote = None
    try:
        for _ in range(args.repeats):
            t = time.perf_counter()
            local_rows = study.run_cases(name)
            local_s.append(time.perf_counter() - t)
            t = time.perf_counter()
            remote = kdask.run(study, client, progress=False)[name]
            dask_s.append(time.perf_counter() - t)
    finally:
        client.close()
        cluster.close()
    here = kdask.table(study, name, local_rows)
    same = all(
        np.array_equal(np.asarray(here[c]).view(np.uint64), np.asarray(remote[c]).view(np.uint64))
        if here[c].dtype.kind == "f"
        else list(here[c]) == list(remote[c])
        for c in here
    )
    failed = int((here["status"] != "ok").sum())
    lm, dm = statistics.median(local_s), statistics.median(dask_s)
    print(f"cases: {n} ({failed} not ok); cluster start-up {startup:.2f} s (not counted)")
    print("| run | wall s (each) | median s | cases/s |")
    print("| --- | --- | --- | --- |")
    print(f"| local rayon | {', '.join(f'{s:.2f}' for s in local_s)} | {lm:.2f} | {n / lm:.1f} |")
    print(f"| Dask 2 workers | {', '.join(f'{s:.2f}' for s in dask_s)} | {dm:.2f} | {n / dm:.1f} |")
    lb, db = min(local_s), min(dask_s)
    print(f"throughput ratio dask / local: {lm / dm:.3f} (medians), {lb / db:.3f} (best runs)")
    print(f"with the cluster's start-up added to the dask median: {lm / (dm + startup):.3f}")
    print(f"tables equal bit for bit: {same}")


if __name__ == "__main__":
    main()
