//! The rough harbour: the error sources a real USV and a Sweep-class scanner add to the
//! paper's harbour, each in its own file with its parameters and where they come from.
//!
//! | source | file | default |
//! | --- | --- | --- |
//! | wave-driven surge, sway, yaw; roll and pitch | [`sea`] | sea state 2 in a sheltered basin: yaw 2° at 0.15 Hz + 1° at 0.27 Hz, roll 2.5° + 1°, pitch 1.2°, surge 0.10 m, sway 0.08 m |
//! | the tilted scan plane: longer ranges, water, beams over the walls | [`tilt`] | scanner 0.6 m above the water; quays and end walls 1.5 m, finger piers 1.0 m, moored hulls and boats 1.0 m |
//! | spurious returns off the water | here | 10 % of the beams that meet the water |
//! | range noise at grazing incidence | [`grazing`] | 8 mrad divergence (LIDAR-Lite v3) |
//! | mixed pixels at depth edges | [`mixed`] | half the edge beams, steps over 0.3 m |
//! | heavy-tailed range errors | [`tail`] | 3 % of returns, t(3) at 3σ |
//! | moving boats | [`boats`] | three, at 0.6–1.5× the vessel's speed |
//! | motion distortion within the revolution | [`super::ScannerConfig::motion_distortion`] | on: 0.2 s per revolution |
//!
//! Everything the nominal model (eq. 8, the Sweep's `σ_r = 0.004258 r`, `σ_α = 0.5°`) covers
//! is drawn as in the paper's harbour; the rest is what a user's sensor model does not know.
//! The dataset states the nominal model, so the variants weigh, and the Cramér–Rao bound is
//! computed, with it: that bound is the nominal model's, not this harbour's.

use nalgebra::{Isometry2, Point2, Vector2};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use serde::{Deserialize, Serialize};

use super::world::{Sectors, Segment, Surface};
use super::{Revolution, ScannerConfig};

pub mod boats;
pub mod grazing;
pub mod mixed;
pub mod sea;
pub mod tail;
pub mod tilt;

pub use boats::Boat;
pub use grazing::GrazingNoise;
pub use mixed::MixedPixels;
pub use sea::{SeaMotion, SeaState, Wave};
pub use tail::HeavyTail;
pub use tilt::{Meets, TiltedBeam};

/// The error sources of the rough harbour (see the module documentation).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Rough {
    /// Wave-driven motion of the hull.
    pub sea: SeaState,
    /// Height of the scan plane's centre above the water, m.
    pub scanner_height_m: f64,
    /// Top of the quay walls and end walls above the water, m.
    pub quay_top_m: f64,
    /// Top of the finger piers, m.
    pub pier_top_m: f64,
    /// Freeboard of the moored hulls and the moving boats, m.
    pub hull_top_m: f64,
    /// Probability that a beam meeting the water returns (ripples, spray, floating debris).
    pub water_return_prob: f64,
    /// Range noise at grazing incidence.
    pub grazing: GrazingNoise,
    /// Mixed pixels at depth edges.
    pub mixed: MixedPixels,
    /// Heavy-tailed share of the range errors.
    pub tail: HeavyTail,
    /// Moving boats.
    pub boats: Vec<Boat>,
}

impl Rough {
    /// The defaults of the module documentation's table.
    pub fn harbour() -> Self {
        Self {
            sea: SeaState::sheltered_basin(),
            scanner_height_m: 0.6,
            quay_top_m: 1.5,
            pier_top_m: 1.0,
            hull_top_m: 1.0,
            water_return_prob: 0.1,
            grazing: GrazingNoise::sweep(),
            mixed: MixedPixels::sweep(),
            tail: HeavyTail::harbour(),
            boats: Boat::harbour(),
        }
    }

