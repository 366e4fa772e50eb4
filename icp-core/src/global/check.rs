//! The search's answer to one question about a pose found elsewhere: does a pose of the search
//! space score enough more than it? A fine registration's result is checked this way (a
//! result far from a clearly better pose is a local minimum), and when the result is right
//! (the common case) no pose clears the bar: a branch and bound whose floor starts at the bar
//! prunes every branch that cannot clear it, and proves the answer no after reading a
//! fraction of the cells the full search reads.
//!
//! When a pose clears the bar, the answer is the search's best pose itself (the one
//! [`GlobalMatcher::best`] finds, see [`super::search`]), so whatever a caller decides from
//! the best pose, it decides the same from the answer. What one question proves is kept for
//! the next (the best pose once found; the highest bar nothing cleared), so the results of
//! several registrations of a pair are checked on one preparation.

use nalgebra::Isometry2;

use super::grid::{mean_of, FULL_SCALE};
use super::search::Best;
use super::{GlobalMatcher, GlobalWorkspace};

/// A source scan made ready for searches on one [`GlobalMatcher`] (see
/// [`GlobalMatcher::prepare`]), with what its searches have proven so far.
#[derive(Debug)]
pub struct SourceSearch<'w> {
    /// The source's points and weights, the rotation candidates and the sorted top-level
    /// nodes, with the descents' buffers.
    pub(super) workspace: &'w mut GlobalWorkspace,
    /// The window's centre.
    pub(super) centre: Isometry2<f64>,
    /// Sum of the source's weights.
    pub(super) total_weight: u64,
    /// Cells read so far (the top-level nodes and every descent).
    pub(super) lookups: u64,
    /// The floor above which the top-level nodes were scored (`None`: not yet).
    pub(super) top_floor: Option<u64>,
    /// The search's best pose, once a descent found it.
    pub(super) best: Option<Best>,
    /// The lowest floor a descent proved no pose exceeds.
    pub(super) cleared: Option<u64>,
}

impl SourceSearch<'_> {
    /// Grid cells read so far for this source.
    pub fn grid_lookups(&self) -> u64 {
        self.lookups
    }
}

/// The answer of [`GlobalMatcher::best_above`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Above {
    /// The search's best pose, which clears the bar, and its score: the pose
    /// [`GlobalMatcher::best`] finds, exactly.
    Best {
        /// Maps source points into the reference frame (the centre when no pose scores
        /// above 0).
        t_ref_src: Isometry2<f64>,
        /// Its score (see [`super::score_at`]).
        score: f64,
    },
    /// No pose clears the bar: none scores more than `score`, the highest score that does
    /// not clear (a proven bound, not a pose's score).
    AtMost {
        /// The bound.
        score: f64,
    },
}

impl GlobalMatcher {
    /// Whether a pose of `prepared`'s search space has a score that `clears`: `clears` must
    /// be monotone (a score clears when any lower one does), e.g. `|s| s - result > margin`.
    /// [`Above::Best`] when the best pose clears, else [`Above::AtMost`] the highest score
    /// that does not clear: the answer depends on `prepared` and `clears` alone, not on the
    /// questions asked before.
    ///
    /// Exact: scores are a whole-number sum over a known total, so the bar is the highest sum
    /// that does not clear (found by bisection on `clears` itself), and the branch and bound
    /// searches only above it.
    pub fn best_above(
        &self,
        prepared: &mut SourceSearch<'_>,
        clears: impl Fn(f64) -> bool,
    ) -> Above {
        let total = prepared.total_weight;
        let answer = |prepared: &SourceSearch<'_>, best: &Best| Above::Best {
            t_ref_src: self.pose_of(prepared, best),
            score: mean_of(best.sum, total),
        };
        let Some(floor) = highest_not_clearing(total * u64::from(FULL_SCALE), |sum| {
            clears(mean_of(sum, total))
        }) else {
            // Every score clears, 0 included: the answer is the whole search's.
            self.best(prepared);
            let best = prepared.best.expect("best() keeps its best");
            return answer(prepared, &best);
        };
        let bar = Above::AtMost {
            score: mean_of(floor, total),
        };
        if let Some(best) = prepared.best {
            return if best.sum > floor {
                answer(prepared, &best)
            } else {
                bar
            };
        }
        if prepared.cleared.is_some_and(|c| c <= floor) {
            return bar;
        }
        self.top_above(prepared, floor);
        let (search, buffers) = self.split(prepared);
        let found = search.above(buffers, floor);
        prepared.lookups += found.lookups;
        if found.rotation.is_some() {
            prepared.best = Some(found);
            answer(prepared, &found)
        } else {
            prepared.cleared = Some(prepared.cleared.map_or(floor, |c| c.min(floor)));
            bar
        }
    }
}

/// The highest sum in `0..=max` that does not clear, `clears` being monotone; `None` when
/// every sum clears.
fn highest_not_clearing(max: u64, clears: impl Fn(u64) -> bool) -> Option<u64> {
    if clears(0) {
        return None;
    }
    // Invariant: `lo` does not clear; every sum above `hi` clears (or exceeds `max`).
    let (mut lo, mut hi) = (0, max);
    while lo < hi {
        let mid = lo + (hi - lo).div_ceil(2);
        if clears(mid) {
            hi = mid - 1;
        } else {
            lo = mid;
        }
    }
    Some(lo)
}
