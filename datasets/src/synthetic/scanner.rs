//! The simulated scanner: one revolution's beams cast against the world, with the sensor
//! model's noise (eq. 8), dropouts, spurious returns and optional motion distortion.

use nalgebra::{Isometry2, Point2, Vector2};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

use super::world::{Sectors, Segment};
use super::ScannerConfig;

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
    /// Whether each beam's return came from a moving hull ([`super::rough::Boat`]): `false`
    /// for every beam of a harbour without traffic.
    pub moving: Vec<bool>,
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
            moving: vec![false; ranges.len()],
            ranges_m: ranges,
            bearings_rad: bearings,
            true_normals: normals,
        }
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
