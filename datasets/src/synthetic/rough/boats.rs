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
}
