#!/usr/bin/env bash
# Golden comparison of two imunoise binaries: every result a user takes away must be the same
# byte for byte (a refactor must not change a digit). Runs both binaries on the same inputs and
# compares results.json, demo.json, avar.csv, `avar --format json`, imu.yaml and every exported
# config file.
#
#   bash scripts/golden.sh BIN_BEFORE BIN_AFTER [WORKDIR]
#
# Inputs: the demo (built in), a simulated 3-channel WN + RW + AR1 record (written once by
# BIN_BEFORE), the ADIS16405 imu1 recording (../shared/data, skipped with a line when absent)
# and the 3-hour MCAP of `cargo bench --bench logs` (target/bench-data, skipped when absent).
# Both binaries run at the same SIMD level (IMUNOISE_SIMD, if set, applies to both).
# Exit 0 when every file is identical, 1 with the list of those that differ.
set -euo pipefail
before=$(realpath "$1")
after=$(realpath "$2")
root=$(cd "$(dirname "$0")/.." && pwd)
work=${3:-$root/target/golden}
rm -rf "$work"
mkdir -p "$work/in"

"$before" simulate -q -m "WN(sigma2=1e-4)+RW(gamma2=1e-10)+AR1(phi=0.999,sigma2=1e-8)" \
    -n 1000000 --rate 100 --channels 3 --seed 7 -o "$work/in/sim.csv"
adis="$root/../shared/data/adis16405/adis16405_imu1.csv.gz"
mcap=$(ls "$root"/target/bench-data/imu_*_1khz.mcap 2>/dev/null | head -n 1 || true)

run() {
    local bin=$1 out=$2
    mkdir -p "$out"
    "$bin" demo -q --out "$out/demo" >/dev/null
    "$bin" avar "$work/in/sim.csv" --rate 100 --format json >"$out/sim-avar.json"
    "$bin" analyze "$work/in/sim.csv" --rate 100 -q --export all --out "$out/sim" >/dev/null
    if [ -f "$adis" ]; then
        "$bin" avar "$adis" --rate 100 --format json >"$out/adis-avar.json"
        "$bin" analyze "$adis" --rate 100 -q --export all --out "$out/adis" >/dev/null
    fi
    if [ -n "$mcap" ]; then
        "$bin" analyze "$mcap" -q --export all --out "$out/mcap" >/dev/null
    fi
}

[ -f "$adis" ] || echo "skipping the ADIS16405 recording: $adis not found"
[ -n "$mcap" ] || echo "skipping the 3-hour MCAP: run 'cargo bench --bench logs' to write it"
run "$before" "$work/before"
run "$after" "$work/after"

cd "$work/before"
differ=0
count=0
while IFS= read -r f; do
    count=$((count + 1))
    if ! cmp -s "$f" "$work/after/$f"; then
        echo "DIFFERS: $f"
        differ=$((differ + 1))
    fi
done < <(find . -type f \( -name '*.json' -o -name '*.yaml' -o -name '*.yml' -o -name 'avar.csv' \
    -o -name '*.txt' -o -name '*.cfg' -o -name '*.toml' \) | sort)
# a file only one side wrote
extra=$(cd "$work/after" && find . -type f | sort | comm -13 <(cd "$work/before" && find . -type f | sort) -)
if [ -n "$extra" ]; then
    echo "only after: $extra"
    differ=$((differ + 1))
fi
echo "$count files compared, $differ differ"
[ "$differ" -eq 0 ]
