#!/usr/bin/env bash
# Regenerates the committed reproduction reports (reports/reproduction/{marina,synthetic-paper})
# with the tool itself. `icp-eval reproduce` writes to results/ by default, so running the
# README's main command never rewrites committed files. Regenerating them is legitimate when
# the tool's output changed on purpose (a documented fix, a new column or figure); the commit
# says what moved and why. Figures that move unexplained are a bug, not something to commit.
#
#   scripts/update-reproduction.sh [DATA_DIR]     # DATA_DIR: the marina data (else $ICP_DATA_DIR)
set -euo pipefail
cd "$(dirname "$0")/.."
data=()
if [ $# -gt 0 ]; then data=(--data-dir "$1"); fi
cargo run --release --locked -q -p eval -- reproduce "${data[@]}" --quiet --out reports/reproduction > /dev/null
[ -f reports/reproduction/marina/summary.json ] || { echo "the marina data was not found: give DATA_DIR or set ICP_DATA_DIR" >&2; exit 2; }
echo "reproduction reports updated: reports/reproduction/marina, reports/reproduction/synthetic-paper"
