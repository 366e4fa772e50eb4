//! Moving boats: hulls that sail the basin while the scans are taken, so that part of each
//! scan moves against the rest.
//!
//! Each boat follows the vessel's own track (without the waves) in a lane beside it, at a
//! multiple of the vessel's progress: `τ(t) = start_s + rate · t` is the track time whose pose
//! (shifted `lane_m` to port) is the boat's centre at time `t` (`τ` clamped to the run: before
//! and after it the boat lies still). A positive rate sails with the vessel, a negative one
//! against it. Harbour speed limits are about 3 kn (1.5 m/s); the defaults
//! ([`Boat::harbour`]) have one boat overtaking at 1.5× the vessel's speed, one meeting it at
//! 1.2× and one slower ahead at 0.6×, each 5–8 m long, 2.2–2.8 m wide.
//!
//! Every return off a boat's hull is labelled moving ([`icp_core::Scan::moving`]) while the
//! boat moves; so is a mixed pixel at a hull's edge (its range lies between the hull and what
//! is behind or before it, so it moves with the hull). While a boat lies still (before its
//! track time reaches the run, after it leaves it, or at rate 0) its hull is part of the
//! static scene and its returns are not labelled: no detector of motion can or should find
//! them. Water and spurious returns are not labelled.

use nalgebra::{Isometry2, Point2, Vector2};
use serde::{Deserialize, Serialize};

use crate::synthetic::Segment;

/// One moving boat.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Boat {
    /// Length overall, m.
    pub length_m: f64,
    /// Beam (width), m.
    pub beam_m: f64,
    /// Lane: offset to port of the vessel's track, m.
    pub lane_m: f64,
    /// Track time of the boat's position at `t = 0`, s.
    pub start_s: f64,
    /// Track seconds per second: its speed over the vessel's (negative: oncoming).
    pub rate: f64,
}

impl Boat {
    /// Three boats (see the module documentation).
    pub fn harbour() -> Vec<Boat> {
        vec![
            Boat {
                length_m: 6.0,
                beam_m: 2.4,
                lane_m: -4.0,
                start_s: -20.0,
                rate: 1.5,
            },
            Boat {
                length_m: 8.0,
                beam_m: 2.8,
                lane_m: 4.5,
                start_s: 120.0,
                rate: -1.2,
            },
            Boat {
                length_m: 5.0,
                beam_m: 2.2,
                lane_m: -4.0,
                start_s: 15.0,
                rate: 0.6,
            },
        ]
    }

    /// The first field out of its domain: its name, value and why. A boat needs a finite,
    /// positive length and beam and a finite lane, start and rate.
    pub fn invalid(&self) -> Option<(&'static str, f64, &'static str)> {
        let size = |v: f64| v.is_finite() && v > 0.0;
        let (positive, finite) = ("must be finite and positive", "must be finite");
        [
            ("length_m", self.length_m, size(self.length_m), positive),
            ("beam_m", self.beam_m, size(self.beam_m), positive),
            ("lane_m", self.lane_m, self.lane_m.is_finite(), finite),
            ("start_s", self.start_s, self.start_s.is_finite(), finite),
            ("rate", self.rate, self.rate.is_finite(), finite),
        ]
        .into_iter()
        .find(|c| !c.2)
        .map(|(name, value, _, why)| (name, value, why))
    }

    /// The boats in words, for a dataset's description: how many, and each one's size, lane,
    /// start and rate.
    pub fn describe(boats: &[Boat]) -> String {
        if boats.is_empty() {
            return "no moving boats".to_owned();
        }
        let each: Vec<String> = boats
            .iter()
            .map(|b| {
                format!(
                    "{} × {} m in lane {} m, start {} s, rate {}",
                    b.length_m, b.beam_m, b.lane_m, b.start_s, b.rate
                )
            })
            .collect();
        let plural = if boats.len() == 1 { "" } else { "s" };
        format!("{} moving boat{plural} ({})", boats.len(), each.join("; "))
    }

    /// The boat's pose at `t_s` from the track's pose at track time `τ`, `track(τ)`, over a run of
    /// `duration_s`.
    pub fn pose(
        &self,
        t_s: f64,
        duration_s: f64,
        track: &dyn Fn(f64) -> Isometry2<f64>,
    ) -> Isometry2<f64> {
        let tau = (self.start_s + self.rate * t_s).clamp(0.0, duration_s);
        let on_track = track(tau);
        let heading = if self.rate < 0.0 {
            std::f64::consts::PI
        } else {
            0.0
        };
        on_track * Isometry2::new(Vector2::new(0.0, self.lane_m), heading)
    }

    /// Whether the boat moves at `t_s` in a run of `duration_s`: its track time advances and
    /// is not clamped to the run's ends.
    pub fn moves_at(&self, t_s: f64, duration_s: f64) -> bool {
        let tau = self.start_s + self.rate * t_s;
        self.rate != 0.0 && tau > 0.0 && tau < duration_s
    }

