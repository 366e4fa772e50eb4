//! The reference is not truth: its time offset from the scans, and the steps that are
//! implausible given their neighbours (its motion per pair is [`crate::data::motion`]).

use datasets::ScanPair;
use serde::{Deserialize, Serialize};

/// The estimated lag between the estimated and the reference motion series.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct OffsetEstimate {
    /// The estimated lag in scans: the reference of pair `k + scans` matches the estimate of
    /// pair `k` (positive: the reference runs late). It is the best-scoring lag when that beats
    /// lag 0 by at least `min_score_gain`, else 0: smooth motion correlates almost as well at
    /// neighbouring lags, and a gain within the noise is no evidence of an offset.
    pub scans: i64,
    /// The same lag in seconds, from the nominal scan spacing.
    pub seconds: f64,
    /// Mean of the SOG and ΔCOG correlation coefficients at the estimated lag.
    pub score: f64,
    /// The same score at lag 0.
    pub score_at_zero: f64,
    /// The best-scoring lag, whether or not it was accepted.
    pub best_lag_scans: i64,
    /// Its score.
    pub best_score: f64,
    /// The lags searched, ± this many scans.
    pub max_lag_scans: i64,
    /// Smallest score gain over lag 0 that is accepted as an offset.
    pub min_score_gain: f64,
}

/// Largest lag searched, scans.
pub const MAX_LAG_SCANS: i64 = 5;
/// Smallest gain of the correlation score over lag 0 accepted as evidence of an offset.
pub const MIN_SCORE_GAIN: f64 = 0.05;

/// Estimates the lag by cross-correlating the estimated and reference SOG and ΔCOG series
/// (each correlation over the overlapping part; the score is their mean). `None` when the
/// series are too short (< 10 overlapping values at some lag) or constant.
pub fn estimate_offset(
    est_sog: &[f64],
    est_dcog: &[f64],
    ref_sog: &[f64],
    ref_dcog: &[f64],
    dt_s: f64,
) -> Option<OffsetEstimate> {
    let score = |lag: i64| -> Option<f64> {
        let a = pearson_lagged(est_sog, ref_sog, lag)?;
        let b = pearson_lagged(est_dcog, ref_dcog, lag)?;
        Some(0.5 * (a + b))
    };
    let score_at_zero = score(0)?;
    let (best_lag, best_score) = (-MAX_LAG_SCANS..=MAX_LAG_SCANS)
        .filter_map(|lag| score(lag).map(|s| (lag, s)))
        .fold(
            (0, score_at_zero),
            |acc, (lag, s)| if s > acc.1 { (lag, s) } else { acc },
        );
    let (scans, score) = if best_score - score_at_zero >= MIN_SCORE_GAIN {
        (best_lag, best_score)
    } else {
        (0, score_at_zero)
    };
    Some(OffsetEstimate {
        scans,
        seconds: scans as f64 * dt_s,
        score,
        score_at_zero,
        best_lag_scans: best_lag,
        best_score,
        max_lag_scans: MAX_LAG_SCANS,
        min_score_gain: MIN_SCORE_GAIN,
    })
}

/// Pearson correlation of `est[k]` with `reference[k + lag]` over the overlap; non-finite
/// values (failed pairs) are left out.
fn pearson_lagged(est: &[f64], reference: &[f64], lag: i64) -> Option<f64> {
    let pairs: Vec<(f64, f64)> = (0..est.len() as i64)
        .filter_map(|k| {
            let j = usize::try_from(k + lag).ok()?;
            let (x, y) = (est[k as usize], *reference.get(j)?);
            (x.is_finite() && y.is_finite()).then_some((x, y))
        })
        .collect();
    if pairs.len() < 10 {
        return None;
    }
    let n = pairs.len() as f64;
    let (mx, my) = (
        pairs.iter().map(|p| p.0).sum::<f64>() / n,
        pairs.iter().map(|p| p.1).sum::<f64>() / n,
    );
    let (mut sxy, mut sxx, mut syy) = (0.0, 0.0, 0.0);
    for (x, y) in &pairs {
        sxy += (x - mx) * (y - my);
        sxx += (x - mx).powi(2);
        syy += (y - my).powi(2);
    }
    (sxx > 0.0 && syy > 0.0).then(|| sxy / (sxx * syy).sqrt())
}

