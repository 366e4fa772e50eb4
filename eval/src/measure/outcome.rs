//! How a variant's estimates and flags fare against a rigid reference pose: the fraction of
//! pairs it got right, and how well its flags pick out the numbers it got wrong.
//!
//! The thresholds are the ones of the field's evaluations of pairwise registration on real
//! logs (a step within 0.1 m and 1° of the log's pose is a success; beyond 0.3 m or 3° it is
//! plainly wrong). They judge, they are not tuned: nothing in the registration sees them.

use serde::{Deserialize, Serialize};

use crate::measure::record::PairRecord;
use crate::run::status::{StatusKind, CHI2_3_AT_999};

/// A registration within this translation error of the reference is a success, m.
pub const SUCCESS_TRANS_M: f64 = 0.1;
/// …and within this rotation error, degrees.
pub const SUCCESS_ROT_DEG: f64 = 1.0;
/// A registration beyond this translation error is wrong: a flag should catch it, m.
pub const WRONG_TRANS_M: f64 = 0.3;
/// …or beyond this rotation error, degrees.
pub const WRONG_ROT_DEG: f64 = 3.0;

/// A wrong registration is covered by its covariance when the NEES of its pose error under
/// it is at most this: χ²₃ at 99.9 %.
pub const COVERED_NEES: f64 = CHI2_3_AT_999;

/// The pose errors of a registered row, where the reference is a rigid pose.
fn errors(r: &PairRecord) -> Option<(f64, f64)> {
    Some((r.trans_err_m?, r.rot_err_deg?.abs()))
}

/// Whether a registered row is within the success thresholds (`None` without a rigid
/// reference).
fn success(r: &PairRecord) -> Option<bool> {
    errors(r).map(|(t, a)| t <= SUCCESS_TRANS_M && a <= SUCCESS_ROT_DEG)
}

/// The fraction of `rows` (one variant's, every pair of the run) with a reference that are
/// registered within the success thresholds; a pair not registered is not a success. `None`
/// unless the reference is a rigid pose (`rigid`) and some pair has one.
pub fn success_rate(rows: &[PairRecord], rigid: bool) -> Option<f64> {
    let with_ref: Vec<&PairRecord> = rows.iter().filter(|r| r.sog_ref_mps.is_some()).collect();
    if !rigid || with_ref.is_empty() {
        return None;
    }
    let good = with_ref.iter().filter(|r| success(r) == Some(true)).count();
    Some(good as f64 / with_ref.len() as f64)
}

/// How well one variant's flags (every status but `ok`) separate its wrong numbers from its
/// right ones, over its registered pairs that have a rigid reference.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct FlagQuality {
    /// Registered pairs judged.
    pub pairs: usize,
    /// Of them, wrong (beyond [`WRONG_TRANS_M`] or [`WRONG_ROT_DEG`]).
    pub wrong: usize,
    /// Of them, flagged.
    pub flagged: usize,
    /// Wrong and flagged.
    pub wrong_flagged: usize,
    /// Flagged and not a success (beyond [`SUCCESS_TRANS_M`] or [`SUCCESS_ROT_DEG`]).
    pub flagged_not_success: usize,
    /// Wrong and covered by the reported covariance (its NEES at most [`COVERED_NEES`]),
    /// flagged or not.
    #[serde(default)]
    pub wrong_covered: usize,
    /// Wrong, status `ok` and not covered: a confident wrong number that nothing warns of.
    #[serde(default)]
    pub silent: usize,
    /// Fraction of the wrong numbers that are flagged (`None` when none is wrong).
    pub recall: Option<f64>,
    /// Fraction of the flagged numbers that are not a success (`None` when none is flagged).
    pub precision: Option<f64>,
}

impl FlagQuality {
    /// The flags of `rows` (one variant's) against their rigid reference; `None` when no
    /// registered row has one.
    pub fn of(rows: &[PairRecord]) -> Option<Self> {
        let judged: Vec<Judged> = rows
            .iter()
            .filter(|r| r.status != StatusKind::Failed)
            .filter_map(|r| {
                let (trans_m, rot_deg) = errors(r)?;
                Some(Judged {
                    flagged: r.status != StatusKind::Ok,
                    trans_m,
                    rot_deg,
                    nees: r.nees,
                })
            })
            .collect();
        Self::of_judged(&judged)
    }

