#!/usr/bin/env bash
# Runs the reproduction (no figures) and gates it against the committed baselines.
# Exit 0: nothing regressed; 1: a metric got worse beyond reports/baseline/tolerance.json;
# 2: unusable input (missing data, incomparable runs).
set -euo pipefail
cd "$(dirname "$0")/.."
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
cargo run --release --locked -q -p eval -- reproduce --no-plots --quiet --out "$tmp" > /dev/null
status=0
for ds in marina synthetic-paper; do
  if [ ! -f "$tmp/$ds/summary.json" ]; then
    echo "gate: no $ds run (is ICP_DATA_DIR set?)" >&2
    status=2
    continue
  fi
  cargo run --release --locked -q -p eval -- gate --baseline "reports/baseline/$ds.json" --current "$tmp/$ds/summary.json" || status=$?
done
exit $status
