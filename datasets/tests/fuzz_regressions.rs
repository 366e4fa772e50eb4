//! Replays every input kept in `fuzz/regressions/` through the same calls as the fuzz
//! targets: each must give a dataset or a typed error, never a panic.

use std::fmt::Display;
use std::path::{Path, PathBuf};

use datasets::csvdir::DatasetMeta;
use datasets::matv5::write_doubles;

fn inputs(target: &str) -> Vec<(PathBuf, Vec<u8>)> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../fuzz/regressions")
        .join(target);
    let mut out: Vec<_> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .map(|p| {
            let bytes = std::fs::read(&p).unwrap();
            (p, bytes)
        })
        .collect();
    out.sort();
    assert!(!out.is_empty(), "no regression inputs for {target}");
    out
}

#[test]
fn marina_mat_inputs() {
    let angles = write_doubles(&[(
        "angles_baza",
        4,
        3,
        &[0.0, 1.0, 2.0, 3.0, 0.0, 1.0, 2.0, 3.0, 0.0, 1.0, 2.0, 3.0],
    )])
    .unwrap();
    let gps = write_doubles(&[("slam_pose", 3, 3, &[0.0; 9])]).unwrap();
    let mut ok = 0;
    for (path, data) in inputs("marina_mat") {
        let r = datasets::marina::parse(
            [
                (Path::new("angles.mat"), &angles[..]),
                (Path::new("ranges.mat"), &data[..]),
                (Path::new("gps.mat"), &gps[..]),
            ],
            &datasets::marina::MarinaOptions::default(),
        );
        ok += r.is_ok() as usize;
        if let Err(e) = r {
            assert!(
                e.to_string().contains("ranges.mat"),
                "{}: {e}",
                path.display()
            );
        }
    }
    assert_eq!(ok, 1, "only the seed `good` is a valid set");
}

#[test]
fn carmen_inputs() {
    for (path, data) in inputs("carmen") {
        let r = datasets::carmen::parse(Path::new("fuzz.log"), &data[..], &Default::default());
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        assert_eq!(
            r.is_ok(),
            name == "good",
            "{name}: {:?}",
            r.err().map(|e| e.to_string())
        );
    }
}

#[test]
fn csv_inputs() {
    const SCANS: &[u8] = b"scan,timestamp_s,range_m,bearing_rad\n0,0,5,0\n0,0,6,1\n0,0,7,2\n1,1,5,0\n1,1,6,1\n1,1,7,2\n";
    let meta = DatasetMeta::default();
    for (path, data) in inputs("csv_scans") {
        let as_scans = datasets::csvdir::parse(
            (Path::new("scans.csv"), &data[..]),
            None,
            None,
            &meta,
            "fuzz",
        );
        let as_poses = datasets::csvdir::parse(
            (Path::new("scans.csv"), SCANS),
            Some((Path::new("poses.csv"), &data[..])),
            None,
            &meta,
            "fuzz",
        );
        let as_odometry = datasets::csvdir::parse(
            (Path::new("scans.csv"), SCANS),
            None,
            Some((Path::new("odometry.csv"), &data[..])),
            &meta,
            "fuzz",
        );
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        assert_eq!(as_scans.is_ok(), name == "good", "{name} as scans");
        assert_eq!(as_poses.is_ok(), name == "poses", "{name} as poses");
        assert_eq!(
            as_odometry.is_ok(),
            name == "odometry",
            "{name} as odometry"
        );
    }
}

/// The `rosbag_cdr` target's dispatch: `Ok(())` for a decoded value, the error otherwise.
#[cfg(feature = "rosbag-mcap")]
fn rosbag_cdr(data: &[u8]) -> Result<(), String> {
    use datasets::rosbag::messages::{self, ODOMETRY, POSE_STAMPED, POSE_WITH_COVARIANCE_STAMPED};
    let Some((&selector, rest)) = data.split_first() else {
        return Err("empty".into());
    };
    let e = |e: &dyn Display| e.to_string();
    match selector % 5 {
        0 => messages::laser_scan(rest).map(|_| ()).map_err(|x| e(&x)),
        1 => [ODOMETRY, POSE_STAMPED, POSE_WITH_COVARIANCE_STAMPED]
            .iter()
            .map(|ty| {
                messages::stamped_pose(ty, rest)
                    .map(|_| ())
                    .map_err(|x| e(&x))
            })
            .find(Result::is_ok)
            .unwrap_or_else(|| Err("no rigid-pose type decodes it".into())),
        2 => messages::nav_sat_fix(rest).map(|_| ()).map_err(|x| e(&x)),
        3 => datasets::rosbag::load_mcap_bytes(
            Path::new("fuzz.mcap"),
            rest,
            &datasets::rosbag::RosbagOptions::default(),
        )
        .map(|ds| assert_eq!(ds.scans.len(), 2))
        .map_err(|x| e(&x)),
        _ => messages::tf_message(rest)
            .map_err(|x| e(&x))
            .and_then(|t| datasets::rosbag::tf::FrameTree::new(&t).map_err(|x| e(&x)))
            .and_then(|tree| tree.planar("base_link", "laser").map_err(|x| e(&x)))
            .map(|o| {
                // The seed's two links: the laser 0.5 m ahead, turned 90°.
                assert!((o.x_m - 0.5).abs() < 1e-12 && o.y_m.abs() < 1e-12);
                assert!((o.yaw_rad - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
            }),
    }
}

#[cfg(feature = "rosbag-mcap")]
#[test]
fn rosbag_cdr_inputs() {
    let bad = [
        "laser_scan_huge_count",
        "mcap_truncated",
        "tf_message_truncated",
    ];
    for (path, data) in inputs("rosbag_cdr") {
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        let r = rosbag_cdr(&data);
        assert_eq!(r.is_ok(), !bad.contains(&name.as_str()), "{name}: {r:?}");
    }
}
