#!/usr/bin/env bash
# Renders the demo's report.html in headless Chromium and saves a screenshot under
# target/report-check/ (look at it; it is not committed). Installs Debian's chromium with
# apt-get when absent; skips with a message (exit 0) when it cannot.
# Checks: the report exists, has inline SVG plots and the summary table, the screenshot is a
# non-trivial PNG, and the first screen as Chromium renders it (--dump-dom) shows every
# channel's N, K, B and verdict as results.json has them (scripts/check_first_screen.py).
# Usage: scripts/check-report.sh [REPORT_DIR]
set -euo pipefail
cd "$(dirname "$0")/.."
out=target/report-check
mkdir -p "$out"
dir="${1:-$out/demo}"

browser=""
for b in chromium chromium-browser google-chrome; do
    if command -v "$b" >/dev/null 2>&1; then browser="$b"; break; fi
done
if [ -z "$browser" ]; then
    if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
        echo "check-report: installing chromium with apt-get"
        (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium fonts-dejavu-core) >/dev/null 2>&1 || true
        command -v chromium >/dev/null 2>&1 && browser=chromium
    fi
fi
if [ -z "$browser" ]; then
    echo "check-report: SKIPPED (no chromium and it could not be installed)"
    exit 0
fi

if [ -z "${1:-}" ]; then
    # the binary `cargo test --workspace` builds (a no-op right after it in CI; `cargo run`
    # would build another with other features, 2 min; no release build just for this)
    cargo test --workspace --no-run --quiet
    target/debug/imunoise demo --quiet --samples 262144 --bootstrap 10 --out "$dir" >/dev/null
fi
html="$(realpath "$dir")/report.html"
[ -s "$html" ] || { echo "check-report: FAILED: $html missing"; exit 1; }
n_svg=$(grep -o '<svg' "$html" | wc -l)
grep -q 'Summary: the values a filter needs' "$html" || { echo "check-report: FAILED: no summary table"; exit 1; }
[ "$n_svg" -ge 3 ] || { echo "check-report: FAILED: only $n_svg inline SVG plots"; exit 1; }

shot="$out/report.png"
rm -f "$shot"
"$browser" --headless --no-sandbox --disable-gpu --disable-quic --no-first-run \
    --disable-background-networking --disable-component-update --disable-sync --hide-scrollbars \
    --window-size=1400,1000 --screenshot="$PWD/$shot" "file://$html" >/dev/null 2>&1 || true
if [ ! -s "$shot" ]; then
    echo "check-report: FAILED: chromium produced no screenshot"
    exit 1
fi
size=$(stat -c %s "$shot")
[ "$size" -gt 50000 ] || { echo "check-report: FAILED: screenshot only $size bytes (blank page?)"; exit 1; }
# the first screen as the browser rendered it: N, K, B and the verdicts equal results.json
"$browser" --headless --no-sandbox --disable-gpu --disable-quic --no-first-run \
    --disable-background-networking --disable-component-update --disable-sync \
    --dump-dom "file://$html" > "$out/dom.html" 2>/dev/null || true
[ -s "$out/dom.html" ] || { echo "check-report: FAILED: chromium dumped no DOM"; exit 1; }
python3 scripts/check_first_screen.py "$out/dom.html" "$dir/results.json" || {
    echo "check-report: FAILED: the first screen disagrees with results.json"; exit 1; }
echo "check-report: OK: $n_svg inline SVG plots, summary table present; screenshot $shot ($size bytes)"
