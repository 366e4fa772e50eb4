//! The ROS 2 messages read from bags, decoded from CDR (see [`super::cdr`]).
//!
//! Field orders are those of the message definitions in `common_interfaces`
//! (`std_msgs/msg/Header`, `sensor_msgs/msg/LaserScan`, `sensor_msgs/msg/NavSatFix`,
//! `geometry_msgs/msg/{Pose, PoseStamped, PoseWithCovariance, PoseWithCovarianceStamped}`,
//! `nav_msgs/msg/Odometry`, `tf2_msgs/msg/TFMessage`, `geometry_msgs/msg/TransformStamped`).

use super::cdr::{CdrError, CdrReader};

/// `sensor_msgs/msg/LaserScan`.
pub const LASER_SCAN: &str = "sensor_msgs/msg/LaserScan";
/// `nav_msgs/msg/Odometry`.
pub const ODOMETRY: &str = "nav_msgs/msg/Odometry";
/// `geometry_msgs/msg/PoseStamped`.
pub const POSE_STAMPED: &str = "geometry_msgs/msg/PoseStamped";
/// `geometry_msgs/msg/PoseWithCovarianceStamped`.
pub const POSE_WITH_COVARIANCE_STAMPED: &str = "geometry_msgs/msg/PoseWithCovarianceStamped";
/// `sensor_msgs/msg/NavSatFix`.
pub const NAV_SAT_FIX: &str = "sensor_msgs/msg/NavSatFix";

/// `tf2_msgs/msg/TFMessage`, the type of `/tf_static` (and `/tf`).
pub const TF_MESSAGE: &str = "tf2_msgs/msg/TFMessage";

/// The message types a reference can come from.
pub const REFERENCE_TYPES: [&str; 4] = [
    ODOMETRY,
    POSE_STAMPED,
    POSE_WITH_COVARIANCE_STAMPED,
    NAV_SAT_FIX,
];

/// `std_msgs/msg/Header`: its stamp, seconds (`sec + nanosec · 1e-9`), and its `frame_id`.
fn header<'a>(r: &mut CdrReader<'a>) -> Result<(f64, &'a str), CdrError> {
    let sec = r.i32("header.stamp.sec")?;
    let nanosec = r.u32("header.stamp.nanosec")?;
    let frame_id = r.string("header.frame_id")?;
    Ok((f64::from(sec) + f64::from(nanosec) * 1e-9, frame_id))
}

/// `std_msgs/msg/Header`'s stamp, seconds.
fn header_stamp_s(r: &mut CdrReader<'_>) -> Result<f64, CdrError> {
    Ok(header(r)?.0)
}

/// The `header.frame_id` of any message that starts with a `std_msgs/msg/Header` (the
/// LaserScan's scanner frame, the NavSatFix's antenna frame, a pose's parent frame).
pub fn header_frame_id(message: &[u8]) -> Result<String, CdrError> {
    let mut r = CdrReader::new(message)?;
    Ok(header(&mut r)?.1.to_owned())
}

/// The `child_frame_id` of a `nav_msgs/msg/Odometry`: the body whose pose it gives.
pub fn odometry_child_frame_id(message: &[u8]) -> Result<String, CdrError> {
    let mut r = CdrReader::new(message)?;
    header(&mut r)?;
    Ok(r.string("child_frame_id")?.to_owned())
}

/// One `geometry_msgs/msg/TransformStamped`: the pose of `child` in `parent`.
#[derive(Clone, Debug, PartialEq)]
pub struct Transform {
    /// `header.frame_id`: the parent frame.
    pub parent: String,
    /// `child_frame_id`.
    pub child: String,
    /// `transform.translation` (x, y, z), metres.
    pub translation_m: [f64; 3],
    /// `transform.rotation`, the quaternion (x, y, z, w).
    pub rotation_xyzw: [f64; 4],
}

