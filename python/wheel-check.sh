#!/usr/bin/env bash
# Builds the kanedyn wheel as a release would ship it, installs it into a fresh virtual environment
# with no Rust toolchain on PATH, and runs the quick start of python/README.md with it:
#
#   python/wheel-check.sh                        # the manylinux2014 wheel
#   KANEDYN_WHEEL_TAG=host python/wheel-check.sh  # the host's tag, reusing run-tests.sh's build
#
# Fails if the wheel is not tagged manylinux2014 (or, with the host's tag, manylinux at all), if rustc or cargo can be found while installing,
# if pip would build anything from source, or if install + quick start take more than 30 s. The
# wheel is left in python/target/wheel/dist/.
#
# The tag: manylinux2014 (glibc ≥ 2.17), linked by zig against an old glibc (maturin --zig, zig from
# the `ziglang` package on PyPI). The host's own toolchain gives manylinux_2_35 here (Debian 12,
# glibc 2.36), which does not install on RHEL/Rocky 8 and 9, Ubuntu 20.04 or Amazon Linux 2023;
# manylinux2014 installs on all of them, as the wheels on PyPI do. It costs one more compilation of
# the crate (zig as linker changes every unit's fingerprint): measured on this 2-core VM, a cold
# build of about 5 min next to the host build's 0.7 s (reusing run-tests.sh's build). To keep both
# builds warm on a developer's machine, this one has its own target folder, python/target/wheel/.
# KANEDYN_WHEEL_TAG=host builds with the host's toolchain in the root's target folder instead, as
# python/run-tests.sh does (seconds after it): the same check of the install, for a wheel that
# only installs on glibc as new as the host's.
#
# Needs python3 (≥ 3.9, with venv) and cargo; maturin and ziglang are installed into a build
# environment of their own (python/target/wheel/build-venv), so the test environment is untouched.
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(dirname "$here")"
work="$here/target/wheel"
build_venv="$work/build-venv"
dist="$work/dist"
tag="${KANEDYN_WHEEL_TAG:-manylinux2014}"
case "$tag" in
    manylinux2014) zig=1 ;;
    host) zig=0 ;;
    *) echo "wheel-check: KANEDYN_WHEEL_TAG is manylinux2014 (default) or host, not $tag" >&2; exit 1 ;;
esac
mkdir -p "$work"
# Seconds since a start time taken from $EPOCHREALTIME, with one decimal (awk: no bc needed).
since() { awk -v a="$1" -v b="$EPOCHREALTIME" 'BEGIN { printf "%.1f", b - a }'; }

if [ ! -x "$build_venv/bin/python" ]; then
    "${PYTHON:-python3}" -m venv "$build_venv"
fi
needs="maturin"
[ "$zig" = 1 ] && needs="maturin, ziglang"
if ! "$build_venv/bin/python" -c "import $needs" 2>/dev/null; then
    echo "wheel-check: installing $needs into $build_venv"
    # shellcheck disable=SC2046 # ziglang only when zig links
    "$build_venv/bin/python" -m pip install --quiet --disable-pip-version-check "maturin>=1.9.4,<2" \
        $([ "$zig" = 1 ] && echo ziglang)
fi

rm -rf "$dist"
start=$EPOCHREALTIME
if [ "$zig" = 1 ]; then
    echo "wheel-check: building the manylinux2014 wheel (maturin --zig)"
    # maturin finds zig as `python -m ziglang` of the python on PATH: the build environment's.
    PATH="$build_venv/bin:$PATH" CARGO_TARGET_DIR="$work/cargo" "$build_venv/bin/maturin" build --release --quiet \
        --manifest-path "$here/Cargo.toml" --zig --compatibility manylinux2014 --out "$dist"
else
    echo "wheel-check: building the wheel with the host's toolchain (its manylinux tag)"
    CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$root/target}" "$build_venv/bin/maturin" build --release --quiet \
        --manifest-path "$here/Cargo.toml" --out "$dist"
