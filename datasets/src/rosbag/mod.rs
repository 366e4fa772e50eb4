//! ROS 2 bags (rosbag2): a bag directory with its `metadata.yaml`, or one `.mcap` / `.db3`
//! storage file.
//!
//! - **Scans**: `sensor_msgs/msg/LaserScan`, bearing `angle_min + k · angle_increment`
//!   (counter-clockwise about `+z`, REP 103), time `header.stamp`. A reading that is NaN, ±∞,
//!   below `range_min` or above `range_max` is a no-return; they are counted in
//!   [`LoadWarning::NoReturnReadings`]. Scans are put in stamp order. The sweep (the
//!   dataset's `sweep_s`) is `|time_increment| · (readings − 1)`, the median over the scans,
//!   when every scan gives a finite, non-zero `time_increment`; otherwise it is unknown
//!   (drivers that do not know write 0). `scan_time` is the time between scans, not the
//!   sweep's, and is not read.
//! - **Reference**, interpolated to the scan stamps (linear in position, shortest-arc in yaw):
//!   `nav_msgs/msg/Odometry`, `geometry_msgs/msg/PoseStamped` or
//!   `geometry_msgs/msg/PoseWithCovarianceStamped`, rigid poses of a body (yaw from the
//!   quaternion) moved to the scanner: `pose_body ∘ T_body_scanner`, the scanner's offset
//!   read from `/tf_static` ([`offset`], [`tf`]) and reported as the dataset's
//!   `scanner_offset`; without a tf path the poses are taken as the scanner's own and
//!   [`LoadWarning::ScannerOffsetUnknown`] says why. Or `sensor_msgs/msg/NavSatFix`, GNSS
//!   positions in the local tangent plane (east, north) about the first fix with the course
//!   over ground as heading: SOG and ΔCOG only, as the paper's reference
//!   ([`ReferenceKind::GnssPositions`], no scan yaw); the antenna's offset from tf is reported,
//!   not applied (no body heading to turn it with). Scans outside the reference's time span
//!   are left out ([`LoadWarning::ScansOutsideReference`]).
//! - **Topics**: the `LaserScan` topic and the reference topic are found by type when there is
//!   one of each; [`RosbagOptions`] names them otherwise.
//!
//! The sensor model is not in a bag: the default (the Sweep's) is used; `--sensor` sets it.

pub mod cdr;
pub mod messages;
pub mod offset;
pub mod storage;
pub mod tf;
pub mod track;

use std::path::Path;

use icp_core::{BearingSense, Scan, SensorModel};
use sha2::{Digest, Sha256};

use crate::dataset::{
    nominal_dt_s, Dataset, FileProvenance, LoadWarning, Provenance, ReferenceKind, ReferencePose,
};
use crate::DatasetError;
use messages::{StampedPose, LASER_SCAN, NAV_SAT_FIX, ODOMETRY, REFERENCE_TYPES};
use storage::{Bag, Topic};

/// Which topic the reference comes from.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub enum ReferenceChoice {
    /// The one topic of a reference type, if there is exactly one; none if there is none.
    #[default]
    Auto,
    /// No reference, whatever the bag holds.
    Off,
    /// This topic.
    Topic(String),
}

/// Options of the bag loader.
#[derive(Clone, Debug, PartialEq)]
pub struct RosbagOptions {
    /// The `LaserScan` topic; `None`: the only one.
    pub scan_topic: Option<String>,
    /// The reference topic.
    pub reference: ReferenceChoice,
    /// What the reference is; `None`: by its type (`Odometry`: [`ReferenceKind::Odometry`];
    /// `PoseStamped`, `PoseWithCovarianceStamped`: [`ReferenceKind::Unknown`]; `NavSatFix`:
    /// [`ReferenceKind::GnssPositions`], the only kind allowed for it).
    pub reference_kind: Option<ReferenceKind>,
    /// The frame whose pose the reference gives; `None`: `Odometry.child_frame_id`, a
    /// `NavSatFix`'s `header.frame_id`, [`offset::DEFAULT_BODY_FRAME`] for poses.
    pub body_frame: Option<String>,
    /// Whether `/tf_static` is read for the scanner's offset from that frame (default on).
    pub tf: bool,
}

impl Default for RosbagOptions {
    fn default() -> Self {
        Self {
            scan_topic: None,
            reference: ReferenceChoice::Auto,
            reference_kind: None,
            body_frame: None,
            tf: true,
        }
    }
}

fn topic_error(path: &Path, what: String) -> DatasetError {
    DatasetError::BagTopic {
        path: path.to_path_buf(),
        what,
    }
}

fn list(topics: &[&Topic]) -> String {
    if topics.is_empty() {
        return "none".into();
    }
    topics
        .iter()
        .map(|t| format!("{} ({})", t.name, t.ty))
        .collect::<Vec<_>>()
        .join(", ")
}

