//! Paired comparison of variants on the same pairs: the difference of absolute errors per
//! pair, with a bootstrap confidence interval of its mean and a Wilcoxon signed-rank p-value.
//! "HD_ICP beats HM_ICP" becomes a claim with an interval, not a glance at two stds.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::measure::record::PairRecord;
use crate::measure::report::RunReport;

/// Bootstrap percentile interval of the mean of `d`: `level` in (0, 1), `resamples` draws
/// (seeded ChaCha8). `None` when `d` is empty.
pub fn bootstrap_mean_ci(d: &[f64], level: f64, resamples: usize, seed: u64) -> Option<(f64, f64)> {
    if d.is_empty() || resamples == 0 {
        return None;
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let n = d.len();
    let mut means: Vec<f64> = (0..resamples)
        .map(|_| (0..n).map(|_| d[rng.random_range(0..n)]).sum::<f64>() / n as f64)
        .collect();
    means.sort_by(f64::total_cmp);
    let alpha = 0.5 * (1.0 - level);
    Some((
        crate::measure::stats::quantile_sorted(&means, alpha),
        crate::measure::stats::quantile_sorted(&means, 1.0 - alpha),
    ))
}

/// The outcome of a Wilcoxon signed-rank test.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Wilcoxon {
    /// Non-zero differences used.
    pub n: usize,
    /// Sum of the ranks of the positive differences.
    pub w_plus: f64,
    /// Two-sided p-value.
    pub p_value: f64,
    /// Whether the p-value is exact (else the normal approximation).
    pub exact: bool,
}

/// Wilcoxon signed-rank test of `d` against a zero median, two-sided. Zeros are dropped,
/// tied |d| get their average rank. Without ties and with n ≤ 50 the p-value is exact (the
/// distribution of W+ by counting); otherwise the normal approximation with tie and
/// continuity corrections. `None` when no difference is non-zero.
pub fn wilcoxon_signed_rank(d: &[f64]) -> Option<Wilcoxon> {
    let mut nz: Vec<f64> = d
        .iter()
        .copied()
        .filter(|v| *v != 0.0 && v.is_finite())
        .collect();
    let n = nz.len();
    if n == 0 {
        return None;
    }
    nz.sort_by(|a, b| a.abs().total_cmp(&b.abs()));
    // Average ranks over runs of equal |d|; tie groups kept for the variance correction.
    let mut ranks = vec![0.0; n];
    let mut tie_term = 0.0;
    let mut i = 0;
    while i < n {
        let mut j = i;
        while j + 1 < n && nz[j + 1].abs() == nz[i].abs() {
            j += 1;
        }
        let avg = 0.5 * ((i + 1) + (j + 1)) as f64;
        ranks[i..=j].iter_mut().for_each(|r| *r = avg);
        let t = (j - i + 1) as f64;
        tie_term += t * t * t - t;
        i = j + 1;
    }
    let w_plus: f64 = nz
        .iter()
        .zip(&ranks)
        .filter(|(v, _)| **v > 0.0)
        .map(|(_, r)| r)
        .sum();
    let nf = n as f64;
    let mean = nf * (nf + 1.0) / 4.0;
    if tie_term == 0.0 && n <= 50 {
        // Exact: counts of subsets of {1..n} by sum.
        let max = n * (n + 1) / 2;
        let mut counts = vec![0f64; max + 1];
        counts[0] = 1.0;
        for k in 1..=n {
            for s in (k..=max).rev() {
                counts[s] += counts[s - k];
            }
        }
        let total = 2f64.powi(n as i32);
        let w = w_plus.round() as usize;
        let tail = if w_plus >= mean {
            counts[w..].iter().sum::<f64>()
        } else {
            counts[..=w].iter().sum::<f64>()
        };
        return Some(Wilcoxon {
            n,
            w_plus,
            p_value: (2.0 * tail / total).min(1.0),
            exact: true,
        });
    }
    let var = nf * (nf + 1.0) * (2.0 * nf + 1.0) / 24.0 - tie_term / 48.0;
    let dev = w_plus - mean;
    let corrected = (dev.abs() - 0.5).max(0.0);
    let z = corrected / var.sqrt();
    Some(Wilcoxon {
        n,
        w_plus,
        p_value: erfc(z / std::f64::consts::SQRT_2).min(1.0),
        exact: false,
    })
}

/// Complementary error function (Numerical Recipes' Chebyshev fit, relative error < 1.2e-7).
pub fn erfc(x: f64) -> f64 {
    let z = x.abs();
    let t = 1.0 / (1.0 + 0.5 * z);
    let poly = -z * z - 1.265_512_23
        + t * (1.000_023_68
            + t * (0.374_091_96
                + t * (0.096_784_18
                    + t * (-0.186_288_06
                        + t * (0.278_868_07
                            + t * (-1.135_203_98
                                + t * (1.488_515_87 + t * (-0.822_152_23 + t * 0.170_872_77))))))));
    let r = t * poly.exp();
    if x >= 0.0 {
        r
    } else {
        2.0 - r
    }
}

