//! Scenes shared by the global search's tests: a scan of known points seen from a known pose,
//! with its surface estimates.

use icp_core::{Prepared, Scan, SurfaceParams, Surfaces};
use nalgebra::{Isometry2, Point2};

/// A scan of `points` (reference frame) seen from `t_ref_src`: the points in the source frame.
pub fn seen_from(points: &[Point2<f64>], t_ref_src: &Isometry2<f64>) -> Scan {
    let inv = t_ref_src.inverse();
    let xy: Vec<[f64; 2]> = points
        .iter()
        .map(|p| {
            let q = inv * p;
            [q.x, q.y]
        })
        .collect();
    Scan::from_cartesian(&xy).unwrap()
}

/// A scan with its surface estimates (default parameters).
pub struct Owned {
    pub scan: Scan,
    pub surfaces: Surfaces,
}

impl Owned {
    pub fn new(scan: Scan) -> Self {
        let surfaces = Surfaces::estimate(&scan, &SurfaceParams::default());
        Self { scan, surfaces }
    }

    pub fn prepared(&self) -> Prepared<'_> {
        Prepared::new(&self.scan, &self.surfaces)
    }
}
