//! A deterministic synthetic harbour basin scanned by a simulated Scanse Sweep, with exact
//! ground truth for every scan ([`ReferenceKind::GroundTruth`]: the scanner's own pose, so the
//! scanner offset is the identity). There is no odometry channel.
//!
//! The world is built around the vessel's track, like the Gdynia yacht basin of the paper:
//! concrete quays on both sides (polylines following the track at 14 m to port and 11 m to
//! starboard), finger piers on the starboard quay, moored hulls along the port quay, and end
//! walls closing the basin; beyond 40 m the water returns nothing. The scanner casts one ray
//! per beam against these segments and adds the sensor model's noise (eq. 8): the beam leaves
//! at its nominal bearing plus `N(0, σ_α)` and the range gets `N(0, σ_r(r))`. Each return
//! keeps the true normal of the surface it came from ([`Scan::true_normals`]); spurious
//! returns have none.
//!
//! Frames: the world is east-north (x east, y north); the scanner's `+x` is the bow and its
//! bearings grow counter-clockwise; the reference heading is navigational (clockwise from
//! north), so yaw `ψ = 90° − HDG`.

use icp_core::{BearingSense, Scan, SensorModel};
use nalgebra::{Isometry2, Point2, Vector2};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use serde::{Deserialize, Serialize};

use crate::dataset::{Dataset, Pose2, Provenance, ReferenceKind, ReferencePose};
use crate::DatasetError;

/// A heading change spread over a range of scans (a smooth cosine ramp).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Turn {
    /// Scan at which the turn starts.
    pub start_scan: usize,
    /// Scan at which it ends.
    pub end_scan: usize,
    /// Heading change, degrees, clockwise positive (to starboard).
    pub heading_change_deg: f64,
}

/// The simulated scanner.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScannerConfig {
    /// Error model of the returns.
    pub sensor: SensorModel,
    /// When false the returns are exact (the sensor model still serves the weights).
    pub noise: bool,
    /// Largest range, metres; farther surfaces give no return.
    pub max_range_m: f64,
    /// Rotation rate of the head, revolutions per second.
    pub rotation_hz: f64,
    /// Range samples per second. With the rotation rate it sets the bearing spacing:
    /// 3,750 Hz at 5 Hz gives 750 beams per revolution, the public data's 0.48°.
    pub sample_rate_hz: f64,
    /// Probability that a beam that hit something returns nothing.
    pub dropout_prob: f64,
    /// Fraction of beams that return a spurious range (spray, water): uniform in 1 m to half
    /// the maximum range.
    pub gross_error_fraction: f64,
    /// When true each beam is taken at its own time within the revolution, from the pose the
    /// vessel has then, and reported as if from the scan's start pose.
    pub motion_distortion: bool,
}

impl ScannerConfig {
    /// Beams per revolution: samples per second over revolutions per second, rounded.
    pub fn beams_per_rev(&self) -> usize {
        let beams = (self.sample_rate_hz / self.rotation_hz).round();
        if beams.is_finite() && beams >= 0.0 {
            beams as usize
        } else {
            0
        }
    }

    /// Time of one revolution, seconds.
    pub fn rotation_period_s(&self) -> f64 {
        1.0 / self.rotation_hz
    }
}

impl Default for ScannerConfig {
    fn default() -> Self {
        Self {
            sensor: SensorModel::sweep(),
            noise: true,
            max_range_m: 40.0,
            rotation_hz: 5.0,
            sample_rate_hz: 3750.0,
            dropout_prob: 0.05,
            gross_error_fraction: 0.005,
            motion_distortion: false,
        }
    }
}

/// A synthetic run: the track, the timing and the scanner.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    /// Name, e.g. `paper`.
    pub name: String,
    /// Number of scans.
    pub n_scans: usize,
    /// Time between scans, seconds.
    pub dt_s: f64,
    /// Mean speed over ground, m/s.
    pub speed_mps: f64,
    /// Amplitude of a slow (30 s) speed oscillation, m/s.
    pub speed_wobble_mps: f64,
    /// Heading at the first scan, degrees (navigational).
    pub initial_heading_deg: f64,
    /// Amplitude of a short (8 s) yaw oscillation, degrees: a small hull in a chop.
    pub yaw_wobble_deg: f64,
    /// The turns.
    pub turns: Vec<Turn>,
    /// The scanner.
    pub scanner: ScannerConfig,
    /// Seed of the world's details and of the noise.
    pub seed: u64,
}

