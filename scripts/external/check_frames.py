#!/usr/bin/env python3
"""Checks each tool's script on scans with a known motion before any number is trusted.

A room (walls and three boxes, not symmetric) is ray-cast from four poses, 360 beams over 360°,
no noise; the scans go to a `csv:DIR` dataset and each tool's script is run on it exactly as on
the real data. Its per-pair motion (the CSV, or for KISS-ICP the TUM poses read back as
`pose_{k+1}⁻¹ · pose_k`, as icp-eval does) must lie within a quarter of the true motion of the
true `t_ref_src`, in translation and in rotation (the motions are 0.37–0.40 m and 4–6°). A
frame error misses by far more: the inverse motion or a flipped sign errs by about twice the
motion, the identity by the whole motion. This checks conventions, not accuracy (icp-eval
measures that); the errors are printed. Exits 1 when a tool misses.

    check_frames.py [--tools small_gicp_GICP,small_gicp_ICP,...]

`--tools small_gicp_PLANE_ICP` (points at z = 0 only) misses: small_gicp's normals of a flat
scan point along z, so point-to-plane sees no in-plane residual and returns the identity; the
runs use it with `--extrude-m 0.5`.
"""

from __future__ import annotations

import argparse
import math
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
FRACTION_OF_MOTION = 0.25

# World poses of the scans: x, y (m), yaw (deg, counter-clockwise).
POSES = [(0.0, 0.0, 0.0), (0.35, 0.12, 4.0), (0.70, 0.30, 9.0), (0.95, 0.55, 15.0)]

# Wall segments (x0, y0, x1, y1), metres: a 16 × 10 m room and three boxes.
def segments() -> np.ndarray:
    s = [(-6, -4, 10, -4), (10, -4, 10, 6), (10, 6, -6, 6), (-6, 6, -6, -4)]
    for cx, cy, w, h in [(3, 2, 1.5, 1.0), (-2.5, -2.0, 1.0, 2.0), (6, -1.5, 0.8, 0.8)]:
        c = [(cx - w / 2, cy - h / 2), (cx + w / 2, cy - h / 2), (cx + w / 2, cy + h / 2), (cx - w / 2, cy + h / 2)]
        s += [(*c[i], *c[(i + 1) % 4]) for i in range(4)]
    return np.array(s, dtype=float)


def ray_cast(pose, segs: np.ndarray, bearings_rad: np.ndarray) -> np.ndarray:
    """Range of the nearest wall along each bearing from `pose` (NaN where none)."""
    x, y, yaw = pose[0], pose[1], math.radians(pose[2])
    d = np.column_stack((np.cos(bearings_rad + yaw), np.sin(bearings_rad + yaw)))  # rays
    p0, e = segs[:, :2] - (x, y), segs[:, 2:] - segs[:, :2]
    ranges = np.full(len(d), np.nan)
    for i, di in enumerate(d):
        den = di[0] * e[:, 1] - di[1] * e[:, 0]
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (p0[:, 0] * e[:, 1] - p0[:, 1] * e[:, 0]) / den  # along the ray
            u = (p0[:, 0] * di[1] - p0[:, 1] * di[0]) / den  # along the segment
        hit = (np.abs(den) > 1e-12) & (t > 0) & (u >= 0) & (u <= 1)
        if hit.any():
            ranges[i] = t[hit].min()
    return ranges


def se2(pose) -> np.ndarray:
    c, s = math.cos(math.radians(pose[2])), math.sin(math.radians(pose[2]))
    return np.array([[c, -s, pose[0]], [s, c, pose[1]], [0, 0, 1]])


def truth(k: int) -> tuple[float, float, float]:
    """`t_ref_src` of pair k → k+1: `pose_{k+1}⁻¹ · pose_k`."""
    t = np.linalg.inv(se2(POSES[k + 1])) @ se2(POSES[k])
    return t[0, 2], t[1, 2], math.degrees(math.atan2(t[1, 0], t[0, 0]))


def write_dataset(directory: Path) -> None:
    bearings = np.radians(np.arange(360) - 180.0)
    segs = segments()
    with open(directory / "scans.csv", "w") as f:
        f.write("scan,timestamp_s,range_m,bearing_rad\n")
        for k, pose in enumerate(POSES):
            for r, a in zip(ray_cast(pose, segs, bearings), bearings):
                f.write(f"{k},{0.1 * k!r},{'' if math.isnan(r) else repr(float(r))},{float(a)!r}\n")


def pair_motions(tool: str, out: Path) -> list[tuple[float, float, float]]:
    """The motions a tool's output gives for the pairs, in our convention."""
    if tool == "kiss_icp":
        poses = []
        for line in out.read_text().splitlines():
            if line.startswith("#"):
                continue
            _, x, y, _z, qx, qy, qz, qw = map(float, line.split())
            yaw = math.atan2(2 * (qw * qz + qx * qy), 1 - 2 * (qy * qy + qz * qz))
            poses.append((x, y, math.degrees(yaw)))
        motions = []
        for k in range(len(poses) - 1):
            t = np.linalg.inv(se2(poses[k + 1])) @ se2(poses[k])
            motions.append((t[0, 2], t[1, 2], math.degrees(math.atan2(t[1, 0], t[0, 0]))))
        return motions
    rows = out.read_text().splitlines()[1:]
    return [tuple(map(float, r.split(",")[2:])) for r in rows]


TOOLS = {
    "small_gicp_GICP": ["run_small_gicp.py", "--method", "GICP"],
    "small_gicp_ICP": ["run_small_gicp.py", "--method", "ICP"],
    "small_gicp_PLANE_ICP": ["run_small_gicp.py", "--method", "PLANE_ICP"],
    "small_gicp_PLANE_ICP_extruded": ["run_small_gicp.py", "--method", "PLANE_ICP", "--extrude-m", "0.5"],
    "small_gicp_GICP_extruded": ["run_small_gicp.py", "--method", "GICP", "--extrude-m", "0.5"],
    "open3d": ["run_open3d.py"],
    "kiss_icp": ["run_kiss_icp.py"],
}


def main() -> int:
    p = argparse.ArgumentParser(description="check each tool's frame convention on a known motion")
    p.add_argument("--tools", default=",".join(t for t in TOOLS if t != "small_gicp_PLANE_ICP"))
    a = p.parse_args()
    bad = 0
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        write_dataset(tmp)
        for tool in a.tools.split(","):
            out = tmp / (tool + (".tum" if tool == "kiss_icp" else ".csv"))
            cmd = [sys.executable, str(HERE / TOOLS[tool][0]), *TOOLS[tool][1:], "--dataset", f"csv:{tmp}", "--out", str(out)]
            subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
            for k, (got, want) in enumerate(zip(pair_motions(tool, out), map(truth, range(len(POSES) - 1)))):
                err_m = math.hypot(got[0] - want[0], got[1] - want[1])
                err_deg = abs((got[2] - want[2] + 180) % 360 - 180)
                ok = (err_m <= FRACTION_OF_MOTION * math.hypot(want[0], want[1])
                      and err_deg <= FRACTION_OF_MOTION * abs(want[2]))
                bad += not ok
                print(f"{tool:22s} pair {k}: got ({got[0]:+.4f} m, {got[1]:+.4f} m, {got[2]:+.3f}°) "
                      f"true ({want[0]:+.4f}, {want[1]:+.4f}, {want[2]:+.3f}°) "
                      f"error {err_m * 100:.2f} cm {err_deg:.3f}° {'ok' if ok else 'MISS'}")
    print(f"{bad} pair(s) missed" if bad else "every tool recovers the known motions")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
