#!/usr/bin/env python3
"""Checks that our readers give the tools the very points icp-eval registers.

For an external estimator's rows of a run's `pairs.csv`, icp-eval writes `n_pairs` = every
return of the source scan and `mean_residual_m` = their mean distance, moved by the estimate,
to the nearest return of the reference scan (eval/README.md, "External estimates"). This
recomputes both from `scans.py`'s points and the row's own `tx_m, ty_m, theta_deg` (a k-d tree,
scipy): the counts must be equal and the mean distances agree to 1e-9 m on every pair. A
different no-return rule, bearing layout or scan order shows at once. Exits 1 on a mismatch.

    check_readers.py --dataset carmen:aces.log.gz --run reports/external/aces/global --variant O3D_ICP
"""

from __future__ import annotations

import argparse
import csv
import math
import sys
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

import scans

TOLERANCE_M = 1e-9


def main() -> int:
    p = argparse.ArgumentParser(description="check the readers against icp-eval's pairs.csv")
    p.add_argument("--dataset", required=True)
    p.add_argument("--run", required=True, type=Path, help="an icp-eval run directory")
    p.add_argument("--variant", required=True, help="an external estimator of that run")
    a = p.parse_args()
    data = scans.load(a.dataset)
    rows = [r for r in csv.DictReader(open(a.run / "pairs.csv")) if r["variant"] == a.variant]
    rows = [r for r in rows if r["tx_m"]]  # pairs the estimator has an estimate for
    if not rows:
        scans.fail(f"{a.run / 'pairs.csv'}: no estimated row of {a.variant}")
    bad, worst_m = 0, 0.0
    for r in rows:
        src, ref = data[int(r["source"])].points_m, data[int(r["reference"])].points_m
        theta = math.radians(float(r["theta_deg"]))
        c, s = math.cos(theta), math.sin(theta)
        moved = src @ np.array([[c, s], [-s, c]]) + (float(r["tx_m"]), float(r["ty_m"]))
        mean_m = float(np.mean(cKDTree(ref).query(moved)[0]))
        diff_m = abs(mean_m - float(r["mean_residual_m"]))
        worst_m = max(worst_m, diff_m)
        if int(r["n_pairs"]) != len(src) or diff_m > TOLERANCE_M:
            bad += 1
            print(f"pair {r['pair']}: icp-eval {r['n_pairs']} returns, mean {r['mean_residual_m']} m; "
                  f"ours {len(src)}, {mean_m!r} m")
    print(f"{len(rows)} pairs of {a.variant}: {bad} mismatched, largest mean-distance difference {worst_m:.2e} m")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
