//! Summary statistics of an error series, computed in one place.

use serde::{Deserialize, Serialize};

/// Statistics of a series of signed errors `e`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Stats {
    /// Number of values.
    pub n: usize,
    /// Mean of `e`.
    pub mean: f64,
    /// Sample standard deviation of `e` (n − 1 in the denominator; 0 for one value).
    pub std: f64,
    /// The signed value of largest magnitude ("max" in the paper's Table 1).
    pub max_signed: f64,
    /// Median of `|e|`.
    pub median_abs: f64,
    /// Root mean square of `e`.
    pub rmse: f64,
    /// 95th percentile of `|e|` (linear interpolation between order statistics).
    pub p95_abs: f64,
}

impl Stats {
    /// Statistics of `values`; `None` when empty or when any value is not finite (the caller
    /// filters and counts those first, so nothing non-finite is folded in silently).
    pub fn of(values: &[f64]) -> Option<Stats> {
        if values.is_empty() || values.iter().any(|v| !v.is_finite()) {
            return None;
        }
        let n = values.len();
        let mean = values.iter().sum::<f64>() / n as f64;
        let std = if n > 1 {
            (values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt()
        } else {
            0.0
        };
        let max_signed =
            values.iter().copied().fold(
                0.0f64,
                |best, v| if v.abs() > best.abs() { v } else { best },
            );
        let rmse = rms(values);
        let mut abs: Vec<f64> = values.iter().map(|v| v.abs()).collect();
        abs.sort_by(f64::total_cmp);
        Some(Stats {
            n,
            mean,
            std,
            max_signed,
            median_abs: quantile_sorted(&abs, 0.5),
            rmse,
            p95_abs: quantile_sorted(&abs, 0.95),
        })
    }
}

/// Root mean square of `values` (NaN when empty).
pub fn rms(values: &[f64]) -> f64 {
    (values.iter().map(|v| v * v).sum::<f64>() / values.len() as f64).sqrt()
}

/// The factor that makes a median absolute deviation a standard deviation for Gaussian data
/// (1/Φ⁻¹(3/4)).
pub const MAD_TO_SD: f64 = 1.4826;

/// `1.4826 · MAD` about the median: the spread of `values` without their tails, the standard
/// deviation for Gaussian data (NaN when empty).
pub fn robust_sd(values: &[f64]) -> f64 {
    let mut v = values.to_vec();
    let Some(med) = icp_core::robust::median_in_place(&mut v) else {
        return f64::NAN;
    };
    let mut dev: Vec<f64> = v.iter().map(|x| (x - med).abs()).collect();
    MAD_TO_SD * icp_core::robust::median_in_place(&mut dev).unwrap_or(f64::NAN)
}

/// Quantile `q` in [0, 1] of ascending `sorted` values, interpolating linearly between order
/// statistics at position `q (n − 1)` (Hyndman & Fan type 7, numpy's default).
pub fn quantile_sorted(sorted: &[f64], q: f64) -> f64 {
    let n = sorted.len();
    if n == 0 {
        return f64::NAN;
    }
    let pos = q.clamp(0.0, 1.0) * (n - 1) as f64;
    let lo = pos.floor() as usize;
    let hi = (lo + 1).min(n - 1);
    let f = pos - lo as f64;
    sorted[lo] + f * (sorted[hi] - sorted[lo])
}

/// Median and 95th percentile of `values` (any order), `None` when empty.
pub fn median_p95(values: &[f64]) -> Option<(f64, f64)> {
    if values.is_empty() {
        return None;
    }
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    Some((quantile_sorted(&v, 0.5), quantile_sorted(&v, 0.95)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn robust_sd_by_hand() {
        // Odd count: median 3, departures 2, 1, 0, 1, 97: MAD 1 (the outlier does not count).
        assert_eq!(robust_sd(&[1.0, 2.0, 3.0, 4.0, 100.0]), MAD_TO_SD);
        // Even count: median 2.5, departures 1.5, 0.5, 0.5, 1.5: MAD 1.
        assert_eq!(robust_sd(&[4.0, 1.0, 3.0, 2.0]), MAD_TO_SD);
        assert!(robust_sd(&[]).is_nan());
    }

    #[test]
    fn hand_computed_example() {
        // e = [1, -2, 3, -4, 0.5]
        let s = Stats::of(&[1.0, -2.0, 3.0, -4.0, 0.5]).unwrap();
        assert_eq!(s.n, 5);
        assert!((s.mean - (-0.3)).abs() < 1e-15); // -1.5 / 5
                                                  // Σ(e − mean)² = 1.69 + 2.89 + 10.89 + 13.69 + 0.64 = 29.8; / 4 = 7.45
        assert!((s.std - 7.45f64.sqrt()).abs() < 1e-12);
        assert_eq!(s.max_signed, -4.0);
        // |e| sorted = [0.5, 1, 2, 3, 4]: median 2; p95 at position 3.8: 3 + 0.8 · 1 = 3.8
        assert_eq!(s.median_abs, 2.0);
        assert!((s.p95_abs - 3.8).abs() < 1e-12);
        // Σe² = 1 + 4 + 9 + 16 + 0.25 = 30.25; / 5 = 6.05
        assert!((s.rmse - 6.05f64.sqrt()).abs() < 1e-12);
    }

    #[test]
    fn signed_max_keeps_the_sign_and_even_median_interpolates() {
        let s = Stats::of(&[0.2, -0.1, 0.3, -0.25]).unwrap();
        assert_eq!(s.max_signed, 0.3);
        assert!((s.median_abs - 0.225).abs() < 1e-15);
        assert_eq!(Stats::of(&[2.0]).unwrap().std, 0.0);
        assert_eq!(Stats::of(&[]), None);
        assert_eq!(Stats::of(&[1.0, f64::NAN]), None);
        assert_eq!(median_p95(&[3.0, 1.0, 2.0]), Some((2.0, 2.9)));
    }
}
