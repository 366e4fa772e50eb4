"""Scans as icp-eval sees them, for the external tools, and the two files icp-eval reads back.

Readers (each gives a list of `Scan`, in file order, with the time icp-eval gives the scan):

- `carmen:PATH` (`.log` or `.log.gz`): `FLASER n r_1 … r_n x y θ odom_x odom_y odom_θ
  ipc_timestamp host logger_timestamp`, read as `datasets/src/carmen.rs` reads it: the n beams
  over a 180° field of view, first beam at −90°, as far apart as CARMEN's reader takes them
  (`carmen_beam_spacing_deg`: 1° for 180 or 181 beams), a reading ≥ 50 m (the maximum range)
  or = 0 is a no-return, the time is `ipc_timestamp`.
- `csv:DIR`: our own dataset directory (`icp-eval synth --out DIR` writes one): `scans.csv`
  with `scan,timestamp_s,range_m,bearing_rad[,…]`, an empty or zero range a no-return
  (`datasets/src/csvdir.rs`).
- `marina:DIR`: the paper's MATLAB v5 files `angles.mat` (`angles_baza`, beams × scans,
  radians) and `ranges.mat` (`ranges_baza`, metres, NaN or 0 = no-return), scan k at
  `k · 1.0 s` (`datasets/src/marina.rs`).

Every return is the point `x = r cos α, y = r sin α` in the scan frame (PAPER.md eq. 10), the
same for every bearing sense: icp-eval turns bearings into points this way for every dataset.

Writers: `write_pair_csv` (`source,reference,tx_m,ty_m,theta_deg`, the motion `t_ref_src` that
maps points of scan k into the frame of scan k+1, θ counter-clockwise in the scan frame) and
`write_tum` (`timestamp x y z qx qy qz qw`, one pose per scan at the scan's own time, which
icp-eval matches to its scans within 1 ms).
"""

from __future__ import annotations

import csv
import gzip
import math
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

CARMEN_FOV_DEG = 180.0
CARMEN_MAX_RANGE_M = 50.0
MARINA_DT_S = 1.0


# The SICK LMS 2xx's angular resolutions, degrees.
SICK_RESOLUTIONS_DEG = (1.0, 0.5, 0.25)


def carmen_beam_spacing_deg(fov_deg: float, n: int) -> float:
    """The angle between two beams of a FLASER line, as `datasets/src/carmen.rs` (and CARMEN's
    own reader, `carmen_laser_guess_angle_increment`) takes it: `fov/n` where that is one of the
    SICK's resolutions (its last reading dropped: 180 beams over 180° are 1° apart), else
    `fov/(n − 1)`."""
    if n < 2:
        return 0.0
    dropped_last = fov_deg / n
    if any(abs(dropped_last - r) < 1e-9 for r in SICK_RESOLUTIONS_DEG):
        return dropped_last
    return fov_deg / (n - 1)


class DataError(Exception):
    """A dataset file that is not what its reader expects (names the file, line and field)."""


@dataclass
class Scan:
    """One scan: its time, s, and its returns as points in the scan frame, metres (N × 2)."""

    time_s: float
    points_m: np.ndarray


def load(spec: str) -> list[Scan]:
    """The scans of `KIND:TARGET` (`carmen:PATH`, `csv:DIR`, `marina:DIR`)."""
    kind, _, target = spec.partition(":")
    readers = {"carmen": load_carmen, "csv": load_csvdir, "marina": load_marina}
    if kind not in readers or not target:
        raise DataError(f"dataset {spec!r}: expected one of {', '.join(k + ':PATH' for k in readers)}")
    scans = readers[kind](Path(target))
    if len(scans) < 2:
        raise DataError(f"{target}: {len(scans)} scans, a pair needs 2")
    return scans


def points_from_polar(ranges_m: np.ndarray, bearings_rad: np.ndarray) -> np.ndarray:
    """The returns of one scan (NaN or 0 range = no-return, dropped) as N × 2 points (eq. 10)."""
    keep = ~np.isnan(ranges_m) & (ranges_m != 0.0)
    r, a = ranges_m[keep], bearings_rad[keep]
    return np.column_stack((r * np.cos(a), r * np.sin(a)))


def load_carmen(path: Path) -> list[Scan]:
    opener = gzip.open if path.read_bytes()[:2] == b"\x1f\x8b" else open
    scans = []
    with opener(path, "rt") as f:
        for n_line, line in enumerate(f, start=1):
            fields = line.split()
            if not fields or fields[0] != "FLASER":
                continue
            where = f"{path}, line {n_line}"
            try:
                n = int(fields[1])
                values = [float(v) for v in fields[2 : n + 2]]
                time_s = float(fields[n + 8])  # after n, n ranges, x y θ, odometry x y θ
            except (ValueError, IndexError) as e:
                raise DataError(f"{where}: not a FLASER line ({e})") from None
            if len(values) != n:
                raise DataError(f"{where}: {len(values)} readings, {n} announced")
            ranges = np.array(values)
            if np.any(ranges < 0) or not np.all(np.isfinite(ranges)):
                raise DataError(f"{where}: a reading is negative or not finite")
            ranges[ranges >= CARMEN_MAX_RANGE_M] = np.nan
            step_deg = carmen_beam_spacing_deg(CARMEN_FOV_DEG, n)
            bearings = np.radians(-0.5 * CARMEN_FOV_DEG + step_deg * np.arange(n))
            scans.append(Scan(time_s, points_from_polar(ranges, bearings)))
    if not scans:
        raise DataError(f"{path}: no FLASER line: not a CARMEN laser log")
    return scans


