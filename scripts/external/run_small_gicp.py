#!/usr/bin/env python3
"""small_gicp (Koide, PyPI `small_gicp`) on every consecutive pair, from the identity.

`small_gicp.align(target, source, registration_type=…)` with the documented defaults of its
Python binding (1.0.1): `downsampling_resolution=0.25` m (voxel grid), covariances and normals
from 10 neighbours (`preprocess_points`), `max_correspondence_distance=1.0` m,
`max_iterations=20`, `rotation_epsilon=0.1°`, `translation_epsilon=1e-3` m, one thread. None
tuned on any dataset. The 2D returns enter as 3D points at z = 0; the planar part of the
result is kept (`scans.planar`).

    run_small_gicp.py --method GICP --dataset carmen:aces.log.gz --out sgicp_gicp.csv
"""

from __future__ import annotations

from importlib.metadata import version

import numpy as np
import small_gicp

import pairwise
import scans

METHODS = ("GICP", "ICP", "PLANE_ICP")


def main() -> None:
    p = pairwise.arguments(__doc__.splitlines()[1])
    p.add_argument("--method", choices=METHODS, required=True, help="small_gicp's registration_type")
    p.add_argument(
        "--extrude-m",
        type=float,
        default=0.0,
        help="also put every return at z = ±H (a wall of three rows) so that surface normals lie "
        "in the plane; 0 (the default) gives the points at z = 0 only",
    )
    a = p.parse_args()

    def lift(points_m: np.ndarray) -> np.ndarray:
        flat = scans.points_3d(points_m)
        if a.extrude_m == 0.0:
            return flat
        return np.vstack([flat + (0.0, 0.0, z) for z in (-a.extrude_m, 0.0, a.extrude_m)])

    def align(target_m: np.ndarray, source_m: np.ndarray) -> tuple[np.ndarray, bool]:
        r = small_gicp.align(lift(target_m), lift(source_m), registration_type=a.method)
        return np.asarray(r.T_target_source), bool(r.converged)

    params = {
        "registration_type": a.method,
        "extrude_m": a.extrude_m,
        "defaults": f"small_gicp.align {version('small_gicp')} (see run_small_gicp.py)",
    }
    pairwise.run(a.dataset, a.out, a.stats, f"small_gicp {a.method}" + (f" extruded ±{a.extrude_m} m" if a.extrude_m else ""), params, align)


if __name__ == "__main__":
    main()
