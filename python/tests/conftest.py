"""Shared fixtures: the repository, its examples, and the `kanedyn` command-line tool.

The CLI is the independent source the Python package is checked against. It is taken from
$KANEDYN_CLI when set (run-tests.sh sets it), otherwise built here with cargo from the repository
root, so the tests always compare against the CLI of the same source tree.
"""

import json
import os
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples"


def _build_cli() -> Path:
    """Builds the CLI with cargo and returns the executable cargo reports (any target folder)."""
    out = subprocess.run(
        ["cargo", "build", "--release", "--bin", "kanedyn", "--message-format=json-render-diagnostics"],
        cwd=ROOT,
        check=True,
        stdout=subprocess.PIPE,
        text=True,
    ).stdout
    for line in out.splitlines():
        msg = json.loads(line)
        if msg.get("reason") == "compiler-artifact" and msg.get("executable") and msg["target"]["name"] == "kanedyn":
            return Path(msg["executable"])
    raise RuntimeError("cargo built no `kanedyn` executable")


@pytest.fixture(scope="session")
def cli_path() -> Path:
    given = os.environ.get("KANEDYN_CLI")
    path = Path(given) if given else _build_cli()
    assert path.is_file(), f"no kanedyn CLI at {path}"
    return path


class Cli:
    """Runs the CLI and returns (exit ok, stdout, stderr)."""

    def __init__(self, path: Path):
        self.path = path

    def __call__(self, *args, cwd=ROOT):
        p = subprocess.run([str(self.path), *map(str, args)], cwd=cwd, capture_output=True, text=True)
        return p.returncode == 0, p.stdout, p.stderr

    def error(self, *args, cwd=ROOT) -> str:
        """The message of a failing run: stderr without the `error: ` prefix and final newline."""
        ok, out, err = self(*args, cwd=cwd)
        assert not ok, f"kanedyn {' '.join(map(str, args))} should fail; printed:\n{out}"
        assert err.startswith("error: ") and err.endswith("\n"), err
        assert "panicked" not in err, err
        return err[len("error: ") : -1]


@pytest.fixture(scope="session")
def cli(cli_path) -> Cli:
    return Cli(cli_path)


class StudyRuns:
    """`kanedyn run STUDY --out <tmp>` of the CLI, once per study file for the whole session."""

    def __init__(self, cli: Cli, root: Path):
        self.cli, self.root, self.done = cli, root, {}

    def __call__(self, study: Path) -> Path:
        """The CLI's output folder of `study` (its CSV, SVG, summary.md and results.json)."""
        study = Path(study)
        if study not in self.done:
            out = self.root / f"run{len(self.done)}"
            ok, stdout, err = self.cli("run", study, "--out", out)
            assert ok, err
            # The digest's last line is the study's report page, in its output folder.
            self.done[study] = Path(stdout.splitlines()[-1]).parent
        return self.done[study]


@pytest.fixture(scope="session")
def cli_run(cli, tmp_path_factory) -> StudyRuns:
    return StudyRuns(cli, tmp_path_factory.mktemp("cli_runs"))


def read_csv(path: Path) -> dict:
    """A CSV file written by kanedyn as {header: float64 array}, an empty cell as NaN.

    kanedyn prints every number with Rust's shortest round-trip form, so `float()` gives back the
    very f64 it wrote."""
    import csv

    import numpy as np

    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    header, body = rows[0], rows[1:]
    return {h: np.array([float(r[k]) if r[k] != "" else np.nan for r in body]) for k, h in enumerate(header)}


def same_bits(a, b) -> bool:
    """Equal bit for bit (NaN with NaN, -0.0 apart from 0.0), shapes included."""
    import numpy as np

    a, b = np.ascontiguousarray(a, dtype=np.float64), np.ascontiguousarray(b, dtype=np.float64)
    if a.shape != b.shape:
        return False
    # Every NaN kanedyn writes is an empty cell, read back as the canonical NaN: compare those as
    # NaN, everything else by its bits.
    nan = np.isnan(a) & np.isnan(b)
    return bool(np.array_equal(a.view(np.uint64)[~nan], b.view(np.uint64)[~nan]) and np.array_equal(np.isnan(a), np.isnan(b)))