/// Half-width of the rolling median window of the plausibility test, steps.
pub const PLAUSIBILITY_HALF_WINDOW: usize = 3;
/// A step is implausible when it departs from its neighbours' median by more than this many
/// robust standard deviations (1.4826 × the median absolute departure over the whole run).
pub const PLAUSIBILITY_THRESHOLD_SIGMA: f64 = 5.0;
/// Floors of the robust scale, so a perfectly smooth reference does not flag rounding noise:
/// 0.02 m/s and 0.2°/s.
pub const SCALE_FLOOR_SOG_MPS: f64 = 0.02;
/// See [`SCALE_FLOOR_SOG_MPS`].
pub const SCALE_FLOOR_ROT_DPS: f64 = 0.2;

/// A reference step flagged as implausible.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FlaggedStep {
    /// Pair index (position in the run's pair list).
    pub pair: usize,
    /// Scan indices of the pair.
    pub source: usize,
    /// See `source`.
    pub reference: usize,
    /// What is implausible, with the numbers.
    pub reason: String,
}

/// Flags reference steps whose speed or yaw rate departs from what their neighbours predict
/// (± [`PLAUSIBILITY_HALF_WINDOW`] steps: their median, or near an end of the series their
/// robust line; see `predicted`) by more than [`PLAUSIBILITY_THRESHOLD_SIGMA`] robust standard
/// deviations of all such departures. A repeated position (zero speed between moving
/// neighbours) is caught this way, at the ends of the series too.
pub fn flag_implausible(pairs: &[ScanPair], sog_mps: &[f64], rot_dps: &[f64]) -> Vec<FlaggedStep> {
    let sog_out = outliers(sog_mps, SCALE_FLOOR_SOG_MPS);
    let rot_out = outliers(rot_dps, SCALE_FLOOR_ROT_DPS);
    let mut flagged = Vec::new();
    for (i, pair) in pairs.iter().enumerate() {
        let mut why = Vec::new();
        if let Some((dev, med)) = sog_out[i] {
            why.push(format!(
                "speed {:.3} m/s vs {:.3} m/s from its neighbours ({dev:.1} sigma)",
                sog_mps[i], med
            ));
        }
        if let Some((dev, med)) = rot_out[i] {
            why.push(format!(
                "yaw rate {:.2} deg/s vs {:.2} deg/s from its neighbours ({dev:.1} sigma)",
                rot_dps[i], med
            ));
        }
        if !sog_mps[i].is_finite() || !rot_dps[i].is_finite() {
            why.push("no reference for this pair".into());
        }
        if !why.is_empty() {
            flagged.push(FlaggedStep {
                pair: i,
                source: pair.source,
                reference: pair.reference,
                reason: why.join("; "),
            });
        }
    }
    flagged
}

/// What the neighbours of value `i` (± [`PLAUSIBILITY_HALF_WINDOW`] steps, finite ones) say it
/// should be. Inside the series, their median: the window is symmetric, so a steady trend
/// cancels. Near an end a window is one-sided, and its median lags a trend by about two
/// steps' change, which flagged exact ground truth at the start and end of a turn or an
/// acceleration. There the window keeps its width (the 2h values nearest the end), and the
/// value at `i` of the repeated-median line through them
/// (Siegel 1982: per neighbour the median of its slopes to the others, then their median;
/// one glitch among them does not move it) is taken instead. NaN without neighbours.
fn predicted(x: &[f64], i: usize) -> f64 {
    let (n, h) = (x.len(), PLAUSIBILITY_HALF_WINDOW);
    let symmetric = i >= h && i + h < n;
    // Near an end, the window keeps its width (2h neighbours), shifted inwards.
    let (lo, hi) = if symmetric {
        (i - h, i + h + 1)
    } else if i < h {
        (0, (2 * h + 1).min(n))
    } else {
        (n.saturating_sub(2 * h + 1), n)
    };
    let neighbours: Vec<(f64, f64)> = (lo..hi)
        .filter(|&j| j != i && x[j].is_finite())
        .map(|j| (j as f64, x[j]))
        .collect();
    let median = |mut v: Vec<f64>| icp_core::robust::median_in_place(&mut v).unwrap_or(f64::NAN);
    if symmetric || neighbours.len() < 2 {
        return median(neighbours.iter().map(|&(_, v)| v).collect());
    }
    let slope = median(
        neighbours
            .iter()
            .map(|&(ja, va)| {
                median(
                    neighbours
                        .iter()
                        .filter(|&&(jb, _)| jb != ja)
                        .map(|&(jb, vb)| (vb - va) / (jb - ja))
                        .collect(),
                )
            })
            .collect(),
    );
    let intercept = median(neighbours.iter().map(|&(j, v)| v - slope * j).collect());
    intercept + slope * i as f64
}

