//! The static frame tree of a bag (`/tf_static`, `tf2_msgs/msg/TFMessage`) and the scanner's
//! pose in the reference's body frame, composed in 3D along the tree and projected to the
//! plane.
//!
//! Each `TransformStamped` gives the pose of `child_frame_id` in `header.frame_id`
//! (`T_parent_child`, REP 105 / tf2); a frame has at most one parent, so the tree is stored
//! child → parent, a later transform of the same child replacing an earlier one (as tf2 does
//! for re-published static transforms). Frame names are compared without a leading `/`
//! (tf2 strips it). Dynamic transforms (`/tf`) are not read: a scanner on a moving joint has
//! no fixed offset.

use std::collections::HashMap;

use nalgebra::{Isometry3, Quaternion, Translation3, UnitQuaternion, Vector3};

use super::messages::Transform;
use crate::dataset::Pose2;

/// Largest tilt of the scanner's `z` axis from the body's `z` axis, degrees, for the scan to
/// count as planar in the body's plane (a scan plane tilted by θ puts a reading at range `r`
/// `r·sin θ` off the plane; 1° is 17 cm at 10 m).
pub const MAX_TILT_DEG: f64 = 1.0;

/// A frame name as tf2 compares it: without a leading `/`.
pub fn frame_name(name: &str) -> &str {
    name.strip_prefix('/').unwrap_or(name)
}

/// Why a static transform tree gives no planar scanner offset.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum TfError {
    /// No chain of transforms joins the two frames.
    #[error("no path from frame {from:?} to frame {to:?} in /tf_static (its frames: {frames})")]
    NoPath {
        /// The body frame.
        from: String,
        /// The scanner frame.
        to: String,
        /// The frames the tree has.
        frames: String,
    },
    /// A transform that is not a rigid motion.
    #[error(
        "the transform of {child:?} in {parent:?} is not finite or its quaternion is zero \
         ({translation_m:?}, {rotation_xyzw:?})"
    )]
    BadTransform {
        /// Parent frame.
        parent: String,
        /// Child frame.
        child: String,
        /// Its translation, metres.
        translation_m: [f64; 3],
        /// Its quaternion (x, y, z, w).
        rotation_xyzw: [f64; 4],
    },
    /// The scanner's plane is tilted from the body's.
    #[error(
        "frame {to:?} is tilted {tilt_deg:.2}° from the plane of {from:?} (more than \
         {MAX_TILT_DEG}°): its planar scan is not in the body's plane"
    )]
    Tilted {
        /// The body frame.
        from: String,
        /// The scanner frame.
        to: String,
        /// The angle between the two `z` axes, degrees.
        tilt_deg: f64,
    },
}

/// The static frame tree: each child frame's parent and pose in it.
#[derive(Clone, Debug, Default)]
pub struct FrameTree {
    parent_of: HashMap<String, (String, Isometry3<f64>)>,
}

impl FrameTree {
    /// The tree of `transforms`, in order (a later transform of a child replaces an earlier).
    pub fn new(transforms: &[Transform]) -> Result<Self, TfError> {
        let mut parent_of = HashMap::new();
        for t in transforms {
            let [x, y, z] = t.translation_m;
            let [qx, qy, qz, qw] = t.rotation_xyzw;
            let q = Quaternion::new(qw, qx, qy, qz);
            let norm = q.norm();
            if !(t.translation_m.iter().all(|v| v.is_finite()) && norm.is_finite() && norm > 0.0) {
                return Err(TfError::BadTransform {
                    parent: t.parent.clone(),
                    child: t.child.clone(),
                    translation_m: t.translation_m,
                    rotation_xyzw: t.rotation_xyzw,
                });
            }
            let pose = Isometry3::from_parts(
                Translation3::new(x, y, z),
                UnitQuaternion::from_quaternion(q),
            );
            parent_of.insert(
                frame_name(&t.child).to_owned(),
                (frame_name(&t.parent).to_owned(), pose),
            );
        }
        Ok(Self { parent_of })
    }

    /// Whether the tree names `frame` (as a parent or a child).
    pub fn has(&self, frame: &str) -> bool {
        let frame = frame_name(frame);
        self.parent_of.contains_key(frame) || self.parent_of.values().any(|(p, _)| p == frame)
    }

    /// The frames of the tree, sorted, comma-separated.
    fn frames(&self) -> String {
        let mut all: Vec<&str> = self
            .parent_of
            .iter()
            .flat_map(|(c, (p, _))| [c.as_str(), p.as_str()])
            .collect();
        all.sort_unstable();
        all.dedup();
        all.join(", ")
    }

    /// `frame`'s ancestors from itself up to its root, each with `T_ancestor_frame`. A cycle
    /// (bad data) stops at the first repeated frame.
    fn chain(&self, frame: &str) -> Vec<(String, Isometry3<f64>)> {
        let mut out = vec![(frame.to_owned(), Isometry3::identity())];
        let mut pose = Isometry3::identity();
        let mut at = frame;
        while let Some((parent, t_parent_at)) = self.parent_of.get(at) {
            if out.iter().any(|(f, _)| f == parent) {
                break;
            }
            pose = t_parent_at * pose;
            out.push((parent.clone(), pose));
            at = parent;
        }
        out
    }

