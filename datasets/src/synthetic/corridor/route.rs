//! The robot's route: laps of the corridor loop on its centre line, counter-clockwise from the
//! south-west corner, as legs of equal steps between scans.
//!
//! A straight stretch is driven in pieces of at most [`PIECE_M`], each at its own step drawn
//! uniformly in [`MIN_STEP_M`, `MAX_STEP_M`] (an indoor robot's 0.3–0.5 m/s with a scan a
//! second). At a corner the robot stops and turns on the spot by 90° in steps of
//! [`CORNER_STEP_DEG`]; on the east side it turns into the laboratory's door, drives 3 m into
//! the room, turns about by 180° in steps of [`MAX_TURN_DEG`] and comes back out. No step
//! moves more than [`MAX_STEP_M`] or turns more than [`MAX_TURN_DEG`].

use nalgebra::{Isometry2, Vector2};
use rand::Rng;
use rand_chacha::ChaCha8Rng;

use super::building::{side_frame, CORRIDOR_WIDTH_M, LAB_DOOR_AT_M};

/// Shortest step along a straight stretch, m.
pub const MIN_STEP_M: f64 = 0.3;
/// Longest step along a straight stretch, m.
pub const MAX_STEP_M: f64 = 0.5;
/// Largest turn between two scans, degrees (the about-turn in the laboratory).
pub const MAX_TURN_DEG: f64 = 20.0;
/// Turn between two scans at a corner or a door, degrees: 90° in 5 scans.
pub const CORNER_STEP_DEG: f64 = 18.0;
/// Longest straight piece driven at one step, m.
pub const PIECE_M: f64 = 12.0;
/// How far into the laboratory the robot drives past the door, m.
const INTO_ROOM_M: f64 = 3.0;

/// Scans taken with the same motion between each and the next.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Leg {
    steps: usize,
    /// Forward motion per step, m.
    forward_m: f64,
    /// Turn per step, degrees, counter-clockwise positive.
    turn_deg: f64,
}

impl Leg {
    /// A straight drive of `length_m` in equal steps near one drawn in the step range (and
    /// within it for a drive of at least 1.5 m).
    fn straight(length_m: f64, rng: &mut ChaCha8Rng) -> Self {
        let step = rng.random_range(MIN_STEP_M..=MAX_STEP_M);
        let fewest = (length_m / MAX_STEP_M).ceil().max(1.0);
        let steps = (length_m / step)
            .round()
            .min((length_m / MIN_STEP_M).floor())
            .max(fewest) as usize;
        Self {
            steps,
            forward_m: length_m / steps as f64,
            turn_deg: 0.0,
        }
    }

    /// A turn on the spot by `angle_deg` in steps of `step_deg`.
    fn pivot(angle_deg: f64, step_deg: f64) -> Self {
        let steps = (angle_deg.abs() / step_deg).round() as usize;
        Self {
            steps,
            forward_m: 0.0,
            turn_deg: angle_deg / steps as f64,
        }
    }
}

/// A straight stretch from `from_m` to `to_m` along a side, in pieces of at most [`PIECE_M`].
fn stretch(legs: &mut Vec<Leg>, from_m: f64, to_m: f64, rng: &mut ChaCha8Rng) {
    let pieces = ((to_m - from_m) / PIECE_M).ceil().max(1.0);
    for _ in 0..pieces as usize {
        legs.push(Leg::straight((to_m - from_m) / pieces, rng));
    }
}

/// One lap's legs, the steps drawn from `rng`.
fn lap(rng: &mut ChaCha8Rng) -> Vec<Leg> {
    let mut legs = Vec::new();
    for k in 0..4 {
        let (_, _, length) = side_frame(k);
        if k == 1 {
            // The laboratory lies behind the outer wall, to the right.
            let room = Leg::straight(0.5 * CORRIDOR_WIDTH_M + INTO_ROOM_M, rng);
            stretch(&mut legs, 0.0, LAB_DOOR_AT_M, rng);
            legs.extend([
                Leg::pivot(-90.0, CORNER_STEP_DEG),
                room,
                Leg::pivot(180.0, MAX_TURN_DEG),
                room,
                Leg::pivot(-90.0, CORNER_STEP_DEG),
            ]);
            stretch(&mut legs, LAB_DOOR_AT_M, length, rng);
        } else {
            stretch(&mut legs, 0.0, length, rng);
        }
        legs.push(Leg::pivot(90.0, CORNER_STEP_DEG));
    }
    legs
}

/// The robot's pose at each of `n_scans` scans (world frame): laps of the loop from the
/// south-west corner heading east, each lap's steps drawn anew from `rng`.
pub fn poses(n_scans: usize, rng: &mut ChaCha8Rng) -> Vec<Isometry2<f64>> {
    let mut pose = Isometry2::identity();
    let mut out = Vec::with_capacity(n_scans);
    while out.len() < n_scans {
        for leg in lap(rng) {
            for _ in 0..leg.steps {
                out.push(pose);
                // The truth is whatever is composed here: exact by construction.
                pose *= Isometry2::new(Vector2::new(leg.forward_m, 0.0), leg.turn_deg.to_radians());
            }
        }
    }
    out.truncate(n_scans);
    out
}