/// Decodes a `tf2_msgs/msg/TFMessage` (a sequence of `TransformStamped`).
pub fn tf_message(message: &[u8]) -> Result<Vec<Transform>, CdrError> {
    let mut r = CdrReader::new(message)?;
    let n = r.u32("transforms")? as usize;
    // Each transform takes at least 4 + 4 + 4 + 4 + 7 · 8 bytes: a corrupt count is caught
    // before reserving.
    let mut out = Vec::with_capacity(n.min(message.len() / 72));
    for _ in 0..n {
        let (_, parent) = header(&mut r)?;
        let child = r.string("transforms.child_frame_id")?;
        let translation_m = [
            r.f64("transforms.transform.translation.x")?,
            r.f64("transforms.transform.translation.y")?,
            r.f64("transforms.transform.translation.z")?,
        ];
        let rotation_xyzw = [
            r.f64("transforms.transform.rotation.x")?,
            r.f64("transforms.transform.rotation.y")?,
            r.f64("transforms.transform.rotation.z")?,
            r.f64("transforms.transform.rotation.w")?,
        ];
        out.push(Transform {
            parent: parent.to_owned(),
            child: child.to_owned(),
            translation_m,
            rotation_xyzw,
        });
    }
    r.finish()?;
    Ok(out)
}

/// A decoded `LaserScan`: the fields a scan needs.
#[derive(Clone, Debug, PartialEq)]
pub struct LaserScan {
    /// `header.stamp`, seconds.
    pub stamp_s: f64,
    /// Bearing of the first reading, radians (counter-clockwise about `+z`, REP 103).
    pub angle_min_rad: f64,
    /// Bearing step between readings, radians.
    pub angle_increment_rad: f64,
    /// `time_increment`: time between two readings, seconds (0 when the driver does not say;
    /// negative when the readings were taken in the reverse order).
    pub time_increment_s: f64,
    /// Readings below this are invalid, metres.
    pub range_min_m: f64,
    /// Readings above this are invalid, metres.
    pub range_max_m: f64,
    /// The readings, metres (float32 in the message).
    pub ranges_m: Vec<f64>,
}

/// Decodes a `sensor_msgs/msg/LaserScan`.
pub fn laser_scan(message: &[u8]) -> Result<LaserScan, CdrError> {
    let mut r = CdrReader::new(message)?;
    let stamp_s = header_stamp_s(&mut r)?;
    let angle_min_rad = f64::from(r.f32("angle_min")?);
    let _angle_max = r.f32("angle_max")?;
    let angle_increment_rad = f64::from(r.f32("angle_increment")?);
    let time_increment_s = f64::from(r.f32("time_increment")?);
    // `scan_time` is the time between two scans, not the sweep's: not needed.
    let _scan_time = r.f32("scan_time")?;
    let range_min_m = f64::from(r.f32("range_min")?);
    let range_max_m = f64::from(r.f32("range_max")?);
    let mut ranges_m = Vec::new();
    r.f32_sequence("ranges", &mut ranges_m)?;
    // `intensities` follows; not needed, but it must be there for the message to be whole.
    let mut intensities = Vec::new();
    r.f32_sequence("intensities", &mut intensities)?;
    r.finish()?;
    Ok(LaserScan {
        stamp_s,
        angle_min_rad,
        angle_increment_rad,
        time_increment_s,
        range_min_m,
        range_max_m,
        ranges_m,
    })
}

/// A stamped planar pose: position, metres, and yaw, radians from `+x` towards `+y`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StampedPose {
    /// `header.stamp`, seconds.
    pub stamp_s: f64,
    /// Position `x`, metres.
    pub x_m: f64,
    /// Position `y`, metres.
    pub y_m: f64,
    /// Yaw of the orientation quaternion about `+z`, radians.
    pub yaw_rad: f64,
}

/// The yaw of a unit quaternion `(x, y, z, w)`: the `z` Euler angle of the ZYX (yaw, pitch,
/// roll) decomposition, `atan2(2(wz + xy), 1 − 2(y² + z²))`. `None` when the quaternion is not
/// finite or has zero norm.
pub fn yaw_from_quaternion(x: f64, y: f64, z: f64, w: f64) -> Option<f64> {
    let norm_sq = x * x + y * y + z * z + w * w;
    if !(norm_sq.is_finite() && norm_sq > 0.0) {
        return None;
    }
    // Scaling by the norm keeps a non-normalized quaternion's yaw.
    Some((2.0 * (w * z + x * y)).atan2(norm_sq - 2.0 * (y * y + z * z)))
}

