//! The one type every loader produces, and the checks every loaded dataset goes through.

use std::fmt;
use std::path::PathBuf;

use icp_core::motion::wrap_deg;
use icp_core::robust::median_in_place;
use icp_core::{BearingSense, Scan, SensorModel};
use nalgebra::{Isometry2, Vector2};
use serde::{Deserialize, Serialize};

use crate::DatasetError;

/// A reference pose of the vessel at one scan, in a local level frame.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ReferencePose {
    /// First coordinate of the reference position, metres.
    pub x_m: f64,
    /// Second coordinate of the reference position, metres.
    pub y_m: f64,
    /// Heading as the source gives it, radians, growing in the dataset's
    /// `reference_heading_sense`.
    pub heading_rad: f64,
    /// Orientation of the scan frame in the `(x, y)` frame (radians, from `+x` towards `+y`),
    /// when the reference is a true 2D pose of the scanner; `None` when position and heading
    /// are not one rigid frame (the marina `slam_pose`: its positions do not turn with it).
    pub scan_yaw_rad: Option<f64>,
}

impl ReferencePose {
    /// The scanner pose `t_world_scan`, when the reference is a 2D pose of the scanner.
    pub fn scan_pose(&self) -> Option<nalgebra::Isometry2<f64>> {
        self.scan_yaw_rad
            .map(|yaw| nalgebra::Isometry2::new(nalgebra::Vector2::new(self.x_m, self.y_m), yaw))
    }
}

/// What a dataset's reference poses are, which says how far to trust them.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ReferenceKind {
    /// Exact by construction (the synthetic harbour): every disagreement is the estimate's
    /// error, so the reference plausibility checks can be off (`--reference-checks off`), and
    /// per-pair pose errors and the noise bound are meaningful.
    GroundTruth,
    /// Rigid poses of the scanner from a SLAM correction of the run (CARMEN "corrected" logs):
    /// globally consistent, but made from the same scans by another matcher, so a small error
    /// against them is partly theirs. Good for pose errors and drift; checks on.
    SlamCorrected,
    /// Wheel odometry, the log's only poses (an uncorrected log): it slips and drifts, so it
    /// bounds gross failures rather than measuring accuracy. Checks on.
    Odometry,
    /// GNSS positions with a separately measured heading, not one rigid frame (the marina
    /// files' `slam_pose` in `gps.mat`: RTK positions in a local metric frame that advance
    /// along +x whatever the heading, beside a heading in radians): speed over ground and
    /// heading change can be checked, per-pair pose errors cannot; GNSS steps jump, so checks
    /// on.
    GnssPositions,
    /// Not stated (a CSV dataset whose `dataset.json` has no `reference_kind`): treat it as a
    /// measurement, checks on.
    Unknown,
}

impl fmt::Display for ReferenceKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::GroundTruth => "ground truth (exact)",
            Self::SlamCorrected => "SLAM-corrected poses",
            Self::Odometry => "wheel odometry",
            Self::GnssPositions => "GNSS positions and a separate heading (not one rigid frame)",
            Self::Unknown => "not stated",
        })
    }
}

/// A rigid 2D pose: a position, metres, and an orientation, radians from `+x` towards `+y`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Pose2 {
    /// First coordinate, metres.
    pub x_m: f64,
    /// Second coordinate, metres.
    pub y_m: f64,
    /// Orientation, radians from `+x` towards `+y`.
    pub yaw_rad: f64,
}

impl Pose2 {
    /// The identity: no offset.
    pub const IDENTITY: Self = Self {
        x_m: 0.0,
        y_m: 0.0,
        yaw_rad: 0.0,
    };

    /// The pose as an isometry.
    pub fn isometry(&self) -> Isometry2<f64> {
        Isometry2::new(Vector2::new(self.x_m, self.y_m), self.yaw_rad)
    }
}

