#!/usr/bin/env python3
"""Open3D (PyPI `open3d`) point-to-point `registration_icp` on every consecutive pair, from the
identity.

Open3D has no default correspondence distance (its tutorial's 0.02 is for its own demo data):
`--max-correspondence-m` defaults to 1.0 m, small_gicp's documented default, so the two
pairwise tools share one gate chosen before any run (not tuned on aces). A pair's motion is
0.24 m on the harbour, about 1.2 m on marina and on aces a median 0.97 m and 10.6° (95th
percentile 1.14 m and 38°, reference poses), so from the identity many aces returns start
beyond the gate: that is the tool's default use, not corrected here. Everything else
is Open3D's default: `TransformationEstimationPointToPoint(with_scaling=False)`,
`ICPConvergenceCriteria(relative_fitness=1e-6, relative_rmse=1e-6, max_iteration=30)`, no
downsampling. The 2D returns enter as 3D points at z = 0.

    run_open3d.py --dataset carmen:aces.log.gz --out o3d_p2p.csv
"""

from __future__ import annotations

import numpy as np
import open3d as o3d

import pairwise
import scans


def cloud(points_m: np.ndarray) -> o3d.geometry.PointCloud:
    return o3d.geometry.PointCloud(o3d.utility.Vector3dVector(scans.points_3d(points_m)))


def main() -> None:
    p = pairwise.arguments(__doc__.splitlines()[1])
    p.add_argument("--max-correspondence-m", type=float, default=1.0)
    a = p.parse_args()
    reg = o3d.pipelines.registration

    def align(target_m: np.ndarray, source_m: np.ndarray) -> tuple[np.ndarray, bool]:
        r = reg.registration_icp(cloud(source_m), cloud(target_m), a.max_correspondence_m, np.eye(4))
        # Open3D reports no convergence flag; a result without any inlier is no registration.
        return np.asarray(r.transformation), len(r.correspondence_set) > 0

    params = {"max_correspondence_distance_m": a.max_correspondence_m, "estimation": "PointToPoint",
              "criteria": "Open3D default (1e-6, 1e-6, 30 iterations)", "open3d": o3d.__version__}
    pairwise.run(a.dataset, a.out, a.stats, "Open3D point-to-point", params, align)


if __name__ == "__main__":
    main()