    /// The first parameter out of its domain: its name, value and why.
    pub(super) fn invalid(&self) -> Option<(&'static str, f64, &'static str)> {
        let positive = |v: f64| v.is_finite() && v > 0.0;
        let probability = |v: f64| (0.0..=1.0).contains(&v);
        let checks: [(&'static str, f64, bool, &'static str); 10] = [
            (
                "scanner_height_m",
                self.scanner_height_m,
                positive(self.scanner_height_m),
                "must be positive",
            ),
            (
                "quay_top_m",
                self.quay_top_m,
                self.quay_top_m.is_finite(),
                "must be finite",
            ),
            (
                "pier_top_m",
                self.pier_top_m,
                self.pier_top_m.is_finite(),
                "must be finite",
            ),
            (
                "hull_top_m",
                self.hull_top_m,
                self.hull_top_m.is_finite(),
                "must be finite",
            ),
            (
                "water_return_prob",
                self.water_return_prob,
                probability(self.water_return_prob),
                "must be a probability",
            ),
            (
                "beam_divergence_rad",
                self.grazing.beam_divergence_rad,
                self.grazing.beam_divergence_rad.is_finite()
                    && self.grazing.beam_divergence_rad >= 0.0,
                "must be finite and non-negative",
            ),
            (
                "mixed.probability",
                self.mixed.probability,
                probability(self.mixed.probability),
                "must be a probability",
            ),
            (
                "mixed.min_depth_step_m",
                self.mixed.min_depth_step_m,
                positive(self.mixed.min_depth_step_m),
                "must be positive",
            ),
            (
                "tail.share",
                self.tail.share,
                probability(self.tail.share),
                "must be a probability",
            ),
            (
                "tail.dof",
                self.tail.dof,
                self.tail.dof.is_finite() && self.tail.dof > 2.0,
                "must exceed 2 (a finite variance)",
            ),
        ];
        if let Some((name, value, _, why)) = checks.iter().find(|c| !c.2) {
            return Some((name, *value, why));
        }
        if !self.tail.scale_sigmas.is_finite() || self.tail.scale_sigmas < 0.0 {
            return Some((
                "tail.scale_sigmas",
                self.tail.scale_sigmas,
                "must be finite and non-negative",
            ));
        }
        if let Some(w) = self
            .sea
            .waves()
            .find(|w| !w.amplitude.is_finite() || !positive(w.period_s))
        {
            return Some((
                "sea",
                w.period_s,
                "every wave needs a finite amplitude and a positive period",
            ));
        }
        self.boats.iter().find_map(Boat::invalid)
    }

    fn top_m(&self, surface: Surface) -> f64 {
        match surface {
            Surface::Quay | Surface::EndWall => self.quay_top_m,
            Surface::Pier => self.pier_top_m,
            Surface::Hull => self.hull_top_m,
        }
    }
}

/// Where the rough scanner is at a time: its track and the sea's motion about it.
pub struct Motion<'a> {
    /// The track's pose at a time (without the waves).
    pub track: &'a dyn Fn(f64) -> Isometry2<f64>,
    /// The sea's motion.
    pub sea: &'a SeaMotion,
    /// Length of the run, s (the boats lie still outside it).
    pub duration_s: f64,
}

impl Motion<'_> {
    /// The scanner's pose at `t_s`: the track's, moved by the waves.
    pub fn pose(&self, t_s: f64) -> Isometry2<f64> {
        (self.track)(t_s) * self.sea.offset(t_s)
    }
}

/// Casts a Sweep-class scanner's beams in the rough harbour.
pub struct RoughScanner<'a> {
    config: &'a ScannerConfig,
    rough: &'a Rough,
    world: &'a [Segment],
    surfaces: &'a [Surface],
}

/// What one beam met before the noise: its range, true normal (scan frame) and the surface
/// (none for the water), and whether that surface is a moving hull.
struct Echo {
    range_m: f64,
    normal: Option<Vector2<f64>>,
    cos_incidence: f64,
    moving: bool,
}

impl<'a> RoughScanner<'a> {
    /// A scanner in `world`, whose segment `i` is part of `surfaces[i]`.
    pub fn new(
        config: &'a ScannerConfig,
        rough: &'a Rough,
        world: &'a [Segment],
        surfaces: &'a [Surface],
    ) -> Self {
        Self {
            config,
            rough,
            world,
            surfaces,
        }
    }

