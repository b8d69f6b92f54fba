#!/usr/bin/env bash
# The Python bench: a venv of its own under target/pyvenv-bench with numpy, dask[distributed]
# and allantools (a peer tool, for comparison only), the wheel built by maturin in the release
# profile (what `pip install ./python` builds; the tests use the quicker dev profile) and
# installed there, then python/bench/bench.py with any arguments given.
set -euo pipefail
cd "$(dirname "$0")/../.."
root=$(pwd)
venv="$root/target/pyvenv-bench"
if [ ! -x "$venv/bin/python" ]; then
    python3 -m venv "$venv"
fi
"$venv/bin/python" -m pip install --quiet "maturin>=1.9,<2" numpy "dask[distributed]" allantools
rm -rf "$root/target/wheels-bench"
(cd python && CARGO_TARGET_DIR="$root/target" "$venv/bin/maturin" build --release \
    --interpreter "$venv/bin/python" --out "$root/target/wheels-bench")
"$venv/bin/python" -m pip install --quiet --force-reinstall --no-deps \
    "$root"/target/wheels-bench/imunoise-*.whl
IMUNOISE_ROOT="$root" "$venv/bin/python" python/bench/bench.py "$@"
