"""The pairwise tools' common loop: every consecutive pair k → k+1 registered from the identity,
`align(target = scan k+1, source = scan k)`, the result `T_target_source` = our `t_ref_src`
written as the per-pair CSV icp-eval reads (`--estimates NAME=FILE`).

A scan with fewer than `MIN_RETURNS` returns (the last marina scan has none) is not handed to
the tools (small_gicp crashes on an empty cloud): its pairs get no estimate, which icp-eval
counts as failures of the tool.

Each tool's script gives an `align(target_m, source_m) -> (4 × 4 T_target_source, converged)`
on N × 2 points; this loop times it (wall clock, one thread) and says what it saw.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from typing import Callable

import numpy as np

import scans

MIN_RETURNS = 10  # small_gicp's neighbourhood for covariances and normals

Align = Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, bool]]


def arguments(description: str) -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(description=description)
    p.add_argument("--dataset", required=True, help="carmen:PATH, csv:DIR or marina:DIR")
    p.add_argument("--out", required=True, type=Path, help="the per-pair CSV to write")
    p.add_argument("--stats", type=Path, help="a JSON of run times and convergence to write")
    return p


def run(dataset: str, out: Path, stats_path: Path | None, name: str, params: dict, align: Align) -> None:
    try:
        data = scans.load(dataset)
    except (scans.DataError, OSError) as e:
        scans.fail(str(e))
    rows, times_s, not_converged, tz_m, tilt_deg = [], [], 0, [], []
    for k in range(len(data) - 1):
        if min(len(data[k].points_m), len(data[k + 1].points_m)) < MIN_RETURNS:
            continue
        start = time.perf_counter()
        t_ref_src, converged = align(data[k + 1].points_m, data[k].points_m)
        times_s.append(time.perf_counter() - start)
        if not np.all(np.isfinite(t_ref_src)):
            continue  # no estimate: icp-eval counts the pair as a failure of the tool
        tx, ty, theta, tz, tilt = scans.planar(t_ref_src)
        tz_m.append(tz)
        tilt_deg.append(tilt)
        not_converged += not converged
        rows.append((k, k + 1, tx, ty, theta))
    scans.write_pair_csv(out, rows)
    stats = {
        "tool": name,
        "dataset": dataset,
        "parameters": params,
        "pairs": len(data) - 1,
        "pairs_estimated": len(rows),
        "pairs_not_converged": not_converged,
        "time_per_pair_ms_mean": 1e3 * float(np.mean(times_s)),
        "time_per_pair_ms_median": 1e3 * float(np.median(times_s)),
        "out_of_plane_tz_m_max": max(tz_m, default=0.0),
        "out_of_plane_tilt_deg_max": max(tilt_deg, default=0.0),
        "pairs_tilt_above_1_deg": sum(t > 1.0 for t in tilt_deg),
    }
    print(json.dumps(stats, indent=1))
    if stats_path:
        stats_path.parent.mkdir(parents=True, exist_ok=True)
        stats_path.write_text(json.dumps(stats, indent=1) + "\n")
