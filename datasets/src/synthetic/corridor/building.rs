//! The corridor scenario's floor: one storey of an office building, a rectangular loop of
//! corridors around a block of rooms, as wall segments (world frame, metres).
//!
//! The loop's centre line is a rectangle [`LOOP_LENGTH_M`] × [`LOOP_WIDTH_M`] with its first
//! corner at the origin, run counter-clockwise in four sides (south, east, north, west). The
//! corridors are [`CORRIDOR_WIDTH_M`] wide. Each side's walls carry the features of [`SIDES`]:
//! doors into rooms behind either wall and shallow recesses (fire-hose cabinets, pillars,
//! lift doors); everything else is bare wall. The south side has a row of identical offices
//! at a regular pitch (the scene repeats), the north side is bare but for one door over
//! 72 m (a long featureless stretch), the east side has a laboratory the robot visits.

use nalgebra::{Point2, Vector2};

use crate::synthetic::Segment;

/// Length of the loop's centre line along x (the south and north sides), m: a long office
/// wing, longer than the scanner's 50 m reach, so that in its middle the ends are beyond it.
pub const LOOP_LENGTH_M: f64 = 72.0;
/// Width of the loop's centre line along y (the east and west sides), m.
pub const LOOP_WIDTH_M: f64 = 24.0;
/// Width of a corridor wall to wall, m: 1.8–2.4 m is the usual office corridor (building
/// codes ask at least 1.1–1.8 m for escape routes; 2 m lets two people pass a trolley).
pub const CORRIDOR_WIDTH_M: f64 = 2.0;
/// Clear width of a door, m: the common 0.9 m single-leaf office door.
pub const DOOR_WIDTH_M: f64 = 0.9;

/// What a wall has at a place along its side.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Feature {
    /// A door (its centre `at_m` along the side) into a room behind the wall: `width_m` along
    /// the wall, `depth_m` deep. Cellular offices are 3–4 m wide and 4–5 m deep.
    Door {
        /// Position of the door's centre along the side from the side's first corner, m.
        at_m: f64,
        /// Room width along the wall, m, centred on the door.
        width_m: f64,
        /// Room depth behind the wall, m.
        depth_m: f64,
    },
    /// A recess in the wall (a cabinet niche, a door set back, a column's gap).
    Recess {
        /// Position of its centre along the side, m.
        at_m: f64,
        /// Width along the wall, m.
        width_m: f64,
        /// Depth behind the wall, m.
        depth_m: f64,
    },
}

impl Feature {
    fn span(&self) -> (f64, f64, f64) {
        match *self {
            Feature::Door {
                at_m,
                width_m,
                depth_m,
            }
            | Feature::Recess {
                at_m,
                width_m,
                depth_m,
            } => (at_m, width_m, depth_m),
        }
    }
}

/// One side of the loop: the features of its outer wall (away from the block of rooms the
/// loop surrounds) and of its inner wall, each sorted along the side.
pub struct Side {
    /// Outer wall's features.
    pub outer: &'static [Feature],
    /// Inner wall's features.
    pub inner: &'static [Feature],
}

/// An office: 3.6 m wide, 4.5 m deep.
const fn office(at_m: f64) -> Feature {
    Feature::Door {
        at_m,
        width_m: 3.6,
        depth_m: 4.5,
    }
}

/// A niche 1.2 m wide, 0.4 m deep.
const fn niche(at_m: f64) -> Feature {
    Feature::Recess {
        at_m,
        width_m: 1.2,
        depth_m: 0.4,
    }
}

/// Where the east side's laboratory door is, along the side, m: the robot visits the room.
pub const LAB_DOOR_AT_M: f64 = 12.0;

/// The four sides, counter-clockwise from the south one.
pub const SIDES: [Side; 4] = [
    // South: six identical offices at a 4 m pitch on the outer wall, facing bare wall with one
    // niche; then 36 m of bare corridor to the corner.
    Side {
        outer: &[
            office(10.0),
            office(14.0),
            office(18.0),
            office(22.0),
            office(26.0),
            office(30.0),
        ],
        inner: &[niche(20.0)],
    },
    // East: a 6 × 7 m laboratory behind the outer wall, niches on the inner one.
    Side {
        outer: &[Feature::Door {
            at_m: LAB_DOOR_AT_M,
            width_m: 7.0,
            depth_m: 6.0,
        }],
        inner: &[niche(6.0), niche(18.0)],
    },
    // North: bare walls for 72 m but for one office door near the middle.
    Side {
        outer: &[office(38.0)],
        inner: &[],
    },
    // West: two offices on the inner wall, a niche on the outer.
    Side {
        outer: &[niche(12.0)],
        inner: &[office(7.0), office(17.0)],
    },
];

/// The loop's corners (centre line), counter-clockwise from the origin.
pub fn corners() -> [Point2<f64>; 4] {
    [
        Point2::new(0.0, 0.0),
        Point2::new(LOOP_LENGTH_M, 0.0),
        Point2::new(LOOP_LENGTH_M, LOOP_WIDTH_M),
        Point2::new(0.0, LOOP_WIDTH_M),
    ]
}

/// Side `k`'s first corner, unit direction and length, m.
pub fn side_frame(k: usize) -> (Point2<f64>, Vector2<f64>, f64) {
    let c = corners();
    let (a, b) = (c[k % 4], c[(k + 1) % 4]);
    let length = (b - a).norm();
    (a, (b - a) / length, length)
}

/// Every wall segment of the floor.
pub fn walls() -> Vec<Segment> {
    let half = 0.5 * CORRIDOR_WIDTH_M;
    let mut segs = Vec::new();
    for (k, side) in SIDES.iter().enumerate() {
        let (a, d, length) = side_frame(k);
        // The loop runs counter-clockwise: the block of rooms is to the left.
        let left = Vector2::new(-d.y, d.x);
        // The outer wall runs corner to corner of the outer rectangle, the inner one of the
        // inner rectangle.
        wall(
            &mut segs,
            a - left * half,
            d,
            -left,
            (-half, length + half),
            side.outer,
        );
        wall(
            &mut segs,
            a + left * half,
            d,
            left,
            (half, length - half),
            side.inner,
        );
    }
    segs
}

/// One straight wall from `origin + dir · from` to `origin + dir · to`, with its features
/// cut into it; `back` points away from the corridor.
fn wall(
    segs: &mut Vec<Segment>,
    origin: Point2<f64>,
    dir: Vector2<f64>,
    back: Vector2<f64>,
    (from, to): (f64, f64),
    features: &[Feature],
) {
    let at = |s: f64, depth: f64| origin + dir * s + back * depth;
    let mut open_from = from;
    for f in features {
        let (centre, width, depth) = f.span();
        let (lo, hi) = (centre - 0.5 * width, centre + 0.5 * width);
        let (gap_lo, gap_hi) = match f {
            Feature::Door { .. } => (centre - 0.5 * DOOR_WIDTH_M, centre + 0.5 * DOOR_WIDTH_M),
            Feature::Recess { .. } => (lo, hi),
        };
        segs.push(Segment {
            a: at(open_from, 0.0),
            b: at(gap_lo, 0.0),
        });
        // The room's or recess's side walls and back wall.
        for (p, q) in [
            (at(lo, 0.0), at(lo, depth)),
            (at(lo, depth), at(hi, depth)),
            (at(hi, depth), at(hi, 0.0)),
        ] {
            segs.push(Segment { a: p, b: q });
        }
        // The wall beside a door is the room's front wall.
        open_from = gap_hi;
    }
    segs.push(Segment {
        a: at(open_from, 0.0),
        b: at(to, 0.0),
    });
}
