#!/usr/bin/env bash
# The Python package's tests: a venv in target/pyvenv with maturin, numpy, pytest,
# dask[distributed] and matplotlib; the abi3 wheel built by maturin in the dev profile (our
# code at opt-level 2, dependencies at 3, no LTO) into target/, sharing the workspace's
# compiled dependencies; installed; then pytest on python/tests. Prints the time of each
# step. pytest's exit code 5 ("no tests collected") counts as a failure.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)
venv="$root/target/pyvenv"
t0=$(date +%s)
step() { echo "test-python: $1 ($(( $(date +%s) - t0 )) s so far)"; }

if [ ! -x "$venv/bin/python" ]; then
    python3 -m venv "$venv"
fi
"$venv/bin/python" -m pip install --quiet --upgrade pip
"$venv/bin/python" -m pip install --quiet "maturin>=1.9,<2" numpy pytest \
    "dask[distributed]" matplotlib
step "venv ready"

# the imunoise binary for the tests that compare with the command's JSON: the one
# `cargo test --workspace` builds (a no-op right after it; `cargo build` would rebuild with
# other features)
cargo test --workspace --no-run --quiet
step "imunoise binary ready"

rm -rf "$root/target/wheels"
(cd python && CARGO_TARGET_DIR="$root/target" "$venv/bin/maturin" build \
    --profile dev --interpreter "$venv/bin/python" --out "$root/target/wheels")
wheel=$(ls "$root"/target/wheels/imunoise-*.whl)
"$venv/bin/python" -m pip install --quiet --force-reinstall --no-deps "$wheel"
step "wheel built and installed: $(basename "$wheel")"

set +e
IMUNOISE_BIN="$root/target/debug/imunoise" IMUNOISE_ROOT="$root" \
    MPLBACKEND=Agg "$venv/bin/python" -m pytest -q -p no:cacheprovider python/tests
rc=$?
set -e
step "pytest finished (exit $rc)"
if [ "$rc" -eq 5 ]; then
    echo "test-python: pytest collected no tests" >&2
    exit 1
fi
exit "$rc"
