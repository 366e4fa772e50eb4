#!/usr/bin/env python3
"""KISS-ICP (Vizzo et al. 2023, PyPI `kiss-icp`): its odometry pipeline over the scans in order,
the pose of every scan written as TUM at the scan's own time (icp-eval takes the pair motions
`t_ref_src = pose_{k+1}⁻¹ · pose_k` from it).

The configuration is KISS-ICP's default (`kiss_icp.config.load_config(None)`, 1.3.0):
`max_range=100` m, `min_range=0` m, so `voxel_size = max_range / 100 = 1.0` m,
`max_points_per_voxel=20`, adaptive threshold from `initial_threshold=2.0` m with
`min_motion_th=0.1` m, `max_num_iterations=500`, `convergence_criterion=1e-4`, except
`max_num_threads=1` (its default, 0, uses every core and its parallel sums then differ from run
to run in the last bits: one thread makes the file reproducible). Deskewing is on
in the default but needs per-point times, which a 2D scan here does not have (an empty array
is passed, so the scan is taken as one instant). A scan with fewer than 10 returns gets no pose
(`pairwise.MIN_RETURNS`). The 2D returns enter as 3D points at z = 0;
the registration is KISS-ICP's own: scan-to-local-map, constant-velocity prediction, so it is
not a pairwise tool and its start is not the identity.

`--max-range-m 50` sets the range to the laser's own (KISS-ICP's documentation asks for the
sensor's maximum range: `kiss_icp_data='{"max_range": 50}'`), so the voxel is 0.5 m.

    run_kiss_icp.py --dataset carmen:aces.log.gz --out kiss.tum
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
from kiss_icp.config import load_config
from kiss_icp.kiss_icp import KissICP

import pairwise
import scans


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    p.add_argument("--dataset", required=True, help="carmen:PATH, csv:DIR or marina:DIR")
    p.add_argument("--out", required=True, type=Path, help="the TUM file to write")
    p.add_argument("--stats", type=Path, help="a JSON of run times and the configuration")
    p.add_argument(
        "--max-range-m",
        type=float,
        help="KISS-ICP's data.max_range (and so voxel_size = max_range / 100); default: its own 100 m",
    )
    a = p.parse_args()
    try:
        data = scans.load(a.dataset)
    except (scans.DataError, OSError) as e:
        scans.fail(str(e))
    config = load_config(None)
    # One thread (the default 0 takes every core): the same poses bit for bit on every run.
    config.registration.max_num_threads = 1
    if a.max_range_m is not None:  # as load_config derives it from a config file's max_range
        config.data.max_range = a.max_range_m
        config.mapping.voxel_size = a.max_range_m / 100.0
    odometry = KissICP(config)
    poses, times_s = [], []
    kept = [s for s in data if len(s.points_m) >= pairwise.MIN_RETURNS]  # no pose for the others
    for scan in kept:
        start = time.perf_counter()
        odometry.register_frame(scans.points_3d(scan.points_m), np.zeros(0))
        times_s.append(time.perf_counter() - start)
        poses.append(np.array(odometry.last_pose))
    scans.write_tum(a.out, [s.time_s for s in kept], poses)
    stats = {
        "tool": "KISS-ICP",
        "dataset": a.dataset,
        "parameters": config.model_dump(),
        "scans": len(data),
        "scans_with_pose": len(kept),
        "time_per_scan_ms_mean": 1e3 * float(np.mean(times_s)),
        "time_per_scan_ms_median": 1e3 * float(np.median(times_s)),
        "out_of_plane_tz_m_max": max(abs(pose[2, 3]) for pose in poses),
        "out_of_plane_tilt_deg_max": max(scans.planar(pose)[4] for pose in poses),
    }
    print(json.dumps(stats, indent=1))
    if a.stats:
        a.stats.parent.mkdir(parents=True, exist_ok=True)
        a.stats.write_text(json.dumps(stats, indent=1) + "\n")


if __name__ == "__main__":
    main()