fi
build_s=$(since "$start")
wheels=("$dist"/*.whl)
if [ "${#wheels[@]}" -ne 1 ] || [ ! -f "${wheels[0]}" ]; then
    echo "wheel-check: expected one wheel in $dist, found: ${wheels[*]}" >&2
    exit 1
fi
wheel="${wheels[0]}"
want="kanedyn-*-cp39-abi3-manylinux2014_x86_64*.whl"
[ "$zig" = 1 ] || want="kanedyn-*-cp39-abi3-manylinux_*.whl"
# shellcheck disable=SC2053 # a glob on purpose
if [[ "$(basename "$wheel")" != $want ]]; then
    echo "wheel-check: $(basename "$wheel") is not a $want wheel" >&2
    exit 1
fi
# The extras the README documents are in the wheel's metadata.
"$build_venv/bin/python" - "$wheel" <<'EOF'
import sys, zipfile
with zipfile.ZipFile(sys.argv[1]) as z:
    meta = next(n for n in z.namelist() if n.endswith(".dist-info/METADATA"))
    lines = z.read(meta).decode().splitlines()
extras = {l.split(":", 1)[1].strip() for l in lines if l.startswith("Provides-Extra:")}
missing = {"dask", "notebook"} - extras
if missing:
    sys.exit(f"wheel-check: the wheel's metadata lacks the extras {sorted(missing)} (has {sorted(extras)})")
EOF
printf 'wheel-check: built %s in %s s\n' "$(basename "$wheel")" "$build_s"

# PATH without any folder holding rustc or cargo (~/.cargo/bin and the like), for what follows.
bare=""
IFS=':' read -ra dirs <<<"$PATH"
for d in "${dirs[@]}"; do
    if [ -n "$d" ] && [ ! -e "$d/rustc" ] && [ ! -e "$d/cargo" ]; then
        bare="${bare:+$bare:}$d"
    fi
done
if PATH="$bare" command -v rustc >/dev/null 2>&1 || PATH="$bare" command -v cargo >/dev/null 2>&1; then
    echo "wheel-check: rustc or cargo still on the stripped PATH ($bare)" >&2
    exit 1
fi

fresh="$(mktemp -d "${TMPDIR:-/tmp}/kanedyn-wheel-check.XXXXXX")"
trap 'rm -rf "$fresh"' EXIT
# The quick start is the first ```python block after "## Quick start" in python/README.md.
"$build_venv/bin/python" - "$here/README.md" "$fresh/quick_start.py" <<'EOF'
import re, sys
text = open(sys.argv[1], encoding="utf-8").read()
m = re.search(r"^## Quick start\n.*?^```python\n(.*?)^```", text, re.S | re.M)
if not m:
    sys.exit("wheel-check: no ```python block under '## Quick start' in python/README.md")
open(sys.argv[2], "w", encoding="utf-8").write(m.group(1))
EOF

env -u CARGO_HOME -u RUSTUP_HOME -u RUSTC PATH="$bare" python3 -m venv "$fresh/venv"
start=$EPOCHREALTIME
# --only-binary: pip may not fall back to building anything from source (numpy comes as a wheel).
env -u CARGO_HOME -u RUSTUP_HOME -u RUSTC PATH="$bare" "$fresh/venv/bin/python" -m pip install --quiet \
    --disable-pip-version-check --only-binary=:all: "$wheel"
install_s=$(since "$start")
# From the repository root, as the README's paths are written.
start=$EPOCHREALTIME
(cd "$root" && env -u CARGO_HOME -u RUSTUP_HOME -u RUSTC PATH="$bare" "$fresh/venv/bin/python" "$fresh/quick_start.py")
quick_s=$(since "$start")
total_s=$(awk -v a="$install_s" -v b="$quick_s" 'BEGIN { printf "%.1f", a + b }')
printf 'wheel-check: install %s s + quick start %s s = %s s (limit 30 s), no rustc or cargo on PATH\n' \
    "$install_s" "$quick_s" "$total_s"
if awk -v t="$total_s" 'BEGIN { exit !(t > 30) }'; then
    echo "wheel-check: install + quick start took $total_s s, more than 30 s" >&2
    exit 1
fi
