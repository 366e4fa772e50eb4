#!/usr/bin/env bash
# Checks our ATE/RPE and evo result zips against the real evo (PyPI `evo`) on a small run:
# evo_ape / evo_rpe on our TUM files must give summary.json's numbers, evo_res must read our
# zips (see scripts/check-evo.py). Exit 1 on any disagreement.
set -euo pipefail
cd "$(dirname "$0")/.."
for tool in evo_ape evo_rpe evo_res; do
  command -v "$tool" >/dev/null || { echo "check-evo: $tool not on PATH (pip install evo)" >&2; exit 2; }
done
export MPLBACKEND=Agg
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
cargo run --release --locked -q -p eval -- run --dataset synthetic:paper --scans 60 \
  --variants HD_ICP,PL_ICP --no-plots --reference-checks off --quiet --out "$tmp/run" > /dev/null
python3 scripts/check-evo.py "$tmp/run"