/// Something a loader noticed about the data that does not stop a run but bears on how to
/// read its numbers. `Display` gives the sentence `table.md` prints.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum LoadWarning {
    /// Every step of the odometry equals the reference's step (see [`SAME_STEP_M`]): the log
    /// has no independent odometry, so nothing started or checked from it is independent of
    /// the reference.
    OdometryEqualsReference {
        /// Consecutive steps compared.
        steps: usize,
    },
    /// A CARMEN log's `FLASER` odometry fields repeat the reference, but its `ODOM` lines
    /// carry the robot's own odometry: the odometry channel is their motion (their increments
    /// chained, the lines that re-anchor the stream to the corrected poses dropped; see
    /// the CARMEN loader).
    OdometryFromOdomLines {
        /// `ODOM` lines read.
        lines: usize,
        /// Those that re-anchored the stream (timestamp not after the line before's).
        reanchored: usize,
    },
    /// The median motion between consecutive scans is beyond what a registration started at
    /// the identity is trusted with ([`LARGE_STEP_M`], [`LARGE_TURN_DEG`]).
    LargeSteps {
        /// Median distance between consecutive poses, metres.
        median_step_m: f64,
        /// Median absolute heading change between consecutive poses, degrees.
        median_turn_deg: f64,
        /// The poses measured: `reference`, or `odometry` when there is no reference.
        measured_on: PoseChannel,
    },
    /// No usable timestamps (none, or no positive step between them) and no spacing given:
    /// the spacing was assumed, and speeds and turn rates scale with it.
    AssumedScanSpacing {
        /// The spacing assumed, seconds.
        dt_s: f64,
    },
    /// Timestamps that do not increase between consecutive scans: those pairs have no usable
    /// time step.
    NonIncreasingTimestamps {
        /// Consecutive pairs whose second timestamp is not after the first.
        pairs: usize,
        /// The first scan of the first such pair.
        first_scan: usize,
    },
    /// Readings that are no-returns because they are not finite or lie outside the scanner's
    /// stated `[range_min, range_max]` (ROS `LaserScan`): left out of the scans.
    NoReturnReadings {
        /// All readings of the scans kept.
        readings: usize,
        /// NaN or ±∞.
        non_finite: usize,
        /// Finite and below `range_min`.
        below_range_min: usize,
        /// Finite and above `range_max`.
        above_range_max: usize,
    },
    /// Scans stored out of their stamps' order: the scans were sorted by stamp.
    ScansReordered {
        /// Scans whose stamp is earlier than the one stored before them.
        scans: usize,
    },
    /// Scans stamped before the reference's first message or after its last: left out, as
    /// they have no reference.
    ScansOutsideReference {
        /// Scans before the reference's time span.
        before: usize,
        /// Scans after it.
        after: usize,
    },
    /// Reference messages that carry no usable pose (a non-finite position or a zero
    /// quaternion; a GNSS fix with status "no fix" or no position): skipped.
    UnusableReferenceMessages {
        /// Messages skipped.
        messages: usize,
    },
    /// The data do not say how noisy the scanner is: the loader's default model was assumed
    /// (a ROS `LaserScan`, a CARMEN log, a CSV directory whose dataset.json gives none). The
    /// weights of eqs. 12–13, the surface metrics' covariances and the noise bound use it.
    AssumedSensorModel {
        /// The model assumed.
        sensor: SensorModel,
        /// Which scanner it is the model of.
        of: String,
    },
    /// A ROS bag whose static transforms do not give the scanner's offset from the body whose
    /// pose the reference is (no `/tf_static`, no path between the frames, `?tf=off`): the
    /// reference poses are taken as the scanner's own, so a lever arm `d` turning by `Δψ`
    /// between scans errs the reference motion by up to `2·d·sin(Δψ/2)`.
    ScannerOffsetUnknown {
        /// Why, naming the frames.
        reason: String,
    },
    /// A scan with fewer readings (returns and no-returns) than the count more than half the
    /// scans share: a file cut inside that scan (a CSV's last scan cut at a line boundary), or
    /// a scan of another setting (a CARMEN line with another reading count). The first such
    /// scan is named.
    ShortScan {
        /// The first scan with fewer readings.
        scan: usize,
        /// Its readings.
        readings: usize,
        /// The readings of the scans before and after it, where there are such scans.
        neighbour_readings: Vec<usize>,
        /// The reading count more than half the scans share.
        usual_readings: usize,
        /// Scans with fewer readings than that, this one included.
        scans: usize,
    },
}

