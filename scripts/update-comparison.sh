#!/usr/bin/env bash
# Regenerates the committed comparison reports (reports/comparison/{marina,synthetic-paper}):
# the paper's four variants, the worked example IR_ICP, the Tukey variant of configs/, and the
# point-to-line and plane-to-plane variants, compared pair by pair. Legitimate when a change is
# meant to move the figures, with the commit saying by how much and why.
#
#   scripts/update-comparison.sh [DATA_DIR]     # DATA_DIR: the marina data (else $ICP_DATA_DIR)
set -euo pipefail
cd "$(dirname "$0")/.."
data=()
if [ $# -gt 0 ]; then data=(--data-dir "$1"); fi
variants=K_ICP,H_ICP,HM_ICP,HD_ICP,IR_ICP,PL_ICP,HD_PL_ICP,GICP,HD_GICP
cargo build --release --locked -q -p eval
run() { ./target/release/icp-eval "$@"; }
# The directories hold nothing but this script's output (written before output manifests
# existed): start them afresh, so no stale file survives.
rm -rf reports/comparison/marina reports/comparison/synthetic-paper
run compare --dataset marina "${data[@]}" --variants "$variants" \
  --config configs/variants/tukey_hd_icp.toml --sweep sigma_alpha_deg=0.1,0.25,0.5,1,2 \
  --quiet --out reports/comparison/marina > /dev/null
run compare --dataset synthetic:paper --variants "$variants" \
  --quiet --out reports/comparison/synthetic-paper > /dev/null
echo "comparison reports updated: reports/comparison/marina, reports/comparison/synthetic-paper"
