"""The package is built with the same dependency versions as the CLI.

`python/Cargo.lock` is its own (the crate is its own workspace); a dependency at another version
than the root's lock could change the numbers the bit-for-bit tests compare, so every package
both locks hold must be at the same version.
"""

import pytest

from conftest import ROOT

tomllib = pytest.importorskip("tomllib")


def versions(path):
    """Package name → the set of its locked versions (a name may be locked at two versions)."""
    with open(path, "rb") as f:
        out = {}
        for p in tomllib.load(f)["package"]:
            out.setdefault(p["name"], set()).add(p["version"])
        return out


def test_shared_dependencies_have_the_root_versions():
    root, py = versions(ROOT / "Cargo.lock"), versions(ROOT / "python" / "Cargo.lock")
    shared = sorted(set(root) & set(py))
    assert len(shared) > 50  # nalgebra, parry2d-f64, … (not a vacuous comparison)
    differ = {name: (sorted(root[name]), sorted(py[name])) for name in shared if not py[name] <= root[name]}
    assert not differ, f"python/Cargo.lock has versions the root's Cargo.lock has not (root, python): {differ}"
