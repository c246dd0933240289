"""The notebook example (examples/python/cpva.ipynb) executes without error with its kernel started
at the repository's root (it finds examples/ from any folder inside the repository), and is
stored with its outputs (so a reader sees its figures without running it) that a fresh execution
reproduces: the same text results and printed lines."""

import pytest

from conftest import EXAMPLES

nbformat = pytest.importorskip("nbformat", reason="nbformat is installed by run-tests.sh")
nbclient = pytest.importorskip("nbclient", reason="nbclient is installed by run-tests.sh")
pytest.importorskip("matplotlib", reason="matplotlib is installed by run-tests.sh")
pytest.importorskip("distributed", reason="dask[distributed] is installed by run-tests.sh")

NOTEBOOK = EXAMPLES / "python" / "cpva.ipynb"


def text_outputs(nb):
    """Per code cell, its text results and printed lines (the figures' PNG bytes depend on the
    plotting library's version; the Dask progress bar's frames carry wall times)."""
    out = []
    for c in nb.cells:
        if c.cell_type != "code":
            continue
        texts = []
        for o in c.outputs:
            if o.output_type == "execute_result":
                texts.append(o["data"]["text/plain"])
            elif o.output_type == "stream" and o.name == "stdout" and "Completed" not in o.text and "\x1b" not in o.text:
                texts.append(o.text)
        out.append(texts)
    return out


def test_the_notebook_is_stored_with_its_figures():
    nb = nbformat.read(NOTEBOOK, as_version=4)
    code = [c for c in nb.cells if c.cell_type == "code"]
    images = [o for c in code for o in c.outputs if "image/png" in o.get("data", {})]
    # Fig. 2, the harmonic-balance branch and the design study's scatter.
    assert len(images) == 3
    assert all(c.execution_count is not None for c in code)


def test_the_notebook_executes(monkeypatch):
    # A headless plotting backend: the kernel draws into memory only.
    monkeypatch.setenv("MPLBACKEND", "Agg")
    stored = text_outputs(nbformat.read(NOTEBOOK, as_version=4))
    nb = nbformat.read(NOTEBOOK, as_version=4)
    client = nbclient.NotebookClient(
        nb, timeout=600, kernel_name="python3", resources={"metadata": {"path": str(EXAMPLES.parent)}}
    )
    client.execute()  # raises CellExecutionError, with the cell and its traceback, on any error
    printed = "".join(o.get("text", "") for c in nb.cells if c.cell_type == "code" for o in c.outputs)
    assert "equal to the local run bit for bit: True" in printed
    assert "status ['ok']" in printed
    assert text_outputs(nb) == stored
