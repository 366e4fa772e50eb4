//! Nearest-neighbour matching, Algorithm 1 step 2.
//!
//! A [`Matcher`] is the stage's configuration; it builds a [`NearestIndex`] once per
//! registration over the selected reference points, which then answers one query per moved
//! source point at every iteration.

use nalgebra::Point2;

use crate::registry::{Family, StageSpec};
use crate::IcpError;

mod brute;
mod delaunay;
mod grid;
mod kdtree;
mod last_index;

pub use brute::BruteForce;
pub use delaunay::Delaunay;
pub use grid::Grid;
pub use kdtree::KdTree;
pub(crate) use last_index::LastIndex;

/// One matched pair: source point `src` (moved) and its nearest reference point `dst`.
/// The distance is *squared*, as nearest-neighbour indices return it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Correspondence {
    /// Index of the source point.
    pub src: usize,
    /// Index of the nearest reference point.
    pub dst: usize,
    /// Squared distance between the moved source point and the reference point, m².
    pub dist_sq: f64,
}

/// A nearest-neighbour index over the reference points, built once per registration.
pub trait NearestIndex: Send + Sync {
    /// Index and squared distance of the reference point nearest to `query`. Among points at
    /// exactly the same distance any may be returned.
    fn nearest(&self, query: &Point2<f64>) -> (usize, f64);

    /// Fills `out` (cleared first) with one correspondence per query, in query order. An index
    /// may keep what it learnt about each query at its previous call (the previous ICP
    /// iteration) to do less work; the pairs are the same either way.
    fn match_all(&mut self, queries: &[Point2<f64>], out: &mut Vec<Correspondence>) {
        out.clear();
        out.extend(queries.iter().enumerate().map(|(src, q)| {
            let (dst, dist_sq) = self.nearest(q);
            Correspondence { src, dst, dist_sq }
        }));
    }
}

/// Matching, Algorithm 1 step 2: builds a [`NearestIndex`] over a reference scan.
pub trait Matcher: Send + Sync {
    /// What this stage is, as configuration data.
    fn spec(&self) -> StageSpec {
        StageSpec::unregistered::<Self>()
    }

    /// Builds the index over `reference` (non-empty, finite points).
    fn build(&self, reference: &[Point2<f64>]) -> Result<Box<dyn NearestIndex>, IcpError>;
}

/// Every registered matcher. Adding one: a file with its `impl Matcher` and its `KIND`, and
/// one line here.
pub static MATCHERS: Family<dyn Matcher> = Family {
    name: "matcher",
    summary: "Alg. 1 step 2: the nearest reference point of each moved source point (every kind is exact)",
    kinds: &[&grid::KIND, &kdtree::KIND, &delaunay::KIND, &brute::KIND],
};

