#!/usr/bin/env bash
# Renders the demo's report.html in headless Chromium and saves a screenshot under
# target/report-check/ (look at it; it is not committed). Installs Debian's chromium with
# apt-get when absent; skips with a message (exit 0) when it cannot.
# Checks: the report exists, has inline SVG plots and the noise table, and the screenshot
# is a non-trivial PNG. Usage: scripts/check-report.sh [REPORT_DIR]
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
    cargo run --release --quiet -- demo --quiet --samples 262144 --bootstrap 10 --out "$dir" >/dev/null
fi
html="$dir/report.html"
[ -s "$html" ] || { echo "check-report: FAILED: $html missing"; exit 1; }
n_svg=$(grep -o '<svg' "$html" | wc -l)
grep -q 'Summary: the values a filter needs' "$html" || { echo "check-report: FAILED: no summary table"; exit 1; }
[ "$n_svg" -ge 3 ] || { echo "check-report: FAILED: only $n_svg inline SVG plots"; exit 1; }

shot="$out/report.png"
rm -f "$shot"
"$browser" --headless --no-sandbox --disable-gpu --hide-scrollbars \
    --window-size=1400,2400 --screenshot="$PWD/$shot" "file://$PWD/$html" >/dev/null 2>&1 || true
if [ ! -s "$shot" ]; then
    echo "check-report: FAILED: chromium produced no screenshot"
    exit 1
fi
size=$(stat -c %s "$shot")
[ "$size" -gt 50000 ] || { echo "check-report: FAILED: screenshot only $size bytes (blank page?)"; exit 1; }
echo "check-report: OK: $n_svg inline SVG plots, noise table present; screenshot $shot ($size bytes)"
