//! The matched pairs of one iteration, as every stage after matching sees them.

use nalgebra::{Isometry2, Point2, Vector2};

use crate::matching::Correspondence;
use crate::scan::Return;
use crate::surface::SurfacePoint;

/// The pairs of one iteration with everything known about their points. Indices of a
/// [`Correspondence`] point into the `src*` and `dst*` slices (the selected points).
#[derive(Clone, Copy, Debug)]
pub struct PairSet<'a> {
    /// The matched pairs, one per source point.
    pub pairs: &'a [Correspondence],
    /// The source returns (scan k), in scan k's frame.
    pub src: &'a [Return],
    /// The reference returns (scan k+1), in scan k+1's frame.
    pub dst: &'a [Return],
    /// The source points moved by the current estimate into scan k+1's frame.
    pub src_moved: &'a [Point2<f64>],
    /// The reference points (`dst[i].point`, kept contiguous for the minimisers).
    pub dst_points: &'a [Point2<f64>],
    /// The surface at each source return, in scan k's frame.
    pub src_surfaces: &'a [Option<SurfacePoint>],
    /// The surface at each reference return, in scan k+1's frame.
    pub dst_surfaces: &'a [Option<SurfacePoint>],
    /// The current estimate: `src_moved[i]` is `t_ref_src * src[i].point`; a direction `β`
    /// in scan k+1's frame is `β − θ` in scan k's frame.
    pub t_ref_src: Isometry2<f64>,
}

impl PairSet<'_> {
    /// The unit normal of the reference surface at pair `i`'s reference point, in scan k+1's
    /// frame, when it has a usable estimate.
    #[inline]
    pub fn dst_normal(&self, i: usize) -> Option<Vector2<f64>> {
        self.dst_surfaces[self.pairs[i].dst].map(|s| s.normal)
    }
}
