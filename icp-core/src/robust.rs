//! Robust rejection, Algorithm 1 step 4: a factor on each pair's weight from the whole batch.

use crate::matching::Correspondence;

/// Multiplies pair weights by a robust factor computed over all the pairs of an iteration
/// (the batch is needed because thresholds such as the median depend on it).
pub trait RobustKernel: Send + Sync {
    /// Scales `weights[i]` (one per pair) in place. `scratch` is a reusable buffer.
    fn reweight(&self, pairs: &[Correspondence], weights: &mut [f64], scratch: &mut Vec<f64>);
}

/// No rejection: weights are left as they are (K_ICP).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct NoRobust;

impl RobustKernel for NoRobust {
    fn reweight(&self, _pairs: &[Correspondence], _weights: &mut [f64], _scratch: &mut Vec<f64>) {}
}

/// Huber down-weighting with a median-scaled threshold (Naus & Marchel 2019, Algorithm 1 step 4):
/// `kHu = c · median_i d_i` over the pair distances `d_i`; a pair with `d > kHu` has its
/// weight multiplied by `kHu / d`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HuberMedian {
    /// The factor `c` on the median distance (dimensionless).
    pub c: f64,
}

impl HuberMedian {
    /// The paper's `c = 2.0138`.
    pub const PAPER_C: f64 = 2.0138;
}

impl Default for HuberMedian {
    fn default() -> Self {
        Self { c: Self::PAPER_C }
    }
}

impl RobustKernel for HuberMedian {
    fn reweight(&self, pairs: &[Correspondence], weights: &mut [f64], scratch: &mut Vec<f64>) {
        scratch.clear();
        scratch.extend(pairs.iter().map(|p| p.dist_sq.sqrt()));
        let Some(median) = median_in_place(scratch) else {
            return;
        };
        let k = self.c * median;
        for (p, w) in pairs.iter().zip(weights.iter_mut()) {
            let d = p.dist_sq.sqrt();
            if d > k {
                *w *= k / d;
            }
        }
    }
}

/// Median of `values` (reordered in place): the middle value, or the mean of the two middle
/// values for an even count. `None` for an empty slice.
pub fn median_in_place(values: &mut [f64]) -> Option<f64> {
    let n = values.len();
    if n == 0 {
        return None;
    }
    let mid = n / 2;
    let (lower, upper_mid, _) = values.select_nth_unstable_by(mid, f64::total_cmp);
    let upper_mid = *upper_mid;
    if n % 2 == 1 {
        return Some(upper_mid);
    }
    let lower_mid = lower
        .iter()
        .copied()
        .max_by(f64::total_cmp)
        .expect("n >= 2 here");
    Some(0.5 * (lower_mid + upper_mid))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pairs(d: &[f64]) -> Vec<Correspondence> {
        d.iter()
            .enumerate()
            .map(|(i, &d)| Correspondence {
                src: i,
                dst: i,
                dist_sq: d * d,
            })
            .collect()
    }

    #[test]
    fn median_by_hand() {
        assert_eq!(median_in_place(&mut []), None);
        assert_eq!(median_in_place(&mut [3.0]), Some(3.0));
        assert_eq!(median_in_place(&mut [4.0, 1.0, 3.0, 2.0]), Some(2.5));
        assert_eq!(median_in_place(&mut [5.0, 1.0, 9.0, 2.0, 7.0]), Some(5.0));
    }

    #[test]
    fn huber_threshold_by_hand() {
        // Distances 0.1, 0.2, 0.3, 0.4, 5.0: median 0.3, kHu = 2.0138 * 0.3 = 0.60414.
        let p = pairs(&[0.1, 0.2, 0.3, 0.4, 5.0]);
        let mut w = vec![2.0; 5];
        HuberMedian::default().reweight(&p, &mut w, &mut Vec::new());
        assert_eq!(&w[..4], &[2.0; 4]);
        assert!((w[4] - 2.0 * 0.60414 / 5.0).abs() < 1e-12, "{}", w[4]);
    }

    #[test]
    fn no_robust_leaves_weights() {
        let p = pairs(&[0.1, 100.0]);
        let mut w = vec![1.5, 0.5];
        NoRobust.reweight(&p, &mut w, &mut Vec::new());
        assert_eq!(w, vec![1.5, 0.5]);
    }
}
