//! The robot's own odometry from a CARMEN log's `ODOM` lines
//! (`ODOM x y θ tv rv accel ipc_timestamp ipc_hostname logger_timestamp`).
//!
//! Some corrected logs overwrite the odometry fields of their `FLASER` lines with the corrected
//! poses but keep the wheel odometry in their `ODOM` lines (`aces`). There the stream is also
//! re-anchored after every scan: an `ODOM` line with timestamp 0 repeats the scan's corrected
//! pose, and the lines after it continue from there. So the odometry here is the stream's own
//! motion: the increments between consecutive lines chained from the first, where a line whose
//! timestamp is not after the line before's re-anchors the stream (the increment into it is a
//! correction's jump, not motion, and is dropped; the next increment starts from it). At a
//! scan's time the chained pose is the sample's at that time, or the line between the two
//! samples around it when they are at most [`MAX_ODOM_GAP_S`] apart.

use nalgebra::{Isometry2, Vector2};

use crate::dataset::Pose2;
use crate::rosbag::messages::StampedPose;
use crate::rosbag::track::interpolate;

/// Longest time between the two `ODOM` samples around a scan that its odometry is
/// interpolated over, seconds. A guard against bridging a hole in the stream, not an accuracy
/// figure: the classic logs write odometry at 5–40 Hz, and every `aces` scan has a sample at
/// its own time.
pub const MAX_ODOM_GAP_S: f64 = 1.0;

/// The chained motion of a stream of `ODOM` lines (see the module doc).
#[derive(Clone, Debug, Default)]
pub(crate) struct OdomLines {
    /// The chained poses, at strictly increasing times.
    chained: Vec<StampedPose>,
    /// The last line's own pose, which the next increment starts from.
    last: Option<Isometry2<f64>>,
    /// Lines read.
    pub lines: usize,
    /// Lines that re-anchored the stream.
    pub reanchored: usize,
}

/// `pose` at `stamp_s`.
fn stamped(stamp_s: f64, pose: &Isometry2<f64>) -> StampedPose {
    StampedPose {
        stamp_s,
        x_m: pose.translation.x,
        y_m: pose.translation.y,
        yaw_rad: pose.rotation.angle(),
    }
}

impl OdomLines {
    /// Takes the line at time `t_s` with pose `pose`.
    pub(crate) fn push(&mut self, t_s: f64, pose: Pose2) {
        let pose = pose.isometry();
        self.lines += 1;
        match (self.last, self.chained.last()) {
            (None, _) => self.chained.push(stamped(t_s, &pose)),
            (Some(previous), Some(c)) if t_s > c.stamp_s => {
                let chained = Isometry2::new(Vector2::new(c.x_m, c.y_m), c.yaw_rad);
                self.chained
                    .push(stamped(t_s, &(chained * (previous.inverse() * pose))));
            }
            _ => self.reanchored += 1,
        }
        self.last = Some(pose);
    }

    /// The chained pose at `t_s`: a sample's at that time, else the line between the two
    /// samples around it ([`interpolate`]) when they are at most [`MAX_ODOM_GAP_S`] apart;
    /// `None` otherwise.
    pub(crate) fn at(&self, t_s: f64) -> Option<Pose2> {
        let k = self.chained.partition_point(|p| p.stamp_s < t_s);
        if self.chained.get(k)?.stamp_s != t_s {
            let before = self.chained.get(k.checked_sub(1)?)?;
            if self.chained[k].stamp_s - before.stamp_s > MAX_ODOM_GAP_S {
                return None;
            }
        }
        let p = interpolate(&self.chained, t_s)?;
        Some(Pose2 {
            x_m: p.x_m,
            y_m: p.y_m,
            yaw_rad: p.yaw_rad,
        })
    }

    /// The chained pose at every time of `times_s`, when the stream covers each of them.
    pub(crate) fn at_each(&self, times_s: &[Option<f64>]) -> Option<Vec<Pose2>> {
        times_s.iter().map(|t| self.at((*t)?)).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector2;

    fn pose(x_m: f64, y_m: f64, yaw_rad: f64) -> Pose2 {
        Pose2 { x_m, y_m, yaw_rad }
    }

    fn relative(a: &Pose2, b: &Pose2) -> Isometry2<f64> {
        a.isometry().inverse() * b.isometry()
    }

    /// A re-anchored stream gives the motion of its own increments: the jump into a
    /// re-anchoring line is dropped, whatever its size.
    #[test]
    fn re_anchoring_lines_are_not_motion() {
        let mut lines = OdomLines::default();
        lines.push(1.0, pose(0.0, 0.0, 0.0));
        lines.push(2.0, pose(1.0, 0.0, 0.1));
        // Re-anchored 3 m away (timestamp 0), then 0.5 m ahead along its heading.
        lines.push(0.0, pose(3.0, 4.0, 1.0));
        lines.push(
            3.0,
            pose(3.0 + 0.5 * 1f64.cos(), 4.0 + 0.5 * 1f64.sin(), 1.0),
        );
        assert_eq!((lines.lines, lines.reanchored), (4, 1));
        let [a, b, c] = [1.0, 2.0, 3.0].map(|t| lines.at(t).unwrap());
        let first = relative(&a, &b);
        assert!((first.translation.vector - Vector2::new(1.0, 0.0)).norm() < 1e-12);
        assert!((first.rotation.angle() - 0.1).abs() < 1e-12);
        // From the re-anchoring pose: 0.5 m straight ahead, no turn.
        let second = relative(&b, &c);
        assert!((second.translation.vector - Vector2::new(0.5, 0.0)).norm() < 1e-12);
        assert!(second.rotation.angle().abs() < 1e-12);
    }

    /// Between two samples the pose moves along the step; past a hole of more than
    /// [`MAX_ODOM_GAP_S`], or outside the samples, there is none.
    #[test]
    fn interpolation_stops_at_holes_and_ends() {
        let mut lines = OdomLines::default();
        lines.push(10.0, pose(0.0, 0.0, 0.0));
        lines.push(10.5, pose(1.0, 0.0, 0.2));
        lines.push(10.5 + MAX_ODOM_GAP_S + 0.01, pose(2.0, 0.0, 0.2));
        let mid = lines.at(10.25).unwrap();
        let half = Isometry2::new(Vector2::new(1.0, 0.0), 0.2);
        let expected = Isometry2::new(half.translation.vector * 0.5, 0.1);
        assert!((mid.isometry().translation.vector - expected.translation.vector).norm() < 1e-12);
        assert!((mid.yaw_rad - 0.1).abs() < 1e-12);
        assert_eq!(lines.at(11.0), None);
        assert_eq!(lines.at(9.9), None);
        assert_eq!(lines.at(20.0), None);
        assert!(lines.at(10.5).is_some());
        assert_eq!(lines.at_each(&[Some(10.0), None]), None);
        assert_eq!(
            lines.at_each(&[Some(10.0), Some(10.5)]).map(|p| p.len()),
            Some(2)
        );
    }
}