impl Scenario {
    /// The paper's run: 865 scans every 0.2 s at about 1.2 m/s (about 208 m), turning to
    /// starboard by 85° over scans 220–365 and back to port by 68° over scans 720–825.
    pub fn paper() -> Self {
        Self {
            name: "paper".into(),
            n_scans: 865,
            dt_s: 0.2,
            speed_mps: 1.2,
            speed_wobble_mps: 0.05,
            initial_heading_deg: 270.0,
            yaw_wobble_deg: 0.6,
            turns: vec![
                Turn {
                    start_scan: 220,
                    end_scan: 365,
                    heading_change_deg: 85.0,
                },
                Turn {
                    start_scan: 720,
                    end_scan: 825,
                    heading_change_deg: -68.0,
                },
            ],
            scanner: ScannerConfig::default(),
            seed: 2019,
        }
    }

    /// Like the public marina files: the same track sampled about every 1 s (177 scans).
    pub fn marina_like() -> Self {
        let paper = Self::paper();
        let scale = |k: usize| (k as f64 * 177.0 / 865.0).round() as usize;
        Self {
            name: "marina-like".into(),
            n_scans: 177,
            dt_s: 1.0,
            turns: paper
                .turns
                .iter()
                .map(|t| Turn {
                    start_scan: scale(t.start_scan),
                    end_scan: scale(t.end_scan),
                    ..*t
                })
                .collect(),
            ..paper
        }
    }

    /// A scenario by name: `paper` or `marina-like`.
    pub fn by_name(name: &str) -> Option<Self> {
        match name {
            "paper" => Some(Self::paper()),
            "marina-like" | "marina_like" => Some(Self::marina_like()),
            _ => None,
        }
    }

    fn validate(&self) -> Result<(), DatasetError> {
        let s = &self.scanner;
        let checks: [(&'static str, f64, bool); 8] = [
            ("n_scans", self.n_scans as f64, self.n_scans >= 2),
            ("dt_s", self.dt_s, self.dt_s.is_finite() && self.dt_s > 0.0),
            (
                "speed_mps",
                self.speed_mps,
                self.speed_mps.is_finite() && self.speed_mps >= 0.0,
            ),
            (
                "max_range_m",
                s.max_range_m,
                s.max_range_m.is_finite() && s.max_range_m > 1.0,
            ),
            (
                "sample_rate_hz",
                s.sample_rate_hz,
                s.sample_rate_hz.is_finite()
                    && s.beams_per_rev() >= 3
                    && s.beams_per_rev() <= 1_000_000,
            ),
            (
                "dropout_prob",
                s.dropout_prob,
                (0.0..=1.0).contains(&s.dropout_prob),
            ),
            (
                "gross_error_fraction",
                s.gross_error_fraction,
                (0.0..=1.0).contains(&s.gross_error_fraction),
            ),
            (
                "rotation_hz",
                s.rotation_hz,
                s.rotation_hz.is_finite() && s.rotation_hz > 0.0,
            ),
        ];
        for (name, value, ok) in checks {
            if !ok {
                return Err(DatasetError::InvalidParameter {
                    name,
                    value,
                    reason: "out of range for a synthetic scenario",
                });
            }
        }
        let finite = [
            self.speed_wobble_mps,
            self.initial_heading_deg,
            self.yaw_wobble_deg,
        ];
        if finite.iter().any(|v| !v.is_finite())
            || self.turns.iter().any(|t| !t.heading_change_deg.is_finite())
        {
            return Err(DatasetError::InvalidParameter {
                name: "scenario",
                value: f64::NAN,
                reason: "every angle and speed must be finite",
            });
        }
        if self.turns.iter().any(|t| t.end_scan <= t.start_scan) {
            return Err(DatasetError::InvalidParameter {
                name: "turns",
                value: f64::NAN,
                reason: "a turn must end after it starts",
            });
        }
        s.sensor.validate().map_err(|e| DatasetError::BadValue {
            path: "<scenario>".into(),
            what: e.to_string(),
        })
    }

    /// Navigational heading at time `t_s`, degrees (unwrapped).
    fn heading_deg(&self, t_s: f64) -> f64 {
        let mut h = self.initial_heading_deg
            + self.yaw_wobble_deg * (std::f64::consts::TAU * t_s / 8.0).sin();
        for turn in &self.turns {
            let (t0, t1) = (
                turn.start_scan as f64 * self.dt_s,
                turn.end_scan as f64 * self.dt_s,
            );
            let u = ((t_s - t0) / (t1 - t0)).clamp(0.0, 1.0);
            h += turn.heading_change_deg * 0.5 * (1.0 - (std::f64::consts::PI * u).cos());
        }
        h
    }

    fn speed_mps(&self, t_s: f64) -> f64 {
        self.speed_mps + self.speed_wobble_mps * (std::f64::consts::TAU * t_s / 30.0).sin()
    }
}

/// The vessel's track: scanner poses sampled finely in time.
struct Track {
    step_s: f64,
    poses: Vec<Isometry2<f64>>,
}

impl Track {
    const SUBSTEPS: usize = 50;

