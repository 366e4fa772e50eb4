#!/usr/bin/env bash
# Downloads the paper's public marina data (Naus & Marchel 2019; the authors' repository
# lukisp2/ICP_DATA_MARINA) and checks every file against the sha256 sums pinned in
# datasets/marina.sha256. Nothing is kept unless all three match.
#
#   scripts/fetch-marina.sh [DEST]      # DEST defaults to datasets/marina
#
# Then run with `--data-dir DEST` or ICP_DATA_DIR=DEST (or leave it in datasets/marina,
# where icp-eval looks last). Set MARINA_BASE_URL to fetch from a mirror.
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
dest="${1:-$here/datasets/marina}"
base="${MARINA_BASE_URL:-https://github.com/lukisp2/ICP_DATA_MARINA/raw/HEAD}"
sums="$here/datasets/marina.sha256"
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
for f in angles.mat ranges.mat gps.mat; do
  echo "fetching $base/$f"
  curl -fsSL --retry 3 -o "$tmp/$f" "$base/$f"
done
(cd "$tmp" && sha256sum --check --strict "$sums")
mkdir -p "$dest"
mv "$tmp"/*.mat "$dest"/
echo "marina data in $dest (sha256 verified)"
