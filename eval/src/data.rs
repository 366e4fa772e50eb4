//! Data in: what the harness reads from a dataset beyond its scans, for every later stage: the
//! reference's motion between two scans, and the scans' times.

use datasets::Dataset;
use icp_core::motion::{wrap_360, wrap_deg};
use icp_core::BearingSense;
use nalgebra::Isometry2;

/// The reference's motion between two scans.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RefMotion {
    /// Reference speed over ground, m/s.
    pub sog_mps: f64,
    /// Reference heading change, degrees, clockwise positive.
    pub dcog_deg: f64,
    /// Reference heading at the source scan, degrees in [0, 360), growing clockwise (the
    /// navigational sense; the dataset's heading negated when it grows counter-clockwise).
    pub hdg0_deg: f64,
    /// The same at the reference scan.
    pub hdg1_deg: f64,
    /// The true `t_ref_src`, when the reference is a rigid 2D pose of the scanner.
    pub t_ref_src: Option<Isometry2<f64>>,
}

/// The reference motion between scans `a` and `b` over `dt_s`; `None` when the dataset has no
/// reference or an index is out of range.
pub fn motion(ds: &Dataset, a: usize, b: usize, dt_s: f64) -> Option<RefMotion> {
    let r = ds.reference.as_ref()?;
    let (p, q) = (r.get(a)?, r.get(b)?);
    let dh = wrap_deg((q.heading_rad - p.heading_rad).to_degrees());
    let sign = match ds.reference_heading_sense {
        BearingSense::Clockwise => 1.0,
        BearingSense::CounterClockwise => -1.0,
    };
    let t_ref_src = match (p.scan_pose(), q.scan_pose()) {
        (Some(pa), Some(pb)) => Some((pa.inverse() * pb).inverse()),
        _ => None,
    };
    Some(RefMotion {
        sog_mps: (q.x_m - p.x_m).hypot(q.y_m - p.y_m) / dt_s,
        dcog_deg: sign * dh,
        hdg0_deg: wrap_360(sign * p.heading_rad.to_degrees()),
        hdg1_deg: wrap_360(sign * q.heading_rad.to_degrees()),
        t_ref_src,
    })
}

/// The time of scan `k` on the trajectories' clock: its timestamp, else `k` nominal steps.
pub fn scan_time_s(ds: &Dataset, k: usize) -> f64 {
    ds.scans[k].timestamp_s().unwrap_or(k as f64 * ds.dt_s)
}
