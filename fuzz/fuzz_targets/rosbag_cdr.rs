//! The ROS 2 bag path on arbitrary bytes: the first byte picks what the rest is fed to (a
//! `LaserScan`, a rigid-pose message of each type, a `NavSatFix`, a whole MCAP bag through
//! topic selection, decoding and interpolation, or a `TFMessage` through the frame tree and
//! the planar `base_link → laser` lookup): a value or a typed error, never a panic.
#![no_main]

use std::path::Path;

use datasets::rosbag::messages::{self, ODOMETRY, POSE_STAMPED, POSE_WITH_COVARIANCE_STAMPED};
use datasets::rosbag::tf::FrameTree;
use datasets::rosbag::{load_mcap_bytes, RosbagOptions};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Some((&selector, rest)) = data.split_first() else {
        return;
    };
    match selector % 5 {
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
        3 => {
            let _ = load_mcap_bytes(Path::new("fuzz.mcap"), rest, &RosbagOptions::default());
        }
        _ => {
            if let Ok(transforms) = messages::tf_message(rest) {
                if let Ok(tree) = FrameTree::new(&transforms) {
                    let _ = tree.planar("base_link", "laser");
                }
            }
        }
    }
});
