//! Surfaces as runs of neighbouring returns: what a detection grows along. A moving hull that
//! slides along its own sides leaves no trace on them between scans, only at its ends; the
//! ends and the sides are one run of returns, and a run short enough to be a hull is left out
//! whole when enough of it is seen to move.

use std::ops::Range;

use crate::Scan;

/// The runs of `scan`'s returns, in their order, where each return lies within `gap_m` of
/// the one before it.
pub fn segments(scan: &Scan, gap_m: f64) -> Vec<Range<usize>> {
    let returns = scan.returns();
    let mut runs = Vec::new();
    let mut start = 0;
    for i in 1..=returns.len() {
        let split = i == returns.len() || (returns[i].point - returns[i - 1].point).norm() > gap_m;
        if split {
            runs.push(start..i);
            start = i;
        }
    }
    runs
}

/// The diagonal of the bounding box of the returns of `run`, m.
pub fn extent_m(scan: &Scan, run: &Range<usize>) -> f64 {
    let points = scan.returns()[run.clone()].iter().map(|r| r.point);
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for p in points {
        lo = [lo[0].min(p.x), lo[1].min(p.y)];
        hi = [hi[0].max(p.x), hi[1].max(p.y)];
    }
    if lo[0] > hi[0] {
        return 0.0;
    }
    (hi[0] - lo[0]).hypot(hi[1] - lo[1])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn splits_at_gaps_and_measures_extent() {
        let points = [[1.0, 0.0], [1.3, 0.0], [1.6, 0.4], [3.0, 0.4], [3.1, 0.4]];
        let scan = Scan::from_cartesian(&points).unwrap();
        let runs = segments(&scan, 0.5);
        assert_eq!(runs, vec![0..3, 3..5]);
        assert!((extent_m(&scan, &runs[0]) - 0.6f64.hypot(0.4)).abs() < 1e-12);
        assert!((extent_m(&scan, &runs[1]) - 0.1).abs() < 1e-12);
        let empty = Scan::from_cartesian(&[]).unwrap();
        assert!(segments(&empty, 0.5).is_empty());
    }
}
