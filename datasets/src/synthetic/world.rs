//! The harbour's walls and hulls as segments, built around the track, and the sector index
//! that casts a beam against them.

use nalgebra::{Point2, Vector2};
use rand::Rng;
use rand_chacha::ChaCha8Rng;

use super::track::Track;

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
    pub(super) fn hit(&self, o: &Point2<f64>, u: &Vector2<f64>) -> Option<f64> {
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
    pub(super) fn normal_facing(&self, u: &Vector2<f64>) -> Option<Vector2<f64>> {
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

/// What a segment of the basin is part of (in the rough harbour each has its own height above
/// the water).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Surface {
    /// A quay wall along the basin.
    Quay,
    /// A wall closing the basin at either end.
    EndWall,
    /// A finger pier off the starboard quay.
    Pier,
    /// The side of a moored hull.
    Hull,
}

/// Builds the basin around the track: its segments and, one per segment, what each is part of.
pub(super) fn build_world(
    track: &Track,
    duration_s: f64,
    rng: &mut ChaCha8Rng,
) -> (Vec<Segment>, Vec<Surface>) {
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
    let mut kinds = Vec::new();
    for quay in [&port, &starboard] {
        segs.extend(quay.windows(2).map(|w| Segment { a: w[0], b: w[1] }));
    }
    kinds.resize(segs.len(), Surface::Quay);
    // End walls close the basin.
    segs.push(Segment {
        a: port[0],
        b: starboard[0],
    });
    segs.push(Segment {
        a: *port.last().expect("non-empty"),
        b: *starboard.last().expect("non-empty"),
    });
    kinds.resize(segs.len(), Surface::EndWall);
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
            kinds.push(Surface::Pier);
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
                kinds.resize(segs.len(), Surface::Hull);
            }
            next_hull += 5.0 + rng.random_range(0.0..6.0);
        }
    }
    (segs, kinds)
}

/// The segments near one revolution, binned by the directions in which they can be seen from
/// the revolution's beam origins, so that a beam is tested only against its sector's segments.
///
/// Exact: every origin lies within `spread` of `centre`, so a point `X` of a segment hit by a
/// beam of direction `ψ` is seen from `centre` within `asin(spread / D)` of `ψ`, `D` being the
/// segment's distance from `centre`. A segment is listed in every sector its arc (as seen from
/// `centre`) widened by that much overlaps; one closer than `spread` in all of them. The
/// nearest hit among a sector's segments is therefore the nearest among all of them.
pub(super) struct Sectors<'w> {
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

    pub(super) fn new(segments: Vec<&'w Segment>, centre: &Point2<f64>, spread: f64) -> Self {
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
    /// `t`, metres, and the segment hit (of several at exactly that distance, the first), named
    /// by its position in the list the index was built from.
    pub(super) fn cast_index(&self, o: &Point2<f64>, u: &Vector2<f64>) -> Option<(f64, usize)> {
        let k = Self::sector(u.y.atan2(u.x));
        self.members[self.start[k] as usize..self.start[k + 1] as usize]
            .iter()
            .filter_map(|&i| self.segments[i as usize].hit(o, u).map(|t| (t, i as usize)))
            .fold(None, |nearest, (t, i)| match nearest {
                Some((best, _)) if best <= t => nearest,
                _ => Some((t, i)),
            })
    }
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
                    let cast = sectors.cast_index(&o, &u).map(|(t, i)| (t, sectors.segments[i]));
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

    #[test]
    fn a_segment_across_the_seam_is_found_on_both_sides() {
        let wall = Segment {
            a: Point2::new(-10.0, -3.0),
            b: Point2::new(-10.0, 3.0),
        };
        let sectors = Sectors::new(vec![&wall], &Point2::origin(), 0.0);
        for psi in [std::f64::consts::PI, -std::f64::consts::PI, 3.0, -3.0] {
            let u = Vector2::new(psi.cos(), psi.sin());
            let (t, _) = sectors.cast_index(&Point2::origin(), &u).unwrap();
            assert!((t - 10.0 / psi.cos().abs()).abs() < 1e-9, "{psi}: {t}");
        }
        // Seen from the centre it spans 2 atan(3/10) = 33.4° of the turn: 47.5 sectors of the 512,
        // so 48 once aligned on their edges.
        assert_eq!(Sectors::span(&wall, &Point2::origin(), 0.0).1, 48);
    }
}