/// The index of the topic named `name` (it must have one of `types`), or of the only topic of
/// one of `types` when `name` is `None` (`Ok(None)` when there is none and `required` is
/// false).
fn pick_topic(
    path: &Path,
    bag: &Bag,
    name: Option<&str>,
    types: &[&str],
    what: &str,
    option: &str,
    required: bool,
) -> Result<Option<usize>, DatasetError> {
    let all: Vec<&Topic> = bag.topics.iter().collect();
    let of_type: Vec<usize> = (0..bag.topics.len())
        .filter(|&i| types.contains(&bag.topics[i].ty.as_str()))
        .collect();
    let found = match name {
        Some(name) => {
            let i = bag
                .topics
                .iter()
                .position(|t| t.name == name)
                .ok_or_else(|| {
                    topic_error(
                        path,
                        format!(
                            "no topic {name:?} (given as {option}); the bag has: {}",
                            list(&all)
                        ),
                    )
                })?;
            if !of_type.contains(&i) {
                return Err(topic_error(
                    path,
                    format!(
                        "topic {name:?} has type {}, not {} ({what})",
                        bag.topics[i].ty,
                        types.join(" or ")
                    ),
                ));
            }
            i
        }
        None => match of_type[..] {
            [i] => i,
            [] if !required => return Ok(None),
            [] => {
                return Err(topic_error(
                    path,
                    format!(
                        "no {what} topic ({}); the bag has: {}",
                        types.join(" or "),
                        list(&all)
                    ),
                ))
            }
            _ => {
                let named: Vec<&Topic> = of_type.iter().map(|&i| &bag.topics[i]).collect();
                return Err(topic_error(
                    path,
                    format!(
                        "{} {what} topics: {}; choose one with {option}",
                        named.len(),
                        list(&named)
                    ),
                ));
            }
        },
    };
    let t = &bag.topics[found];
    if t.encoding != "cdr" {
        return Err(topic_error(
            path,
            format!(
                "topic {} is serialized as {:?}, not cdr",
                t.name, t.encoding
            ),
        ));
    }
    Ok(Some(found))
}

/// The decoded messages of topic `topic`, in storage order.
fn decode<T>(
    path: &Path,
    bag: &Bag,
    topic: usize,
    f: impl Fn(&[u8]) -> Result<T, cdr::CdrError>,
) -> Result<Vec<T>, DatasetError> {
    bag.messages
        .iter()
        .filter(|m| m.topic == topic)
        .enumerate()
        .map(|(index, m)| {
            f(&m.data).map_err(|source| DatasetError::BagMessage {
                path: path.to_path_buf(),
                topic: bag.topics[topic].name.clone(),
                index,
                source,
            })
        })
        .collect()
}

/// Counts of readings taken as no-returns.
#[derive(Default)]
struct NoReturnCounts {
    non_finite: usize,
    below_range_min: usize,
    above_range_max: usize,
}

/// Reads the bag at `path` (a bag directory or one `.mcap` / `.db3` file).
pub fn load(path: &Path, options: &RosbagOptions) -> Result<Dataset, DatasetError> {
    let bag = storage::read(path)?;
    let mut ds = from_bag(path, &bag, options)?;
    ds.provenance.files = bag
        .files
        .iter()
        .map(|f| {
            let bytes = std::fs::read(f).map_err(|source| DatasetError::Io {
                path: f.clone(),
                source,
            })?;
            Ok(FileProvenance {
                path: f.clone(),
                sha256: Sha256::digest(&bytes)
                    .iter()
                    .map(|b| format!("{b:02x}"))
                    .collect(),
                matches_pinned: None,
            })
        })
        .collect::<Result<_, DatasetError>>()?;
    Ok(ds)
}

/// The dataset of an MCAP bag held in memory; `name` names it in errors (no file provenance).
#[cfg(feature = "rosbag-mcap")]
pub fn load_mcap_bytes(
    name: &Path,
    bytes: &[u8],
    options: &RosbagOptions,
) -> Result<Dataset, DatasetError> {
    from_bag(name, &storage::mcap_from_bytes(name, bytes)?, options)
}