    /// One revolution starting at `t_s` (see [`super::Scanner::scan`]), with every error
    /// source of [`Rough`]: `noise_rng` draws the Gaussian noise, `event_rng` everything else.
    pub fn scan(
        &self,
        motion: &Motion<'_>,
        t_s: f64,
        noise_rng: &mut ChaCha8Rng,
        event_rng: &mut ChaCha8Rng,
    ) -> Revolution {
        let (sc, rough) = (self.config, self.rough);
        let unit = Normal::new(0.0, 1.0).expect("unit normal");
        let beams = sc.beams_per_rev();
        let beam_step = std::f64::consts::TAU / beams as f64;
        let start = motion.pose(t_s);
        let world_to_scan = start.rotation.inverse();
        let centre = Point2::from(start.translation.vector);
        let times: Vec<f64> = (0..beams)
            .map(|j| {
                if sc.motion_distortion {
                    t_s + sc.rotation_period_s() * j as f64 / beams as f64
                } else {
                    t_s
                }
            })
            .collect();
        let poses: Vec<Isometry2<f64>> = times.iter().map(|&t| motion.pose(t)).collect();
        let spread = poses
            .iter()
            .map(|p| (Point2::from(p.translation.vector) - centre).norm())
            .fold(0.0, f64::max);
        // The slant range never falls short of the horizontal one: the sectors of the level
        // scanner's reach hold every segment a tilted beam can meet.
        let near: Vec<usize> = (0..self.world.len())
            .filter(|&i| self.world[i].distance_to(&centre) <= sc.max_range_m + spread)
            .collect();
        let sectors = Sectors::new(
            near.iter().map(|&i| &self.world[i]).collect(),
            &centre,
            spread,
        );
        let phase = event_rng.random_range(0.0..beam_step);
        let mut ranges = Vec::with_capacity(beams);
        let mut true_ranges = Vec::with_capacity(beams);
        let mut bearings = Vec::with_capacity(beams);
        let mut normals = Vec::with_capacity(beams);
        let mut on_hull = Vec::with_capacity(beams);
        for (j, (pose, &t)) in poses.iter().zip(&times).enumerate() {
            let bearing = phase + j as f64 * beam_step;
            let (n_alpha, n_range) = (unit.sample(noise_rng), unit.sample(noise_rng));
            let noisy = if sc.noise { 1.0 } else { 0.0 };
            let alpha = bearing + noisy * sc.sensor.sigma_alpha_rad * n_alpha;
            let (roll, pitch) = motion.sea.attitude_rad(t);
            let beam = TiltedBeam::new(alpha, roll, pitch);
            let dir = pose.rotation * Vector2::new(beam.azimuth_rad.cos(), beam.azimuth_rad.sin());
            let origin = Point2::from(pose.translation.vector);
            let echo = self.echo(motion, t, &sectors, &near, &origin, &dir, &beam, event_rng);
            let (mut r, mut r_true, mut normal, mut hull) = (f64::NAN, f64::NAN, None, false);
            if let Some(e) = echo.filter(|e| e.range_m <= sc.max_range_m) {
                if !event_rng.random_bool(sc.dropout_prob) {
                    hull = e.moving;
                    let sigma = sc
                        .sensor
                        .sigma_r_m(e.range_m)
                        .hypot(rough.grazing.sigma_m(e.range_m, e.cos_incidence));
                    if sc.noise {
                        r = e.range_m + sigma * rough.tail.draw_sigmas(n_range, event_rng);
                    } else {
                        r = e.range_m;
                    }
                    r_true = if e.normal.is_some() {
                        e.range_m
                    } else {
                        f64::NAN
                    };
                    normal = e.normal.map(|n| world_to_scan * n);
                }
            }
            if event_rng.random_bool(sc.gross_error_fraction) {
                r = event_rng.random_range(1.0..0.5 * sc.max_range_m);
                (r_true, normal, hull) = (f64::NAN, None, false);
            }
            on_hull.push(hull);
            ranges.push(r);
            true_ranges.push(r_true);
            bearings.push(bearing);
            normals.push(normal);
        }
        let mut mixed = vec![false; beams];
        rough
            .mixed
            .apply(&true_ranges, &mut ranges, &mut mixed, event_rng);
        for (j, r) in ranges.iter_mut().enumerate() {
            if r.is_nan() || *r <= 0.0 {
                *r = f64::NAN;
            }
            if r.is_nan() || mixed[j] {
                normals[j] = None;
            }
        }
        // A mixed pixel straddling a hull's edge moves with it: it is labelled moving when
        // either surface it mixes is a hull (beam `j` mixes its own with beam `j + 1`'s).
        let moving = (0..beams)
            .map(|j| !ranges[j].is_nan() && (on_hull[j] || (mixed[j] && on_hull[j + 1])))
            .collect();
        Revolution {
            ranges_m: ranges,
            bearings_rad: bearings,
            true_normals: normals,
            moving,
        }
    }

