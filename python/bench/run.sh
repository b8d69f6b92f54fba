#!/usr/bin/env bash
# The Python bench: the venv and wheel of scripts/test-python.sh (built here if missing),
# allantools added to that venv under target/ (a peer tool for comparison only), then
# python/bench/bench.py with any arguments given.
set -euo pipefail
cd "$(dirname "$0")/../.."
root=$(pwd)
venv="$root/target/pyvenv"
if ! "$venv/bin/python" -c "import imunoise" 2>/dev/null; then
    IMUNOISE_SKIP_PYTEST=1 bash scripts/test-python.sh
fi
"$venv/bin/python" -c "import allantools" 2>/dev/null \
    || "$venv/bin/python" -m pip install --quiet allantools
IMUNOISE_ROOT="$root" "$venv/bin/python" python/bench/bench.py "$@"
