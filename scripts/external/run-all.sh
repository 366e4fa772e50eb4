#!/usr/bin/env bash
# Redoes reports/external/: installs the pinned tools when missing, checks their frames on a
# known motion, runs every tool on aces, the synthetic harbour and marina, then icp-eval compare
# with the built-in variants and the tools' estimates (--init identity and global), checks the
# readers against icp-eval's pairs.csv, and writes the tables. Run from anywhere; it works from the repository root so the paths it records are
# relative. Not called from .ci/run (heavy installs).
#
#   scripts/external/run-all.sh
#   ACES=path/aces.log.gz ICP_DATA_DIR=dir scripts/external/run-all.sh
set -euo pipefail
cd "$(dirname "$0")/../.."
S=scripts/external
OUT=reports/external
ACES=${ACES:-/work/shared/datasets/carmen/aces.log.gz}
MARINA_DIR=${ICP_DATA_DIR:-/work/shared/datasets}/marina
VARIANTS=HD_ICP,PL_ICP,HD_PL_ICP,GICP,HD_GICP
PY=${PYTHON:-python3}

# 1. The pinned packages (pip only when one is missing or of another version).
if ! "$PY" - "$S/requirements.txt" <<'EOF'; then
import sys
from importlib.metadata import version, PackageNotFoundError
for line in open(sys.argv[1]):
    line = line.split("#")[0].strip()
    if line:
        name, want = line.split("==")
        try:
            assert version(name) == want
        except (PackageNotFoundError, AssertionError):
            sys.exit(1)
EOF
    "$PY" -m pip install -r "$S/requirements.txt"
fi
# Open3D's wheel links libusb-1.0 (Debian: libusb-1.0-0), absent from slim images.
if ! "$PY" -c "import open3d" 2>/dev/null; then
    if command -v apt-get >/dev/null && [ "$(id -u)" = 0 ]; then
        apt-get update -q && apt-get install -y -q libusb-1.0-0
    fi
    "$PY" -c "import open3d"
fi

# 2. icp-eval, and the synthetic harbour as files for the tools (the same scans as
#    --dataset synthetic:paper: same generator, same seed).
cargo build --release -p eval
EVAL=target/release/icp-eval
SYNTH=target/external/synthetic-paper
"$EVAL" synth --scenario paper --out "$SYNTH"

# 3. The frame check: every tool on scans with a known motion.
"$PY" "$S/check_frames.py"

# 4. Each tool on one dataset: estimates/NAME.csv|tum and tool-stats/NAME.json under $2.
tools() {
    local ds=$1 dir=$2
    mkdir -p "$dir/estimates" "$dir/tool-stats"
    local -a runs=(
        "SG_GICP run_small_gicp.py --method GICP"
        "SG_ICP run_small_gicp.py --method ICP"
        "SG_GICP_X run_small_gicp.py --method GICP --extrude-m 0.5"
        "SG_PLANE_X run_small_gicp.py --method PLANE_ICP --extrude-m 0.5"
        "O3D_ICP run_open3d.py"
    )
    local run name script args
    for run in "${runs[@]}"; do
        read -r name script args <<<"$run"
        # shellcheck disable=SC2086  # args are words
        "$PY" "$S/$script" $args --dataset "$ds" --out "$dir/estimates/$name.csv" \
            --stats "$dir/tool-stats/$name.json" >/dev/null
    done
    "$PY" "$S/run_kiss_icp.py" --dataset "$ds" --out "$dir/estimates/KISS_ICP.tum" \
        --stats "$dir/tool-stats/KISS_ICP.json" >/dev/null
}

# 5. icp-eval compare with every estimate of $2 (relative paths), one run per --init.
compare() {
    local ds=$1 dir=$2 init f n
    local -a est=()
    for f in "$dir"/estimates/*; do
        n=$(basename "$f")
        est+=(--estimates "${n%.*}=$f")
    done
    for init in identity global; do
        rm -rf "${dir:?}/$init"
        "$EVAL" compare --dataset "$ds" --variants "$VARIANTS" --init "$init" "${est[@]}" \
            --threads 1 --no-plots --quiet --out "$dir/$init"
    done
}

# 6. One dataset: the tools, the two runs, and the check that our readers gave the tools
#    icp-eval's own points (its pairs.csv recomputed from them). $1: the folder under $OUT,
#    $2: the tools' dataset, $3: icp-eval's, $4: a file it needs (skipped when absent).
datasets=()
dataset() {
    local name=$1 tools_ds=$2 eval_ds=$3 needs=$4
    if [ ! -e "$needs" ]; then
        echo "skipping $name: no $needs (see the variables at the top)" >&2
        return
    fi
    tools "$tools_ds" "$OUT/$name"
    compare "$eval_ds" "$OUT/$name"
    "$PY" "$S/check_readers.py" --dataset "$tools_ds" --run "$OUT/$name/global" --variant SG_GICP
    datasets+=("$OUT/$name")
}
dataset aces "carmen:$ACES" "carmen:$ACES" "$ACES"
dataset synthetic-paper "csv:$SYNTH" synthetic:paper "$SYNTH/scans.csv"
dataset marina "marina:$MARINA_DIR" "marina?data_dir=$MARINA_DIR" "$MARINA_DIR/ranges.mat"

# 7. The tables.
"$PY" "$S/tables.py" "${datasets[@]}" >"$OUT/tables.md"
echo "wrote $OUT/tables.md"
