"""The Dask script of the README (examples/python/dask_study.py) run as a user runs it: a separate
Python process on a file, with a LocalCluster of worker processes. Its tables equal the local run's;
the same script without its `if __name__ == "__main__":` guard fails, as the README says."""

import re
import subprocess
import sys

import numpy as np
import pytest

import kanedyn

from conftest import EXAMPLES, ROOT

pytest.importorskip("distributed", reason="dask[distributed] is installed by run-tests.sh")

SCRIPT = EXAMPLES / "python" / "dask_study.py"
GUARD = 'if __name__ == "__main__":\n'


def run_script(path, cwd):
    # A fresh interpreter, as `python dask_study.py` from a shell; the worker processes import the
    # file again (multiprocessing's spawn), which is what the guard is about. 300 s is far above
    # the ~3 s it takes, only a bound against a hang.
    return subprocess.run([sys.executable, str(path)], cwd=cwd, capture_output=True, text=True, timeout=300)


def test_the_readme_shows_the_whole_script():
    text = SCRIPT.read_text(encoding="utf-8")
    assert GUARD in text
    readme = (ROOT / "python" / "README.md").read_text(encoding="utf-8")
    assert f"```python\n{text}```\n" in readme, "python/README.md must show examples/python/dask_study.py verbatim"


def test_the_script_runs_on_a_local_cluster_and_equals_the_local_run(tmp_path):
    # From another folder: the script finds the study beside itself, not in the working folder.
    p = run_script(SCRIPT, tmp_path)
    assert p.returncode == 0, p.stderr
    designs = kanedyn.Study.from_file(EXAMPLES / "design_study.ron").run().designs
    counts = dict(
        (name, (int(n), int(ok))) for name, n, ok in re.findall(r"^(\w+): (\d+) cases, (\d+) ok$", p.stdout, re.M)
    )
    assert counts == {
        name: (len(t["case"]), int((t["status"] == "ok").sum())) for name, t in designs.items()
    }, p.stdout
    assert counts == {"tuning": (15, 15), "response": (24, 24)}
    # The printed peak is the local table's to the 6 significant digits printed (the Dask tables
    # equal the local ones bit for bit, test_design.py; here only the script's output is read).
    peak = float(re.search(r"largest peak 1x acceleration (\S+) rad/s²", p.stdout).group(1))
    assert peak == float(f"{np.nanmax(designs['response']['peak_accel_1x_rad_s2']):.6g}")


def test_without_the_guard_the_script_fails(tmp_path):
    text = SCRIPT.read_text(encoding="utf-8")
    # The same script, the guard replaced by a condition that always holds: what a user who
    # leaves it out runs. Written in tmp_path, so the study is named by its absolute path.
    here = 'Path(__file__).resolve().parent.parent / "design_study.ron"'
    assert here in text and GUARD in text
    unguarded = tmp_path / "dask_study_unguarded.py"
    unguarded.write_text(
        text.replace(here, repr(str(EXAMPLES / "design_study.ron"))).replace(GUARD, "if True:\n"), encoding="utf-8"
    )
    p = run_script(unguarded, tmp_path)
    assert p.returncode != 0, p.stdout
    # multiprocessing's own explanation, raised in each worker that imported the script.
    assert "bootstrapping phase" in p.stderr, p.stderr[-2000:]