/// Which pose channel of a dataset a figure was measured on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PoseChannel {
    /// The reference poses.
    Reference,
    /// The odometry poses.
    Odometry,
}

impl fmt::Display for LoadWarning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::OdometryEqualsReference { steps } => write!(
                f,
                "the odometry equals the reference (all {steps} steps within {} mm and \
                 {SAME_TURN_DEG}°): no independent odometry",
                SAME_STEP_M * 1e3
            ),
            Self::OdometryFromOdomLines { lines, reanchored } => write!(
                f,
                "the FLASER lines' odometry repeats the reference: the odometry is the motion \
                 of the {lines} ODOM lines instead (their increments chained; the {reanchored} \
                 lines that re-anchor the stream to the corrected poses are not motion)"
            ),
            Self::LargeSteps {
                median_step_m,
                median_turn_deg,
                measured_on,
            } => write!(
                f,
                "median step {:.2} m / {:.1}° between consecutive scans ({}): beyond the \
                 {LARGE_STEP_M} m / {LARGE_TURN_DEG}° an identity start is trusted with; \
                 try `--init global` or independent odometry",
                median_step_m,
                median_turn_deg,
                match measured_on {
                    PoseChannel::Reference => "reference",
                    PoseChannel::Odometry => "odometry",
                }
            ),
            Self::AssumedSensorModel { sensor, of } => write!(
                f,
                "the data give no sensor model: {of}'s assumed (σ_r = {} m + {}·r, σ_α = {:.3}°); \
                 the weights, the surface covariances and the noise bound use it: give the \
                 scanner's with --sensor",
                sensor.sigma_r_const_m,
                sensor.sigma_r_per_m,
                sensor.sigma_alpha_rad.to_degrees()
            ),
            Self::AssumedScanSpacing { dt_s } => write!(
                f,
                "no usable timestamps and no dt_s given: {dt_s} s between scans assumed \
                 (the speeds and turn rates of scans without a timestamp scale with it: give \
                 dt_s or --dt; stamped scans keep their own time steps)"
            ),
            Self::NonIncreasingTimestamps { pairs, first_scan } => write!(
                f,
                "timestamps do not increase at {pairs} consecutive pair(s), first at scan \
                 {first_scan} → {}: those pairs have no usable time step",
                first_scan + 1
            ),
            Self::NoReturnReadings {
                readings,
                non_finite,
                below_range_min,
                above_range_max,
            } => write!(
                f,
                "{} of {readings} readings are no-returns: {non_finite} NaN or ±∞, \
                 {below_range_min} below range_min, {above_range_max} above range_max",
                non_finite + below_range_min + above_range_max
            ),
            Self::ScansReordered { scans } => write!(
                f,
                "{scans} scan(s) were stored out of stamp order: scans sorted by header.stamp"
            ),
            Self::ScansOutsideReference { before, after } => write!(
                f,
                "{before} scan(s) before and {after} after the reference's time span have no \
                 reference and were left out (reference=none keeps them)"
            ),
            Self::ScannerOffsetUnknown { reason } => write!(
                f,
                "the scanner's offset from the reference's body is unknown ({reason}): the \
                 reference poses are taken as the scanner's own"
            ),
            Self::UnusableReferenceMessages { messages } => write!(
                f,
                "{messages} reference message(s) without a usable pose (non-finite, zero \
                 quaternion, or no GNSS fix) were skipped"
            ),
            Self::ShortScan {
                scan,
                readings,
                neighbour_readings,
                usual_readings,
                scans,
            } => {
                let neighbours: Vec<String> = [scan.checked_sub(1), Some(scan + 1)]
                    .into_iter()
                    .flatten()
                    .zip(neighbour_readings)
                    .map(|(k, n)| format!("{n} (scan {k})"))
                    .collect();
                let (whose, have) = if neighbours.len() == 1 {
                    ("neighbour", "has")
                } else {
                    ("neighbours", "have")
                };
                write!(
                    f,
                    "scan {scan} has {readings} readings where its {whose} {have} {} and more \
                     than half the scans {usual_readings}: was the file cut inside it?",
                    neighbours.join(" and ")
                )?;
                if *scans > 1 {
                    write!(
                        f,
                        " ({} more scan(s) have fewer than {usual_readings})",
                        scans - 1
                    )?;
                }
                Ok(())
            }
        }
    }
}

