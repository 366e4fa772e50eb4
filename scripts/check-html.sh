#!/usr/bin/env bash
# Opens report.html of a run, a compare with a sweep and a basin in a real browser (headless
# Chromium, offline: the network is switched off for it) and checks what a reader would see:
# the page loads, its inline script ran (it marks <body data-sort-ready="N"> with the number
# of sortable tables), every figure is there as inline SVG, a screenshot is drawn, and a click
# on a column header sorts the table. Exit 1 on any failure.
set -euo pipefail
cd "$(dirname "$0")/.."
browser="$(command -v chromium || command -v chromium-browser || true)"
[ -n "$browser" ] || { echo "check-html: no chromium on PATH (Debian: apt-get install chromium)" >&2; exit 2; }
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
run() { cargo run --release --locked -q -p eval -- "$@" --quiet > /dev/null; }
run run --dataset synthetic:paper --scans 40 --variants K_ICP,H_ICP,HM_ICP,HD_ICP,IR_ICP,PL_ICP,HD_PL_ICP,GICP,HD_GICP --out "$tmp/run"
run compare --dataset synthetic:paper --scans 30 --variants K_ICP,HD_ICP --sweep sigma_alpha_deg=0.25,1 --out "$tmp/compare"
run basin --dataset synthetic:paper --scans 10 --variants HD_ICP,PL_ICP --perturbations 3 --out "$tmp/basin"
chrome=("$browser" --headless --no-sandbox --disable-gpu --hide-scrollbars --no-first-run
  --proxy-server=127.0.0.1:9 --proxy-bypass-list='<-loopback>' --user-data-dir="$tmp/profile")
fail=0
for dir in run compare basin; do
  page="file://$tmp/$dir/report.html"
  "${chrome[@]}" --virtual-time-budget=5000 --dump-dom "$page" > "$tmp/$dir.dom" 2> "$tmp/$dir.err" || true
  "${chrome[@]}" --window-size=1280,2400 --screenshot="$tmp/$dir.png" "$page" > /dev/null 2>&1 || true
  python3 scripts/check-html.py "$tmp/$dir" "$tmp/$dir.dom" "$tmp/$dir.png" || fail=1
done
# A click sorts: the test page clicks the first column of the first sortable table twice and
# writes the first cell before and after into the DOM.
python3 - "$tmp/run/report.html" "$tmp/run/click.html" <<'PY'
import sys
page = open(sys.argv[1], encoding="utf-8").read()
probe = """<script>
const t = document.querySelector('#results table.sortable');
const first = () => t.tBodies[0].rows[0].cells[0].textContent;
const before = first();
const h = t.querySelector('thead th');
h.click(); const asc = first(); h.click(); const desc = first();
document.body.dataset.sortProbe = [before, asc, desc].join('|');
</script></body>"""
open(sys.argv[2], "w", encoding="utf-8").write(page.replace("</body>", probe))
PY
"${chrome[@]}" --virtual-time-budget=5000 --dump-dom "file://$tmp/run/click.html" > "$tmp/click.dom" 2>/dev/null || true
probe="$(grep -o 'data-sort-probe="[^"]*"' "$tmp/click.dom" || true)"
# The first column holds the variants' names in run order (K_ICP first): ascending puts GICP,
# the alphabetically first of the nine, on top, descending PL_ICP, the last.
case "$probe" in
  'data-sort-probe="K_ICP|GICP|PL_ICP"') echo "check-html: a click sorts the table ($probe)";;
  *) echo "check-html: sorting by a click failed: ${probe:-no probe in the DOM}" >&2; fail=1;;
esac
exit $fail
