#!/usr/bin/env bash
# Every test, exactly what CI runs (.ci/run): `cargo test --workspace`, then the Python package
# (wheel built with maturin into a venv under target/, then pytest).
set -euo pipefail
exec bash "$(dirname "$0")/../.ci/run"
