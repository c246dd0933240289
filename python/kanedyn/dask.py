"""Design studies on a Dask cluster: the cases of a study's ``DesignStudy`` analyses, spread over
workers, with a progress bar; the table equals the local run's (``Study.run().designs``) bit for
bit.

A case is a pure function of the study and its index (``Study.run_cases``), so where it runs does
not change its numbers. The study travels to the workers pickled (its text, file name and load
options; ``Study.__reduce__``) with each task, and each worker reads the mechanism again from the file system:
on a cluster past one machine, the study's folder must be at the same path on every worker (a
shared file system), and ``kanedyn`` installed there.

    import kanedyn, kanedyn.dask
    study = kanedyn.Study.from_file("examples/design_study.ron")
    tables = kanedyn.dask.run(study)            # a LocalCluster with 2 workers, closed after
    tables["response"]["peak_accel_1x_rad_s2"], tables["response"]["status"]

A failed case is a row with ``status == "failed"`` and its reason in ``error``, never an
exception; a chunk of cases lost with its worker (the worker died, the study did not load there)
is reported the same way, row by row, and the other chunks keep their results.
"""

from __future__ import annotations

import math
from typing import Any, Dict, List, Optional, Sequence, Union

import numpy as np

from ._kanedyn import Study

__all__ = ["run", "table"]


def _run_chunk(state: tuple, name: str, indices: List[int]) -> List[Dict[str, Any]]:
    """Runs cases on a worker. The study is rebuilt here from its state for every task (about a
    millisecond; never cached, so a mechanism file edited between runs is read afresh), and a
    study that cannot be loaded on this worker fails the task with kanedyn's own message."""
    from ._pickle import restore_study

    study = restore_study(*state)
    # One worker thread per chunk: rayon would only compete with the other workers for cores.
    return study.run_cases(name, indices, parallel=False)


def table(study: Study, name: str, rows: Sequence[Dict[str, Any]]) -> Dict[str, np.ndarray]:
    """The case table of design study ``name`` from its rows (``Study.run_cases``), as
    ``Study.run().designs[name]`` holds it: ``case``, the parameter and result columns (float64,
    NaN where none exists), ``status`` and ``error`` (string arrays). Rows are put in case order.
    """
    cols = study.design_columns(name)
    rows = sorted(rows, key=lambda r: r["case"])
    out: Dict[str, np.ndarray] = {"case": np.array([float(r["case"]) for r in rows], dtype=np.float64)}
    for k, (col, _unit) in enumerate(cols["parameters"]):
        out[col] = np.array([r["values"][k] for r in rows], dtype=np.float64)
    for k, (col, _unit) in enumerate(cols["results"]):
        out[col] = np.array([r["results"][k] for r in rows], dtype=np.float64)
    out["status"] = np.array([r["status"] for r in rows])
    out["error"] = np.array([r["error"] for r in rows])
    return out


def _failed_rows(study: Study, name: str, indices: List[int], why: str) -> List[Dict[str, Any]]:
    """Rows for cases whose chunk was lost: values from a fresh local draw (cheap, no analysis),
    results NaN, status failed."""
    n_results = len(study.design_columns(name)["results"])
    values = study.case_values(name)
    return [
        {
            "case": i,
            "values": [float(v) for v in values[i]],
            "results": [math.nan] * n_results,
            "status": "failed",
            "error": why,
        }
        for i in indices
    ]


def run(
    study: Study,
    client: Union[None, str, Any] = None,
    *,
    names: Optional[Sequence[str]] = None,
    chunk_size: Optional[int] = None,
    progress: bool = True,
) -> Dict[str, Dict[str, np.ndarray]]:
    """Runs the study's design studies on a Dask cluster and returns their case tables.

    Parameters
    ----------
    study : Study
        The study; only its ``DesignStudy`` analyses are run (``Study.run`` runs the others).
    client : None, str or distributed.Client
        None: a ``distributed.LocalCluster`` of 2 worker processes with one thread each, started
        here and closed at the end. A str: the address of a running scheduler
        (``"tcp://host:8786"``), connected to and disconnected from here. A ``Client``: used as it
        is and left open.
    names : list of str, optional
        The design studies to run (default: all, ``study.design_studies``).
    chunk_size : int, optional
        Cases per task (default: about 8 tasks per worker, so the progress bar moves and the load
        balances while the per-task overhead stays small).
    progress : bool, default True
        Show ``distributed.progress``'s text bar while the cases run.

    Returns
    -------
    dict
        ``{name: table}``, each table as ``Study.run().designs[name]``: equal to it bit for bit.

    Raises
    ------
    ArgumentError
        No design study of a given name, or none at all.
    """
    from distributed import Client, LocalCluster, progress as show_progress

    names = list(study.design_studies if names is None else names)
    if not names:
        from ._kanedyn import ArgumentError

        raise ArgumentError(f"study `{study.name}` has no design study (DesignStudy analysis) to run")
    counts = {name: study.case_count(name) for name in names}

    cluster = None
    own_client = False
    if client is None:
        cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0")
        client = Client(cluster)
        own_client = True
    elif isinstance(client, str):
        client = Client(client)
        own_client = True
    try:
        workers = max(1, len(client.scheduler_info().get("workers", {})))
        # The study goes with each task as its state (a few kB of text, parsed on the worker):
        # a worker that cannot load it fails those tasks with kanedyn's message, which is
        # reported row by row below instead of failing the whole run.
        state = study.__reduce__()[1]
        tasks = []
        for name, n in counts.items():
            size = chunk_size or max(1, math.ceil(n / (8 * workers)))
            for start in range(0, n, size):
                chunk = list(range(start, min(n, start + size)))
                future = client.submit(_run_chunk, state, name, chunk, pure=False)
                tasks.append((name, chunk, future))
        futures = [f for _, _, f in tasks]
        if progress and futures:
            show_progress(futures, notebook=False)
        rows: Dict[str, List[Dict[str, Any]]] = {name: [] for name in names}
        for name, chunk, future in tasks:
            try:
                rows[name].extend(future.result())
            except Exception as e:  # noqa: BLE001 - any failure of a chunk becomes its rows' error
                why = f"the Dask task for cases {chunk[0]}..{chunk[-1]} failed: {type(e).__name__}: {e}"
                rows[name].extend(_failed_rows(study, name, chunk, why))
        return {name: table(study, name, rows[name]) for name in names}
    finally:
        if own_client:
            client.close()
        if cluster is not None:
            cluster.close()