def load_csvdir(directory: Path) -> list[Scan]:
    path = directory / "scans.csv"
    rows: dict[int, tuple[float | None, list[float], list[float]]] = {}
    with open(path, newline="") as f:
        reader = csv.DictReader(f)
        for field in ("scan", "timestamp_s", "range_m", "bearing_rad"):
            if field not in (reader.fieldnames or []):
                raise DataError(f"{path}: no column {field!r} (header {reader.fieldnames})")
        for row in reader:
            where = f"{path}, line {reader.line_num}"
            try:
                k = int(row["scan"])
                t = float(row["timestamp_s"]) if row["timestamp_s"] else None
                r = float(row["range_m"]) if row["range_m"] else math.nan
                a = float(row["bearing_rad"]) if row["bearing_rad"] else math.nan
            except ValueError as e:
                raise DataError(f"{where}: {e}") from None
            _, ranges, bearings = rows.setdefault(k, (t, [], []))
            ranges.append(r)
            bearings.append(a)
    if sorted(rows) != list(range(len(rows))):
        raise DataError(f"{path}: scan indices are not 0..{len(rows) - 1}")
    scans = []
    for k in range(len(rows)):
        t, ranges, bearings = rows[k]
        if t is None:
            raise DataError(f"{path}: scan {k} has no timestamp_s (needed for the TUM output)")
        scans.append(Scan(t, points_from_polar(np.array(ranges), np.array(bearings))))
    return scans


def load_marina(directory: Path) -> list[Scan]:
    import scipy.io

    def variable(file: str, name: str) -> np.ndarray:
        data = scipy.io.loadmat(directory / file)
        if name not in data:
            raise DataError(f"{directory / file}: no variable {name!r}")
        return np.asarray(data[name], dtype=float)

    angles = variable("angles.mat", "angles_baza")
    ranges = variable("ranges.mat", "ranges_baza")
    if angles.shape != ranges.shape:
        raise DataError(f"{directory}: angles {angles.shape} but ranges {ranges.shape}")
    return [
        Scan(k * MARINA_DT_S, points_from_polar(ranges[:, k], angles[:, k]))
        for k in range(angles.shape[1])
    ]


def points_3d(points_m: np.ndarray) -> np.ndarray:
    """2D points as the 3D tools take them: z = 0."""
    return np.column_stack((points_m, np.zeros(len(points_m))))


def planar(t_4x4: np.ndarray) -> tuple[float, float, float, float, float]:
    """A 3D rigid transform's planar part `(tx_m, ty_m, theta_deg)` and how far it leaves the
    plane, `|tz|` in metres and the roll/pitch tilt in degrees: a tool working in 3D on planar
    points may move out of the plane; that part is dropped."""
    rot = t_4x4[:3, :3]
    theta_rad = math.atan2(rot[1, 0], rot[0, 0])
    tilt_rad = math.acos(max(-1.0, min(1.0, rot[2, 2])))
    return t_4x4[0, 3], t_4x4[1, 3], math.degrees(theta_rad), abs(t_4x4[2, 3]), math.degrees(tilt_rad)


def write_pair_csv(path: Path, rows: list[tuple[int, int, float, float, float]]) -> None:
    """Per-pair motions `t_ref_src` as `source,reference,tx_m,ty_m,theta_deg`."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w") as f:
        f.write("source,reference,tx_m,ty_m,theta_deg\n")
        for source, reference, tx, ty, theta in rows:
            f.write(f"{source},{reference},{float(tx)!r},{float(ty)!r},{float(theta)!r}\n")


def write_tum(path: Path, times_s: list[float], poses_4x4: list[np.ndarray]) -> None:
    """One pose per scan, `timestamp x y z qx qy qz qw`, the time in full precision."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w") as f:
        f.write("# timestamp x y z qx qy qz qw\n")
        for t, pose in zip(times_s, poses_4x4):
            qx, qy, qz, qw = quaternion(pose[:3, :3])
            x, y, z = pose[:3, 3]
            f.write(" ".join(repr(float(v)) for v in (t, x, y, z, qx, qy, qz, qw)) + "\n")


def quaternion(rot: np.ndarray) -> tuple[float, float, float, float]:
    """`(qx, qy, qz, qw)` of a rotation matrix (Shepperd's method, the largest pivot)."""
    trace = np.trace(rot)
    pivots = [trace, rot[0, 0], rot[1, 1], rot[2, 2]]
    i = int(np.argmax(pivots))
    if i == 0:
        s = 2.0 * math.sqrt(1.0 + trace)
        q = (
            (rot[2, 1] - rot[1, 2]) / s,
            (rot[0, 2] - rot[2, 0]) / s,
            (rot[1, 0] - rot[0, 1]) / s,
            s / 4,
        )
    elif i == 1:
        s = 2.0 * math.sqrt(1.0 + rot[0, 0] - rot[1, 1] - rot[2, 2])
        q = (s / 4, (rot[0, 1] + rot[1, 0]) / s, (rot[0, 2] + rot[2, 0]) / s, (rot[2, 1] - rot[1, 2]) / s)
    elif i == 2:
        s = 2.0 * math.sqrt(1.0 + rot[1, 1] - rot[0, 0] - rot[2, 2])
        q = ((rot[0, 1] + rot[1, 0]) / s, s / 4, (rot[1, 2] + rot[2, 1]) / s, (rot[0, 2] - rot[2, 0]) / s)
    else:
        s = 2.0 * math.sqrt(1.0 + rot[2, 2] - rot[0, 0] - rot[1, 1])
        q = ((rot[0, 2] + rot[2, 0]) / s, (rot[1, 2] + rot[2, 1]) / s, s / 4, (rot[1, 0] - rot[0, 1]) / s)
    norm = math.sqrt(sum(v * v for v in q))
    return tuple(v / norm for v in q)


def fail(message: str) -> None:
    print(f"error: {message}", file=sys.stderr)
    sys.exit(2)