    /// From the judged registrations.
    fn of_judged(judged: &[Judged]) -> Option<Self> {
        if judged.is_empty() {
            return None;
        }
        let wrong = |j: &Judged| j.trans_m > WRONG_TRANS_M || j.rot_deg > WRONG_ROT_DEG;
        let not_success = |j: &Judged| j.trans_m > SUCCESS_TRANS_M || j.rot_deg > SUCCESS_ROT_DEG;
        let covered = |j: &Judged| j.nees.is_some_and(|n| n <= COVERED_NEES);
        let count = |f: &dyn Fn(&Judged) -> bool| judged.iter().filter(|j| f(j)).count();
        let n_wrong = count(&wrong);
        let flagged = count(&|j| j.flagged);
        let wrong_flagged = count(&|j| j.flagged && wrong(j));
        let flagged_not_success = count(&|j| j.flagged && not_success(j));
        let ratio = |n: usize, of: usize| (of > 0).then(|| n as f64 / of as f64);
        Some(Self {
            pairs: judged.len(),
            wrong: n_wrong,
            flagged,
            wrong_flagged,
            flagged_not_success,
            wrong_covered: count(&|j| wrong(j) && covered(j)),
            silent: count(&|j| wrong(j) && !j.flagged && !covered(j)),
            recall: ratio(wrong_flagged, n_wrong),
            precision: ratio(flagged_not_success, flagged),
        })
    }
}

/// One registration as [`FlagQuality`] judges it.
#[derive(Clone, Copy, Debug)]
struct Judged {
    flagged: bool,
    /// Translation error, m.
    trans_m: f64,
    /// |Rotation error|, degrees.
    rot_deg: f64,
    /// NEES of the pose error under the reported covariance, where there is one.
    nees: Option<f64>,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recall_precision_and_silence_by_hand() {
        // Wrong: rows 0 (0.5 m), 1 (5°), 2 (0.31 m), 6 (0.8 m, covered: NEES 16) and 7 (0.4 m,
        // NEES 17: not covered, silent). Flagged: 0, 1, 3 (0.2 m: not a success, not wrong) and
        // 4 (0.05 m, 0.5°: a success, a false alarm).
        let j = |flagged, trans_m, rot_deg, nees| Judged {
            flagged,
            trans_m,
            rot_deg,
            nees,
        };
        let judged = [
            j(true, 0.5, 0.0, Some(3.0)),
            j(true, 0.0, 5.0, None),
            j(false, 0.31, 0.0, None),
            j(true, 0.2, 0.0, Some(100.0)),
            j(true, 0.05, 0.5, Some(1.0)),
            j(false, 0.01, 0.1, Some(1.0)),
            j(false, 0.8, 0.0, Some(16.0)),
            j(false, 0.4, 0.0, Some(17.0)),
        ];
        let q = FlagQuality::of_judged(&judged).unwrap();
        assert_eq!((q.pairs, q.wrong, q.flagged), (8, 5, 4));
        assert_eq!((q.wrong_flagged, q.flagged_not_success), (2, 3));
        // Covered: rows 0 and 6; silent: 2 (no covariance) and 7.
        assert_eq!((q.wrong_covered, q.silent), (2, 2));
        assert_eq!(q.recall, Some(2.0 / 5.0));
        assert_eq!(q.precision, Some(3.0 / 4.0));
        assert_eq!(FlagQuality::of_judged(&[]), None);
        let none_wrong = FlagQuality::of_judged(&[j(false, 0.0, 0.0, None)]).unwrap();
        assert_eq!((none_wrong.recall, none_wrong.precision), (None, None));
    }

    /// [`COVERED_NEES`] is χ²₃'s 99.9 % point: the closed-form distribution function
    /// `erf(√(x/2)) − √(2x/π) e^(−x/2)`, its erf by Simpson's rule, reaches 0.999 there.
    #[test]
    fn covered_is_chi_squared_3s_99_9_percent_point() {
        let x: f64 = COVERED_NEES;
        let integral = crate::run::extended::simpson(|t| (-t * t).exp(), (x / 2.0).sqrt());
        let erf = 2.0 / std::f64::consts::PI.sqrt() * integral;
        let cdf = erf - (2.0 * x / std::f64::consts::PI).sqrt() * (-x / 2.0).exp();
        assert!((cdf - 0.999).abs() < 1e-9, "{cdf}");
    }
}
