//! Registrations across lags (`--lags L`): besides each consecutive pair `k → k+1`, every
//! variant registers `k → k+ℓ` for `2 ≤ ℓ ≤ L` wherever the run's pairs `k … k+ℓ` are
//! consecutive, with the same init chain and gate rules. Their loops against the chained
//! consecutive pairs need no reference (measured in `measure/cycles.rs`).
//!
//! # The search window across a lag
//! The global search's window bounds the motion between the scans of a pair (±2 m by default:
//! aces' largest step is 1.54 m). Across ℓ pairs the scanner moves up to ℓ steps, so a pair
//! across lag ℓ is searched within ℓ × the window ([`lag_window`]). With the consecutive
//! pairs' window, 162 of aces' 438 lag-2 pairs moved more than 2 m along an axis: their
//! search could not reach the motion, their registrations ended 1.3–2.5 m off with status
//! ok, and the loops they closed accused right lag-1 registrations (`measure/cycles.rs`). The
//! consecutive pairs' own search is not touched: their results stay as they were.

use datasets::{Dataset, ScanPair};
use icp_core::global::{GlobalParams, MAX_WINDOW_CELLS};
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

/// The global search's parameters for a pair across lag `lag` from those of the consecutive
/// pairs, `global`: the translation window `lag` times as wide (capped at the widest window
/// the search takes), the same for the largest rotation (capped at 180°); `global` itself for
/// `lag` 1. Both bound the motion of one step, and ℓ steps move up to ℓ times as far. The
/// histogram window is not a motion bound (it is how far from a histogram peak the rotation
/// may lie) and the cell and step sizes set the search's precision, not its reach: they stay.
/// By default the rotation is already searched all round (180°), so only the window widens.
pub fn lag_window(global: &GlobalParams, lag: usize) -> GlobalParams {
    let scale = lag as f64;
    GlobalParams {
        window_m: (global.window_m * scale).min(MAX_WINDOW_CELLS * global.resolution_m),
        max_rotation_deg: (global.max_rotation_deg * scale).min(180.0),
        ..*global
    }
}

/// Registers `lag_pairs` (the [`lag_pairs`] of a run across `lags`, each lag's pairs
/// together) with the registrars of `methods` as `plan` says, each lag's pairs within its
/// [`lag_window`]; `None` for `lags` 1.
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
    let mut runs = Runs::empty(registrars.len());
    for same_lag in lag_pairs.chunk_by(|a, b| a.lag == b.lag) {
        let global = lag_window(plan.global, same_lag[0].lag);
        let lag_plan = RunPlan {
            global: &global,
            ..plan.clone()
        };
        let scan_pairs: Vec<ScanPair> = same_lag.iter().map(|p| p.pair).collect();
        runs.append_pairs(runner::run_all(
            ds,
            &scan_pairs,
            registrars,
            &lag_plan,
            progress,
        ));
    }
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

    #[test]
    fn lag_windows_scale_the_motion_bounds_only() {
        let one = GlobalParams {
            max_rotation_deg: 50.0,
            ..GlobalParams::default()
        };
        // Lag 1: the consecutive pairs' search, unchanged.
        assert_eq!(lag_window(&one, 1), one);
        let two = lag_window(&one, 2);
        assert_eq!((two.window_m, two.max_rotation_deg), (4.0, 100.0));
        assert_eq!(
            GlobalParams {
                window_m: one.window_m,
                max_rotation_deg: one.max_rotation_deg,
                ..two
            },
            one
        );
        // Capped: a turn of at most 180°, and the widest window the search takes.
        let far = lag_window(&one, 5000);
        assert_eq!(far.max_rotation_deg, 180.0);
        assert_eq!(far.window_m, MAX_WINDOW_CELLS * one.resolution_m);
        assert!(far.validate().is_ok());
    }
}