/// One input file and its checksum.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FileProvenance {
    /// Where it was read.
    pub path: PathBuf,
    /// SHA-256 of its bytes, hex.
    pub sha256: String,
    /// Whether the checksum equals the one pinned for this dataset (`None`: nothing pinned).
    pub matches_pinned: Option<bool>,
}

impl FileProvenance {
    /// The provenance of `bytes` read from `path`: their SHA-256, nothing pinned.
    pub fn of(path: PathBuf, bytes: &[u8]) -> Self {
        use sha2::{Digest, Sha256};
        FileProvenance {
            path,
            sha256: Sha256::digest(bytes)
                .iter()
                .map(|b| format!("{b:02x}"))
                .collect(),
            matches_pinned: None,
        }
    }
}

/// Where a dataset came from.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Provenance {
    /// Short name, e.g. `marina`.
    pub name: String,
    /// Human description with the citation.
    pub description: String,
    /// The files read, if any.
    pub files: Vec<FileProvenance>,
}

/// A pair of consecutive scans to register: `source` (k) onto `reference` (k+1).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ScanPair {
    /// Index of scan k.
    pub source: usize,
    /// Index of scan k+1.
    pub reference: usize,
}

/// A consecutive pair that cannot be registered, with the reason.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct SkippedPair {
    /// The pair.
    pub pair: ScanPair,
    /// Why it is skipped.
    pub reason: String,
}

/// The first scans of a source, kept by its `scans` option (`icp-eval run --scans N`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct FirstScans {
    /// The scans asked for.
    pub requested: usize,
    /// The scans the source has; when fewer than asked for, all of them are kept.
    pub available: usize,
}

impl fmt::Display for FirstScans {
    /// `the first 30 of 440 scans: `--scans 30``, or all of them and why.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let Self {
            requested,
            available,
        } = *self;
        match requested.cmp(&available) {
            std::cmp::Ordering::Less => write!(
                f,
                "the first {requested} of {available} scans: `--scans {requested}`"
            ),
            std::cmp::Ordering::Equal => write!(f, "all {available} scans: `--scans {requested}`"),
            std::cmp::Ordering::Greater => write!(
                f,
                "all {available} scans: `--scans {requested}` asks for more than the data have"
            ),
        }
    }
}

/// Scans in order, with what is known about them.
#[derive(Clone, Debug)]
pub struct Dataset {
    /// Where the data came from.
    pub provenance: Provenance,
    /// The scans, in acquisition order.
    pub scans: Vec<Scan>,
    /// Reference pose per scan, when the source has one.
    pub reference: Option<Vec<ReferencePose>>,
    /// What the reference is: `Some` exactly when `reference` is.
    pub reference_kind: Option<ReferenceKind>,
    /// Odometry pose per scan, in the odometry's own frame (only differences between scans
    /// mean anything), when the source has an odometry channel.
    pub odometry: Option<Vec<Pose2>>,
    /// The scanner's pose in the frame of the point whose positions the source gives
    /// (`t_point_scanner`), where known: the identity when the source's poses are the
    /// scanner's own, `None` when the offset is unknown (the marina files name no lever arm
    /// between the GNSS antenna and the scanner). Reported, not for consumers to apply: a
    /// loader that knows it has already moved rigid reference poses to the scanner (a ROS
    /// bag's body poses through `/tf_static`), and GNSS positions stay the antenna's.
    pub scanner_offset: Option<Pose2>,
    /// Sense in which the reference heading grows, seen from above.
    pub reference_heading_sense: BearingSense,
    /// Nominal time between consecutive scans, seconds (used where scans carry no timestamps).
    pub dt_s: f64,
    /// Time the scanner takes from a scan's first return to its last, seconds, where the
    /// source states it (0: every return of a scan at one instant); `None` when unknown. A
    /// moving scanner's returns are each taken from where it is at their time, in bearing
    /// order: consumers use it to account for that motion within the scan.
    pub sweep_s: Option<f64>,
    /// The sensor's error model.
    pub sensor: SensorModel,
    /// Sense in which the scanner's bearings grow, seen from above.
    pub bearing_sense: BearingSense,
    /// What the loader noticed (see [`LoadWarning`]), in the order found.
    pub warnings: Vec<LoadWarning>,
    /// When only the first scans of the source were kept ([`Dataset::keep_first`]): how many
    /// were asked for and how many the source has. `None`: every scan the loader read.
    pub first_scans: Option<FirstScans>,
}

