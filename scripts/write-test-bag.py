#!/usr/bin/env python3
"""Writes a small ROS 2 bag with the Python `rosbags` package, an independent writer, in both
storages: OUT/mcap and OUT/sqlite3 (bag directories with metadata.yaml).

Content (what datasets/tests/rosbag.rs `bags_written_by_rosbags_are_read` checks): 50
LaserScan messages on /scan every 0.1 s from t = 1 700 000 000 s, 360 beams over a full turn,
every reading 10 m (a circle around the scanner) except beam k with k % 10 == 0, which is NaN;
Odometry on /odom at the same stamps, the pose of base_link: x = t' m (1 m/s), y = 0,
yaw = 0.1 t' rad (t' from the first stamp); /tf_static, one TFMessage of two links,
base_link -> laser_mount at (0.3, 0, 0.1) m unrotated and laser_mount -> laser at
(0.2, 0, 0.05) m turned 90 degrees about z: the laser 0.5 m ahead of base_link, turned 90 degrees.

Usage: scripts/write-test-bag.py OUT
"""

import math
import shutil
import sys
from pathlib import Path

import numpy as np
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore

T0_SEC = 1_700_000_000
SCANS = 50
BEAMS = 360


def main(out: Path) -> None:
    store = get_typestore(Stores.ROS2_HUMBLE)
    LaserScan = store.types["sensor_msgs/msg/LaserScan"]
    Odometry = store.types["nav_msgs/msg/Odometry"]
    Header = store.types["std_msgs/msg/Header"]
    Time = store.types["builtin_interfaces/msg/Time"]
    Pose = store.types["geometry_msgs/msg/Pose"]
    PoseWithCovariance = store.types["geometry_msgs/msg/PoseWithCovariance"]
    Point = store.types["geometry_msgs/msg/Point"]
    Quaternion = store.types["geometry_msgs/msg/Quaternion"]
    Twist = store.types["geometry_msgs/msg/Twist"]
    TwistWithCovariance = store.types["geometry_msgs/msg/TwistWithCovariance"]
    Vector3 = store.types["geometry_msgs/msg/Vector3"]
    TFMessage = store.types["tf2_msgs/msg/TFMessage"]
    TransformStamped = store.types["geometry_msgs/msg/TransformStamped"]
    Transform = store.types["geometry_msgs/msg/Transform"]

    def link(parent: str, child: str, xyz: tuple, yaw: float) -> object:
        return TransformStamped(
            header=Header(stamp=Time(sec=T0_SEC, nanosec=0), frame_id=parent),
            child_frame_id=child,
            transform=Transform(
                translation=Vector3(x=xyz[0], y=xyz[1], z=xyz[2]),
                rotation=Quaternion(x=0.0, y=0.0, z=math.sin(yaw / 2), w=math.cos(yaw / 2)),
            ),
        )

    tf_static = TFMessage(
        transforms=[
            link("base_link", "laser_mount", (0.3, 0.0, 0.1), 0.0),
            link("laser_mount", "laser", (0.2, 0.0, 0.05), math.pi / 2),
        ]
    )

    ranges = np.full(BEAMS, 10.0, dtype=np.float32)
    ranges[::10] = np.nan
    for name, plugin in [("mcap", StoragePlugin.MCAP), ("sqlite3", StoragePlugin.SQLITE3)]:
        path = out / name
        if path.exists():
            shutil.rmtree(path)
        with Writer(path, version=9, storage_plugin=plugin) as writer:
            scan_conn = writer.add_connection("/scan", LaserScan.__msgtype__, typestore=store)
            odom_conn = writer.add_connection("/odom", Odometry.__msgtype__, typestore=store)
            tf_conn = writer.add_connection("/tf_static", TFMessage.__msgtype__, typestore=store)
            writer.write(
                tf_conn,
                T0_SEC * 1_000_000_000,
                store.serialize_cdr(tf_static, TFMessage.__msgtype__),
            )
            for k in range(SCANS):
                t = 0.1 * k
                nanosec = round(t * 1e9)
                stamp = Time(sec=T0_SEC + nanosec // 1_000_000_000, nanosec=nanosec % 1_000_000_000)
                scan = LaserScan(
                    header=Header(stamp=stamp, frame_id="laser"),
                    angle_min=-math.pi,
                    angle_max=-math.pi + (BEAMS - 1) * (2 * math.pi / BEAMS),
                    angle_increment=2 * math.pi / BEAMS,
                    # A 10 Hz scanner's full turn: the sweep is (BEAMS - 1) of these.
                    time_increment=0.1 / BEAMS,
                    scan_time=0.1,
                    range_min=0.1,
                    range_max=30.0,
                    ranges=ranges,
                    intensities=np.zeros(BEAMS, dtype=np.float32),
                )
                yaw = 0.1 * t
                odom = Odometry(
                    header=Header(stamp=stamp, frame_id="odom"),
                    child_frame_id="base_link",
                    pose=PoseWithCovariance(
                        pose=Pose(
                            position=Point(x=t, y=0.0, z=0.0),
                            orientation=Quaternion(x=0.0, y=0.0, z=math.sin(yaw / 2), w=math.cos(yaw / 2)),
                        ),
                        covariance=np.zeros(36, dtype=np.float64),
                    ),
                    twist=TwistWithCovariance(
                        twist=Twist(linear=Vector3(x=1.0, y=0.0, z=0.0), angular=Vector3(x=0.0, y=0.0, z=0.1)),
                        covariance=np.zeros(36, dtype=np.float64),
                    ),
                )
                receive_ns = (T0_SEC * 1_000_000_000) + nanosec
                writer.write(scan_conn, receive_ns, store.serialize_cdr(scan, LaserScan.__msgtype__))
                writer.write(odom_conn, receive_ns, store.serialize_cdr(odom, Odometry.__msgtype__))
        print(f"wrote {path}")


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    main(Path(sys.argv[1]))
