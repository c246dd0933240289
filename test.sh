#!/usr/bin/env bash
# Every test of the repository: the Rust crate's (unit, integration, doc) and the Python
# package's (python/run-tests.sh makes its own virtual environment on first use).
set -euo pipefail
cd "$(dirname "$0")"
cargo test --release
python/run-tests.sh -q
