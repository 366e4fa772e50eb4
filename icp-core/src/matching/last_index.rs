//! The last index a workspace built, kept for the next registration against the same
//! reference points: the variants of one pair run one after another on one workspace, and each
//! would otherwise build the same index again.

use nalgebra::Point2;

use super::{Matcher, NearestIndex};
use crate::registry::StageSpec;
use crate::IcpError;

/// Prefix of the kind of a matcher written in user code (see [`StageSpec::unregistered`]): its
/// spec names its type, not its parameters, so two of them may differ under one spec.
const UNREGISTERED: &str = "user:";

/// An index with what it was built from.
struct Built {
    matcher: StageSpec,
    reference: Vec<Point2<f64>>,
    index: Box<dyn NearestIndex>,
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
    /// An index of `matcher` over `reference`: the last one when it was built by an equal
    /// matcher over equal points, else a new one (kept for the next call). Reuse never changes
    /// a pair: an index answers the exact nearest point, and what it learnt from earlier
    /// queries only spares work.
    pub(crate) fn get(
        &mut self,
        matcher: &dyn Matcher,
        reference: &[Point2<f64>],
    ) -> Result<&mut dyn NearestIndex, IcpError> {
        let spec = matcher.spec();
        let keep = !spec.kind.starts_with(UNREGISTERED);
        // The kept points' buffer is refilled for a new index (no allocation once warm).
        let mut points = Vec::new();
        match self.0.take() {
            Some(last) if keep && last.matcher == spec && last.reference == reference => {
                return Ok(self.0.insert(last).index.as_mut());
            }
            Some(last) => points = last.reference,
            None => {}
        }
        points.clear();
        if keep {
            // A user's matcher is built afresh each time: nothing is kept to compare with.
            points.extend_from_slice(reference);
        }
        let built = Built {
            index: matcher.build(reference)?,
            reference: points,
            matcher: spec,
        };
        Ok(self.0.insert(built).index.as_mut())
    }
}

#[cfg(test)]
mod tests {
    use std::sync::atomic::{AtomicUsize, Ordering};

    use super::*;
    use crate::matching::{BruteForce, Correspondence, Grid};

    fn points(offset: f64) -> Vec<Point2<f64>> {
        (0..40)
            .map(|i| Point2::new(i as f64 * 0.3 + offset, (i as f64 * 0.7).sin()))
            .collect()
    }

    fn pairs(index: &mut dyn NearestIndex, queries: &[Point2<f64>]) -> Vec<(usize, f64)> {
        let mut out: Vec<Correspondence> = Vec::new();
        index.match_all(queries, &mut out);
        out.iter().map(|c| (c.dst, c.dist_sq)).collect()
    }

    #[test]
    fn a_kept_index_answers_as_a_fresh_one_and_other_points_get_their_own() {
        let (a, b) = (points(0.0), points(5.0));
        let queries: Vec<_> = points(0.1)
            .iter()
            .map(|p| p + nalgebra::Vector2::new(0.0, 0.2))
            .collect();
        let mut last = LastIndex::default();
        let first = pairs(last.get(&Grid, &a).unwrap(), &queries);
        // Again over the same points (the index now holds what the first call learnt).
        let again = pairs(last.get(&Grid, &a).unwrap(), &queries);
        let fresh = pairs(Grid.build(&a).unwrap().as_mut(), &queries);
        assert_eq!(first, fresh);
        assert_eq!(again, fresh);
        // Other points under the same matcher: answered over those points, not the kept ones.
        let over_b = pairs(last.get(&Grid, &b).unwrap(), &queries);
        assert_eq!(
            over_b,
            pairs(BruteForce.build(&b).unwrap().as_mut(), &queries)
        );
        assert_ne!(over_b, fresh);
        // Another matcher over the same points is built, not taken for the grid.
        let brute = pairs(last.get(&BruteForce, &b).unwrap(), &queries);
        assert_eq!(brute, over_b);
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
    fn a_user_matcher_is_built_for_every_registration() {
        let builds = AtomicUsize::new(0);
        let a = points(0.0);
        let mut last = LastIndex::default();
        for _ in 0..3 {
            last.get(&Counting(&builds), &a).unwrap();
        }
        assert_eq!(builds.load(Ordering::Relaxed), 3);
    }
}