    fn new(scenario: &Scenario, duration_s: f64) -> Self {
        let step_s = scenario.dt_s / Self::SUBSTEPS as f64;
        let n = (duration_s / step_s).ceil() as usize + 2;
        let yaw = |t: f64| (90.0 - scenario.heading_deg(t)).to_radians();
        let mut p = Vector2::zeros();
        let mut poses = Vec::with_capacity(n);
        for i in 0..n {
            let t = i as f64 * step_s;
            poses.push(Isometry2::new(p, yaw(t)));
            // Midpoint rule; the truth is whatever is integrated here, so it is exact by
            // construction whatever the integration error.
            let tm = t + 0.5 * step_s;
            p += Vector2::new(yaw(tm).cos(), yaw(tm).sin()) * scenario.speed_mps(tm) * step_s;
        }
        Self { step_s, poses }
    }

    /// Pose at time `t_s`: exact at the samples, interpolated between them.
    fn pose_at(&self, t_s: f64) -> Isometry2<f64> {
        let x = t_s / self.step_s;
        let i = (x.floor() as usize).min(self.poses.len() - 2);
        let f = x - i as f64;
        if f == 0.0 {
            return self.poses[i];
        }
        self.poses[i].lerp_slerp(&self.poses[i + 1], f)
    }
}

/// A straight piece of a wall or hull side, world frame, metres.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Segment {
    /// One end.
    pub a: Point2<f64>,
    /// The other end.
    pub b: Point2<f64>,
}

impl Segment {
    /// Distance along the ray `o + t u` (|u| = 1) to the segment, if it is hit at `t > 0`.
    fn hit(&self, o: &Point2<f64>, u: &Vector2<f64>) -> Option<f64> {
        let e = self.b - self.a;
        let denom = u.x * e.y - u.y * e.x;
        if denom.abs() < 1e-15 {
            return None;
        }
        let w = self.a - o;
        let t = (w.x * e.y - w.y * e.x) / denom;
        let s = (w.x * u.y - w.y * u.x) / denom;
        (t > 1e-9 && (0.0..=1.0).contains(&s)).then_some(t)
    }

    /// The segment's unit normal facing back along a ray of direction `u` that hits it (so
    /// `nᵀ(o − p) > 0` for the ray's origin `o` and hit `p`); `None` if the ray runs along it.
    fn normal_facing(&self, u: &Vector2<f64>) -> Option<Vector2<f64>> {
        let e = self.b - self.a;
        let n = Vector2::new(-e.y, e.x).try_normalize(0.0)?;
        match n.dot(u) {
            along if along < 0.0 => Some(n),
            along if along > 0.0 => Some(-n),
            _ => None,
        }
    }

    /// Distance from `p` to the segment, metres.
    pub fn distance_to(&self, p: &Point2<f64>) -> f64 {
        let e = self.b - self.a;
        let s = ((p - self.a).dot(&e) / e.norm_squared()).clamp(0.0, 1.0);
        (self.a + e * s - p).norm()
    }
}

