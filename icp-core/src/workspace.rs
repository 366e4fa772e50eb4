//! The buffers a registration reuses ([`Workspace`]).

use nalgebra::Point2;

use crate::matching::{Correspondence, LastIndex};
use crate::scan::Return;
use crate::surface::SurfacePoint;

/// The buffers of a registration. Passing one workspace to successive registrations (one per
/// thread) reuses them: after the first, a registration allocates only for the overlap check
/// and, when its reference points or matcher differ from the previous registration's, for a
/// new nearest-neighbour index (the variants of one pair share one, and their first matching
/// when they start alike). What it holds between calls never changes a result.
#[derive(Debug, Default)]
pub struct Workspace {
    pub(crate) src_idx: Vec<usize>,
    pub(crate) ref_idx: Vec<usize>,
    pub(crate) src: Vec<Return>,
    pub(crate) dst: Vec<Return>,
    pub(crate) src_pts: Vec<Point2<f64>>,
    pub(crate) dst_pts: Vec<Point2<f64>>,
    pub(crate) src_surfaces: Vec<Option<SurfacePoint>>,
    pub(crate) dst_surfaces: Vec<Option<SurfacePoint>>,
    pub(crate) moved: Vec<Point2<f64>>,
    pub(crate) pairs: Vec<Correspondence>,
    pub(crate) dists: Vec<f64>,
    pub(crate) residuals: Vec<f64>,
    pub(crate) weights: Vec<f64>,
    pub(crate) scratch: Vec<f64>,
    pub(crate) index: LastIndex,
}
