//! The last index a workspace built and the first matching it answered, kept for the next
//! registration against the same reference points: the variants of one pair run one after
//! another on one workspace, from the same start, and each would otherwise build the same
//! index and search the same first matching again.

use nalgebra::Point2;

use super::{Correspondence, Matcher, NearestIndex};
use crate::registry::StageSpec;
use crate::IcpError;

/// Prefix of the kind of a matcher written in user code (see [`StageSpec::unregistered`]): its
/// spec names its type, not its parameters, so two of them may differ under one spec.
const UNREGISTERED: &str = "user:";

/// An index with what it was built from, and its first matching.
struct Built {
    matcher: StageSpec,
    reference: Vec<Point2<f64>>,
    index: Box<dyn NearestIndex>,
    /// The queries of the index's first matching and the pairs it answered.
    first_queries: Vec<Point2<f64>>,
    first_pairs: Vec<Correspondence>,
}

/// The last index built, if its matcher is a registered kind (whose spec says everything that
/// shapes the index).
#[derive(Default)]
pub(crate) struct LastIndex(Option<Built>);

impl std::fmt::Debug for LastIndex {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match &self.0 {
            Some(built) => write!(
                f,
                "LastIndex({} over {} points)",
                built.matcher.kind,
                built.reference.len()
            ),
            None => f.write_str("LastIndex(none)"),
        }
    }
}

impl LastIndex {
    /// Matches `queries` (Alg. 1 step 2, first time) into `out` with an index of `matcher`
    /// over `reference`, and returns the index for the later matchings. The index is the last
    /// one when it was built by an equal matcher over equal points, and the pairs are the last
    /// first matching's when its queries were equal too; else they are built and searched
    /// (and kept for the next call). Neither changes a pair: the registered matchers answer
    /// the exact nearest point (ties by index), and what an index learnt from earlier queries
    /// only spares work.
    pub(crate) fn first_matching(
        &mut self,
        matcher: &dyn Matcher,
        reference: &[Point2<f64>],
        queries: &[Point2<f64>],
        out: &mut Vec<Correspondence>,
    ) -> Result<&mut dyn NearestIndex, IcpError> {
        let spec = matcher.spec();
        let keep = !spec.kind.starts_with(UNREGISTERED);
        let built = match self.0.take() {
            Some(last) if keep && last.matcher == spec && last.reference == reference => {
                let built = self.0.insert(last);
                if built.first_queries == queries {
                    out.clone_from(&built.first_pairs);
                    return Ok(built.index.as_mut());
                }
                built
            }
            last => {
                // The kept buffers are refilled (no allocation once warm).
                let (mut points, first_queries, first_pairs) = match last {
                    Some(last) => (last.reference, last.first_queries, last.first_pairs),
                    None => Default::default(),
                };
                points.clear();
                if keep {
                    // A user's matcher is built afresh each time: nothing to compare with.
                    points.extend_from_slice(reference);
                }
                self.0.insert(Built {
                    index: matcher.build(reference)?,
                    reference: points,
                    matcher: spec,
                    first_queries,
                    first_pairs,
                })
            }
        };
        built.index.match_all(queries, out);
        built.first_queries.clear();
        built.first_pairs.clear();
        if keep {
            built.first_queries.extend_from_slice(queries);
            built.first_pairs.extend_from_slice(out);
        }
        Ok(built.index.as_mut())
    }
}

#[cfg(test)]
mod tests {
    use std::sync::atomic::{AtomicUsize, Ordering};

    use super::*;
    use crate::matching::{BruteForce, Grid};

    fn points(offset: f64) -> Vec<Point2<f64>> {
        (0..40)
            .map(|i| Point2::new(i as f64 * 0.3 + offset, (i as f64 * 0.7).sin()))
            .collect()
    }

    fn answers(pairs: &[Correspondence]) -> Vec<(usize, f64)> {
        pairs.iter().map(|c| (c.dst, c.dist_sq)).collect()
    }

    fn brute(reference: &[Point2<f64>], queries: &[Point2<f64>]) -> Vec<(usize, f64)> {
        let mut out = Vec::new();
        BruteForce
            .build(reference)
            .unwrap()
            .match_all(queries, &mut out);
        answers(&out)
    }

    #[test]
    fn kept_indexes_and_matchings_answer_as_fresh_ones() {
        let (a, b) = (points(0.0), points(5.0));
        let shift = nalgebra::Vector2::new(0.05, 0.2);
        let queries: Vec<_> = points(0.1).iter().map(|p| p + shift).collect();
        let later: Vec<_> = queries.iter().map(|p| p + shift).collect();
        let mut last = LastIndex::default();
        let mut out = Vec::new();
        // A first matching, and a later one on the same index (as the next iteration).
        let index = last.first_matching(&Grid, &a, &queries, &mut out).unwrap();
        assert_eq!(answers(&out), brute(&a, &queries));
        index.match_all(&later, &mut out);
        assert_eq!(answers(&out), brute(&a, &later));
        // The next registration from the same start: the kept first matching.
        out.clear();
        let index = last.first_matching(&Grid, &a, &queries, &mut out).unwrap();
        assert_eq!(answers(&out), brute(&a, &queries));
        index.match_all(&later, &mut out);
        assert_eq!(answers(&out), brute(&a, &later));
        // Another start on the kept index: searched.
        last.first_matching(&Grid, &a, &later, &mut out).unwrap();
        assert_eq!(answers(&out), brute(&a, &later));
        // Other points under the same matcher: answered over those points, not the kept ones.
        last.first_matching(&Grid, &b, &later, &mut out).unwrap();
        assert_eq!(answers(&out), brute(&b, &later));
        assert_ne!(answers(&out), brute(&a, &later));
        // Another matcher over the same points is built, not taken for the grid.
        last.first_matching(&BruteForce, &b, &later, &mut out)
            .unwrap();
        assert_eq!(answers(&out), brute(&b, &later));
        assert!(format!("{last:?}").contains("brute"), "{last:?}");
    }

    /// A matcher written in user code, counting its builds.
    struct Counting<'a>(&'a AtomicUsize);

    impl Matcher for Counting<'_> {
        fn build(&self, reference: &[Point2<f64>]) -> Result<Box<dyn NearestIndex>, IcpError> {
            self.0.fetch_add(1, Ordering::Relaxed);
            BruteForce.build(reference)
        }
    }

    #[test]
    fn a_user_matcher_is_built_and_searched_for_every_registration() {
        let builds = AtomicUsize::new(0);
        let a = points(0.0);
        let mut last = LastIndex::default();
        let mut out = Vec::new();
        for _ in 0..3 {
            last.first_matching(&Counting(&builds), &a, &a, &mut out)
                .unwrap();
            assert_eq!(answers(&out), brute(&a, &a));
        }
        assert_eq!(builds.load(Ordering::Relaxed), 3);
    }
}
