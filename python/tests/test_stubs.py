"""The type stubs (kanedyn/_kanedyn.pyi) agree with the native module: names, signatures, defaults."""

import subprocess
import sys

import pytest

pytest.importorskip("mypy", reason="mypy is installed by run-tests.sh")


def test_stubs_match_the_native_module():
    p = subprocess.run(
        [sys.executable, "-m", "mypy.stubtest", "kanedyn._kanedyn"], capture_output=True, text=True
    )
    assert p.returncode == 0, p.stdout + p.stderr
