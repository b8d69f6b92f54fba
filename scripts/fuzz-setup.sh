#!/usr/bin/env bash
# Tools for `cargo xtask fuzz --coverage` (coverage-guided fuzzing of the readers with
# libFuzzer, see fuzz/ and docs/reliability.md): cargo-fuzz, installed into target/tools from
# crates.io (pinned, --locked), and the nightly toolchain's llvm-tools (llvm-profdata and
# llvm-cov, for the line coverage of `cargo fuzz coverage`). Idempotent: skips what is there.
# Exits non-zero when cargo-fuzz cannot be had (no nightly, no network); llvm-tools are
# optional (the report then gives libFuzzer's cov/ft figures only).
set -euo pipefail
cd "$(dirname "$0")/.."
root="$(pwd)/target/tools"
version="0.13.2"
if ! rustup toolchain list | grep -q '^nightly'; then
    echo "fuzz-setup: the nightly toolchain is needed (rustup toolchain install nightly)" >&2
    exit 1
fi
if [ -x "$root/bin/cargo-fuzz" ] && "$root/bin/cargo-fuzz" --version | grep -q "$version"; then
    echo "fuzz-setup: cargo-fuzz $version present in $root"
else
    cargo install cargo-fuzz --version "$version" --locked --root "$root"
fi
if ls "$(rustc +nightly --print sysroot)"/lib/rustlib/*/bin/llvm-cov >/dev/null 2>&1; then
    echo "fuzz-setup: llvm-tools present"
elif rustup component add llvm-tools-preview --toolchain nightly; then
    echo "fuzz-setup: llvm-tools installed"
else
    echo "fuzz-setup: llvm-tools-preview could not be added: line coverage will be skipped" >&2
fi