/// Builds the basin around the track.
fn build_world(track: &Track, duration_s: f64, rng: &mut ChaCha8Rng) -> Vec<Segment> {
    const PORT_QUAY_M: f64 = 14.0;
    const STARBOARD_QUAY_M: f64 = 11.0;
    const SAMPLE_M: f64 = 2.0;
    const END_MARGIN_M: f64 = 15.0;
    // Centre-line samples every ~2 m, extended straight beyond both ends.
    let mut centre: Vec<(Point2<f64>, Vector2<f64>)> = Vec::new();
    let mut since = f64::INFINITY;
    let mut last = track.poses[0].translation.vector;
    let n_used = ((duration_s / track.step_s).ceil() as usize + 1).min(track.poses.len());
    for pose in &track.poses[..n_used] {
        since += (pose.translation.vector - last).norm();
        last = pose.translation.vector;
        if since >= SAMPLE_M {
            let dir = pose.rotation * Vector2::x();
            centre.push((Point2::from(pose.translation.vector), dir));
            since = 0.0;
        }
    }
    let (p0, d0) = centre[0];
    let (p1, d1) = *centre.last().expect("the track has samples");
    centre.insert(0, (p0 - d0 * END_MARGIN_M, d0));
    centre.push((p1 + d1 * END_MARGIN_M, d1));
    let left = |(p, d): &(Point2<f64>, Vector2<f64>), off: f64| p + Vector2::new(-d.y, d.x) * off;
    let port: Vec<Point2<f64>> = centre.iter().map(|c| left(c, PORT_QUAY_M)).collect();
    let starboard: Vec<Point2<f64>> = centre.iter().map(|c| left(c, -STARBOARD_QUAY_M)).collect();
    let mut segs = Vec::new();
    for quay in [&port, &starboard] {
        segs.extend(quay.windows(2).map(|w| Segment { a: w[0], b: w[1] }));
    }
    // End walls close the basin.
    segs.push(Segment {
        a: port[0],
        b: starboard[0],
    });
    segs.push(Segment {
        a: *port.last().expect("non-empty"),
        b: *starboard.last().expect("non-empty"),
    });
    // Finger piers off the starboard quay, moored hulls along the port quay.
    let mut along = 0.0;
    let mut next_pier = 10.0;
    let mut next_hull = 6.0;
    for w in centre.windows(2) {
        along += (w[1].0 - w[0].0).norm();
        let (p, d) = w[1];
        let n = Vector2::new(-d.y, d.x);
        if along >= next_pier {
            segs.push(Segment {
                a: p - n * STARBOARD_QUAY_M,
                b: p - n * (STARBOARD_QUAY_M - 5.0),
            });
            next_pier += 24.0 + rng.random_range(-4.0..4.0);
        }
        if along >= next_hull {
            if rng.random_bool(0.8) {
                let (beam, inner) = (rng.random_range(2.2..3.2), rng.random_range(6.5..8.0));
                let (outer, half) = (PORT_QUAY_M - 0.5, 0.5 * beam);
                let c = [
                    p + n * outer - d * half,
                    p + n * (inner + 1.0) - d * half,
                    p + n * inner,
                    p + n * (inner + 1.0) + d * half,
                    p + n * outer + d * half,
                ];
                segs.extend(c.windows(2).map(|w| Segment { a: w[0], b: w[1] }));
                segs.push(Segment { a: c[4], b: c[0] });
            }
            next_hull += 5.0 + rng.random_range(0.0..6.0);
        }
    }
    segs
}

/// The segments near one revolution, binned by the directions in which they can be seen from
/// the revolution's beam origins, so that a beam is tested only against its sector's segments.
///
/// Exact: every origin lies within `spread` of `centre`, so a point `X` of a segment hit by a
/// beam of direction `ψ` is seen from `centre` within `asin(spread / D)` of `ψ`, `D` being the
/// segment's distance from `centre`. A segment is listed in every sector its arc (as seen from
/// `centre`) widened by that much overlaps; one closer than `spread` in all of them. The
/// nearest hit among a sector's segments is therefore the nearest among all of them.
struct Sectors<'w> {
    segments: Vec<&'w Segment>,
    /// `members[start[k]..start[k + 1]]` index `segments` seen in sector `k`.
    start: Vec<u32>,
    members: Vec<u32>,
}

impl<'w> Sectors<'w> {
    /// Sectors over the full turn: a beam meets a few segments instead of every near one.
    const COUNT: usize = 512;
    /// Added to every widening, radians: far above the rounding of the angles.
    const MARGIN_RAD: f64 = 1e-6;

    /// Width of a sector, radians.
    const WIDTH_RAD: f64 = std::f64::consts::TAU / Self::COUNT as f64;

