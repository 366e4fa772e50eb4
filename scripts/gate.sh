#!/usr/bin/env bash
# Runs the reproduction (no figures) and gates it against the committed baselines, each with
# the reports/baseline/tolerance.json beside it (`icp-eval gate`'s default).
# Exit 0: nothing regressed; 1: a metric got worse beyond the tolerances, or a variant of a
# baseline was not run; 2: unusable input (missing data, incomparable runs). Of two datasets'
# exit codes, the larger.
set -euo pipefail
cd "$(dirname "$0")/.."
icp_eval() { cargo run --release --locked -q -p eval -- "$@"; }
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
icp_eval reproduce --no-plots --quiet --out "$tmp" > /dev/null
status=0
for ds in marina synthetic-paper; do
  if [ ! -f "$tmp/$ds/summary.json" ]; then
    echo "gate: no $ds run (is ICP_DATA_DIR set?)" >&2
    status=2
    continue
  fi
  rc=0
  icp_eval gate --baseline "reports/baseline/$ds.json" --current "$tmp/$ds/summary.json" || rc=$?
  if [ "$rc" -gt "$status" ]; then status=$rc; fi
done
exit $status