    /// What the beam of horizontal world direction `dir` from `origin` at `t_s` meets: the
    /// nearest of the harbour's segments and the boats' sides, then the water or nothing.
    #[allow(clippy::too_many_arguments)]
    fn echo(
        &self,
        motion: &Motion<'_>,
        t_s: f64,
        sectors: &Sectors<'_>,
        near: &[usize],
        origin: &Point2<f64>,
        dir: &Vector2<f64>,
        beam: &TiltedBeam,
        event_rng: &mut ChaCha8Rng,
    ) -> Option<Echo> {
        let rough = self.rough;
        // The nearest hit: distance, segment, its top above the water, and whether it moves.
        let mut hit: Option<(f64, Segment, f64, bool)> =
            sectors.cast_index(origin, dir).map(|(d, k)| {
                let i = near[k];
                (d, self.world[i], rough.top_m(self.surfaces[i]), false)
            });
        for boat in &rough.boats {
            let pose = boat.pose(t_s, motion.duration_s, motion.track);
            for side in boat.sides(&pose) {
                if let Some(d) = side.hit(origin, dir) {
                    if hit.is_none_or(|(best, ..)| d < best) {
                        let moving = boat.moves_at(t_s, motion.duration_s);
                        hit = Some((d, side, rough.hull_top_m, moving));
                    }
                }
            }
        }
        match beam.meets(rough.scanner_height_m, hit.map(|(d, _, top, _)| (d, top))) {
            Meets::Surface(range_m) => {
                let (_, segment, _, moving) = hit.expect("a surface was met");
                let normal = segment.normal_facing(dir)?;
                Some(Echo {
                    range_m,
                    normal: Some(normal),
                    cos_incidence: normal.dot(dir).abs() * beam.cos_elevation,
                    moving,
                })
            }
            Meets::Water(range_m) => {
                event_rng
                    .random_bool(rough.water_return_prob)
                    .then_some(Echo {
                        range_m,
                        normal: None,
                        cos_incidence: 1.0,
                        moving: false,
                    })
            }
            Meets::Nothing => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synthetic::Scanner;
    use rand::SeedableRng;

    /// A rough harbour with every source of its own off.
    pub(super) fn calm() -> Rough {
        Rough {
            sea: SeaState {
                surge_m: vec![],
                sway_m: vec![],
                yaw_deg: vec![],
                roll_deg: vec![],
                pitch_deg: vec![],
            },
            water_return_prob: 0.0,
            grazing: GrazingNoise {
                beam_divergence_rad: 0.0,
            },
            mixed: MixedPixels {
                probability: 0.0,
                ..MixedPixels::sweep()
            },
            tail: HeavyTail {
                share: 0.0,
                ..HeavyTail::harbour()
            },
            boats: vec![],
            ..Rough::harbour()
        }
    }

    /// A closed 40 m × 16 m room of quay walls about the origin, and what its walls are.
    pub(super) fn room() -> (Vec<Segment>, Vec<Surface>) {
        let room = [(-20.0, -8.0), (20.0, -8.0), (20.0, 8.0), (-20.0, 8.0)];
        let world = (0..4)
            .map(|i| Segment {
                a: Point2::new(room[i].0, room[i].1),
                b: Point2::new(room[(i + 1) % 4].0, room[(i + 1) % 4].1),
            })
            .collect();
        (world, vec![Surface::Quay; 4])
    }

    /// With its own sources off, the rough scanner is the paper's scanner, bit for bit in the
    /// beams' draws and to rounding in the ranges (its azimuth goes through the tilt's
    /// trigonometry), with and without motion distortion; distortion lengthens or shortens the
    /// late beams of a revolution by what the vessel sailed and turned meanwhile, and leaves the
    /// first beam alone.
    #[test]
    fn calm_it_is_the_papers_scanner_and_motion_distortion_acts() {
        let (world, surfaces) = room();
        let track = |t: f64| Isometry2::new(Vector2::new(-5.0 + 1.2 * t, 0.0), 0.3 * t);
        let rough = calm();
        let sea = rough.sea.with_phases(&mut ChaCha8Rng::seed_from_u64(0));
        let motion = Motion {
            track: &track,
            sea: &sea,
            duration_s: 10.0,
        };
        let mut distorted_ranges = Vec::new();
        for distortion in [false, true] {
            let config = ScannerConfig {
                motion_distortion: distortion,
                ..ScannerConfig::default()
            };
            let plain = Scanner::new(&config, &world).scan(
                &track,
                1.0,
                &mut ChaCha8Rng::seed_from_u64(1),
                &mut ChaCha8Rng::seed_from_u64(2),
            );
            let ours = RoughScanner::new(&config, &rough, &world, &surfaces).scan(
                &motion,
                1.0,
                &mut ChaCha8Rng::seed_from_u64(1),
                &mut ChaCha8Rng::seed_from_u64(2),
            );
            assert_eq!(plain.bearings_rad, ours.bearings_rad);
            for (a, b) in plain.ranges_m.iter().zip(&ours.ranges_m) {
                assert_eq!(a.is_nan(), b.is_nan());
                if a.is_finite() {
                    assert!((a - b).abs() < 1e-9, "{a} {b}");
                }
            }
            distorted_ranges.push(ours);
        }
        // Exact returns: the undistorted and distorted revolutions share their bearings.
        let exact = ScannerConfig {
            noise: false,
            dropout_prob: 0.0,
            gross_error_fraction: 0.0,
            ..ScannerConfig::default()
        };
        let mut revs = Vec::new();
        for distortion in [false, true] {
            let config = ScannerConfig {
                motion_distortion: distortion,
                ..exact
            };
            revs.push(RoughScanner::new(&config, &rough, &world, &surfaces).scan(
                &motion,
                1.0,
                &mut ChaCha8Rng::seed_from_u64(1),
                &mut ChaCha8Rng::seed_from_u64(2),
            ));
        }
        let shift = |j: usize| {
            let (r0, r1, a) = (
                revs[0].ranges_m[j],
                revs[1].ranges_m[j],
                revs[0].bearings_rad[j],
            );
            (Vector2::new(a.cos(), a.sin()) * (r1 - r0)).norm()
        };
        let beams = revs[0].ranges_m.len();
        assert!(shift(0) < 1e-12, "the first beam is taken at the start");
        let late = (beams * 3 / 4..beams).map(shift).fold(0.0, f64::max);
        // Turning 0.3 rad/s in a 40 m room: the last beams move by decimetres to metres.
        assert!(late > 0.05, "{late}");
        assert!(distorted_ranges.len() == 2);
    }

    /// The default harbour's parameters are valid; a bad one is named.
    #[test]
    fn parameters_are_checked() {
        assert_eq!(Rough::harbour().invalid(), None);
        let bad = Rough {
            water_return_prob: 1.5,
            ..Rough::harbour()
        };
        assert_eq!(bad.invalid().map(|b| b.0), Some("water_return_prob"));
        let mut bad = Rough::harbour();
        bad.tail.dof = 2.0;
        assert_eq!(bad.invalid().map(|b| b.0), Some("tail.dof"));
        let mut bad = Rough::harbour();
        bad.sea.roll_deg[0].period_s = 0.0;
        assert_eq!(bad.invalid().map(|b| b.0), Some("sea"));
    }
}
