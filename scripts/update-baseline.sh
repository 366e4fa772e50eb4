#!/usr/bin/env bash
# Regenerates the gate's baselines (reports/baseline/{marina,synthetic-paper}.json) with the
# tool itself (`icp-eval baseline`, which checks each run can be gated and leaves
# reports/baseline/tolerance.json as it is). Legitimate only when a change is *meant* to move
# the figures (a better algorithm, a corrected bug, a deliberate new default) and the new
# figures are explained in the commit message; never to make a red gate green.
#
#   scripts/update-baseline.sh [DATA_DIR]     # DATA_DIR: the marina data (else $ICP_DATA_DIR)
set -euo pipefail
cd "$(dirname "$0")/.."
icp_eval() { cargo run --release --locked -q -p eval -- "$@"; }
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
data=()
if [ $# -gt 0 ]; then data=(--data-dir "$1"); fi
icp_eval reproduce "${data[@]}" --no-plots --quiet --out "$tmp" > /dev/null
[ -f "$tmp/marina/summary.json" ] || { echo "the marina data was not found: give DATA_DIR or set ICP_DATA_DIR" >&2; exit 2; }
for ds in marina synthetic-paper; do
  icp_eval baseline --from "$tmp/$ds" --out "reports/baseline/$ds.json"
done
