//! Surfaces that lie where the scans on both sides left moving returns out. A hull's long side
//! slides along itself: few of its returns are ever seen through, and in a scan where too few
//! are, the side is kept, while the scan before and the scan after left it out (their
//! neighbours saw its ends move). The static scene is left out here and there by one scan,
//! seldom at the same place by the scans on both sides: asking both keeps it.

use nalgebra::{Isometry2, Point2};

use super::chain::Step;
use super::segments::{extent_m, segments};
use super::Detection;
use crate::matching::{KdTree, Matcher};
use crate::Scan;

/// The returns `detection` left out of `scan`, moved by `t_to_scan` into another scan's frame.
pub fn left_out_points(
    scan: &Scan,
    detection: &Detection,
    t_to_scan: &Isometry2<f64>,
) -> Vec<Point2<f64>> {
    scan.returns()
        .iter()
        .zip(&detection.left_out)
        .filter(|(_, &out)| out)
        .map(|(r, _)| t_to_scan * r.point)
        .collect()
}

/// The returns left out of the scans before and after scan `k`, in its frame: `left_out(j,
/// t_k_j)` gives scan `j`'s moved by `t_k_j`, placed by the registrations of consecutive scans
/// `steps` ([`neighbour_poses`](super::neighbour_poses)'s); none from a side whose step is
/// missing.
pub fn beside(
    k: usize,
    steps: &[Option<Step>],
    left_out: impl Fn(usize, &Isometry2<f64>) -> Vec<Point2<f64>>,
) -> [Vec<Point2<f64>>; 2] {
    let step = |i: usize| steps.get(i).and_then(Option::as_ref).map(|(t, _)| *t);
    let before = k
        .checked_sub(1)
        .and_then(|j| Some(left_out(j, &step(j)?)))
        .unwrap_or_default();
    let after = step(k)
        .map(|t| left_out(k + 1, &t.inverse()))
        .unwrap_or_default();
    [before, after]
}

/// How a surface is judged to lie where both neighbours left returns out.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Between {
    /// A return lies where a neighbour left returns out when one of them is this close, m.
    pub gap_m: f64,
    /// A surface kept by the detection is left out when at least this share of its returns
    /// lies where both neighbours left returns out (and at least one does).
    pub min_share: f64,
    /// Neighbouring returns closer than this are one surface, m.
    pub segment_gap_m: f64,
    /// A surface longer than this (bounding-box diagonal, m) is never left out whole.
    pub max_extent_m: f64,
}

