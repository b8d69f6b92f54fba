#!/usr/bin/env bash
# The format owners' readers for the log corpus test (tests/logs_corpus.rs): a venv in
# target/pyvenv-logs with pyulog (PX4) and pymavlink (ArduPilot), pinned. Their code stays in
# the venv, out of the repository. Exits non-zero (and leaves no half-made venv) when the venv
# cannot be made, e.g. without network; the test then skips with a message. CI runs this first
# (.ci/run), where the registries are reachable.
set -euo pipefail
cd "$(dirname "$0")/.."
venv="$(pwd)/target/pyvenv-logs"
if [ -x "$venv/bin/python" ] && "$venv/bin/python" -c "import pyulog, pymavlink" 2>/dev/null; then
    exit 0
fi
rm -rf "$venv"
mkdir -p target
if ! python3 -m venv "$venv" ||
    ! "$venv/bin/python" -m pip install --quiet --disable-pip-version-check --retries 1 \
        --timeout 20 "pyulog==1.3.0" "pymavlink==2.4.50"; then
    rm -rf "$venv"
    echo "logs-corpus-venv: could not make $venv with pyulog and pymavlink (no network?)" >&2
    exit 1
fi
echo "logs-corpus-venv: $venv ready"
