"""The design studies of examples/design_study.ron on a local Dask cluster, as a script.

kanedyn is not on the package index: install it from this repository, with the Dask extra, then run
the script from the repository's root:

    pip install "./python[dask]"                # compiles the crate (a Rust toolchain ≥ 1.90)
    # or, with no Rust on the machine, a wheel built where Rust is (python/README.md, "Install"):
    #   pip install "kanedyn-0.1.0-cp39-abi3-manylinux2014_x86_64.manylinux_2_17_x86_64.whl[dask]"
    python examples/python/dask_study.py
"""

from pathlib import Path

import kanedyn
import kanedyn.dask


def main():
    study = kanedyn.Study.from_file(Path(__file__).resolve().parent.parent / "design_study.ron")
    # A LocalCluster of 2 worker processes, started and closed by run().
    tables = kanedyn.dask.run(study, progress=False)
    for name, t in tables.items():
        ok = int((t["status"] == "ok").sum())
        print(f"{name}: {len(t['case'])} cases, {ok} ok")
    peak = tables["response"]["peak_accel_1x_rad_s2"]
    print(f"response: largest peak 1x acceleration {peak.max():.6g} rad/s²")


# Needed: the cluster's worker processes start by importing this file again; without the guard
# each of them would run main() and try to start a cluster of its own, and the script fails.
if __name__ == "__main__":
    main()