/// Checks what every index needs: at least one point, all finite, indices fit in `u32`.
fn check_reference(reference: &[Point2<f64>]) -> Result<(), IcpError> {
    if reference.is_empty() {
        return Err(IcpError::TooFewPoints {
            role: crate::error::ScanRole::Reference,
            got: 0,
            need: 1,
        });
    }
    if reference.len() > u32::MAX as usize {
        return Err(IcpError::InvalidParameter {
            name: "reference.len()",
            value: reference.len() as f64,
            reason: "a nearest-neighbour index holds at most u32::MAX points",
        });
    }
    for (index, p) in reference.iter().enumerate() {
        if let Some(&value) = p.coords.iter().find(|v| !v.is_finite()) {
            return Err(IcpError::NonFinite {
                what: "reference coordinate",
                index,
                value,
            });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn points(v: &[(f64, f64)]) -> Vec<Point2<f64>> {
        v.iter().map(|&(x, y)| Point2::new(x, y)).collect()
    }

    fn check_all_agree(reference: &[Point2<f64>], queries: &[Point2<f64>]) {
        let brute = BruteForce.build(reference).unwrap();
        let kd = KdTree.build(reference).unwrap();
        let dl = Delaunay.build(reference).unwrap();
        let gr = Grid.build(reference).unwrap();
        for q in queries {
            let want = brute.nearest(q);
            for (name, got) in [
                ("kdtree", kd.nearest(q)),
                ("delaunay", dl.nearest(q)),
                ("grid", gr.nearest(q)),
            ] {
                assert_eq!(got.1, want.1, "{name} distance for {q:?}");
                // Continuous random inputs have no ties, so the index must agree too.
                assert_eq!(got.0, want.0, "{name} index for {q:?}");
            }
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        #[test]
        fn kdtree_and_delaunay_agree_with_brute_force(
            reference in prop::collection::vec((-40.0..40.0f64, -40.0..40.0f64), 3..400),
            queries in prop::collection::vec((-50.0..50.0f64, -50.0..50.0f64), 1..200),
        ) {
            check_all_agree(&points(&reference), &points(&queries));
        }
    }

    #[test]
    fn matchers_agree_on_a_wall_scan() {
        // Dense, structured points (a quay seen by a LIDAR) with queries just off them.
        let reference: Vec<_> = (0..700)
            .map(|i| {
                let a = i as f64 * 0.48f64.to_radians();
                let r = 12.0 + 6.0 * (3.0 * a).sin();
                Point2::new(r * a.cos(), r * a.sin())
            })
            .collect();
        let queries: Vec<_> = reference
            .iter()
            .map(|p| p + nalgebra::Vector2::new(0.07, -0.03))
            .collect();
        check_all_agree(&reference, &queries);
    }

    #[test]
    fn duplicates_resolve_to_the_lowest_index_with_equal_distance() {
        let reference = points(&[(1.0, 1.0), (0.0, 0.0), (1.0, 1.0), (5.0, 0.0)]);
        let q = Point2::new(1.1, 1.0);
        for (i, d) in [
            BruteForce.build(&reference).unwrap().nearest(&q),
            KdTree.build(&reference).unwrap().nearest(&q),
            Delaunay.build(&reference).unwrap().nearest(&q),
            Grid.build(&reference).unwrap().nearest(&q),
        ] {
            assert!(i == 0 || i == 2);
            assert!((d - 0.01).abs() < 1e-15);
        }
        assert_eq!(BruteForce.build(&reference).unwrap().nearest(&q).0, 0);
    }

    #[test]
    fn collinear_reference_still_matches() {
        let reference = points(&[(0.0, 0.0), (1.0, 1.0), (2.0, 2.0), (3.0, 3.0)]);
        let queries = points(&[(2.9, 3.2), (-1.0, 0.0), (1.4, 1.7)]);
        check_all_agree(&reference, &queries);
    }

    #[test]
    fn empty_reference_is_an_error() {
        assert!(BruteForce.build(&[]).is_err());
        assert!(KdTree.build(&[]).is_err());
        assert!(Delaunay.build(&[]).is_err());
        assert!(Grid.build(&[]).is_err());
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        /// Matching a query set that moves a little at each call, as in ICP iterations (with
        /// jumps, so both certified and searched queries occur), gives at every call exactly
        /// the pairs of a cold brute-force search, ties resolved to the lowest index.
        #[test]
        fn repeated_grid_matching_equals_brute_force(
            reference in prop::collection::vec((-40.0..40.0f64, -40.0..40.0f64), 1..300),
            queries in prop::collection::vec((-60.0..60.0f64, -60.0..60.0f64), 1..200),
            steps in prop::collection::vec((-0.5..0.5f64, -0.5..0.5f64, -0.05..0.05f64), 1..12),
            dup in 0usize..5,
        ) {
            let mut reference = points(&reference);
            // Duplicates make ties.
            for i in 0..dup.min(reference.len()) {
                let p = reference[i];
                reference.push(p);
            }
            let mut queries = points(&queries);
            let mut brute = BruteForce.build(&reference).unwrap();
            let mut grid = Grid.build(&reference).unwrap();
            let (mut want, mut got) = (Vec::new(), Vec::new());
            for (k, &(dx, dy, angle)) in steps.iter().enumerate() {
                // Steps shrinking like an ICP's, about the origin.
                let scale = 0.5f64.powi(k as i32);
                let t = nalgebra::Isometry2::new(nalgebra::Vector2::new(dx, dy) * scale, angle * scale);
                for q in queries.iter_mut() {
                    *q = t * *q;
                }
                brute.match_all(&queries, &mut want);
                grid.match_all(&queries, &mut got);
                prop_assert_eq!(&got, &want);
            }
        }
    }

    #[test]
    fn a_grid_index_answers_new_queries_of_the_same_count_exactly() {
        // Certificates bound the index's own points from their anchors, so they stay valid
        // when the next call asks other queries (here far from the first ones).
        let reference = points(&[(0.0, 0.5), (1.0, 0.1), (20.0, 0.0), (9.0, 3.0)]);
        let mut grid = Grid.build(&reference).unwrap();
        let mut brute = BruteForce.build(&reference).unwrap();
        let (mut got, mut want) = (Vec::new(), Vec::new());
        for queries in [
            points(&[(1.0, 0.0), (9.0, 0.0), (19.0, 0.0)]),
            points(&[(19.0, 0.5), (0.2, 0.4), (8.0, 2.0)]),
            points(&[(1.0, 0.0), (9.0, 0.0), (19.0, 0.0)]),
        ] {
            grid.match_all(&queries, &mut got);
            brute.match_all(&queries, &mut want);
            assert_eq!(got, want);
        }
    }

    #[test]
    fn grid_handles_degenerate_layouts() {
        for reference in [
            points(&[(3.0, 3.0)]),
            points(&[(0.0, 0.0), (0.0, 5.0), (0.0, 9.0)]),
            points(&[(1e6, -1e6), (1e6 + 1e-3, -1e6), (-1e6, 1e6)]),
            points(&[(2.0, 2.0); 5]),
        ] {
            let queries = points(&[(0.0, 0.0), (1e7, 1e7), (-3.0, 4.0), (1e6, -1e6 + 0.1)]);
            check_all_agree(&reference, &queries);
        }
    }

    #[test]
    fn out_of_range_coordinates_are_an_error_not_a_panic() {
        let reference = points(&[(0.0, 0.0), (1e300, 0.0), (0.0, 1.0)]);
        assert!(matches!(
            Delaunay.build(&reference),
            Err(IcpError::CoordinateOutOfRange { index: 1, .. })
        ));
        let nan = points(&[(0.0, f64::NAN)]);
        for r in [
            BruteForce.build(&nan).err(),
            KdTree.build(&nan).err(),
            Delaunay.build(&nan).err(),
        ] {
            assert!(matches!(r, Some(IcpError::NonFinite { .. })));
        }
    }
}
