//! Exhaustive nearest-neighbour search: the oracle the other matchers are tested against.

use nalgebra::Point2;

use super::{check_reference, Matcher, NearestIndex};
use crate::registry::{Kind, NoParams, StageKind, StageSpec};
use crate::IcpError;

/// O(n) search per query; among equidistant points it returns the lowest index.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BruteForce;

/// The registered kind.
pub const KIND: Kind<NoParams, dyn Matcher> = Kind::new(
    "brute",
    "exhaustive search: the oracle the other matchers are tested against",
    |_, _| Box::new(BruteForce),
);

/// The reference points, searched exhaustively.
#[derive(Clone, Debug)]
pub struct BruteForceIndex {
    points: Vec<Point2<f64>>,
}

impl Matcher for BruteForce {
    fn spec(&self) -> StageSpec {
        StageSpec::kind(KIND.name())
    }

    fn build(&self, reference: &[Point2<f64>]) -> Result<Box<dyn NearestIndex>, IcpError> {
        check_reference(reference)?;
        Ok(Box::new(BruteForceIndex {
            points: reference.to_vec(),
        }))
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
