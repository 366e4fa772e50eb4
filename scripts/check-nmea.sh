#!/usr/bin/env bash
# Checks the live NMEA output of `--sequence causal` (`V+causal.nmea`) with an independent parser
# (PyPI `pynmea2`, scripts/check-nmea.py): checksums, CRLF, the scans' times and every figure
# against sequence.csv. Three runs cover the three kinds of scan: the synthetic harbour (every
# scan estimated, headings from the reference), marina's PL_ICP (steps no registration spans:
# empty fields; needs the marina data, ICP_DATA_DIR) and a CSV dataset without poses (headings
# relative: HDT and VTG's course empty). Exit 1 on any disagreement.
set -euo pipefail
cd "$(dirname "$0")/.."
python3 -c 'import pynmea2' 2>/dev/null || { echo "check-nmea: no pynmea2 (pip install pynmea2)" >&2; exit 2; }
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
icp_eval() { cargo run --release --locked -q -p eval -- "$@" > /dev/null; }
run() { icp_eval run --no-plots --quiet "$@"; }
run --dataset synthetic:paper --scans 60 --variants HD_GICP,PL_ICP --lags 3 \
  --sequence batch,causal --out "$tmp/synthetic"
python3 scripts/check-nmea.py "$tmp/synthetic"
run --dataset marina --variants PL_ICP --lags 3 --sequence causal --out "$tmp/marina"
python3 scripts/check-nmea.py "$tmp/marina"
# No poses.csv, and dataset.json without the reference kind that promises one.
icp_eval synth --scenario marina-like --scans 30 --out "$tmp/csv"
rm "$tmp/csv/poses.csv"
python3 - "$tmp/csv/dataset.json" <<'PY'
import json, sys
meta = json.load(open(sys.argv[1]))
meta.pop("reference_kind")
json.dump(meta, open(sys.argv[1], "w"))
PY
run --dataset "csv:$tmp/csv" --variants GICP --lags 2 --sequence causal --out "$tmp/unreferenced"
python3 scripts/check-nmea.py "$tmp/unreferenced"
