#!/usr/bin/env bash
# Builds the kanedyn Python package and the kanedyn CLI, then runs the Python tests.
#
#   python/run-tests.sh [pytest arguments…]
#
# On a clean machine it creates a virtual environment (python/.venv, or $KANEDYN_VENV) and
# installs maturin, numpy, pytest, mypy (for the stub check), jsonschema (for results.json),
# dask[distributed] (design studies on a cluster), nbclient, nbformat, ipykernel and matplotlib
# (the notebook example, executed by a test) and opentorsion (the OpenTorsion importer's tests) into it; later runs reuse it, and cargo rebuilds only what changed, so a second run takes
# seconds. Needs python3 (≥ 3.9, with venv) and cargo on PATH; $PYTHON picks another
# interpreter for a new environment.
#
# The package is a member of the root's workspace, built into its target folder (target/, or
# $CARGO_TARGET_DIR): the library and every crate below it resolve alike for both
# (python/tests/test_lockfile.py), so after `cargo test --release` (./test.sh) no dependency is
# compiled again, and the package and the CLI built below share one compilation of the library.
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(dirname "$here")"
export CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$root/target}"
venv="${KANEDYN_VENV:-$here/.venv}"
py="$venv/bin/python"

if [ ! -x "$py" ]; then
    echo "run-tests: creating $venv"
    "${PYTHON:-python3}" -m venv "$venv"
fi
# Installed once; checked by import so that a half-made environment is completed.
if ! "$py" -c "import maturin, numpy, pytest, mypy, jsonschema, distributed, nbclient, nbformat, ipykernel, matplotlib, opentorsion" 2>/dev/null; then
    echo "run-tests: installing maturin, numpy, pytest, mypy (for the stub check), jsonschema (for results.json)," \
        "dask[distributed] (design studies on a cluster), nbclient, nbformat, ipykernel, matplotlib (the notebook)," \
        "opentorsion (the importer's tests)"
    "$py" -m pip install --quiet --disable-pip-version-check "maturin>=1.9.4,<2" numpy pytest mypy jsonschema \
        "dask[distributed]" nbclient nbformat ipykernel matplotlib opentorsion
fi

# The package, in release mode (the bit-for-bit tests compare against the release CLI, and the
# overhead benchmark needs optimised code), installed into the environment in editable form.
echo "run-tests: building the kanedyn package"
VIRTUAL_ENV="$venv" "$venv/bin/maturin" develop --release --quiet --manifest-path "$here/Cargo.toml"

# The CLI the tests compare against, from the same source tree.
echo "run-tests: building the kanedyn CLI"
cli="$(cd "$root" && cargo build --release --bin kanedyn --quiet --message-format=json-render-diagnostics |
    "$py" -c 'import json, sys
for line in sys.stdin:
    m = json.loads(line)
    if m.get("reason") == "compiler-artifact" and m["target"]["name"] == "kanedyn" and m.get("executable"):
        print(m["executable"])')"
if [ -z "$cli" ]; then
    echo "run-tests: cargo reported no kanedyn executable" >&2
    exit 1
fi

cd "$here"
KANEDYN_CLI="$cli" exec "$py" -m pytest "$@"
