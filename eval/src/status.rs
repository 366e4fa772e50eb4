//! What the harness says about one registration: it stands, or why its number cannot be
//! trusted. The status is typed; it becomes text only in the output files.
//!
//! Every status but [`PairStatus::Ok`] is a failure of its variant on that pair: it is counted
//! in the variant's failure rate. A flagged registration's number still enters its variant's
//! error statistics (which are taken over the same pairs for every variant, see
//! [`crate::report`]), so flagging a wrong number never makes a variant look more accurate.

use std::fmt;

use icp_core::quality::{DEGENERATE_RATIO, MIN_OVERLAP, OVERLAP_GATE_M};
use icp_core::{IcpError, Registration};
use serde::{Deserialize, Serialize};

/// The verdict on one registration.
#[derive(Clone, Debug, PartialEq)]
pub enum PairStatus {
    /// Registered, and nothing says the number is wrong.
    Ok,
    /// Registered, but the final pairs barely constrain one direction of the motion
    /// (conditioning ratio below [`DEGENERATE_RATIO`]): a corridor, a single wall.
    Degenerate {
        /// Smallest over largest eigenvalue of the Hessian at the solution.
        cond_ratio: f64,
    },
    /// Registered, but the scans do not see the same surfaces at the solution (overlap below
    /// [`MIN_OVERLAP`]).
    NoOverlap {
        /// The smaller of the two overlap fractions.
        overlap: f64,
    },
    /// No registration: the method refused the input or broke down.
    Failed {
        /// The error, as the method said it.
        error: IcpError,
    },
}

/// The kind of a [`PairStatus`], without its figures: the `status` column of `pairs.csv`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StatusKind {
    /// See [`PairStatus::Ok`].
    Ok,
    /// See [`PairStatus::Degenerate`].
    Degenerate,
    /// See [`PairStatus::NoOverlap`].
    NoOverlap,
    /// See [`PairStatus::Failed`].
    Failed,
}

impl PairStatus {
    /// The verdict on `result`: a failure first, then no overlap (a registration of scans
    /// that do not see the same surfaces means nothing, however well conditioned), then
    /// degenerate.
    pub fn of(result: &Result<Registration, IcpError>) -> Self {
        match result {
            Err(error) => Self::Failed {
                error: error.clone(),
            },
            Ok(r) if r.no_overlap() => Self::NoOverlap { overlap: r.overlap },
            Ok(r) => match r.conditioning {
                Some(c) if c.degenerate() => Self::Degenerate {
                    cond_ratio: c.ratio,
                },
                _ => Self::Ok,
            },
        }
    }

    /// Its kind.
    pub fn kind(&self) -> StatusKind {
        match self {
            Self::Ok => StatusKind::Ok,
            Self::Degenerate { .. } => StatusKind::Degenerate,
            Self::NoOverlap { .. } => StatusKind::NoOverlap,
            Self::Failed { .. } => StatusKind::Failed,
        }
    }

    /// True for every status but [`PairStatus::Ok`]: the pair counts as a failure of its
    /// variant.
    pub fn is_failure(&self) -> bool {
        *self != Self::Ok
    }
}

/// The reason, in words with its figures (empty for [`PairStatus::Ok`]).
impl fmt::Display for PairStatus {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Ok => Ok(()),
            Self::Degenerate { cond_ratio } => write!(
                f,
                "conditioning ratio {cond_ratio:.1e} < {DEGENERATE_RATIO}"
            ),
            Self::NoOverlap { overlap } => write!(
                f,
                "{:.0} % of the pairs within {OVERLAP_GATE_M} m (< {:.0} %)",
                100.0 * overlap,
                100.0 * MIN_OVERLAP
            ),
            Self::Failed { error } => write!(f, "{error}"),
        }
    }
}
