//! Nearest neighbour by k-d tree (`kiddo`'s immutable tree).

use kiddo::{ImmutableKdTree, SquaredEuclidean};
use nalgebra::Point2;

use super::{check_reference, Matcher, NearestIndex};
use crate::registry::{Kind, NoParams, StageKind, StageSpec};
use crate::IcpError;

/// Exact nearest neighbour with a k-d tree; gives the same pairs as the paper's Delaunay search.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct KdTree;

/// The registered kind.
pub const KIND: Kind<NoParams, dyn Matcher> = Kind::new(
    "kdtree",
    "k-d tree (kiddo): exact nearest neighbour",
    |_, _| Box::new(KdTree),
);

/// A k-d tree over the reference points.
pub struct KdTreeIndex {
    tree: ImmutableKdTree<f64, 2>,
    points: Vec<Point2<f64>>,
}

impl Matcher for KdTree {
    fn spec(&self) -> StageSpec {
        StageSpec::kind(KIND.name())
    }

    fn build(&self, reference: &[Point2<f64>]) -> Result<Box<dyn NearestIndex>, IcpError> {
        check_reference(reference)?;
        let coords: Vec<[f64; 2]> = reference.iter().map(|p| [p.x, p.y]).collect();
        let tree =
            ImmutableKdTree::new_from_slice(&coords).map_err(|_| IcpError::InvalidParameter {
                name: "reference",
                value: reference.len() as f64,
                reason: "the k-d tree could not be built over these points",
            })?;
        Ok(Box::new(KdTreeIndex {
            tree,
            points: reference.to_vec(),
        }))
    }
}

impl NearestIndex for KdTreeIndex {
    fn nearest(&self, query: &Point2<f64>) -> (usize, f64) {
        let found = self
            .tree
            .query(&[query.x, query.y])
            .nearest_one::<SquaredEuclidean<f64>>()
            .execute();
        let i = found.item as usize;
        // The distance is recomputed the same way by every matcher, so they agree bit for bit.
        (i, (self.points[i] - query).norm_squared())
    }
}
