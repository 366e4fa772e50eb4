//! Exhaustive nearest-neighbour search: the oracle the other matchers are tested against.

use nalgebra::Point2;

use super::{check_reference, Matcher, NearestIndex};
use crate::IcpError;

/// O(n) search per query; among equidistant points it returns the lowest index.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BruteForce;

/// The reference points, searched exhaustively.
#[derive(Clone, Debug)]
pub struct BruteForceIndex {
    points: Vec<Point2<f64>>,
}

impl Matcher for BruteForce {
    type Index = BruteForceIndex;
    fn build(&self, reference: &[Point2<f64>]) -> Result<Self::Index, IcpError> {
        check_reference(reference)?;
        Ok(BruteForceIndex {
            points: reference.to_vec(),
        })
    }
}

impl NearestIndex for BruteForceIndex {
    fn nearest(&self, query: &Point2<f64>) -> (usize, f64) {
        let mut best = (0, f64::INFINITY);
        for (i, p) in self.points.iter().enumerate() {
            let d = (p - query).norm_squared();
            if d < best.1 {
                best = (i, d);
            }
        }
        best
    }
}