    /// The hull's four sides at `pose` (a rectangle, bow along the pose's `x`).
    pub fn sides(&self, pose: &Isometry2<f64>) -> [Segment; 4] {
        let (l, b) = (0.5 * self.length_m, 0.5 * self.beam_m);
        let c = [(l, b), (-l, b), (-l, -b), (l, -b)].map(|(x, y)| pose * Point2::new(x, y));
        [0, 1, 2, 3].map(|i| Segment {
            a: c[i],
            b: c[(i + 1) % 4],
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synthetic::rough::tests::{calm, room};
    use crate::synthetic::rough::{Motion, RoughScanner};
    use crate::synthetic::ScannerConfig;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    /// On a straight track at 1.2 m/s a boat at rate 1.5 moves 1.8 m/s, in its lane, with its
    /// sides around its centre; before its start it lies still.
    #[test]
    fn a_boat_moves_along_its_lane_at_its_rate() {
        let track = |tau: f64| Isometry2::new(Vector2::new(1.2 * tau, 0.0), 0.0);
        let boat = Boat::harbour()[0];
        let (a, b) = (
            boat.pose(20.0, 100.0, &track),
            boat.pose(30.0, 100.0, &track),
        );
        assert!((b.translation.x - a.translation.x - 18.0).abs() < 1e-12);
        assert_eq!(a.translation.y, -4.0);
        assert_eq!(boat.pose(0.0, 100.0, &track), boat.pose(5.0, 100.0, &track));
        let oncoming = Boat::harbour()[1];
        let (a, b) = (
            oncoming.pose(20.0, 200.0, &track),
            oncoming.pose(30.0, 200.0, &track),
        );
        assert!((b.translation.x - a.translation.x + 14.4).abs() < 1e-9);
        let sides = boat.sides(&a);
        for s in &sides {
            let mid = Point2::from((s.a.coords + s.b.coords) * 0.5);
            let d = (mid - Point2::from(a.translation.vector)).norm();
            assert!((d - 1.2).abs() < 1e-9 || (d - 3.0).abs() < 1e-9, "{d}");
        }
    }

    /// The moving labels are exact: one boat meets a turning vessel in a closed room, each beam
    /// cast at its own time (motion distortion), exact returns. Without mixed pixels a return
    /// is labelled exactly when its beam's nearest hit is the hull at the beam's time, and then
    /// its point lies on the hull within 1e-6 m while no unlabelled one does. With every edge
    /// beam mixed, a mixed pixel (no true normal) is labelled when either beam it mixes met
    /// the hull.
    #[test]
    fn moving_labels_mark_exactly_the_returns_off_the_hull() {
        let (world, surfaces) = room();
        let track = |t: f64| Isometry2::new(Vector2::new(-5.0 + 1.2 * t, 0.0), 0.05 * t);
        let boat = Boat {
            length_m: 6.0,
            beam_m: 2.4,
            lane_m: 4.0,
            start_s: 8.0,
            rate: -1.0,
        };
        let config = ScannerConfig {
            noise: false,
            dropout_prob: 0.0,
            gross_error_fraction: 0.0,
            motion_distortion: true,
            ..ScannerConfig::default()
        };
        let mut edge_labels = 0;
        for mixed_probability in [0.0, 1.0] {
            let mut rough = calm();
            rough.boats = vec![boat];
            rough.mixed.probability = mixed_probability;
            let sea = rough.sea.with_phases(&mut ChaCha8Rng::seed_from_u64(0));
            let motion = Motion {
                track: &track,
                sea: &sea,
                duration_s: 10.0,
            };
            let scanner = RoughScanner::new(&config, &rough, &world, &surfaces);
            let (mut noise_rng, mut event_rng) =
                (ChaCha8Rng::seed_from_u64(1), ChaCha8Rng::seed_from_u64(2));
            let mut labelled = 0;
            for t_s in [0.5, 2.0, 3.5, 5.0, 6.5] {
                let rev = scanner.scan(&motion, t_s, &mut noise_rng, &mut event_rng);
                let beams = rev.ranges_m.len();
                let pose = |j: usize| {
                    motion.pose(t_s + config.rotation_period_s() * j as f64 / beams as f64)
                };
                let hull = |j: usize| {
                    let t = t_s + config.rotation_period_s() * j as f64 / beams as f64;
                    boat.sides(&boat.pose(t, motion.duration_s, &track))
                };
                // Whether beam `j`'s nearest hit is the hull.
                let meets_hull = |j: usize| {
                    let (p, a) = (pose(j), rev.bearings_rad[j]);
                    let (o, u) = (
                        Point2::from(p.translation.vector),
                        p.rotation * Vector2::new(a.cos(), a.sin()),
                    );
                    let nearest = |s: &[Segment]| {
                        s.iter()
                            .filter_map(|s| s.hit(&o, &u))
                            .fold(f64::INFINITY, f64::min)
                    };
                    nearest(&hull(j)) < nearest(&world)
                };
                for j in (0..beams).filter(|&j| !rev.ranges_m[j].is_nan()) {
                    let moving = rev.moving[j];
                    labelled += usize::from(moving);
                    if mixed_probability > 0.0 {
                        let mixed = rev.true_normals[j].is_none();
                        let expected = meets_hull(j) || (mixed && meets_hull(j + 1));
                        assert_eq!(moving, expected, "beam {j} at {t_s} s");
                        edge_labels += usize::from(moving && !meets_hull(j));
                        continue;
                    }
                    assert_eq!(moving, meets_hull(j), "beam {j} at {t_s} s");
                    let (r, a) = (rev.ranges_m[j], rev.bearings_rad[j]);
                    let p = pose(j) * Point2::new(r * a.cos(), r * a.sin());
                    let off = hull(j)
                        .iter()
                        .map(|s| s.distance_to(&p))
                        .fold(f64::INFINITY, f64::min);
                    assert_eq!(
                        off < 1e-6,
                        moving,
                        "beam {j} at {t_s} s: {off} m off the hull"
                    );
                }
            }
            // The boat passes within 2-3 m: tens of beams a revolution.
            assert!(labelled > 150, "{labelled} labelled returns");
        }
        assert!(edge_labels > 0, "a mixed pixel labelled by its neighbour");
    }
}
