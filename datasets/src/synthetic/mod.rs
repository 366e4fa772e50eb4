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
//! returns have none. Every return is labelled moving or not ([`Scan::moving`]): only the rough
//! harbour's boats ([`rough::Boat`]) move. Neither is read by a registration: they are truth
//! for scoring.
//!
//! Frames: the world is east-north (x east, y north); the scanner's `+x` is the bow and its
//! bearings grow counter-clockwise; the reference heading is navigational (clockwise from
//! north), so yaw `ψ = 90° − HDG`.

use icp_core::{BearingSense, Scan, SensorModel};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::dataset::{Dataset, Pose2, Provenance, ReferenceKind, ReferencePose};
use crate::DatasetError;

pub mod corridor;
pub mod rough;
mod scanner;
mod track;
mod traffic;
mod world;

pub use corridor::{generate_corridor, Corridor};
pub use rough::Rough;
pub use scanner::{Revolution, Scanner};
pub use traffic::{
    generate_corridor_without_boats, generate_with_boats, read_boats, BoatsError, NO_BOATS,
};
pub use world::{Segment, Surface};

use track::Track;
use world::build_world;

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

    /// Refuses a configuration out of range (naming the field) or an unusable sensor model.
    pub(crate) fn validate(&self) -> Result<(), DatasetError> {
        check_ranges([
            (
                "max_range_m",
                self.max_range_m,
                self.max_range_m.is_finite() && self.max_range_m > 1.0,
            ),
            (
                "sample_rate_hz",
                self.sample_rate_hz,
                self.sample_rate_hz.is_finite()
                    && self.beams_per_rev() >= 3
                    && self.beams_per_rev() <= 1_000_000,
            ),
            (
                "dropout_prob",
                self.dropout_prob,
                (0.0..=1.0).contains(&self.dropout_prob),
            ),
            (
                "gross_error_fraction",
                self.gross_error_fraction,
                (0.0..=1.0).contains(&self.gross_error_fraction),
            ),
            (
                "rotation_hz",
                self.rotation_hz,
                self.rotation_hz.is_finite() && self.rotation_hz > 0.0,
            ),
        ])?;
        self.sensor.validate().map_err(|e| DatasetError::BadValue {
            path: "<scenario>".into(),
            what: e.to_string(),
        })
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
    /// The error sources of a real vessel and scanner beyond the sensor model ([`rough`]);
    /// `None`: the paper's harbour.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rough: Option<Rough>,
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
            rough: None,
        }
    }

    /// The paper's run in a rough harbour ([`rough`]): the same track, basin and scanner, with
    /// the waves' motion (in place of the paper scenario's 0.6° yaw wobble), the tilted scan
    /// plane, grazing-incidence noise, mixed pixels, a heavy-tailed share of range errors,
    /// moving boats and motion distortion. The dataset states the nominal (Sweep) model.
    pub fn rough() -> Self {
        let paper = Self::paper();
        Self {
            name: "rough".into(),
            yaw_wobble_deg: 0.0,
            scanner: ScannerConfig {
                motion_distortion: true,
                ..paper.scanner
            },
            seed: 2022,
            rough: Some(Rough::harbour()),
            ..paper
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

    /// The synthetic scenarios' names, for messages: the harbour's and [`Corridor::NAME`].
    pub const NAMES: &'static str = "paper, marina-like, rough or corridor";

    /// A scenario by name: `paper`, `marina-like` or `rough`.
    pub fn by_name(name: &str) -> Option<Self> {
        match name {
            "paper" => Some(Self::paper()),
            "marina-like" | "marina_like" => Some(Self::marina_like()),
            "rough" => Some(Self::rough()),
            _ => None,
        }
    }

    fn validate(&self) -> Result<(), DatasetError> {
        check_ranges(run_checks(self.n_scans, self.dt_s))?;
        check_ranges([(
            "speed_mps",
            self.speed_mps,
            self.speed_mps.is_finite() && self.speed_mps >= 0.0,
        )])?;
        self.scanner.validate()?;
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
        match self.rough.as_ref().and_then(Rough::invalid) {
            Some((name, value, reason)) => Err(DatasetError::InvalidParameter {
                name,
                value,
                reason,
            }),
            None => Ok(()),
        }
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

/// The first of `checks` (a parameter's name, its value, whether it is in range) out of
/// range, as the error naming it.
fn check_ranges<const N: usize>(
    checks: [(&'static str, f64, bool); N],
) -> Result<(), DatasetError> {
    match checks.into_iter().find(|c| !c.2) {
        Some((name, value, _)) => Err(DatasetError::InvalidParameter {
            name,
            value,
            reason: "out of range for a synthetic scenario",
        }),
        None => Ok(()),
    }
}

/// The checks of every synthetic run: at least two scans, a finite positive spacing.
fn run_checks(n_scans: usize, dt_s: f64) -> [(&'static str, f64, bool); 2] {
    [
        ("n_scans", n_scans as f64, n_scans >= 2),
        ("dt_s", dt_s, dt_s.is_finite() && dt_s > 0.0),
    ]
}

/// Mixed into a scenario's seed to seed its noise, apart from its events.
const NOISE_SEED_MIX: u64 = 0x005e_ed0f_5e45;

/// The ChaCha8 stream of the rough harbour's wave phases.
const SEA_STREAM: u64 = 22;

/// Generates the scenario's dataset.
pub fn generate(scenario: &Scenario) -> Result<Dataset, DatasetError> {
    scenario.validate()?;
    let sc = &scenario.scanner;
    let duration_s = (scenario.n_scans - 1) as f64 * scenario.dt_s + sc.rotation_period_s();
    let track = Track::new(scenario, duration_s);
    let mut event_rng = ChaCha8Rng::seed_from_u64(scenario.seed);
    let mut noise_rng = ChaCha8Rng::seed_from_u64(scenario.seed ^ NOISE_SEED_MIX);
    let (world, surfaces) = build_world(&track, duration_s, &mut event_rng);
    let scanner = Scanner::new(sc, &world);
    let pose_at = |t: f64| track.pose_at(t);
    // The rough harbour: the sea's phases from their own stream of the seed, so the paper's
    // draws are untouched.
    let sea = scenario.rough.as_ref().map(|r| {
        let mut rng = ChaCha8Rng::seed_from_u64(scenario.seed);
        rng.set_stream(SEA_STREAM);
        r.sea.with_phases(&mut rng)
    });
    let rough = scenario.rough.as_ref().zip(sea.as_ref()).map(|(r, sea)| {
        let motion = rough::Motion {
            track: &pose_at,
            sea,
            duration_s,
        };
        (rough::RoughScanner::new(sc, r, &world, &surfaces), motion)
    });
    let mut scans = Vec::with_capacity(scenario.n_scans);
    let mut reference = Vec::with_capacity(scenario.n_scans);
    for k in 0..scenario.n_scans {
        let t_k = k as f64 * scenario.dt_s;
        let (rev, pose_k) = match &rough {
            Some((rough_scanner, motion)) => (
                rough_scanner.scan(motion, t_k, &mut noise_rng, &mut event_rng),
                motion.pose(t_k),
            ),
            None => (
                scanner.scan(&pose_at, t_k, &mut noise_rng, &mut event_rng),
                track.pose_at(t_k),
            ),
        };
        scans.push(rev.scan(k, t_k)?);
        let yaw = pose_k.rotation.angle();
        reference.push(ReferencePose {
            x_m: pose_k.translation.x,
            y_m: pose_k.translation.y,
            heading_rad: icp_core::motion::wrap_360(90.0 - yaw.to_degrees()).to_radians(),
            scan_yaw_rad: Some(yaw),
        });
    }
    let rough_part = scenario.rough.as_ref().map_or_else(String::new, |r| {
        format!(
            "; rough: waves, tilt, grazing noise, mixed pixels, heavy tails, {}; the dataset's \
             sensor model is the nominal one",
            rough::Boat::describe(&r.boats)
        )
    });
    let description = format!(
        "synthetic harbour basin, scenario {:?}: {} scans every {} s at {} m/s, seed {}{}",
        scenario.name,
        scenario.n_scans,
        scenario.dt_s,
        scenario.speed_mps,
        scenario.seed,
        rough_part,
    );
    Ok(ground_truth_dataset(
        (&scenario.name, description),
        (scans, reference),
        BearingSense::Clockwise,
        scenario.dt_s,
        // Without distortion every beam is cast from the revolution's start pose.
        if sc.motion_distortion {
            sc.rotation_period_s()
        } else {
            0.0
        },
        sc.sensor,
    ))
}

/// A synthetic run's dataset, named `synthetic:NAME` and described: its scans (bearings
/// counter-clockwise) with the exact poses they were taken from ([`ReferenceKind::GroundTruth`],
/// the scanner's own: the offset is the identity), no odometry, each sweep lasting `sweep_s`.
fn ground_truth_dataset(
    (name, description): (&str, String),
    (scans, reference): (Vec<Scan>, Vec<ReferencePose>),
    reference_heading_sense: BearingSense,
    dt_s: f64,
    sweep_s: f64,
    sensor: SensorModel,
) -> Dataset {
    Dataset {
        provenance: Provenance {
            name: format!("synthetic:{name}"),
            description,
            files: Vec::new(),
        },
        scans,
        reference: Some(reference),
        reference_kind: Some(ReferenceKind::GroundTruth),
        odometry: None,
        scanner_offset: Some(Pose2::IDENTITY),
        reference_heading_sense,
        dt_s,
        sweep_s: Some(sweep_s),
        sensor,
        bearing_sense: BearingSense::CounterClockwise,
        warnings: Vec::new(),
        first_scans: None,
    }
    .checked()
}