    /// Where `angle_rad` (from −π) falls, in sectors: its integer part is the sector.
    fn position(angle_rad: f64) -> f64 {
        (angle_rad + std::f64::consts::PI) / Self::WIDTH_RAD
    }

    fn sector(angle_rad: f64) -> usize {
        (Self::position(angle_rad).floor().max(0.0) as usize).min(Self::COUNT - 1)
    }

    /// The first sector and the number of sectors of `segment` seen from `centre`.
    fn span(segment: &Segment, centre: &Point2<f64>, spread: f64) -> (usize, usize) {
        let d = segment.distance_to(centre);
        if d.is_nan() || d <= spread {
            return (0, Self::COUNT);
        }
        let widen = (spread / d).min(1.0).asin() + Self::MARGIN_RAD;
        let angle = |p: &Point2<f64>| (p.y - centre.y).atan2(p.x - centre.x);
        let (from, to) = (angle(&segment.a), angle(&segment.b));
        // The arc from `from` to `to` the straight segment subtends: the shorter one (< π).
        let mut sweep = to - from;
        if sweep > std::f64::consts::PI {
            sweep -= std::f64::consts::TAU;
        } else if sweep < -std::f64::consts::PI {
            sweep += std::f64::consts::TAU;
        }
        let (lo, width) = (from.min(from + sweep) - widen, sweep.abs() + 2.0 * widen);
        // Whole sectors from the one holding `lo` (wrapped into the turn) to the one holding
        // `lo + width`, counted without wrapping.
        let (first, last) = (
            Self::position(lo).floor(),
            Self::position(lo + width).floor(),
        );
        let count = (last - first) as usize + 1;
        if count >= Self::COUNT {
            return (0, Self::COUNT);
        }
        (first.rem_euclid(Self::COUNT as f64) as usize, count)
    }

    fn new(segments: Vec<&'w Segment>, centre: &Point2<f64>, spread: f64) -> Self {
        let spans: Vec<(usize, usize)> = segments
            .iter()
            .map(|s| Self::span(s, centre, spread))
            .collect();
        let mut start = vec![0u32; Self::COUNT + 1];
        for &(first, count) in &spans {
            for k in 0..count {
                start[(first + k) % Self::COUNT + 1] += 1;
            }
        }
        for k in 0..Self::COUNT {
            start[k + 1] += start[k];
        }
        let mut fill = start.clone();
        let mut members = vec![0u32; start[Self::COUNT] as usize];
        for (i, &(first, count)) in spans.iter().enumerate() {
            for k in 0..count {
                let slot = &mut fill[(first + k) % Self::COUNT];
                members[*slot as usize] = i as u32;
                *slot += 1;
            }
        }
        Self {
            segments,
            start,
            members,
        }
    }

    /// The nearest hit of the ray `o + t u` (`|u| = 1`, `o` within the spread): its distance
    /// `t`, metres, and the segment hit (of several at exactly that distance, the first).
    fn cast(&self, o: &Point2<f64>, u: &Vector2<f64>) -> Option<(f64, &'w Segment)> {
        let k = Self::sector(u.y.atan2(u.x));
        self.members[self.start[k] as usize..self.start[k + 1] as usize]
            .iter()
            .filter_map(|&i| {
                let segment = self.segments[i as usize];
                segment.hit(o, u).map(|t| (t, segment))
            })
            .fold(None, |nearest, (t, segment)| match nearest {
                Some((best, _)) if best <= t => nearest,
                _ => Some((t, segment)),
            })
    }
}

/// One revolution's readings, one entry per beam, in the scan frame (the scanner's frame at
/// the revolution's start).
#[derive(Clone, Debug, PartialEq)]
pub struct Revolution {
    /// Ranges, metres; NaN: no return.
    pub ranges_m: Vec<f64>,
    /// Nominal bearings, radians.
    pub bearings_rad: Vec<f64>,
    /// The true surface normal behind each return: the unit normal (unitless, scan frame) of
    /// the segment hit, facing the beam's origin. `None` for a spurious return and for a beam
    /// without return.
    pub true_normals: Vec<Option<Vector2<f64>>>,
}

/// Casts the scanner's beams against a world.
pub struct Scanner<'a> {
    config: &'a ScannerConfig,
    world: &'a [Segment],
}

impl<'a> Scanner<'a> {
    /// A scanner in `world`.
    pub fn new(config: &'a ScannerConfig, world: &'a [Segment]) -> Self {
        Self { config, world }
    }

