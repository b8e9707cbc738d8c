#!/usr/bin/env bash
# Renders a report.html in a real browser (Debian's chromium, headless) into a PNG, to look
# at what a user sees (issue 22, item 8). Usage:
#   bash scripts/report-screenshot.sh OUT/report.html [PNG] [WIDTHxHEIGHT]
# Default PNG: /tmp/frontmesh-report.png; default size 1200x2000. Exit 2 without chromium
# (scripts/install-deps.sh installs it).
set -euo pipefail

report=${1:?usage: report-screenshot.sh REPORT.html [PNG] [WIDTHxHEIGHT]}
png=${2:-/tmp/frontmesh-report.png}
size=${3:-1200x2000}
browser=$(command -v chromium || command -v chromium-browser || true)
if [ -z "$browser" ]; then
  echo "report-screenshot: chromium not found (apt-get install chromium)" >&2
  exit 2
fi
[ -f "$report" ] || { echo "report-screenshot: '$report' does not exist" >&2; exit 2; }
url="file://$(realpath "$report")"
# --no-sandbox: the browser runs as root in CI; the page is our own local file.
"$browser" --headless --no-sandbox --disable-gpu --hide-scrollbars \
  --window-size="${size/x/,}" --screenshot="$png" "$url" >/dev/null 2>&1
[ -s "$png" ] || { echo "report-screenshot: no picture written" >&2; exit 1; }
echo "$png"
