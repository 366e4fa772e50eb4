//! The scanner's offset from the body whose pose a bag's reference gives: the frames named by
//! the messages (the `LaserScan`'s `header.frame_id`; `Odometry.child_frame_id`, a
//! `NavSatFix`'s `header.frame_id`, or for `PoseStamped` / `PoseWithCovarianceStamped`, whose
//! header names only the parent frame, `?body_frame=` or else `base_link`) joined through the
//! bag's `/tf_static` ([`super::tf::FrameTree`]).

use std::path::Path;

use super::messages::{self, NAV_SAT_FIX, ODOMETRY};
use super::storage::{is_tf_static, Bag};
use super::tf::{frame_name, FrameTree, TfError};
use super::{decode, RosbagOptions};
use crate::dataset::Pose2;
use crate::DatasetError;

/// The body frame assumed for a pose reference whose messages do not name it.
pub const DEFAULT_BODY_FRAME: &str = "base_link";

/// The one value of `values`, or why there is not one (`what` names them).
fn the_one(values: Vec<String>, what: &str) -> Result<String, String> {
    let mut distinct = values.clone();
    distinct.sort();
    distinct.dedup();
    match &distinct[..] {
        [one] if !frame_name(one).is_empty() => Ok(one.clone()),
        [_] | [] => Err(format!("the {what} is empty")),
        many => Err(format!(
            "the {what} is not one frame ({}); ?tf=off takes the reference as is",
            many.join(", ")
        )),
    }
}

/// `T_body_scanner` projected to the plane, when the bag says it: `Ok(Ok(offset))`;
/// `Ok(Err(why))` when it does not (the warning's reason); `Err` when the bag's static
/// transforms do not decode or put the scanner out of the body's plane. `reference` is the
/// reference topic's index.
pub fn scanner_offset(
    path: &Path,
    bag: &Bag,
    options: &RosbagOptions,
    scan_topic: usize,
    reference: usize,
) -> Result<Result<Pose2, String>, DatasetError> {
    if !options.tf {
        return Ok(Err("?tf=off".to_owned()));
    }
    let scanner = match the_one(
        decode(path, bag, scan_topic, messages::header_frame_id)?,
        "LaserScan header.frame_id",
    ) {
        Ok(frame) => frame,
        Err(why) => return Ok(Err(why)),
    };
    let ty = bag.topics[reference].ty.as_str();
    let named = match (&options.body_frame, ty) {
        (Some(frame), _) => Some(Ok(frame.clone())),
        (None, ODOMETRY) => Some(the_one(
            decode(path, bag, reference, messages::odometry_child_frame_id)?,
            "Odometry child_frame_id",
        )),
        (None, NAV_SAT_FIX) => Some(the_one(
            decode(path, bag, reference, messages::header_frame_id)?,
            "NavSatFix header.frame_id",
        )),
        (None, _) => None,
    };
    if let Some(Ok(body)) = &named {
        if frame_name(body) == frame_name(&scanner) {
            return Ok(Ok(Pose2::IDENTITY));
        }
    }
    let static_topics: Vec<usize> = (0..bag.topics.len())
        .filter(|&i| is_tf_static(&bag.topics[i]))
        .collect();
    if static_topics.is_empty() {
        let dynamic = if bag.topics.iter().any(|t| t.ty == messages::TF_MESSAGE) {
            " (dynamic tf is not read: a scanner's mount is static)"
        } else {
            ""
        };
        return Ok(Err(format!("the bag has no /tf_static{dynamic}")));
    }
    let mut transforms = Vec::new();
    for &t in &static_topics {
        transforms.extend(
            decode(path, bag, t, messages::tf_message)?
                .into_iter()
                .flatten(),
        );
    }
    let tf_error = |source: TfError| DatasetError::BagTf {
        path: path.to_path_buf(),
        topic: static_topics
            .iter()
            .map(|&t| bag.topics[t].name.as_str())
            .collect::<Vec<_>>()
            .join(", "),
        source: Box::new(source),
    };
    let tree = FrameTree::new(&transforms).map_err(tf_error)?;
    let body = match named {
        Some(Ok(body)) => body,
        Some(Err(why)) => return Ok(Err(why)),
        None if tree.has(DEFAULT_BODY_FRAME) => DEFAULT_BODY_FRAME.to_owned(),
        None => {
            return Ok(Err(format!(
                "a {ty} names no body frame and /tf_static has no {DEFAULT_BODY_FRAME}; \
                 give ?body_frame="
            )))
        }
    };
    match tree.planar(&body, &scanner) {
        Ok(offset) => Ok(Ok(offset)),
        Err(why @ TfError::NoPath { .. }) => Ok(Err(why.to_string())),
        Err(e) => Err(tf_error(e)),
    }
}
