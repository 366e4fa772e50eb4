//! `sequence.csv`'s rows: per scan, the fused state of one smoothed estimator (`--sequence`,
//! made by the `sequence` module): pose, SOG, COG, ROT and HDG with their σ.

use datasets::Dataset;
use icp_core::motion::{wrap_360, wrap_deg};
use icp_core::sequence::Smoothed;
use icp_core::BearingSense;
use serde::{Deserialize, Serialize};

use crate::run::sequence_setup::SequenceMode;

/// One row of `sequence.csv`: a scan's fused state as one smoothed estimator has it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SequenceRecord {
    /// The estimator, `V+batch` or `V+causal`.
    pub method: String,
    /// Scan index in the dataset.
    pub scan: usize,
    /// Scan time, s.
    pub time_s: f64,
    /// Whether an unflagged registration reaches the scan's estimate: for `V+causal` one
    /// spanning the step into the scan (scan 0: the first step), for `V+batch` one spanning a
    /// step next to it. Else the estimate is the prior's extrapolation alone.
    pub supported: bool,
    /// Position in the first scan's frame, m.
    pub x_m: f64,
    pub y_m: f64,
    pub x_sigma_m: f64,
    pub y_sigma_m: f64,
    /// Heading: the first pair's reference heading (0 without a reference) plus the fused turn
    /// since the first scan, degrees in [0, 360), clockwise.
    pub hdg_deg: f64,
    pub hdg_sigma_deg: f64,
    /// Speed over ground from the fused twist, m/s.
    pub sog_mps: f64,
    pub sog_sigma_mps: f64,
    /// Course over ground: the heading plus the drift angle of the fused twist, degrees.
    pub cog_deg: f64,
    pub cog_sigma_deg: f64,
    /// Rate of turn, degrees per second, clockwise positive.
    pub rot_dps: f64,
    pub rot_sigma_dps: f64,
    /// The fused twist along the scan frame's x and y, m/s.
    pub surge_mps: f64,
    pub sway_mps: f64,
}

/// Whether scan `k`'s estimate in `mode` rests on a registration (see
/// [`SequenceRecord::supported`]).
fn scan_supported(s: &Smoothed, mode: SequenceMode, k: usize) -> bool {
    let step = |i: usize| s.steps.get(i).is_some_and(|e| e.supported);
    match mode {
        SequenceMode::Causal => step(k.max(1) - 1),
        SequenceMode::Batch | SequenceMode::Deskew => step(k) || (k > 0 && step(k - 1)),
    }
}

/// `sequence.csv`'s rows of one estimator.
pub fn records(
    ds: &Dataset,
    (scans, times): (&[usize], &[f64]),
    first_heading_deg: Option<f64>,
    (name, mode): (&str, SequenceMode),
    s: &Smoothed,
) -> Vec<SequenceRecord> {
    // Heading clockwise: a turn θ of the scan frame (counter-clockwise bearings) is −θ.
    let sign = match ds.bearing_sense {
        BearingSense::CounterClockwise => -1.0,
        BearingSense::Clockwise => 1.0,
    };
    let hdg0 = first_heading_deg.unwrap_or(0.0);
    scans
        .iter()
        .zip(times)
        .zip(&s.scans)
        .enumerate()
        .map(|(k, ((&scan, &time_s), e))| {
            let c = &e.cov;
            let (u, v) = (e.twist.x, e.twist.y);
            let speed = u.hypot(v);
            let (var_sog, var_drift) = if speed > 0.0 {
                let (gu, gv) = (u / speed, v / speed);
                let (du, dv) = (-v / (speed * speed), u / (speed * speed));
                (
                    gu * gu * c[(3, 3)] + 2.0 * gu * gv * c[(3, 4)] + gv * gv * c[(4, 4)],
                    du * du * c[(3, 3)] + 2.0 * du * dv * c[(3, 4)] + dv * dv * c[(4, 4)],
                )
            } else {
                (c[(3, 3)] + c[(4, 4)], 0.0)
            };
            let hdg_deg = wrap_360(hdg0 + sign * e.pose.z.to_degrees());
            let drift_deg = sign * v.atan2(u).to_degrees();
            SequenceRecord {
                method: name.to_owned(),
                scan,
                time_s,
                supported: scan_supported(s, mode, k),
                x_m: e.pose.x,
                y_m: e.pose.y,
                x_sigma_m: c[(0, 0)].max(0.0).sqrt(),
                y_sigma_m: c[(1, 1)].max(0.0).sqrt(),
                hdg_deg,
                hdg_sigma_deg: c[(2, 2)].max(0.0).sqrt().to_degrees(),
                sog_mps: speed,
                sog_sigma_mps: var_sog.max(0.0).sqrt(),
                cog_deg: wrap_360(hdg_deg + wrap_deg(drift_deg)),
                // The heading and the drift angle, taken as independent.
                cog_sigma_deg: (c[(2, 2)] + var_drift).max(0.0).sqrt().to_degrees(),
                rot_dps: sign * e.twist.z.to_degrees(),
                rot_sigma_dps: c[(5, 5)].max(0.0).sqrt().to_degrees(),
                surge_mps: u,
                sway_mps: v,
            }
        })
        .collect()
}
