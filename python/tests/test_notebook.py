"""The notebook example (examples/python/cpva.ipynb) executes without error from its folder, and is
stored without outputs."""

import pytest

from conftest import EXAMPLES

nbformat = pytest.importorskip("nbformat", reason="nbformat is installed by run-tests.sh")
nbclient = pytest.importorskip("nbclient", reason="nbclient is installed by run-tests.sh")
pytest.importorskip("matplotlib", reason="matplotlib is installed by run-tests.sh")
pytest.importorskip("distributed", reason="dask[distributed] is installed by run-tests.sh")

NOTEBOOK = EXAMPLES / "python" / "cpva.ipynb"


def test_the_notebook_is_stored_without_outputs():
    nb = nbformat.read(NOTEBOOK, as_version=4)
    code = [c for c in nb.cells if c.cell_type == "code"]
    assert code and all(not c.outputs and c.execution_count is None for c in code)


def test_the_notebook_executes(monkeypatch):
    # A headless plotting backend: the kernel draws into memory only.
    monkeypatch.setenv("MPLBACKEND", "Agg")
    nb = nbformat.read(NOTEBOOK, as_version=4)
    client = nbclient.NotebookClient(
        nb, timeout=600, kernel_name="python3", resources={"metadata": {"path": str(NOTEBOOK.parent)}}
    )
    client.execute()  # raises CellExecutionError, with the cell and its traceback, on any error
    printed = "".join(o.get("text", "") for c in nb.cells if c.cell_type == "code" for o in c.outputs)
    assert "equal to the local run bit for bit: True" in printed
    assert "status ['ok']" in printed