/// Per value: `Some((departure in sigmas, what its neighbours predict))` when it is an
/// outlier.
fn outliers(x: &[f64], scale_floor: f64) -> Vec<Option<(f64, f64)>> {
    let n = x.len();
    let medians: Vec<f64> = (0..n).map(|i| predicted(x, i)).collect();
    let mut dev: Vec<f64> = x
        .iter()
        .zip(&medians)
        .map(|(v, m)| (v - m).abs())
        .filter(|d| d.is_finite())
        .collect();
    let mad = icp_core::robust::median_in_place(&mut dev).unwrap_or(0.0);
    let sigma = (crate::measure::stats::MAD_TO_SD * mad).max(scale_floor);
    x.iter()
        .zip(&medians)
        .map(|(v, m)| {
            let d = (v - m).abs() / sigma;
            (d > PLAUSIBILITY_THRESHOLD_SIGMA).then_some((d, *m))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn offset_is_found_on_a_shifted_series() {
        let f = |k: f64| (k * 0.37).sin() + 0.5 * (k * 0.11).cos();
        let est: Vec<f64> = (0..100).map(|k| f(k as f64)).collect();
        let est2: Vec<f64> = (0..100).map(|k| f(k as f64 * 1.7)).collect();
        // The reference runs 2 scans late: reference[k + 2] = est[k].
        let ref1: Vec<f64> = (0..100).map(|k| f(k as f64 - 2.0)).collect();
        let ref2: Vec<f64> = (0..100).map(|k| f((k as f64 - 2.0) * 1.7)).collect();
        let o = estimate_offset(&est, &est2, &ref1, &ref2, 0.2).unwrap();
        assert_eq!(o.scans, 2);
        assert!((o.seconds - 0.4).abs() < 1e-12);
        assert!(o.score > 0.999 && o.score > o.score_at_zero);
        assert!(estimate_offset(&est[..5], &est2[..5], &ref1[..5], &ref2[..5], 1.0).is_none());
    }

    #[test]
    fn glitches_are_flagged_and_smooth_steps_are_not() {
        let pairs: Vec<ScanPair> = (0..40)
            .map(|k| ScanPair {
                source: k,
                reference: k + 1,
            })
            .collect();
        let mut sog: Vec<f64> = (0..40)
            .map(|k| 1.24 + 0.01 * (k as f64 * 0.3).sin())
            .collect();
        // A turn ramping up and down over five steps each, as a vessel turns.
        let rot: Vec<f64> = (0..40)
            .map(|k| {
                0.1 + 3.0
                    * ((k as f64 - 8.0) / 5.0).clamp(0.0, 1.0)
                    * ((26.0 - k as f64) / 5.0).clamp(0.0, 1.0)
            })
            .collect();
        sog[7] = 0.72; // a short step, as in the marina reference
        sog[30] = 0.0; // a repeated position
        let flagged = flag_implausible(&pairs, &sog, &rot);
        let idx: Vec<usize> = flagged.iter().map(|f| f.pair).collect();
        assert_eq!(idx, vec![7, 30], "{flagged:?}");
        assert!(flagged[0].reason.contains("speed 0.720"));
    }

    #[test]
    fn exact_trends_at_the_ends_are_not_flagged_and_glitches_there_are() {
        let n = 30;
        let pairs: Vec<ScanPair> = (0..n)
            .map(|k| ScanPair {
                source: k,
                reference: k + 1,
            })
            .collect();
        // Exact ground truth that accelerates from the first step and turns ever faster to
        // the last: steady trends from one end to the other. A one-sided median lags them by
        // 0.12 m/s and 1.2 deg/s at the ends (6 and 6 sigma of the floors).
        let sog: Vec<f64> = (0..n).map(|k| 0.5 + 0.06 * k as f64).collect();
        let rot: Vec<f64> = (0..n).map(|k| 0.6 * k as f64).collect();
        let flagged = flag_implausible(&pairs, &sog, &rot);
        assert!(flagged.is_empty(), "{flagged:?}");
        // The same with a repeated position at each end: both caught.
        let mut glitched = sog.clone();
        glitched[0] = 0.0;
        glitched[n - 1] = 0.0;
        let idx: Vec<usize> = flag_implausible(&pairs, &glitched, &rot)
            .iter()
            .map(|f| f.pair)
            .collect();
        assert_eq!(idx, vec![0, n - 1]);
    }
}
