//! The noise-limited bound of each pair: the Cramér–Rao bound of `t_ref_src`
//! ([`icp_core::bound`], Censi 2007) from the true surface normals a synthetic dataset records
//! with every return, the dataset's sensor model (its true noise) and the true motion. It says
//! how well any unbiased method could register the pair, so that a variant's error can be
//! reported as a multiple of it.

use datasets::{Dataset, ScanPair};
use icp_core::bound::ScanInformation;
use icp_core::bound::{relative_pose_bound, scan_information, BoundReturn, RelativeBound};
use serde::{Deserialize, Serialize};

use crate::data::RefMotion;
use crate::measure::stats::rms;

/// The bound of one pair.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PairBound {
    /// Square root of the trace of the translation block, m, and the rotation's standard
    /// deviation, degrees.
    Bounded {
        /// `sqrt(trace)` of the bound's translation block, m.
        trans_m: f64,
        /// The bound's rotation standard deviation, degrees.
        rot_deg: f64,
    },
    /// One direction of the motion is not observed by either scan (a corridor).
    Unbounded,
}

impl PairBound {
    /// The translation bound, m, when bounded.
    pub fn trans_m(&self) -> Option<f64> {
        match *self {
            PairBound::Bounded { trans_m, .. } => Some(trans_m),
            PairBound::Unbounded => None,
        }
    }

    /// The rotation bound, degrees, when bounded.
    pub fn rot_deg(&self) -> Option<f64> {
        match *self {
            PairBound::Bounded { rot_deg, .. } => Some(rot_deg),
            PairBound::Unbounded => None,
        }
    }
}

/// The bound of every pair (`None` where a scan has no true normals, the reference is not a
/// rigid pose, or a scan's information cannot be formed). Each scan's information is computed
/// once. The returns enter with their measured ranges at their nominal bearings: the bound's
/// variances move by the relative range noise, below 1 % here.
pub fn pair_bounds(
    ds: &Dataset,
    pairs: &[ScanPair],
    truth: &[Option<RefMotion>],
) -> Vec<Option<PairBound>> {
    let information: Vec<Option<ScanInformation>> = ds
        .scans
        .iter()
        .map(|scan| {
            let normals = scan.true_normals()?;
            let returns = scan.returns().iter().zip(normals).filter_map(|(r, n)| {
                n.map(|normal| BoundReturn {
                    range_m: r.range_m,
                    bearing_rad: r.bearing_rad,
                    normal,
                })
            });
            scan_information(returns, &ds.sensor).ok()
        })
        .collect();
    pairs
        .iter()
        .zip(truth)
        .map(|(p, t)| {
            let t_ref_src = t.as_ref()?.t_ref_src?;
            let (src, reference) = (
                information[p.source].as_ref()?,
                information[p.reference].as_ref()?,
            );
            Some(
                match relative_pose_bound(src, reference, &t_ref_src).ok()? {
                    RelativeBound::Bounded(b) => PairBound::Bounded {
                        trans_m: b.trans_m(),
                        rot_deg: b.rot_deg(),
                    },
                    RelativeBound::Unbounded(_) => PairBound::Unbounded,
                },
            )
        })
        .collect()
}

/// The bound over a run's pairs.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BoundSummary {
    /// Pairs with a finite bound.
    pub pairs: usize,
    /// Pairs whose motion one scan pair cannot observe in some direction.
    pub unbounded_pairs: usize,
    /// RMS over those pairs of the translation bound, m.
    pub trans_rms_m: f64,
    /// RMS of the rotation bound, degrees.
    pub rot_rms_deg: f64,
    /// Which sensor model the bound assumes: always the dataset's nominal one ([`NOMINAL`]).
    #[serde(default)]
    pub sensor_model: String,
}

/// What [`BoundSummary::sensor_model`] says: the bound is the nominal model's, which data
/// with errors beyond it (the rough harbour, real logs) do not reach.
pub const NOMINAL: &str =
    "nominal: the dataset's stated sensor model (eq. 8); errors it leaves out are not in the bound";

/// The summary of `bounds`, when any pair has one.
pub fn summarize(bounds: &[Option<PairBound>]) -> Option<BoundSummary> {
    let trans: Vec<f64> = bounds
        .iter()
        .flatten()
        .filter_map(|b| b.trans_m())
        .collect();
    let rot: Vec<f64> = bounds
        .iter()
        .flatten()
        .filter_map(|b| b.rot_deg())
        .collect();
    let unbounded_pairs = bounds
        .iter()
        .flatten()
        .filter(|b| **b == PairBound::Unbounded)
        .count();
    (!trans.is_empty() || unbounded_pairs > 0).then(|| BoundSummary {
        pairs: trans.len(),
        unbounded_pairs,
        trans_rms_m: rms(&trans),
        rot_rms_deg: rms(&rot),
        sensor_model: NOMINAL.to_owned(),
    })
}

/// A variant's errors as multiples of the bound, over its pairs that have both an error and a
/// bound: `RMSE / RMS bound` over the same pairs.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct OverBound {
    /// Pairs counted.
    pub pairs: usize,
    /// Translation RMSE over them, m.
    pub trans_rmse_m: f64,
    /// RMS translation bound over them, m.
    pub trans_bound_rms_m: f64,
    /// Their ratio.
    pub trans_ratio: f64,
    /// Rotation RMSE over them, degrees.
    pub rot_rmse_deg: f64,
    /// RMS rotation bound over them, degrees.
    pub rot_bound_rms_deg: f64,
    /// Their ratio.
    pub rot_ratio: f64,
}

impl OverBound {
    /// From `(trans error m, rot error deg, bound)` per pair; `None` without any.
    pub fn of(rows: impl Iterator<Item = (f64, f64, PairBound)>) -> Option<Self> {
        let (mut te, mut re, mut tb, mut rb) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        for (t, r, b) in rows {
            if let PairBound::Bounded { trans_m, rot_deg } = b {
                te.push(t);
                re.push(r);
                tb.push(trans_m);
                rb.push(rot_deg);
            }
        }
        if te.is_empty() {
            return None;
        }
        let (trans_rmse_m, trans_bound_rms_m) = (rms(&te), rms(&tb));
        let (rot_rmse_deg, rot_bound_rms_deg) = (rms(&re), rms(&rb));
        Some(Self {
            pairs: te.len(),
            trans_rmse_m,
            trans_bound_rms_m,
            trans_ratio: trans_rmse_m / trans_bound_rms_m,
            rot_rmse_deg,
            rot_bound_rms_deg,
            rot_ratio: rot_rmse_deg / rot_bound_rms_deg,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ratios_by_hand() {
        let b = |t, r| PairBound::Bounded {
            trans_m: t,
            rot_deg: r,
        };
        // Errors 3 and 4 mm against bounds 1 and 1 mm: RMSE sqrt(12.5), bound 1.
        let o = OverBound::of(
            [
                (0.003, 0.1, b(0.001, 0.05)),
                (0.004, 0.1, b(0.001, 0.05)),
                (9.0, 9.0, PairBound::Unbounded),
            ]
            .into_iter(),
        )
        .unwrap();
        assert_eq!(o.pairs, 2);
        assert!((o.trans_ratio - 12.5f64.sqrt()).abs() < 1e-12);
        assert!((o.rot_ratio - 2.0).abs() < 1e-12);
        assert!(OverBound::of(std::iter::empty()).is_none());
        let s = summarize(&[Some(b(0.003, 0.1)), Some(PairBound::Unbounded), None]).unwrap();
        assert_eq!((s.pairs, s.unbounded_pairs), (1, 1));
        assert_eq!(summarize(&[None]), None);
    }
}