/// `geometry_msgs/msg/Pose` into a planar pose; `None` when the orientation is unusable.
fn pose(r: &mut CdrReader<'_>, stamp_s: f64) -> Result<Option<StampedPose>, CdrError> {
    let x_m = r.f64("pose.position.x")?;
    let y_m = r.f64("pose.position.y")?;
    let _z = r.f64("pose.position.z")?;
    let qx = r.f64("pose.orientation.x")?;
    let qy = r.f64("pose.orientation.y")?;
    let qz = r.f64("pose.orientation.z")?;
    let qw = r.f64("pose.orientation.w")?;
    Ok(yaw_from_quaternion(qx, qy, qz, qw)
        .filter(|_| x_m.is_finite() && y_m.is_finite())
        .map(|yaw_rad| StampedPose {
            stamp_s,
            x_m,
            y_m,
            yaw_rad,
        }))
}

/// Decodes a rigid-pose reference message of type `ty` (one of [`ODOMETRY`],
/// [`POSE_STAMPED`], [`POSE_WITH_COVARIANCE_STAMPED`]); `Ok(None)` for a pose that is not
/// finite or whose quaternion is zero.
pub fn stamped_pose(ty: &str, message: &[u8]) -> Result<Option<StampedPose>, CdrError> {
    let mut r = CdrReader::new(message)?;
    let stamp_s = header_stamp_s(&mut r)?;
    if ty == ODOMETRY {
        r.string("child_frame_id")?;
    }
    let p = pose(&mut r, stamp_s)?;
    if ty != POSE_STAMPED {
        r.skip_f64_array("pose.covariance", 36)?;
    }
    if ty == ODOMETRY {
        // twist: TwistWithCovariance (linear, angular, covariance[36]).
        r.skip_f64_array("twist", 6 + 36)?;
    }
    r.finish()?;
    Ok(p)
}

/// A decoded `NavSatFix`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fix {
    /// `header.stamp`, seconds.
    pub stamp_s: f64,
    /// `status.status`: −1 no fix, 0 fix, 1 SBAS, 2 GBAS (RTK).
    pub status: i8,
    /// Latitude, degrees (WGS 84).
    pub latitude_deg: f64,
    /// Longitude, degrees (WGS 84).
    pub longitude_deg: f64,
    /// Altitude above the WGS 84 ellipsoid, metres (NaN when unknown).
    pub altitude_m: f64,
}

/// Decodes a `sensor_msgs/msg/NavSatFix`.
pub fn nav_sat_fix(message: &[u8]) -> Result<Fix, CdrError> {
    let mut r = CdrReader::new(message)?;
    let stamp_s = header_stamp_s(&mut r)?;
    let status = r.i8("status.status")?;
    let _service = r.u16("status.service")?;
    let latitude_deg = r.f64("latitude")?;
    let longitude_deg = r.f64("longitude")?;
    let altitude_m = r.f64("altitude")?;
    r.skip_f64_array("position_covariance", 9)?;
    let _covariance_type = r.u8("position_covariance_type")?;
    r.finish()?;
    Ok(Fix {
        stamp_s,
        status,
        latitude_deg,
        longitude_deg,
        altitude_m,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn yaw_of_rotations_about_z_and_of_unnormalized_quaternions() {
        for yaw in [-3.0f64, -1.0, 0.0, 0.5, 2.9] {
            let (z, w) = ((yaw / 2.0).sin(), (yaw / 2.0).cos());
            assert!((yaw_from_quaternion(0.0, 0.0, z, w).unwrap() - yaw).abs() < 1e-12);
            assert!((yaw_from_quaternion(0.0, 0.0, 3.0 * z, 3.0 * w).unwrap() - yaw).abs() < 1e-12);
        }
        assert_eq!(yaw_from_quaternion(0.0, 0.0, 0.0, 0.0), None);
        assert_eq!(yaw_from_quaternion(f64::NAN, 0.0, 0.0, 1.0), None);
    }
}