    /// One revolution starting at `t_s`, with the scanner at `pose_at(t)` (world frame):
    /// parallel ranges (NaN = no return), nominal bearings and true normals. `noise_rng` draws
    /// the sensor noise and `event_rng` the beam phase, dropouts and gross errors, so a
    /// noise-free and a noisy scan from the same event stream sample the same beams.
    pub fn scan(
        &self,
        pose_at: &dyn Fn(f64) -> Isometry2<f64>,
        t_s: f64,
        noise_rng: &mut ChaCha8Rng,
        event_rng: &mut ChaCha8Rng,
    ) -> Revolution {
        let sc = self.config;
        let unit = Normal::new(0.0, 1.0).expect("unit normal");
        let beams = sc.beams_per_rev();
        let beam_step = std::f64::consts::TAU / beams as f64;
        let start = pose_at(t_s);
        let world_to_scan = start.rotation.inverse();
        let centre = Point2::from(start.translation.vector);
        let reach = sc.max_range_m + if sc.motion_distortion { 2.0 } else { 0.0 };
        let near: Vec<&Segment> = self
            .world
            .iter()
            .filter(|s| s.distance_to(&centre) <= reach)
            .collect();
        let poses: Vec<Isometry2<f64>> = (0..beams)
            .map(|j| {
                if sc.motion_distortion {
                    pose_at(t_s + sc.rotation_period_s() * j as f64 / beams as f64)
                } else {
                    start
                }
            })
            .collect();
        let spread = poses
            .iter()
            .map(|p| (Point2::from(p.translation.vector) - centre).norm())
            .fold(0.0, f64::max);
        let sectors = Sectors::new(near, &centre, spread);
        // Each revolution starts at a random fraction of a beam, as a free-running scanner does.
        let phase = event_rng.random_range(0.0..beam_step);
        let mut ranges = Vec::with_capacity(beams);
        let mut bearings = Vec::with_capacity(beams);
        let mut normals = Vec::with_capacity(beams);
        for (j, pose) in poses.iter().enumerate() {
            let bearing = phase + j as f64 * beam_step;
            let (n_alpha, n_range) = (unit.sample(noise_rng), unit.sample(noise_rng));
            let alpha_err = if sc.noise {
                sc.sensor.sigma_alpha_rad * n_alpha
            } else {
                0.0
            };
            let dir = pose.rotation
                * Vector2::new((bearing + alpha_err).cos(), (bearing + alpha_err).sin());
            let origin = Point2::from(pose.translation.vector);
            let hit = sectors
                .cast(&origin, &dir)
                .filter(|&(t, _)| t <= sc.max_range_m);
            let (mut r, mut normal) = (f64::NAN, None);
            if let Some((hit, segment)) = hit {
                if !event_rng.random_bool(sc.dropout_prob) {
                    r = hit
                        + if sc.noise {
                            sc.sensor.sigma_r_m(hit) * n_range
                        } else {
                            0.0
                        };
                    normal = segment.normal_facing(&dir).map(|n| world_to_scan * n);
                }
            }
            if event_rng.random_bool(sc.gross_error_fraction) {
                r = event_rng.random_range(1.0..0.5 * sc.max_range_m);
                normal = None;
            }
            let returned = r > 0.0;
            ranges.push(if returned { r } else { f64::NAN });
            bearings.push(bearing);
            normals.push(normal.filter(|_| returned));
        }
        Revolution {
            ranges_m: ranges,
            bearings_rad: bearings,
            true_normals: normals,
        }
    }
}

