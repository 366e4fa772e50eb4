//! Registrations across lags (`--lags L`): besides each consecutive pair `k → k+1`, every
//! variant registers `k → k+ℓ` for `2 ≤ ℓ ≤ L` wherever the run's pairs `k … k+ℓ` are
//! consecutive, with the same init chain and gate rules. Their loops against the chained
//! consecutive pairs need no reference (measured in `measure/cycles.rs`).

use datasets::{Dataset, ScanPair};
use indicatif::ProgressBar;
use serde::{Deserialize, Serialize};

use crate::error::EvalError;
use crate::run::runner::{self, Methods, RunPlan, Runs};

/// One registration across a lag.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct LagPair {
    /// The scans registered: `source` = scan k, `reference` = scan k+ℓ.
    pub pair: ScanPair,
    /// ℓ, in pairs of the run.
    pub lag: usize,
    /// Position in the run's pairs of its first consecutive pair (`k → k+1`).
    pub first: usize,
}

/// The registrations across lags, by lag then position (serialized whole into the part files
/// of a sharded run, see the `shard` module).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct LagRuns {
    /// The pairs, in the order of `runs`.
    pub pairs: Vec<LagPair>,
    /// `runs.per_variant[v][i]` registers `pairs[i]` (the registrars only: external
    /// estimates are per consecutive pair).
    pub runs: Runs,
}

/// The pairs across lags `2..=lags` of the run's `pairs`: an error for `lags` 0 or longer
/// than the run; none for `lags` 1.
pub fn lag_pairs(pairs: &[ScanPair], lags: usize) -> Result<Vec<LagPair>, EvalError> {
    if lags == 0 {
        return Err(EvalError::Lags {
            lags,
            why: "a lag is at least 1 (1: consecutive pairs only)".to_owned(),
        });
    }
    if lags > pairs.len() {
        return Err(EvalError::Lags {
            lags,
            why: format!("the run has {} pairs", pairs.len()),
        });
    }
    let contiguous = |i: usize, lag: usize| {
        i + lag <= pairs.len()
            && pairs[i..i + lag]
                .windows(2)
                .all(|w| w[0].reference == w[1].source)
    };
    Ok((2..=lags)
        .flat_map(|lag| {
            (0..pairs.len())
                .filter(move |&i| contiguous(i, lag))
                .map(move |i| LagPair {
                    pair: ScanPair {
                        source: pairs[i].source,
                        reference: pairs[i + lag - 1].reference,
                    },
                    lag,
                    first: i,
                })
        })
        .collect())
}

/// Registers `lag_pairs` (the [`lag_pairs`] of a run across `lags`) with the registrars of
/// `methods` as `plan` says; `None` for `lags` 1.
pub fn run(
    ds: &Dataset,
    lag_pairs: Vec<LagPair>,
    lags: usize,
    methods: Methods<'_>,
    plan: &RunPlan<'_>,
    progress: &ProgressBar,
) -> Option<LagRuns> {
    if lags == 1 {
        return None;
    }
    let registrars = Methods {
        external: &[],
        ..methods
    };
    let scan_pairs: Vec<ScanPair> = lag_pairs.iter().map(|p| p.pair).collect();
    let runs = runner::run_all(ds, &scan_pairs, registrars, plan, progress);
    Some(LagRuns {
        pairs: lag_pairs,
        runs,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lag_pairs_follow_consecutive_runs_only() {
        let p = |a: usize, b: usize| ScanPair {
            source: a,
            reference: b,
        };
        // Scans 0..4 consecutive, then a gap (4 → 5 skipped), then 5 → 6.
        let pairs = [p(0, 1), p(1, 2), p(2, 3), p(3, 4), p(5, 6)];
        let lagged = lag_pairs(&pairs, 3).unwrap();
        let got: Vec<(usize, usize, usize)> = lagged
            .iter()
            .map(|l| (l.pair.source, l.pair.reference, l.lag))
            .collect();
        assert_eq!(
            got,
            vec![(0, 2, 2), (1, 3, 2), (2, 4, 2), (0, 3, 3), (1, 4, 3)]
        );
        assert!(lag_pairs(&pairs, 1).unwrap().is_empty());
        assert!(matches!(
            lag_pairs(&pairs, 0),
            Err(EvalError::Lags { lags: 0, .. })
        ));
        let too_long = lag_pairs(&pairs, 6).unwrap_err().to_string();
        assert!(
            too_long.contains("--lags 6") && too_long.contains("5 pairs"),
            "{too_long}"
        );
    }
}