/// Paired comparison of two variants on one error.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PairedComparison {
    /// First variant.
    pub a: String,
    /// Second variant.
    pub b: String,
    /// The error compared, e.g. `sog_err_mps`.
    pub metric: String,
    /// Pairs every variant registered whose reference is plausible.
    pub n: usize,
    /// Mean of `|e_a| − |e_b|` (negative: `a` is more accurate).
    pub mean_diff: f64,
    /// 95 % bootstrap interval of that mean.
    pub ci95: Option<(f64, f64)>,
    /// Wilcoxon signed-rank test of the differences.
    pub wilcoxon: Option<Wilcoxon>,
    /// The Wilcoxon p-value adjusted for the number of comparisons in the table (Holm).
    pub p_holm: Option<f64>,
    /// `a better`, `b better`, or `no clear difference` (the interval straddles 0, or the
    /// Holm-adjusted p ≥ 0.05).
    pub verdict: String,
}

/// Options of a comparison.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct CompareOptions {
    /// Bootstrap resamples.
    pub resamples: usize,
    /// Bootstrap seed.
    pub seed: u64,
}

impl Default for CompareOptions {
    fn default() -> Self {
        Self {
            resamples: 10_000,
            seed: 0,
        }
    }
}

/// Every pair of variants of `report`, on SOG and ΔCOG error, over the pairs every variant
/// registered (the population of every statistic of the run) whose reference step is
/// plausible.
pub fn compare(report: &RunReport, options: &CompareOptions) -> Vec<PairedComparison> {
    type Get = fn(&PairRecord) -> Option<f64>;
    let metrics: [(&str, Get); 2] = [
        ("sog_err_mps", |r| r.sog_err_mps),
        ("dcog_err_deg", |r| r.dcog_err_deg),
    ];
    let names: Vec<&str> = report.variants.iter().map(|v| v.name.as_str()).collect();
    let rows = |name: &str| -> Vec<&PairRecord> {
        report.pairs.iter().filter(|r| r.variant == name).collect()
    };
    let mut out = Vec::new();
    for (i, a) in names.iter().enumerate() {
        for b in &names[i + 1..] {
            let (ra, rb) = (rows(a), rows(b));
            for (metric, get) in metrics {
                let d: Vec<f64> = ra
                    .iter()
                    .zip(&rb)
                    .filter(|(x, _)| x.all_registered && x.ref_plausible)
                    .filter_map(|(x, y)| Some(get(x)?.abs() - get(y)?.abs()))
                    .collect();
                let mean_diff = if d.is_empty() {
                    f64::NAN
                } else {
                    d.iter().sum::<f64>() / d.len() as f64
                };
                out.push(PairedComparison {
                    a: a.to_string(),
                    b: b.to_string(),
                    metric: metric.to_owned(),
                    n: d.len(),
                    mean_diff,
                    ci95: bootstrap_mean_ci(&d, 0.95, options.resamples, options.seed),
                    wilcoxon: wilcoxon_signed_rank(&d),
                    p_holm: None,
                    verdict: String::new(),
                });
            }
        }
    }
    let p: Vec<Option<f64>> = out.iter().map(|c| c.wilcoxon.map(|w| w.p_value)).collect();
    for (c, adjusted) in out.iter_mut().zip(holm(&p)) {
        c.p_holm = adjusted;
        let significant = adjusted.is_some_and(|p| p < 0.05);
        c.verdict = match c.ci95 {
            Some((_, hi)) if hi < 0.0 && significant => format!("{} better", c.a),
            Some((lo, _)) if lo > 0.0 && significant => format!("{} better", c.b),
            _ => "no clear difference".to_owned(),
        };
    }
    out
}

