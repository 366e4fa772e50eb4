//! Odometry's word on the wrong registrations: where a log carries odometry of its own (not a
//! copy of the reference: [`datasets::Dataset::independent_odometry`]), each registration that
//! is wrong against the reference (beyond [`WRONG_TRANS_M`] or [`WRONG_ROT_DEG`]) is put to a
//! second, independent measurement of its step.
//!
//! The reference of a real log is not truth (a SLAM correction, a GNSS fix), so a registration
//! that reads as wrong against it may be the reference's error. Odometry shares neither the
//! laser nor the correction. It **confirms** the failure when its step lies within
//! [`SUCCESS_TRANS_M`] of the reference's and beyond [`WRONG_TRANS_M`] from the estimate; it
//! **sides with the estimate** in the mirror case; otherwise it is **undecided**. Only
//! translations decide: wheel odometry's heading drifts while turning (on CARMEN `aces` its
//! steps differ from the corrected ones by 0.7° at the median and 4° at the 90th percentile,
//! against 5 cm and 11 cm), so a rotation would often leave it undecided for its own sake. The
//! thresholds are the success and wrong ones of [`crate::measure::outcome`]: nothing is
//! tuned here.
//!
//! Counted apart for flagged and unflagged registrations: the unflagged wrong ones are the
//! flags' misses, and odometry says whether those misses are the registrations' or the
//! reference's.
//!
//! Independent of the laser is not independent of the reference: a SLAM correction may have
//! used the odometry as its prior, and then the two agree partly by construction. Odometry's
//! confirmation weighs most where the estimate is far from both (wheels do not slide a metre
//! along a corridor), and its siding with an estimate is evidence against the reference in
//! any case.

use datasets::Dataset;
use nalgebra::Vector2;
use serde::{Deserialize, Serialize};

use crate::data::RefMotion;
use crate::measure::outcome::{SUCCESS_TRANS_M, WRONG_ROT_DEG, WRONG_TRANS_M};
use crate::measure::record::PairRecord;
use crate::run::init::odometry_motion;
use crate::run::status::StatusKind;

/// How odometry judges a set of wrong registrations.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Verdicts {
    /// Wrong registrations judged.
    pub wrong: usize,
    /// Odometry agrees with the reference and not with the estimate: a failure of the
    /// registration.
    pub confirmed: usize,
    /// Odometry agrees with the estimate and not with the reference: the reference's error,
    /// likely.
    pub sides_with_estimate: usize,
    /// Neither.
    pub undecided: usize,
}

/// Odometry's word on one variant's wrong registrations (see the module doc).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct OdometryWord {
    /// The flagged ones (every status but `ok`).
    pub flagged: Verdicts,
    /// The unflagged ones: the flags' misses.
    pub unflagged: Verdicts,
}

/// The verdict on one wrong registration from its three translations (estimate, reference,
/// odometry), metres.
fn verdict(estimate: Vector2<f64>, reference: Vector2<f64>, odometry: Vector2<f64>) -> Verdict {
    let (to_reference, to_estimate) = ((odometry - reference).norm(), (odometry - estimate).norm());
    if to_reference <= SUCCESS_TRANS_M && to_estimate > WRONG_TRANS_M {
        Verdict::Confirmed
    } else if to_estimate <= SUCCESS_TRANS_M && to_reference > WRONG_TRANS_M {
        Verdict::SidesWithEstimate
    } else {
        Verdict::Undecided
    }
}

/// See [`Verdicts`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Verdict {
    Confirmed,
    SidesWithEstimate,
    Undecided,
}

impl Verdicts {
    fn add(&mut self, v: Verdict) {
        self.wrong += 1;
        match v {
            Verdict::Confirmed => self.confirmed += 1,
            Verdict::SidesWithEstimate => self.sides_with_estimate += 1,
            Verdict::Undecided => self.undecided += 1,
        }
    }
}

impl OdometryWord {
    /// Odometry's word on the wrong registrations of `rows` (one variant's), `refs` being the
    /// reference motion the rows were judged against (pair by pair, at the run's time offset);
    /// `None` when `ds` has no independent odometry or no registered row has a rigid
    /// reference.
    pub fn of(rows: &[PairRecord], ds: &Dataset, refs: &[Option<RefMotion>]) -> Option<Self> {
        let odometry = ds.independent_odometry()?;
        let mut word = Self {
            flagged: Verdicts::default(),
            unflagged: Verdicts::default(),
        };
        let mut judged = false;
        for r in rows.iter().filter(|r| r.status != StatusKind::Failed) {
            let (Some(err_m), Some(err_deg), Some(tx), Some(ty)) =
                (r.trans_err_m, r.rot_err_deg, r.tx_m, r.ty_m)
            else {
                continue;
            };
            judged = true;
            if err_m <= WRONG_TRANS_M && err_deg.abs() <= WRONG_ROT_DEG {
                continue;
            }
            let reference = refs
                .get(r.pair)
                .copied()
                .flatten()
                .and_then(|m| m.t_ref_src)
                .map(|t| t.translation.vector);
            let odometry = odometry
                .get(r.source)
                .zip(odometry.get(r.reference))
                .map(|(s, q)| odometry_motion(s, q).translation.vector);
            let v = match (reference, odometry) {
                (Some(reference), Some(odometry)) => {
                    verdict(Vector2::new(tx, ty), reference, odometry)
                }
                _ => Verdict::Undecided,
            };
            if r.status == StatusKind::Ok {
                word.unflagged.add(v);
            } else {
                word.flagged.add(v);
            }
        }
        judged.then_some(word)
    }
}

#[cfg(test)]
mod tests {
    use super::{verdict, Verdict};
    use nalgebra::Vector2;

    /// The verdict's three cases at and beside the thresholds (0.1 m agrees, beyond 0.3 m is
    /// apart).
    #[test]
    fn verdicts_by_hand() {
        let v = |e: f64, r: f64, o: f64| {
            verdict(
                Vector2::new(e, 0.0),
                Vector2::new(r, 0.0),
                Vector2::new(o, 0.0),
            )
        };
        // A corridor slide: the estimate 0.8 m short, odometry 5 cm from the reference.
        assert_eq!(v(0.2, 1.0, 1.05), Verdict::Confirmed);
        assert_eq!(v(0.2, 1.0, 1.09), Verdict::Confirmed);
        // The reference 0.5 m off, odometry with the estimate.
        assert_eq!(v(1.0, 0.5, 1.02), Verdict::SidesWithEstimate);
        // Odometry between the two, or near both.
        assert_eq!(v(0.2, 1.0, 0.6), Verdict::Undecided);
        assert_eq!(v(0.2, 1.0, 0.85), Verdict::Undecided);
        assert_eq!(v(1.0, 1.05, 1.02), Verdict::Undecided);
    }
}
