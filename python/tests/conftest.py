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