/// Median step between consecutive poses above which [`LoadWarning::LargeSteps`] is given,
/// metres. An identity start handles far more in an open harbour: from the identity, HD_ICP
/// registered every one of 39 sampled pairs of the synthetic `paper` scenario to within 0.1 m
/// and 1° with 3.6 m steps (32 of 39 with 4.8 m), and the marina files (median step 1.25 m)
/// reproduce the paper. Rooms and corridors are tighter, so the threshold keeps a margin of
/// 1.6 over marina's steps rather than sitting at the harbour's edge. Medians of the data: the
/// synthetic `paper` 0.24 m, `marina-like` 1.21 m, marina 1.25 m, CARMEN `aces` 0.97 m.
pub const LARGE_STEP_M: f64 = 2.0;

/// Median absolute heading change between consecutive poses above which
/// [`LoadWarning::LargeSteps`] is given, degrees. It separates the runs an identity start
/// handles (median turns: synthetic `paper` 0.08°, `marina-like` 0.42°, marina 0.09°; the
/// synthetic harbour even gives back 30° turns from the identity) from the CARMEN `aces` log
/// (10.6°, where HD_ICP from the identity misses most steps), with a factor of 2 to aces.
pub const LARGE_TURN_DEG: f64 = 5.0;

/// Two pose channels' steps between consecutive scans count as equal within this distance,
/// metres: far above the rounding of text logs (6 significant digits: 0.1 mm at 100 m), far
/// below any real odometry error over a step.
pub const SAME_STEP_M: f64 = 1e-3;

/// Two pose channels' steps count as equal within this rotation, degrees (see
/// [`SAME_STEP_M`]).
pub const SAME_TURN_DEG: f64 = 0.05;

/// The scan spacing assumed when neither timestamps nor the user give one, seconds.
pub const ASSUMED_DT_S: f64 = 1.0;

/// The nominal scan spacing from the scans' timestamps: the median step between consecutive
/// timestamps when it is positive; otherwise [`ASSUMED_DT_S`] and the warning that says so.
pub(crate) fn nominal_dt_s(scans: &[Scan]) -> (f64, Option<LoadWarning>) {
    let mut steps: Vec<f64> = scans
        .windows(2)
        .filter_map(|w| Some(w[1].timestamp_s()? - w[0].timestamp_s()?))
        .collect();
    match median_in_place(&mut steps).filter(|d| *d > 0.0) {
        Some(dt_s) => (dt_s, None),
        None => (
            ASSUMED_DT_S,
            Some(LoadWarning::AssumedScanSpacing { dt_s: ASSUMED_DT_S }),
        ),
    }
}

/// Fewest valid returns a scan needs to take part in a pair.
pub const MIN_RETURNS: usize = icp_core::scan::MIN_POINTS;

impl LoadWarning {
    /// Whether [`Dataset::checked`] finds it (from the loaded data, whatever the loader),
    /// rather than a loader (from what it read).
    fn is_check(&self) -> bool {
        matches!(
            self,
            Self::OdometryEqualsReference { .. }
                | Self::LargeSteps { .. }
                | Self::NonIncreasingTimestamps { .. }
                | Self::ShortScan { .. }
        )
    }
}

impl Dataset {
    /// The dataset with the warnings every loader's output is checked for appended:
    /// [`LoadWarning::OdometryEqualsReference`], [`LoadWarning::LargeSteps`],
    /// [`LoadWarning::NonIncreasingTimestamps`] and [`LoadWarning::ShortScan`].
    pub fn checked(mut self) -> Self {
        let found = [
            self.odometry_equals_reference(),
            self.large_steps(),
            self.non_increasing_timestamps(),
            self.short_scan(),
        ];
        self.warnings.extend(found.into_iter().flatten());
        self
    }