/// Generates the scenario's dataset.
pub fn generate(scenario: &Scenario) -> Result<Dataset, DatasetError> {
    scenario.validate()?;
    let sc = &scenario.scanner;
    let duration_s = (scenario.n_scans - 1) as f64 * scenario.dt_s + sc.rotation_period_s();
    let track = Track::new(scenario, duration_s);
    let mut event_rng = ChaCha8Rng::seed_from_u64(scenario.seed);
    let mut noise_rng = ChaCha8Rng::seed_from_u64(scenario.seed ^ 0x005e_ed0f_5e45);
    let world = build_world(&track, duration_s, &mut event_rng);
    let scanner = Scanner::new(sc, &world);
    let pose_at = |t: f64| track.pose_at(t);
    let mut scans = Vec::with_capacity(scenario.n_scans);
    let mut reference = Vec::with_capacity(scenario.n_scans);
    for k in 0..scenario.n_scans {
        let t_k = k as f64 * scenario.dt_s;
        let rev = scanner.scan(&pose_at, t_k, &mut noise_rng, &mut event_rng);
        let scan =
            Scan::from_polar_with_true_normals(&rev.ranges_m, &rev.bearings_rad, &rev.true_normals)
                .and_then(|s| s.with_timestamp(t_k))
                .map_err(|source| DatasetError::Scan {
                    path: "<synthetic>".into(),
                    scan: k,
                    source,
                })?;
        scans.push(scan);
        let pose_k = track.pose_at(t_k);
        let yaw = pose_k.rotation.angle();
        reference.push(ReferencePose {
            x_m: pose_k.translation.x,
            y_m: pose_k.translation.y,
            heading_rad: icp_core::motion::wrap_360(90.0 - yaw.to_degrees()).to_radians(),
            scan_yaw_rad: Some(yaw),
        });
    }
    Ok(Dataset {
        provenance: Provenance {
            name: format!("synthetic:{}", scenario.name),
            description: format!(
                "synthetic harbour basin, scenario {:?}: {} scans every {} s at {} m/s, seed {}",
                scenario.name, scenario.n_scans, scenario.dt_s, scenario.speed_mps, scenario.seed
            ),
            files: Vec::new(),
        },
        scans,
        reference: Some(reference),
        reference_kind: Some(ReferenceKind::GroundTruth),
        odometry: None,
        scanner_offset: Some(Pose2::IDENTITY),
        reference_heading_sense: BearingSense::Clockwise,
        dt_s: scenario.dt_s,
        sensor: sc.sensor,
        bearing_sense: BearingSense::CounterClockwise,
        warnings: Vec::new(),
    }
    .checked())
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn point() -> impl Strategy<Value = Point2<f64>> {
        (-60.0..60.0f64, -60.0..60.0f64).prop_map(|(x, y)| Point2::new(x, y))
    }

    proptest! {
        /// The sector index gives bit for bit the nearest hit of every segment, for beams from
        /// anywhere within the spread, whatever the segments: long, tiny, degenerate, around
        /// the centre or across the ±π seam of the angles.
        #[test]
        fn sector_cast_equals_the_brute_force_cast(
            ends in prop::collection::vec((point(), point(), 0.0..1.0f64), 1..40),
            spread in prop_oneof![Just(0.0), 0.0..3.0f64],
            origins in prop::collection::vec((0.0..1.0f64, -3.2..3.2f64), 1..6),
            directions in prop::collection::vec(-3.2..3.2f64, 64),
        ) {
            // A third of the segments are short (down to a point), near wherever `a` is.
            let world: Vec<Segment> = ends
                .iter()
                .map(|&(a, b, f)| Segment { a, b: if f < 0.33 { a + (b - a) * f * f } else { b } })
                .collect();
            let centre = Point2::new(1.5, -2.0);
            let sectors = Sectors::new(world.iter().collect(), &centre, spread);
            for &(r, phi) in &origins {
                let o = centre + Vector2::new(phi.cos(), phi.sin()) * (r * spread);
                for &psi in &directions {
                    let u = Vector2::new(psi.cos(), psi.sin());
                    let brute = world
                        .iter()
                        .filter_map(|s| s.hit(&o, &u))
                        .fold(f64::INFINITY, f64::min);
                    let cast = sectors.cast(&o, &u);
                    prop_assert_eq!(cast.map_or(f64::INFINITY, |(t, _)| t).to_bits(), brute.to_bits());
                    // The segment named is the first one hit at exactly that distance.
                    let first = world.iter().find(|s| s.hit(&o, &u) == Some(brute));
                    let same = match (cast, first) {
                        (Some((_, s)), Some(f)) => std::ptr::eq(s, f),
                        (None, None) => true,
                        _ => false,
                    };
                    prop_assert!(same, "{:?} vs {:?}", cast, first);
                }
            }
        }
    }

    /// Noise-free beams in the paper's harbour, with many spurious returns, with and without
    /// motion distortion: a return with a true normal lies on a world segment, at exactly the
    /// distance of its beam's nearest hit, and its normal (turned back into the world) is that
    /// segment's, facing the beam's origin; a return without one is spurious.
    #[test]
    fn true_normals_are_the_normals_of_the_surfaces_hit() {
        let scenario = Scenario::paper();
        let duration_s = (scenario.n_scans - 1) as f64 * scenario.dt_s + 0.2;
        let track = Track::new(&scenario, duration_s);
        let mut event_rng = ChaCha8Rng::seed_from_u64(5);
        let world = build_world(&track, duration_s, &mut event_rng);
        let mut noise_rng = ChaCha8Rng::seed_from_u64(6);
        let pose_at = |t: f64| track.pose_at(t);
        for motion_distortion in [false, true] {
            let sc = ScannerConfig {
                noise: false,
                gross_error_fraction: 0.05,
                motion_distortion,
                rotation_hz: 1.0, // a slow head: the vessel moves 1.2 m and turns within a scan
                sample_rate_hz: 750.0,
                ..ScannerConfig::default()
            };
            let scanner = Scanner::new(&sc, &world);
            let (mut on_surfaces, mut spurious) = (0, 0);
            for t_s in [0.0, 30.0, 50.0, 60.0, 100.0, 150.0, 160.0] {
                let rev = scanner.scan(&pose_at, t_s, &mut noise_rng, &mut event_rng);
                let start = pose_at(t_s);
                let beams = rev.ranges_m.len();
                for (j, ((&r, &a), n)) in rev
                    .ranges_m
                    .iter()
                    .zip(&rev.bearings_rad)
                    .zip(&rev.true_normals)
                    .enumerate()
                {
                    if r.is_nan() {
                        assert_eq!(*n, None, "a beam without return has no normal");
                        continue;
                    }
                    let pose = if motion_distortion {
                        pose_at(t_s + sc.rotation_period_s() * j as f64 / beams as f64)
                    } else {
                        start
                    };
                    let origin = Point2::from(pose.translation.vector);
                    let u = pose.rotation * Vector2::new(a.cos(), a.sin());
                    let nearest = world
                        .iter()
                        .filter_map(|s| s.hit(&origin, &u))
                        .fold(f64::INFINITY, f64::min);
                    let Some(n) = n else {
                        assert_ne!(r, nearest, "beam {j} at {t_s} s: a return without normal");
                        spurious += 1;
                        continue;
                    };
                    assert_eq!(r.to_bits(), nearest.to_bits(), "beam {j} at {t_s} s");
                    assert!((n.norm() - 1.0).abs() < 1e-15, "{n}");
                    let p = pose * Point2::new(r * a.cos(), r * a.sin());
                    let n_world = start.rotation * n;
                    let matches = world
                        .iter()
                        .filter(|s| s.distance_to(&p) < 1e-9)
                        .map(|s| {
                            let e = (s.b - s.a).normalize();
                            let m = Vector2::new(-e.y, e.x);
                            let m = if m.dot(&(origin - p)) > 0.0 { m } else { -m };
                            (n_world - m).norm()
                        })
                        .fold(f64::INFINITY, f64::min);
                    assert!(
                        matches < 1e-12,
                        "beam {j} at {t_s} s: {n_world} is off by {matches}"
                    );
                    on_surfaces += 1;
                }
            }
            // 7 revolutions of 750 beams, 5 % of them spurious.
            assert!(on_surfaces > 3000, "{on_surfaces}");
            assert!((150..400).contains(&spurious), "{spurious}");
        }
    }

    #[test]
    fn a_segment_across_the_seam_is_found_on_both_sides() {
        let wall = Segment {
            a: Point2::new(-10.0, -3.0),
            b: Point2::new(-10.0, 3.0),
        };
        let sectors = Sectors::new(vec![&wall], &Point2::origin(), 0.0);
        for psi in [std::f64::consts::PI, -std::f64::consts::PI, 3.0, -3.0] {
            let u = Vector2::new(psi.cos(), psi.sin());
            let (t, _) = sectors.cast(&Point2::origin(), &u).unwrap();
            assert!((t - 10.0 / psi.cos().abs()).abs() < 1e-9, "{psi}: {t}");
        }
        // Seen from the centre it spans 2 atan(3/10) = 33.4° of the turn: 47.5 sectors of the 512,
        // so 48 once aligned on their edges.
        assert_eq!(Sectors::span(&wall, &Point2::origin(), 0.0).1, 48);
    }
}
