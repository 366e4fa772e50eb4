//! Nearest-neighbour matching, Algorithm 1 step 2.
//!
//! A [`Matcher`] is the stage's configuration; it builds a [`NearestIndex`] once per reference
//! scan, which then answers one query per moved source point at every iteration.

use nalgebra::Point2;
use serde::{Deserialize, Serialize};

use crate::IcpError;

mod brute;
mod delaunay;
mod grid;
mod kdtree;

pub use brute::BruteForce;
pub use delaunay::Delaunay;
pub use grid::Grid;
pub use kdtree::KdTree;

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

/// The pairs of the last [`NearestIndex::match_all`] call, and what an index remembers about
/// each query to answer the next call (the next ICP iteration) with less work. One value is
/// reused across iterations and registrations: its buffers keep their capacity, and memory left
/// by another index is recognised and ignored.
#[derive(Clone, Debug, Default)]
pub struct Matches {
    /// One correspondence per query, in query order.
    pub pairs: Vec<Correspondence>,
    /// Per query, for the index that wrote them (see `owner`): a proof of its nearest point.
    certificates: Vec<Certificate>,
    /// The build stamp of the index that wrote `certificates` (0: none).
    owner: u64,
}

/// At `anchor`, every reference point other than `best` and `second` (the two nearest) was at
/// least `clearance` away. For a query `q` at `drift = |q − anchor|` those points are at least
/// `clearance − drift` from `q` (triangle inequality), so while the nearer of the two is nearer
/// than that, it is the nearest point. `best`/`dist_sq` are the last answer.
#[derive(Clone, Copy, Debug)]
struct Certificate {
    anchor: Point2<f64>,
    clearance: f64,
    best: usize,
    second: usize,
    dist_sq: f64,
}

impl Matches {
    /// Empty, with room for `n` queries.
    pub fn with_capacity(n: usize) -> Self {
        Self {
            pairs: Vec::with_capacity(n),
            certificates: Vec::with_capacity(n),
            owner: 0,
        }
    }

    /// Makes room for `n` queries.
    pub fn reserve(&mut self, n: usize) {
        self.pairs.reserve(n);
        self.certificates.reserve(n);
    }

    /// Becomes a copy of `other`, in the buffers it already has.
    pub fn copy_from(&mut self, other: &Matches) {
        self.pairs.clone_from(&other.pairs);
        self.certificates.clone_from(&other.certificates);
        self.owner = other.owner;
    }

    /// Forgets the pairs and what the index remembered (keeping the capacity): the next call
    /// searches every query afresh.
    pub fn clear(&mut self) {
        self.pairs.clear();
        self.certificates.clear();
        self.owner = 0;
    }
}

/// A nearest-neighbour index over the reference points.
pub trait NearestIndex: Send + Sync {
    /// Index and squared distance of the reference point nearest to `query`. Among points at
    /// exactly the same distance any may be returned.
    fn nearest(&self, query: &Point2<f64>) -> (usize, f64);

    /// Fills `out.pairs` with one correspondence per moved source point. An index may use what
    /// it left in `out` at its previous call to do less work; the pairs are the same either way.
    fn match_all(&self, moved_src: &[Point2<f64>], out: &mut Matches) {
        out.owner = 0;
        out.pairs.clear();
        out.pairs
            .extend(moved_src.iter().enumerate().map(|(src, q)| {
                let (dst, dist_sq) = self.nearest(q);
                Correspondence { src, dst, dist_sq }
            }));
    }
}

/// Builds a [`NearestIndex`] over a reference scan. An [`crate::Icp`] chain needs its matcher
/// to be `PartialEq + Clone + 'static` too: a [`crate::Workspace`] keeps the last index with
/// the matcher that built it, and hands it to the next registration with an equal matcher and
/// the same reference points.
pub trait Matcher: Send + Sync {
    /// The index this matcher builds.
    type Index: NearestIndex;
    /// Builds the index over `reference` (non-empty, finite points).
    fn build(&self, reference: &[Point2<f64>]) -> Result<Self::Index, IcpError>;
}

/// The matchers by name, for configuration files and the command line.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MatcherKind {
    /// k-d tree ([`KdTree`]).
    Kdtree,
    /// Delaunay nearest vertex, as in the paper ([`Delaunay`]).
    Delaunay,
    /// Exhaustive search ([`BruteForce`]), the oracle for tests.
    Brute,
    /// Uniform grid whose queries keep their nearest point between iterations while a
    /// certificate proves it ([`Grid`]): the default, the fastest here, and with the same pairs
    /// as brute force.
    #[default]
    Grid,
}

impl std::str::FromStr for MatcherKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.to_ascii_lowercase().as_str() {
            "kdtree" | "kd-tree" => Ok(Self::Kdtree),
            "delaunay" => Ok(Self::Delaunay),
            "brute" | "brute-force" => Ok(Self::Brute),
            "grid" => Ok(Self::Grid),
            other => Err(format!(
                "unknown matcher {other:?}: expected kdtree, delaunay, grid or brute"
            )),
        }
    }
}

impl std::fmt::Display for MatcherKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Self::Kdtree => "kdtree",
            Self::Delaunay => "delaunay",
            Self::Brute => "brute",
            Self::Grid => "grid",
        })
    }
}

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
            let brute = BruteForce.build(&reference).unwrap();
            let grid = Grid.build(&reference).unwrap();
            let (mut want, mut got) = (Matches::default(), Matches::default());
            for (k, &(dx, dy, angle)) in steps.iter().enumerate() {
                // Steps shrinking like an ICP's, about the origin.
                let scale = 0.5f64.powi(k as i32);
                let t = nalgebra::Isometry2::new(nalgebra::Vector2::new(dx, dy) * scale, angle * scale);
                for q in queries.iter_mut() {
                    *q = t * *q;
                }
                brute.match_all(&queries, &mut want);
                grid.match_all(&queries, &mut got);
                prop_assert_eq!(&got.pairs, &want.pairs);
            }
        }
    }

    #[test]
    fn matches_left_by_another_index_are_not_trusted() {
        // The same query count on two different references: the second index must not take
        // the first one's certificates for its own.
        let a = points(&[(0.0, 0.0), (10.0, 0.0), (20.0, 0.0)]);
        // At (1, 0) the first index certifies its point 0 with clearance 9; point 0 of the
        // second is 1.1 from it, inside that clearance, but its point 1 is nearer.
        let b = points(&[(0.0, 0.5), (1.0, 0.1), (20.0, 0.0)]);
        let queries = points(&[(1.0, 0.0), (9.0, 0.0), (19.0, 0.0)]);
        let mut m = Matches::default();
        Grid.build(&a).unwrap().match_all(&queries, &mut m);
        let mut want = Matches::default();
        let bb = BruteForce.build(&b).unwrap();
        bb.match_all(&queries, &mut want);
        Grid.build(&b).unwrap().match_all(&queries, &mut m);
        assert_eq!(m.pairs, want.pairs);
        assert_eq!(m.pairs[0].dst, 1);
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
