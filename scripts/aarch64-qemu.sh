#!/usr/bin/env bash
# The workspace's tests on aarch64-unknown-linux-gnu under qemu-user, on an x86-64 Debian host
# (issue 29: aarch64 runs the NEON kernels at its one level, scalar; this shows that it builds
# and that its tests pass there). Not part of CI: under emulation the suite takes far longer
# than CI allows.
#
#   bash scripts/aarch64-qemu.sh                    # every crate but the Python package, every
#                                                   # test binary even after a failure
#   bash scripts/aarch64-qemu.sh -p imunoise-avar   # one crate (any `cargo test` arguments)
#
# Installs what it needs when absent: the rustup target (std for aarch64), Debian's cross gcc
# (the linker, and the C compiler of the zstd and lz4 crates) with the arm64 libc, and
# qemu-user. Test binaries run through qemu (cargo's runner); the `imunoise` binary that the
# CLI tests start runs through the kernel's binfmt_misc entry for aarch64, which this script
# registers when the host lets it (root, binfmt_misc mountable), else those tests fail to start
# it and the script says so first.
set -euo pipefail
cd "$(dirname "$0")/.."
target=aarch64-unknown-linux-gnu
sysroot=/usr/aarch64-linux-gnu

if ! rustup target list --installed | grep -q "^$target\$"; then
    rustup target add "$target"
fi
if ! command -v aarch64-linux-gnu-gcc > /dev/null || ! command -v qemu-aarch64 > /dev/null \
    || [ ! -e "$sysroot/lib/ld-linux-aarch64.so.1" ]; then
    sudo=""
    [ "$(id -u)" -eq 0 ] || sudo=sudo
    $sudo apt-get update -q
    $sudo apt-get install -y -q gcc-aarch64-linux-gnu libc6-dev-arm64-cross qemu-user qemu-user-binfmt
fi

# binfmt_misc: lets an aarch64 executable be started directly (the CLI tests spawn `imunoise`)
binfmt=/proc/sys/fs/binfmt_misc
if [ ! -e "$binfmt/qemu-aarch64" ]; then
    if [ "$(id -u)" -eq 0 ]; then
        [ -e "$binfmt/register" ] || mount -t binfmt_misc binfmt_misc "$binfmt" 2> /dev/null || true
        if [ -e "$binfmt/register" ] && [ -e /usr/lib/binfmt.d/qemu-aarch64.conf ]; then
            cat /usr/lib/binfmt.d/qemu-aarch64.conf > "$binfmt/register" || true
        fi
    fi
    [ -e "$binfmt/qemu-aarch64" ] \
        || echo "note: no binfmt_misc entry for aarch64: the tests that start the imunoise binary will fail" >&2
fi

export CARGO_TARGET_AARCH64_UNKNOWN_LINUX_GNU_LINKER=aarch64-linux-gnu-gcc
export CARGO_TARGET_AARCH64_UNKNOWN_LINUX_GNU_RUNNER="qemu-aarch64 -L $sysroot"
export CC_aarch64_unknown_linux_gnu=aarch64-linux-gnu-gcc
# the dynamic loader and libc of aarch64 for processes started through binfmt_misc
export QEMU_LD_PREFIX=$sysroot

if [ $# -eq 0 ]; then
    set -- --workspace --exclude imunoise-python --no-fail-fast
fi
cargo test --target "$target" "$@"
