#!/usr/bin/env bash
# Every test: the Rust workspace, then the Python package (wheel built with maturin into a
# venv under target/, then pytest). CI runs exactly this (.ci/run); so does the README.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo test --workspace
bash scripts/test-python.sh
