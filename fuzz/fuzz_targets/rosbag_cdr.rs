//! The ROS 2 bag path on arbitrary bytes: the first byte picks what the rest is fed to (a
//! `LaserScan`, a rigid-pose message of each type, a `NavSatFix`, or a whole MCAP bag through
//! topic selection, decoding and interpolation): a value or a typed error, never a panic.
#![no_main]

use std::path::Path;

use datasets::rosbag::messages::{self, ODOMETRY, POSE_STAMPED, POSE_WITH_COVARIANCE_STAMPED};
use datasets::rosbag::{load_mcap_bytes, RosbagOptions};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Some((&selector, rest)) = data.split_first() else {
        return;
    };
    match selector % 4 {
        0 => {
            let _ = messages::laser_scan(rest);
        }
        1 => {
            for ty in [ODOMETRY, POSE_STAMPED, POSE_WITH_COVARIANCE_STAMPED] {
                let _ = messages::stamped_pose(ty, rest);
            }
        }
        2 => {
            let _ = messages::nav_sat_fix(rest);
        }
        _ => {
            let _ = load_mcap_bytes(Path::new("fuzz.mcap"), rest, &RosbagOptions::default());
        }
    }
});