    /// The first `n` scans, with their reference and odometry poses, recorded in
    /// [`Dataset::first_scans`] (all of them when the dataset has fewer). The checks of
    /// [`Dataset::checked`] are made again on the scans kept; the loader's own warnings
    /// (what it read from the whole source) stay. The nominal spacing `dt_s` and the
    /// provenance stay the source's.
    pub fn keep_first(mut self, n: usize) -> Self {
        self.first_scans = Some(FirstScans {
            requested: n,
            available: self.scans.len(),
        });
        self.scans.truncate(n);
        for poses in self.reference.iter_mut() {
            poses.truncate(n);
        }
        for poses in self.odometry.iter_mut() {
            poses.truncate(n);
        }
        self.warnings.retain(|w| !w.is_check());
        self.checked()
    }

    /// The odometry poses when they are independent of the reference: present, and not
    /// flagged as a copy of it ([`LoadWarning::OdometryEqualsReference`]).
    pub fn independent_odometry(&self) -> Option<&[Pose2]> {
        let copy = self
            .warnings
            .iter()
            .any(|w| matches!(w, LoadWarning::OdometryEqualsReference { .. }));
        self.odometry.as_deref().filter(|_| !copy)
    }

    /// Sets the nominal scan spacing (a user's `--dt`), which replaces an assumed one.
    pub fn set_dt_s(&mut self, dt_s: f64) -> Result<(), DatasetError> {
        if !(dt_s.is_finite() && dt_s > 0.0) {
            return Err(DatasetError::InvalidParameter {
                name: "dt_s",
                value: dt_s,
                reason: "must be finite and positive",
            });
        }
        self.dt_s = dt_s;
        self.warnings
            .retain(|w| !matches!(w, LoadWarning::AssumedScanSpacing { .. }));
        Ok(())
    }

    /// The warning when the odometry and a rigid reference move alike at every step: each
    /// channel's relative motion between consecutive scans (so a copy in another frame counts
    /// as equal) within [`SAME_STEP_M`] and [`SAME_TURN_DEG`]. Not tested against a reference
    /// that is not a rigid pose.
    pub(crate) fn odometry_equals_reference(&self) -> Option<LoadWarning> {
        let odometry = self.odometry.as_ref()?;
        let reference: Vec<Isometry2<f64>> = self
            .reference
            .as_ref()?
            .iter()
            .map(ReferencePose::scan_pose)
            .collect::<Option<_>>()?;
        let steps = reference.len().min(odometry.len()).checked_sub(1)?;
        let same = (0..steps).all(|k| {
            let a = reference[k].inverse() * reference[k + 1];
            let b = odometry[k].isometry().inverse() * odometry[k + 1].isometry();
            let d = a.inverse() * b;
            d.translation.vector.norm() <= SAME_STEP_M
                && d.rotation.angle().to_degrees().abs() <= SAME_TURN_DEG
        });
        (steps > 0 && same).then_some(LoadWarning::OdometryEqualsReference { steps })
    }

    /// The warning when the median step between consecutive poses (the reference's, else the
    /// odometry's) exceeds [`LARGE_STEP_M`] or [`LARGE_TURN_DEG`].
    fn large_steps(&self) -> Option<LoadWarning> {
        let (measured_on, poses): (PoseChannel, Vec<(f64, f64, f64)>) =
            match (&self.reference, &self.odometry) {
                (Some(r), _) => (
                    PoseChannel::Reference,
                    r.iter().map(|p| (p.x_m, p.y_m, p.heading_rad)).collect(),
                ),
                (None, Some(o)) => (
                    PoseChannel::Odometry,
                    o.iter().map(|p| (p.x_m, p.y_m, p.yaw_rad)).collect(),
                ),
                (None, None) => return None,
            };
        let (mut steps, mut turns): (Vec<f64>, Vec<f64>) = poses
            .windows(2)
            .map(|w| {
                let ((x0, y0, h0), (x1, y1, h1)) = (w[0], w[1]);
                (
                    (x1 - x0).hypot(y1 - y0),
                    wrap_deg((h1 - h0).to_degrees()).abs(),
                )
            })
            .unzip();
        let median_step_m = median_in_place(&mut steps)?;
        let median_turn_deg = median_in_place(&mut turns)?;
        (median_step_m > LARGE_STEP_M || median_turn_deg > LARGE_TURN_DEG).then_some(
            LoadWarning::LargeSteps {
                median_step_m,
                median_turn_deg,
                measured_on,
            },
        )
    }

