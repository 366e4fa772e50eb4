//! People walking the corridors while the robot scans: each paces up and down a lane of one
//! side of the loop, beside the corridor's centre line the robot keeps to.
//!
//! A person at the scanner's height (legs and hips, ~0.3–0.9 m above the floor) is modelled as
//! a circle [`PERSON_DIAMETER_M`] across (a regular octagon of segments): an adult's hip width
//! is 0.35–0.4 m. They walk at 1.0–1.4 m/s (the usual preferred walking speed, ~1.2–1.4 m/s,
//! a little slower indoors), turning back at their lane's ends. Every return off a person is
//! labelled moving ([`icp_core::Scan::moving`]).

use nalgebra::{Point2, Vector2};
use rand::Rng;
use rand_chacha::ChaCha8Rng;

use super::building::side_frame;
use crate::synthetic::Segment;

/// Diameter of a person at the scanner's height, m.
pub const PERSON_DIAMETER_M: f64 = 0.4;

/// One person pacing a lane.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Walker {
    /// The side of the loop (0 south, 1 east, 2 north, 3 west).
    pub side: usize,
    /// The lane's offset to the left of the centre line, m (the robot keeps to the centre
    /// line, a person's 0.2 m radius off it).
    pub lane_m: f64,
    /// Where along the side the lane starts and ends, m (clear of the corners, where the
    /// robot turns).
    pub from_m: f64,
    /// The lane's end, m.
    pub to_m: f64,
    /// Walking speed, m/s.
    pub speed_mps: f64,
    /// Distance walked at `t = 0` along the lane's out-and-back circuit, m.
    pub start_m: f64,
}

/// The ChaCha8 stream of the walkers' starting places, apart from the noise's and events'.
pub const PEOPLE_STREAM: u64 = 36;

impl Walker {
    /// Three people: one pacing most of the south side (past the offices and the bare
    /// stretch), one on the north side's bare stretch and one on the east side; their
    /// starting places drawn from `rng`.
    pub fn office(rng: &mut ChaCha8Rng) -> Vec<Walker> {
        [
            (0, 0.5, 4.0, 68.0, 1.2),
            (2, -0.5, 6.0, 66.0, 1.4),
            (1, 0.5, 3.0, 21.0, 1.0),
        ]
        .into_iter()
        .map(|(side, lane_m, from_m, to_m, speed_mps)| Walker {
            side,
            lane_m,
            from_m,
            to_m,
            speed_mps,
            start_m: rng.random_range(0.0..2.0 * (to_m - from_m)),
        })
        .collect()
    }

    /// Centre at `t_s`, world frame.
    pub fn centre(&self, t_s: f64) -> Point2<f64> {
        let span = self.to_m - self.from_m;
        let walked = (self.start_m + self.speed_mps * t_s).rem_euclid(2.0 * span);
        let along = self.from_m
            + if walked <= span {
                walked
            } else {
                2.0 * span - walked
            };
        let (a, d, _) = side_frame(self.side);
        a + d * along + Vector2::new(-d.y, d.x) * self.lane_m
    }

    /// The person's outline at `t_s`: a regular octagon around the circle.
    pub fn outline(&self, t_s: f64) -> [Segment; 8] {
        let c = self.centre(t_s);
        let corner = |i: usize| {
            let a = std::f64::consts::FRAC_PI_4 * i as f64;
            c + Vector2::new(a.cos(), a.sin()) * (0.5 * PERSON_DIAMETER_M)
        };
        std::array::from_fn(|i| Segment {
            a: corner(i),
            b: corner(i + 1),
        })
    }
}