/// Holm's step-down adjustment of p-values for multiple comparisons (missing ones stay
/// missing and do not count): the k-th smallest of m becomes
/// `max over j ≤ k of min(1, (m − j + 1) p_(j))`.
pub fn holm(p: &[Option<f64>]) -> Vec<Option<f64>> {
    let mut order: Vec<usize> = (0..p.len()).filter(|&i| p[i].is_some()).collect();
    order.sort_by(|&i, &j| p[i].unwrap_or(1.0).total_cmp(&p[j].unwrap_or(1.0)));
    let m = order.len();
    let mut out = vec![None; p.len()];
    let mut running = 0.0f64;
    for (k, &i) in order.iter().enumerate() {
        let adjusted = ((m - k) as f64 * p[i].unwrap_or(1.0)).min(1.0);
        running = running.max(adjusted);
        out[i] = Some(running);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn holm_by_hand() {
        // p = 0.01, 0.04, 0.03 (m = 3): sorted 0.01·3 = 0.03, 0.03·2 = 0.06, 0.04·1 → max(0.06, 0.04).
        let adj = holm(&[Some(0.01), Some(0.04), None, Some(0.03)]);
        assert_eq!(adj[2], None);
        assert!((adj[0].unwrap() - 0.03).abs() < 1e-15);
        assert!((adj[3].unwrap() - 0.06).abs() < 1e-15);
        assert!((adj[1].unwrap() - 0.06).abs() < 1e-15);
    }

    #[test]
    fn wilcoxon_exact_by_hand() {
        // d = [1.5, -0.5, 2, 3, -1, 2.5] (+ a zero, dropped): ranks of |d| 3, 1, 4, 6, 2, 5;
        // W+ = 3 + 4 + 6 + 5 = 18, W− = 3. Subsets of {1..6} with sum ≤ 3: {}, {1}, {2}, {3},
        // {1,2}: 5 of 64, so p = 2 · 5/64 = 0.15625 (scipy.stats.wilcoxon agrees).
        let w = wilcoxon_signed_rank(&[1.5, -0.5, 2.0, 3.0, -1.0, 2.5, 0.0]).unwrap();
        assert_eq!((w.n, w.w_plus, w.exact), (6, 18.0, true));
        assert!((w.p_value - 0.15625).abs() < 1e-12, "{}", w.p_value);
        assert_eq!(wilcoxon_signed_rank(&[0.0, 0.0]), None);
    }

    #[test]
    fn wilcoxon_normal_approximation_with_ties_matches_scipy() {
        // 25 differences with a tie (|−0.3| = |0.3|): scipy.stats.wilcoxon(d, method="approx",
        // correction=True) gives statistic min(W+, W−) = 63.5 and p = 0.008032737633470864.
        let d = [
            0.8, -0.3, 1.2, 0.5, -0.7, 1.9, 0.25, -0.15, 0.9, 1.1, -0.45, 0.6, 0.35, 1.4, -0.2,
            0.75, 0.05, 1.05, -0.9, 0.55, 0.3, -0.6, 1.7, 0.4, 0.95,
        ];
        let w = wilcoxon_signed_rank(&d).unwrap();
        assert!(!w.exact);
        assert_eq!(25.0 * 26.0 / 2.0 - w.w_plus, 63.5);
        assert!(
            (w.p_value - 0.008032737633470864).abs() < 1e-6,
            "{}",
            w.p_value
        );
    }

    #[test]
    fn bootstrap_by_hand() {
        // Constant differences: every resample has the same mean.
        assert_eq!(
            bootstrap_mean_ci(&[0.25; 8], 0.95, 1000, 1),
            Some((0.25, 0.25))
        );
        // d = [0, 1]: resample means are 0, 0.5, 1 with probabilities 1/4, 1/2, 1/4, so the
        // 2.5 % and 97.5 % points are 0 and 1.
        let (lo, hi) = bootstrap_mean_ci(&[0.0, 1.0], 0.95, 20_000, 7).unwrap();
        assert_eq!((lo, hi), (0.0, 1.0));
        // Seeded: the same draw twice.
        let d: Vec<f64> = (0..50).map(|i| (i as f64 * 0.7).sin()).collect();
        assert_eq!(
            bootstrap_mean_ci(&d, 0.95, 500, 3),
            bootstrap_mean_ci(&d, 0.95, 500, 3)
        );
        // Large sample: close to mean ± 1.96 sd / sqrt(n).
        let d: Vec<f64> = (0..400)
            .map(|i| ((i * 7919) % 1000) as f64 / 1000.0)
            .collect();
        let n = d.len() as f64;
        let mean = d.iter().sum::<f64>() / n;
        let sd = (d.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
        let (lo, hi) = bootstrap_mean_ci(&d, 0.95, 20_000, 11).unwrap();
        let half = 1.96 * sd / n.sqrt();
        assert!(
            ((hi - lo) / (2.0 * half) - 1.0).abs() < 0.05,
            "{lo} {hi} vs ±{half}"
        );
        assert_eq!(bootstrap_mean_ci(&[], 0.95, 10, 0), None);
    }

    #[test]
    fn erfc_known_values() {
        assert!((erfc(0.0) - 1.0).abs() < 1e-7);
        assert!((erfc(1.0) - 0.157_299_207_050_285).abs() < 1e-7);
        assert!((erfc(-1.0) - 1.842_700_792_949_715).abs() < 1e-7);
        assert!((erfc(3.0) - 2.209_049_699_858_544e-5).abs() < 1e-11);
    }
}