    /// The warning when some consecutive timestamps do not increase.
    fn non_increasing_timestamps(&self) -> Option<LoadWarning> {
        let bad: Vec<usize> = (1..self.scans.len())
            .filter(|&k| {
                matches!(
                    (self.scans[k - 1].timestamp_s(), self.scans[k].timestamp_s()),
                    (Some(a), Some(b)) if b <= a
                )
            })
            .map(|k| k - 1)
            .collect();
        let first_scan = *bad.first()?;
        Some(LoadWarning::NonIncreasingTimestamps {
            pairs: bad.len(),
            first_scan,
        })
    }

    /// The warning when more than half the scans share a reading count (returns and
    /// no-returns: a scanner's fixed count) and some scan has fewer.
    fn short_scan(&self) -> Option<LoadWarning> {
        let readings: Vec<usize> = self
            .scans
            .iter()
            .map(|s| s.len() + s.no_returns())
            .collect();
        let mut sorted = readings.clone();
        sorted.sort_unstable();
        // A count more than half the scans share is their median.
        let usual_readings = *sorted.get(sorted.len() / 2)?;
        let sharing = readings.iter().filter(|&&r| r == usual_readings).count();
        if 2 * sharing <= readings.len() {
            return None;
        }
        let mut short = (0..readings.len()).filter(|&k| readings[k] < usual_readings);
        let scan = short.next()?;
        Some(LoadWarning::ShortScan {
            scan,
            readings: readings[scan],
            neighbour_readings: [scan.checked_sub(1), Some(scan + 1)]
                .into_iter()
                .flatten()
                .filter_map(|k| readings.get(k).copied())
                .collect(),
            usual_readings,
            scans: 1 + short.count(),
        })
    }

    /// Consecutive pairs `(k, k+1)`, and the ones skipped because a scan has fewer than
    /// [`MIN_RETURNS`] valid returns.
    pub fn consecutive_pairs(&self) -> (Vec<ScanPair>, Vec<SkippedPair>) {
        let mut pairs = Vec::new();
        let mut skipped = Vec::new();
        for k in 1..self.scans.len() {
            let pair = ScanPair {
                source: k - 1,
                reference: k,
            };
            let short: Vec<String> = [k - 1, k]
                .into_iter()
                .filter(|&i| self.scans[i].len() < MIN_RETURNS)
                .map(|i| {
                    format!(
                        "scan {i} has {} valid returns (< {MIN_RETURNS})",
                        self.scans[i].len()
                    )
                })
                .collect();
            if short.is_empty() {
                pairs.push(pair);
            } else {
                skipped.push(SkippedPair {
                    pair,
                    reason: short.join("; "),
                });
            }
        }
        (pairs, skipped)
    }

    /// True when the dataset has a reference and every pose of it is a rigid 2D pose of the
    /// scanner (pose errors, a reference start and the basin protocol need one).
    pub fn rigid_reference(&self) -> bool {
        self.reference
            .as_ref()
            .is_some_and(|r| r.iter().all(|p| p.scan_yaw_rad.is_some()))
    }

    /// Time between the two scans of a pair: from timestamps when both have one, else the
    /// nominal `dt_s` times the index difference.
    pub fn pair_dt_s(&self, pair: ScanPair) -> f64 {
        match (
            self.scans[pair.source].timestamp_s(),
            self.scans[pair.reference].timestamp_s(),
        ) {
            (Some(a), Some(b)) => b - a,
            _ => self.dt_s * (pair.reference - pair.source) as f64,
        }
    }
}
