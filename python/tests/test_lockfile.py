"""The package is built with the same dependency versions and features as the CLI."""

import shutil
import subprocess

import pytest

from conftest import ROOT


def test_one_lock_file_for_the_library_and_the_package():
    """The package is a member of the root's workspace (python/Cargo.toml has no `[workspace]`):
    one Cargo.lock, so the library and the package are built with the same dependency versions,
    and a version that differed could not change the numbers the bit-for-bit tests compare."""
    assert not (ROOT / "python" / "Cargo.lock").exists()
    assert "[workspace]" not in (ROOT / "python" / "Cargo.toml").read_text()


def resolved(package):
    """Each crate of `package`'s tree (no dev-dependencies) with its resolved features, as cargo
    resolves them for a build of that package alone."""
    p = subprocess.run(
        ["cargo", "tree", "--manifest-path", str(ROOT / "Cargo.toml"), "-p", package, "-e", "no-dev", "-f", "{p} {f}", "--prefix", "none", "--locked"],
        capture_output=True,
        text=True,
        check=True,
    )
    # A crate reached twice is marked `(*)` the second time: the same crate, the same features.
    return {line.removesuffix(" (*)") for line in p.stdout.splitlines() if line.strip()}


@pytest.mark.skipif(shutil.which("cargo") is None, reason="needs cargo")
def test_the_library_resolves_alike_for_the_crate_and_the_package():
    """The library and each crate below it have the same features whether the root crate or the
    package is built (cargo unifies features only over the packages a command builds). Then
    their compiled units are the same, and run-tests.sh reuses the dependencies `cargo test
    --release` compiled and one compilation of the library for the package and the CLI (issue
    54, item 1). The root's
    Cargo.toml lists the features PyO3 and numpy add (matrixmultiply, once_cell, syn); a new
    dependency of the package that adds another makes this fail, naming it."""
    library = resolved("kanedyn")
    package = resolved("kanedyn-python")
    assert len(library) > 100, sorted(library)[:5]
    # A crate whose features differ is a different line: missing from the package's tree.
    differ = sorted(library - package)
    assert not differ, f"resolved differently when the package is built: {differ}"