    /// `T_from_to`: the pose of frame `to` in frame `from`, composed along the tree through
    /// their nearest common ancestor `a`: `T_a_from⁻¹ · T_a_to`.
    pub fn lookup(&self, from: &str, to: &str) -> Result<Isometry3<f64>, TfError> {
        let (from, to) = (frame_name(from), frame_name(to));
        let up_from = self.chain(from);
        let up_to = self.chain(to);
        for (ancestor, t_a_to) in &up_to {
            if let Some((_, t_a_from)) = up_from.iter().find(|(f, _)| f == ancestor) {
                return Ok(t_a_from.inverse() * t_a_to);
            }
        }
        Err(TfError::NoPath {
            from: from.to_owned(),
            to: to.to_owned(),
            frames: self.frames(),
        })
    }

    /// The planar pose of frame `to` in frame `from`: [`Self::lookup`] projected to the plane
    /// (`x`, `y`, and the yaw of the rotated `x` axis), refused when `to`'s `z` axis is more
    /// than [`MAX_TILT_DEG`] from `from`'s (an upside-down scanner included: its bearings
    /// would turn the other way).
    pub fn planar(&self, from: &str, to: &str) -> Result<Pose2, TfError> {
        let t = self.lookup(from, to)?;
        let z = t.rotation * Vector3::z();
        let tilt_deg = z.z.clamp(-1.0, 1.0).acos().to_degrees();
        if tilt_deg > MAX_TILT_DEG {
            return Err(TfError::Tilted {
                from: frame_name(from).to_owned(),
                to: frame_name(to).to_owned(),
                tilt_deg,
            });
        }
        let x = t.rotation * Vector3::x();
        Ok(Pose2 {
            x_m: t.translation.vector.x,
            y_m: t.translation.vector.y,
            yaw_rad: x.y.atan2(x.x),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tf(parent: &str, child: &str, xyz: [f64; 3], rpy: [f64; 3]) -> Transform {
        let q = UnitQuaternion::from_euler_angles(rpy[0], rpy[1], rpy[2]);
        Transform {
            parent: parent.into(),
            child: child.into(),
            translation_m: xyz,
            rotation_xyzw: [q.i, q.j, q.k, q.w],
        }
    }

    /// A chain base → mount → laser and a sibling branch base → imu: the laser in the mount
    /// and the mount in the base compose to the closed form; from the imu the path goes
    /// through the base.
    #[test]
    fn chains_compose_through_the_common_ancestor() {
        let tree = FrameTree::new(&[
            tf("base_link", "mount", [0.3, 0.1, 0.5], [0.0, 0.0, 0.5]),
            tf("/mount", "laser", [0.2, 0.0, 0.1], [0.0, 0.0, 1.0]),
            tf("base_link", "imu", [-1.0, 0.0, 0.0], [0.0, 0.0, 0.0]),
        ])
        .unwrap();
        let p = tree.planar("base_link", "laser").unwrap();
        // mount at (0.3, 0.1) turned 0.5: the laser 0.2 along its x.
        assert!((p.x_m - (0.3 + 0.2 * 0.5f64.cos())).abs() < 1e-12);
        assert!((p.y_m - (0.1 + 0.2 * 0.5f64.sin())).abs() < 1e-12);
        assert!((p.yaw_rad - 1.5).abs() < 1e-12);
        let q = tree.planar("imu", "laser").unwrap();
        assert!((q.x_m - (p.x_m + 1.0)).abs() < 1e-12 && (q.y_m - p.y_m).abs() < 1e-12);
        let back = tree.planar("laser", "base_link").unwrap();
        let round = p.isometry() * back.isometry();
        assert!(round.translation.vector.norm() < 1e-12 && round.rotation.angle() < 1e-12);
        assert!(tree.has("base_link") && tree.has("/laser") && !tree.has("odom"));
    }

    #[test]
    fn no_path_tilt_and_bad_quaternions_are_errors() {
        let tree = FrameTree::new(&[
            tf("base_link", "laser", [0.0; 3], [0.0, 0.02, 0.0]),
            tf("map", "gps", [0.0; 3], [0.0; 3]),
            tf("base_link", "level", [0.0; 3], [0.01, 0.0, 0.3]),
        ])
        .unwrap();
        match tree.planar("base_link", "gps") {
            Err(TfError::NoPath { from, to, frames }) => {
                assert_eq!((from.as_str(), to.as_str()), ("base_link", "gps"));
                assert_eq!(frames, "base_link, gps, laser, level, map");
            }
            other => panic!("{other:?}"),
        }
        match tree.planar("base_link", "laser") {
            Err(TfError::Tilted { tilt_deg, .. }) => {
                assert!((tilt_deg - 0.02f64.to_degrees()).abs() < 1e-9)
            }
            other => panic!("{other:?}"),
        }
        // 0.57° of roll is within the bound; the yaw is kept.
        assert!((tree.planar("base_link", "level").unwrap().yaw_rad - 0.3).abs() < 1e-12);
        let mut bad = tf("a", "b", [0.0; 3], [0.0; 3]);
        bad.rotation_xyzw = [0.0; 4];
        assert!(matches!(
            FrameTree::new(&[bad]),
            Err(TfError::BadTransform { .. })
        ));
    }
}