/// The dataset of a bag already read; `path` names it in errors.
pub fn from_bag(path: &Path, bag: &Bag, options: &RosbagOptions) -> Result<Dataset, DatasetError> {
    let scan_topic = pick_topic(
        path,
        bag,
        options.scan_topic.as_deref(),
        &[LASER_SCAN],
        "LaserScan",
        "?scan=/topic",
        true,
    )?
    .expect("a required topic is found or an error");
    let reference_topic = match &options.reference {
        ReferenceChoice::Off => None,
        ReferenceChoice::Auto => pick_topic(
            path,
            bag,
            None,
            &REFERENCE_TYPES,
            "reference",
            "?reference=/topic (or reference=none)",
            false,
        )?,
        ReferenceChoice::Topic(name) => pick_topic(
            path,
            bag,
            Some(name),
            &REFERENCE_TYPES,
            "reference",
            "?reference=/topic",
            true,
        )?,
    };

    let mut laser = decode(path, bag, scan_topic, messages::laser_scan)?;
    let stored_out_of_order = laser
        .windows(2)
        .filter(|w| w[1].stamp_s < w[0].stamp_s)
        .count();
    laser.sort_by(|a, b| a.stamp_s.total_cmp(&b.stamp_s));
    let mut warnings = Vec::new();
    if stored_out_of_order > 0 {
        warnings.push(LoadWarning::ScansReordered {
            scans: stored_out_of_order,
        });
    }

    let (reference_poses, kind, what) = match reference_topic {
        None => (None, None, "no reference".to_owned()),
        Some(t) => {
            let ty = bag.topics[t].ty.as_str();
            let (mut poses, unusable, kind) = if ty == NAV_SAT_FIX {
                if let Some(k) = options
                    .reference_kind
                    .filter(|k| *k != ReferenceKind::GnssPositions)
                {
                    return Err(DatasetError::BagTopic {
                        path: path.to_path_buf(),
                        what: format!(
                            "reference_kind {k:?} for a NavSatFix reference: GNSS positions \
                             have no scan orientation, only gnss_positions fits"
                        ),
                    });
                }
                let fixes = decode(path, bag, t, messages::nav_sat_fix)?;
                let n = fixes.len();
                let mut usable: Vec<messages::Fix> = fixes
                    .into_iter()
                    .filter(|f| {
                        f.status >= 0 && f.latitude_deg.is_finite() && f.longitude_deg.is_finite()
                    })
                    .collect();
                let unusable = n - usable.len();
                usable.sort_by(|a, b| a.stamp_s.total_cmp(&b.stamp_s));
                usable.dedup_by(|later, earlier| later.stamp_s == earlier.stamp_s);
                (
                    track::gnss_track(&usable),
                    unusable,
                    ReferenceKind::GnssPositions,
                )
            } else {
                let decoded = decode(path, bag, t, |m| messages::stamped_pose(ty, m))?;
                let n = decoded.len();
                let poses: Vec<StampedPose> = decoded.into_iter().flatten().collect();
                let unusable = n - poses.len();
                let default_kind = if ty == ODOMETRY {
                    ReferenceKind::Odometry
                } else {
                    ReferenceKind::Unknown
                };
                (
                    poses,
                    unusable,
                    options.reference_kind.unwrap_or(default_kind),
                )
            };
            track::sort_dedup(&mut poses);
            if unusable > 0 {
                warnings.push(LoadWarning::UnusableReferenceMessages { messages: unusable });
            }
            if poses.is_empty() {
                return Err(topic_error(
                    path,
                    format!(
                        "the reference topic {} has no usable message",
                        bag.topics[t].name
                    ),
                ));
            }
            let what = format!("reference {} ({ty})", bag.topics[t].name);
            (Some((poses, ty == NAV_SAT_FIX)), Some(kind), what)
        }
    };

    // Keep the scans inside the reference's time span.
    let (mut before, mut after) = (0, 0);
    if let Some((poses, _)) = &reference_poses {
        let (t0, t1) = (poses[0].stamp_s, poses[poses.len() - 1].stamp_s);
        before = laser.iter().filter(|s| s.stamp_s < t0).count();
        after = laser.iter().filter(|s| s.stamp_s > t1).count();
        laser.retain(|s| (t0..=t1).contains(&s.stamp_s));
        if before + after > 0 {
            warnings.push(LoadWarning::ScansOutsideReference { before, after });
        }
    }
    if laser.is_empty() {
        return Err(topic_error(
            path,
            format!(
                "no scan to use on {}{}",
                bag.topics[scan_topic].name,
                if before + after > 0 {
                    format!(" inside the reference's time span ({before} before it, {after} after)")
                } else {
                    String::new()
                }
            ),
        ));
    }

    let mut counts = NoReturnCounts::default();
    let mut readings = 0;
    let mut scans = Vec::with_capacity(laser.len());
    let mut ranges = Vec::new();
    let mut bearings = Vec::new();
    for (k, m) in laser.iter().enumerate() {
        if !(m.angle_min_rad.is_finite() && m.angle_increment_rad.is_finite()) {
            return Err(DatasetError::BadValue {
                path: path.to_path_buf(),
                what: format!(
                    "scan {k} (stamp {} s): angle_min {} / angle_increment {} not finite",
                    m.stamp_s, m.angle_min_rad, m.angle_increment_rad
                ),
            });
        }
        ranges.clear();
        bearings.clear();
        for (j, &r) in m.ranges_m.iter().enumerate() {
            readings += 1;
            let no_return = if !r.is_finite() {
                counts.non_finite += 1;
                true
            } else if r < m.range_min_m {
                counts.below_range_min += 1;
                true
            } else if r > m.range_max_m {
                counts.above_range_max += 1;
                true
            } else {
                false
            };
            ranges.push(if no_return { f64::NAN } else { r });
            bearings.push(m.angle_min_rad + j as f64 * m.angle_increment_rad);
        }
        let scan = Scan::from_polar(&ranges, &bearings)
            .and_then(|s| s.with_timestamp(m.stamp_s))
            .map_err(|source| DatasetError::Scan {
                path: path.to_path_buf(),
                scan: k,
                source,
            })?;
        scans.push(scan);
    }
    let no_returns = counts.non_finite + counts.below_range_min + counts.above_range_max;
    if no_returns > 0 {
        warnings.push(LoadWarning::NoReturnReadings {
            readings,
            non_finite: counts.non_finite,
            below_range_min: counts.below_range_min,
            above_range_max: counts.above_range_max,
        });
    }

    let scanner_offset = match reference_topic {
        None => None,
        Some(t) => match offset::scanner_offset(path, bag, options, scan_topic, t)? {
            Ok(o) => Some(o),
            Err(reason) => {
                warnings.push(LoadWarning::ScannerOffsetUnknown { reason });
                None
            }
        },
    };
    let reference = reference_poses.map(|(poses, gnss)| {
        laser
            .iter()
            .map(|s| {
                let p = track::interpolate(&poses, s.stamp_s)
                    .expect("scans outside the reference's span were left out");
                // A rigid pose of the body moved to the scanner: pose_body ∘ T_body_scanner.
                // GNSS positions have no body orientation to turn the lever arm with.
                let (x_m, y_m, scan_yaw_rad) = match (gnss, scanner_offset) {
                    (true, _) => (p.x_m, p.y_m, None),
                    (false, None) => (p.x_m, p.y_m, Some(p.yaw_rad)),
                    (false, Some(o)) => {
                        let (sin, cos) = p.yaw_rad.sin_cos();
                        (
                            p.x_m + cos * o.x_m - sin * o.y_m,
                            p.y_m + sin * o.x_m + cos * o.y_m,
                            Some(track::wrap_pi(p.yaw_rad + o.yaw_rad)),
                        )
                    }
                };
                ReferencePose {
                    x_m,
                    y_m,
                    heading_rad: p.yaw_rad,
                    scan_yaw_rad,
                }
            })
            .collect::<Vec<_>>()
    });
    let (dt_s, assumed) = nominal_dt_s(&scans);
    warnings.extend(assumed);
    // A LaserScan carries no noise figures.
    warnings.push(LoadWarning::AssumedSensorModel {
        sensor: SensorModel::default(),
        of: "the Scanse Sweep (the paper's scanner)".to_owned(),
    });
    let label = path.file_name().map_or_else(
        || path.display().to_string(),
        |f| f.to_string_lossy().into_owned(),
    );
    Ok(Dataset {
        provenance: Provenance {
            name: format!("rosbag:{label}"),
            description: format!(
                "ROS 2 bag {} ({} LaserScan scans on {}, {what})",
                path.display(),
                scans.len(),
                bag.topics[scan_topic].name
            ),
            files: Vec::new(),
        },
        scans,
        reference,
        reference_kind: kind,
        odometry: None,
        // Rigid reference poses were moved to the scanner by it; GNSS positions stay the
        // antenna's, the offset reported only.
        scanner_offset,
        reference_heading_sense: BearingSense::CounterClockwise,
        dt_s,
        sensor: SensorModel::default(),
        sweep_s: sweep_s(&laser),
        bearing_sense: BearingSense::CounterClockwise,
        warnings,
        first_scans: None,
    }
    .checked())
}

/// The sweep of `scans`: the median of `|time_increment| · (readings − 1)`, when every scan
/// gives a finite, non-zero `time_increment` (see the module doc); `None` otherwise.
fn sweep_s(scans: &[messages::LaserScan]) -> Option<f64> {
    let mut sweeps: Vec<f64> = scans
        .iter()
        .map(|m| {
            let dt = m.time_increment_s.abs();
            (dt.is_finite() && dt > 0.0).then(|| dt * m.ranges_m.len().saturating_sub(1) as f64)
        })
        .collect::<Option<_>>()?;
    sweeps.sort_by(f64::total_cmp);
    sweeps.get(sweeps.len() / 2).copied()
}