impl Between {
    /// `left_out` of `scan` with the surfaces it kept whole that lie where the returns left
    /// out of the scan before (`before`) and of the scan after (`after`), both in `scan`'s
    /// frame, lie too. Unchanged where either is empty.
    pub fn fill(
        &self,
        scan: &Scan,
        left_out: &[bool],
        before: &[Point2<f64>],
        after: &[Point2<f64>],
    ) -> Vec<bool> {
        let mut filled = left_out.to_vec();
        let (Ok(before), Ok(after)) = (KdTree.build(before), KdTree.build(after)) else {
            return filled;
        };
        let gap_sq = self.gap_m * self.gap_m;
        let near = |i: usize| {
            let p = scan.returns()[i].point;
            before.nearest(&p).1 <= gap_sq && after.nearest(&p).1 <= gap_sq
        };
        for run in segments(scan, self.segment_gap_m) {
            if left_out[run.clone()].iter().any(|&o| o) || extent_m(scan, &run) > self.max_extent_m
            {
                continue;
            }
            let inside = run.clone().filter(|&i| near(i)).count();
            if inside > 0 && inside as f64 >= self.min_share * run.len() as f64 {
                filled[run].fill(true);
            }
        }
        filled
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn between() -> Between {
        Between {
            gap_m: 0.5,
            min_share: 0.25,
            segment_gap_m: 0.8,
            max_extent_m: 12.0,
        }
    }

    /// A wall (x = 10, 21 returns) and a hull's side (y = 4, 11 returns), none left out.
    fn scene() -> Scan {
        let mut points: Vec<[f64; 2]> = (0..21).map(|i| [10.0, -5.0 + 0.5 * i as f64]).collect();
        points.extend((0..11).map(|i| [-2.0 + 0.4 * i as f64, 4.0]));
        Scan::from_cartesian(&points).unwrap()
    }

    #[test]
    fn beside_moves_each_side_into_the_scan_and_skips_a_missing_step() {
        // Scan 1 sits 1 m along x from scan 0 and 2 m from scan 2: step i maps scan i's
        // points into scan i+1's frame.
        let step = |dx: f64| Some((Isometry2::translation(-dx, 0.0), nalgebra::Matrix3::zeros()));
        let steps = [step(1.0), step(2.0)];
        let origin = |_: usize, t: &Isometry2<f64>| vec![t * Point2::origin()];
        let [before, after] = beside(1, &steps, origin);
        assert_eq!(
            before,
            vec![Point2::new(-1.0, 0.0)],
            "scan 0's origin in scan 1"
        );
        assert_eq!(
            after,
            vec![Point2::new(2.0, 0.0)],
            "scan 2's origin in scan 1"
        );
        let [before, after] = beside(0, &steps, origin);
        assert!(before.is_empty(), "no scan before the first");
        assert_eq!(after, vec![Point2::new(1.0, 0.0)]);
        let [before, after] = beside(1, &[None, step(2.0)], origin);
        assert!(before.is_empty(), "a missing step places nothing");
        assert_eq!(after.len(), 1);
        let [_, after] = beside(2, &steps, origin);
        assert!(after.is_empty(), "no step after the last scan");
    }

    #[test]
    fn a_side_both_neighbours_left_out_goes_the_wall_stays() {
        let scan = scene();
        let kept = vec![false; scan.len()];
        // The side, 0.3 m further along in the scan before and 0.3 m back in the scan after.
        let side = |dx: f64| -> Vec<Point2<f64>> {
            (0..11)
                .map(|i| Point2::new(-2.0 + dx + 0.4 * i as f64, 4.05))
                .collect()
        };
        let filled = between().fill(&scan, &kept, &side(0.3), &side(-0.3));
        assert!(filled[..21].iter().all(|&o| !o), "the wall is kept");
        assert!(filled[21..].iter().all(|&o| o), "the side is left out");
    }

    #[test]
    fn one_side_alone_or_far_returns_leave_it_kept() {
        let scan = scene();
        let kept = vec![false; scan.len()];
        let side: Vec<Point2<f64>> = (0..11)
            .map(|i| Point2::new(-2.0 + 0.4 * i as f64, 4.0))
            .collect();
        let far: Vec<Point2<f64>> = side
            .iter()
            .map(|p| p + nalgebra::Vector2::new(0.0, 0.6))
            .collect();
        assert_eq!(between().fill(&scan, &kept, &side, &[]), kept);
        assert_eq!(between().fill(&scan, &kept, &[], &side), kept);
        assert_eq!(between().fill(&scan, &kept, &side, &far), kept);
    }

    #[test]
    fn a_surface_already_partly_left_out_or_too_long_is_not_touched() {
        let scan = scene();
        let mut partly = vec![false; scan.len()];
        partly[21] = true;
        let wall: Vec<Point2<f64>> = (0..21)
            .map(|i| Point2::new(10.0, -5.0 + 0.5 * i as f64))
            .collect();
        let side: Vec<Point2<f64>> = (0..11)
            .map(|i| Point2::new(-2.0 + 0.4 * i as f64, 4.0))
            .collect();
        let filled = between().fill(&scan, &partly, &side, &side);
        assert_eq!(
            filled, partly,
            "a surface the detection judged stays as judged"
        );
        let short = Between {
            max_extent_m: 5.0,
            ..between()
        };
        let filled = short.fill(&scan, &vec![false; scan.len()], &wall, &wall);
        assert!(
            filled[..21].iter().all(|&o| !o),
            "the 10 m wall is too long to be a hull"
        );
    }
}
