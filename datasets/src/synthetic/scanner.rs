//! The simulated scanner: one revolution's beams cast against the world, with the sensor
//! model's noise (eq. 8), dropouts, spurious returns and optional motion distortion.

use icp_core::{ReadingTruth, Scan};
use nalgebra::{Isometry2, Point2, Vector2};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

use super::world::{Sectors, Segment};
use super::ScannerConfig;
use crate::DatasetError;

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
    /// Whether each beam's return came from a moving body (a hull, [`super::rough::Boat`]; a
    /// walking person, [`super::corridor`]): `false` for every beam of a still world.
    pub moving: Vec<bool>,
}

impl Revolution {
    /// Scan `k` of a synthetic run, taken at `t_s`, with its truth: normals and moving labels.
    pub(super) fn scan(&self, k: usize, t_s: f64) -> Result<Scan, DatasetError> {
        let truth = ReadingTruth {
            true_normals: Some(&self.true_normals),
            moving: Some(&self.moving),
        };
        Scan::from_polar_with_truth(&self.ranges_m, &self.bearings_rad, truth)
            .and_then(|s| s.with_timestamp(t_s))
            .map_err(|source| DatasetError::Scan {
                path: "<synthetic>".into(),
                scan: k,
                source,
            })
    }
}

/// Casts the scanner's beams against a world.
pub struct Scanner<'a> {
    config: &'a ScannerConfig,
    world: &'a [Segment],
    /// Segments from this index on are moving bodies: their returns are labelled moving.
    moving_from: usize,
}

impl<'a> Scanner<'a> {
    /// A scanner in a still `world`.
    pub fn new(config: &'a ScannerConfig, world: &'a [Segment]) -> Self {
        Self::with_moving_from(config, world, world.len())
    }

    /// A scanner in `world` whose segments from `moving_from` on belong to moving bodies
    /// (people, [`super::corridor`]): every return off one of them is labelled moving.
    pub fn with_moving_from(
        config: &'a ScannerConfig,
        world: &'a [Segment],
        moving_from: usize,
    ) -> Self {
        Self {
            config,
            world,
            moving_from,
        }
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
        let beams = sc.beams_per_rev();
        let beam_step = std::f64::consts::TAU / beams as f64;
        let poses: Vec<Isometry2<f64>> = (0..beams)
            .map(|j| {
                if sc.motion_distortion {
                    pose_at(t_s + sc.rotation_period_s() * j as f64 / beams as f64)
                } else {
                    pose_at(t_s)
                }
            })
            .collect();
        let sectors = self.sectors(&poses);
        // Each revolution starts at a random fraction of a beam, as a free-running scanner does.
        let phase = event_rng.random_range(0.0..beam_step);
        let bearings: Vec<f64> = (0..beams).map(|j| phase + j as f64 * beam_step).collect();
        self.cast(&sectors, &poses, &bearings, noise_rng, event_rng)
    }

    /// One scan of a fixed fan of beams at `bearings_rad` (scanner frame), all cast from
    /// `pose` (world frame): a scanner whose bearings are the same every scan, like a SICK
    /// LMS, and whose sweep is short beside the motion between scans. The ScannerConfig's
    /// motion distortion does not apply.
    pub fn scan_fan(
        &self,
        pose: &Isometry2<f64>,
        bearings_rad: &[f64],
        noise_rng: &mut ChaCha8Rng,
        event_rng: &mut ChaCha8Rng,
    ) -> Revolution {
        let poses = vec![*pose; bearings_rad.len()];
        let sectors = self.sectors(&poses);
        self.cast(&sectors, &poses, bearings_rad, noise_rng, event_rng)
    }

    /// The sector index of the segments within reach of the beams' origins `poses` (the first
    /// is the scan's start), with the segments' positions in the world.
    fn sectors(&self, poses: &[Isometry2<f64>]) -> (Sectors<'a>, Vec<usize>) {
        let sc = self.config;
        let centre = Point2::from(poses[0].translation.vector);
        let reach = sc.max_range_m + if sc.motion_distortion { 2.0 } else { 0.0 };
        let (index, near): (Vec<usize>, Vec<&Segment>) = self
            .world
            .iter()
            .enumerate()
            .filter(|(_, s)| s.distance_to(&centre) <= reach)
            .unzip();
        let spread = poses
            .iter()
            .map(|p| (Point2::from(p.translation.vector) - centre).norm())
            .fold(0.0, f64::max);
        (Sectors::new(near, &centre, spread), index)
    }

    /// The beams at `bearings` from `poses` (one each; the first is the scan's frame).
    fn cast(
        &self,
        (sectors, index): &(Sectors<'a>, Vec<usize>),
        poses: &[Isometry2<f64>],
        bearings: &[f64],
        noise_rng: &mut ChaCha8Rng,
        event_rng: &mut ChaCha8Rng,
    ) -> Revolution {
        let sc = self.config;
        let unit = Normal::new(0.0, 1.0).expect("unit normal");
        let world_to_scan = poses[0].rotation.inverse();
        let mut rev = Revolution {
            ranges_m: Vec::with_capacity(bearings.len()),
            bearings_rad: Vec::with_capacity(bearings.len()),
            true_normals: Vec::with_capacity(bearings.len()),
            moving: Vec::with_capacity(bearings.len()),
        };
        for (pose, &bearing) in poses.iter().zip(bearings) {
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
                .cast_index(&origin, &dir)
                .filter(|&(t, _)| t <= sc.max_range_m);
            let (mut r, mut normal, mut moving) = (f64::NAN, None, false);
            if let Some((hit, i)) = hit {
                if !event_rng.random_bool(sc.dropout_prob) {
                    r = hit
                        + if sc.noise {
                            sc.sensor.sigma_r_m(hit) * n_range
                        } else {
                            0.0
                        };
                    let segment = &self.world[index[i]];
                    normal = segment.normal_facing(&dir).map(|n| world_to_scan * n);
                    moving = index[i] >= self.moving_from;
                }
            }
            if event_rng.random_bool(sc.gross_error_fraction) {
                r = event_rng.random_range(1.0..0.5 * sc.max_range_m);
                (normal, moving) = (None, false);
            }
            let returned = r > 0.0;
            rev.ranges_m.push(if returned { r } else { f64::NAN });
            rev.bearings_rad.push(bearing);
            rev.true_normals.push(normal.filter(|_| returned));
            rev.moving.push(moving && returned);
        }
        rev
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synthetic::{build_world, Scenario, Track};
    use rand::SeedableRng;

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
        let (world, _) = build_world(&track, duration_s, &mut event_rng);
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
}
