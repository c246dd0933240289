"""The package is built with the same dependency versions and features as the CLI.

`python/Cargo.lock` is its own (the crate is its own workspace); a dependency at another version
than the root's lock could change the numbers the bit-for-bit tests compare, so every package
both locks hold must be at the same version.
"""

import shutil
import subprocess

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


def resolved(manifest, package):
    """Each crate of `package`'s tree (no dev-dependencies) with its resolved features, as cargo
    resolves them for a build in that manifest's workspace."""
    p = subprocess.run(
        ["cargo", "tree", "--manifest-path", str(manifest), "-p", package, "-e", "no-dev", "-f", "{p} {f}", "--prefix", "none", "--locked"],
        capture_output=True,
        text=True,
        check=True,
    )
    # A crate reached twice is marked `(*)` the second time: the same crate, the same features.
    return {line.removesuffix(" (*)") for line in p.stdout.splitlines() if line.strip()}


@pytest.mark.skipif(shutil.which("cargo") is None, reason="needs cargo")
def test_the_library_resolves_alike_in_both_workspaces():
    """The library and each crate below it have the same features whether the root workspace or
    the package's builds them. Then their compiled units are the same, and run-tests.sh, which
    builds the package into the root's target folder, reuses the library that `cargo test
    --release` compiled instead of compiling it once more (issue 54, item 1). The root's
    Cargo.toml lists the features PyO3 and numpy add (matrixmultiply, once_cell, syn); a new
    dependency of the package that adds another makes this fail, naming it."""
    root = resolved(ROOT / "Cargo.toml", "kanedyn")
    py = resolved(ROOT / "python" / "Cargo.toml", "kanedyn")
    assert len(root) > 100, sorted(root)[:5]
    assert root == py, f"only in the root's resolution: {sorted(root - py)}; only in the package's: {sorted(py - root)}"
