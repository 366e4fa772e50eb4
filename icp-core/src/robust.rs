//! Robust rejection, Algorithm 1 step 4: a factor on each pair's weight from the whole batch.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::registry::{Family, Kind, NoParams, ParamError, Params, StageKind, StageSpec};

/// Multiplies pair weights by a robust factor computed over all the pairs of an iteration
/// (the batch is needed because thresholds such as the median depend on it).
pub trait RobustKernel: Send + Sync {
    /// What this stage is, as configuration data.
    fn spec(&self) -> StageSpec {
        StageSpec::unregistered::<Self>()
    }

    /// Scales `weights[i]` in place. Per pair, `pair_distance_m[i]` is the distance between its
    /// two points and `residual_m[i]` the metric's residual, both in metres, computed once per
    /// iteration; a NaN residual marks a pair the metric does not use (its weight is already 0,
    /// and it takes no part in batch statistics). `scratch` is a reusable buffer.
    fn reweight(
        &self,
        pair_distance_m: &[f64],
        residual_m: &[f64],
        weights: &mut [f64],
        scratch: &mut Vec<f64>,
    );
}

/// Every registered robust kernel, one line each.
pub static ROBUST_KERNELS: Family<dyn RobustKernel> = Family {
    name: "robust",
    summary: "Alg. 1 step 4: a factor on each pair's weight from the whole batch",
    kinds: &[&NONE, &MEDIAN_SCALED],
};

/// The registered kind of [`NoRobust`].
pub const NONE: Kind<NoParams, dyn RobustKernel> = Kind::new(
    "none",
    "no rejection: weights are left as they are (K_ICP)",
    |_, _| Box::new(NoRobust),
);

/// The registered kind of [`MedianScaled`].
pub const MEDIAN_SCALED: Kind<MedianScaled, dyn RobustKernel> = Kind::new(
    "median_scaled",
    "a kernel with threshold k = c · median distance; Huber with c = 2.0138 is the paper's rejection (Naus & Marchel 2019, Alg. 1 step 4)",
    |p, _| Box::new(p),
);

/// No rejection: weights are left as they are (K_ICP).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct NoRobust;

impl RobustKernel for NoRobust {
    fn spec(&self) -> StageSpec {
        StageSpec::kind(NONE.name())
    }

    fn reweight(&self, _: &[f64], _: &[f64], _: &mut [f64], _: &mut Vec<f64>) {}
}

/// The robust kernels: each maps `u = d / k` (a pair's distance over the threshold) to a
/// factor on the pair's weight.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Kernel {
    /// Huber: 1 for `u ≤ 1`, `1/u` beyond (the paper's rejection).
    Huber,
    /// Tukey's biweight: `(1 − u²)²` for `u < 1`, 0 beyond (hard rejection).
    Tukey,
    /// Cauchy: `1 / (1 + u²)`.
    Cauchy,
    /// Geman-McClure: `1 / (1 + u²)²`.
    #[serde(rename = "geman_mcclure")]
    GemanMcClure,
}

impl Kernel {
    /// The weight factor at `u = d / k ≥ 0`.
    #[inline]
    pub fn factor(self, u: f64) -> f64 {
        match self {
            Kernel::Huber => {
                if u <= 1.0 {
                    1.0
                } else {
                    1.0 / u
                }
            }
            Kernel::Tukey => {
                if u < 1.0 {
                    (1.0 - u * u).powi(2)
                } else {
                    0.0
                }
            }
            Kernel::Cauchy => 1.0 / (1.0 + u * u),
            Kernel::GemanMcClure => 1.0 / (1.0 + u * u).powi(2),
        }
    }

    /// The default `c` of `k = c · median d`: the paper's 2.0138 for Huber; for the others the
    /// usual 95 %-efficiency tuning constants (4.685, 2.3849, 2.0), taking the median pair
    /// distance as the scale.
    pub fn default_c(self) -> f64 {
        match self {
            Kernel::Huber => MedianScaled::PAPER_C,
            Kernel::Tukey => 4.685,
            Kernel::Cauchy => 2.3849,
            Kernel::GemanMcClure => 2.0,
        }
    }
}

/// Which distance of a pair a [`MedianScaled`] kernel is taken over.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum ScaleFrom {
    /// The distance between the pair's two points (the paper's; more robust on real scans,
    /// where a wrong match can lie along a wall with a small normal residual).
    #[default]
    PairDistance,
    /// The metric's residual (the normal distance for point-to-line and plane-to-plane; the
    /// same as the pair distance for point-to-point).
    Residual,
}

/// Robust down-weighting with a median-scaled threshold (Naus & Marchel 2019, Algorithm 1
/// step 4, for Huber): `k = c · median_i d_i` over the distances `d_i` of the iteration's
/// usable pairs (the pair distances, or the metric's residuals: `scale_from`); each pair's
/// weight is multiplied by `kernel.factor(d / k)`. With [`Kernel::Huber`] a pair with `d > k`
/// has its weight multiplied by `k / d`, as in the paper.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(default, deny_unknown_fields)]
pub struct MedianScaled {
    /// The kernel: huber (the paper's), tukey, cauchy or geman_mcclure.
    pub kernel: Kernel,
    /// The factor `c` on the median distance, dimensionless (> 0).
    pub c: f64,
    /// Which distance the median and the factors are taken over.
    pub scale_from: ScaleFrom,
}

impl Default for MedianScaled {
    fn default() -> Self {
        Self::paper_huber()
    }
}

impl Params for MedianScaled {
    fn validate(&self) -> Result<(), ParamError> {
        ParamError::check_positive("c", self.c)
    }
}

impl MedianScaled {
    /// The paper's `c = 2.0138` for Huber.
    pub const PAPER_C: f64 = 2.0138;

    /// The paper's Huber rejection: `c = 2.0138`.
    pub fn paper_huber() -> Self {
        Self {
            kernel: Kernel::Huber,
            c: Self::PAPER_C,
            scale_from: ScaleFrom::PairDistance,
        }
    }
}

impl RobustKernel for MedianScaled {
    fn spec(&self) -> StageSpec {
        StageSpec::of(MEDIAN_SCALED.name(), self)
    }

    fn reweight(
        &self,
        pair_distance_m: &[f64],
        residual_m: &[f64],
        weights: &mut [f64],
        scratch: &mut Vec<f64>,
    ) {
        let dist_m = match self.scale_from {
            ScaleFrom::PairDistance => pair_distance_m,
            ScaleFrom::Residual => residual_m,
        };
        // The distances of the usable pairs (NaN residual: unusable), in order.
        scratch.clear();
        let all_usable = residual_m.iter().all(|r| !r.is_nan());
        if all_usable {
            scratch.extend_from_slice(dist_m);
        } else {
            scratch.extend(
                dist_m
                    .iter()
                    .zip(residual_m)
                    .filter(|(_, r)| !r.is_nan())
                    .map(|(&d, _)| d),
            );
        }
        let Some(median) = median_in_place(scratch) else {
            return;
        };
        let k = self.c * median;
        if k <= 0.0 {
            // More than half of the pairs coincide exactly: keep those, drop the rest.
            for (&d, w) in dist_m.iter().zip(weights.iter_mut()) {
                if d > 0.0 {
                    *w = 0.0;
                }
            }
            return;
        }
        // One loop per kernel, so that the kernel's formula is inlined in it.
        fn scale(
            dist_m: &[f64],
            residual_m: &[f64],
            weights: &mut [f64],
            k: f64,
            factor: impl Fn(f64) -> f64,
        ) {
            for ((&d, r), w) in dist_m.iter().zip(residual_m).zip(weights.iter_mut()) {
                if !r.is_nan() {
                    *w *= factor(d / k);
                }
            }
        }
        let (d, r) = (dist_m, residual_m);
        match self.kernel {
            Kernel::Huber => {
                // Huber's factor is 1 up to the threshold: a pair with d <= k has u = d / k
                // <= 1 (rounding is monotonic), and w * 1 = w, so it is left alone without
                // the division; the others take the factor of u as it is computed.
                for ((&d, r), w) in d.iter().zip(r).zip(weights.iter_mut()) {
                    if (d > k || d.is_nan()) && !r.is_nan() {
                        *w *= Kernel::Huber.factor(d / k);
                    }
                }
            }
            Kernel::Tukey => scale(d, r, weights, k, |u| Kernel::Tukey.factor(u)),
            Kernel::Cauchy => scale(d, r, weights, k, |u| Kernel::Cauchy.factor(u)),
            Kernel::GemanMcClure => scale(d, r, weights, k, |u| Kernel::GemanMcClure.factor(u)),
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
        let p = [0.1, 0.2, 0.3, 0.4, 5.0];
        let mut w = vec![2.0; 5];
        MedianScaled::paper_huber().reweight(&p, &p, &mut w, &mut Vec::new());
        assert_eq!(&w[..4], &[2.0; 4]);
        assert!((w[4] - 2.0 * 0.60414 / 5.0).abs() < 1e-12, "{}", w[4]);
    }

    #[test]
    fn kernels_by_hand() {
        for k in [
            Kernel::Huber,
            Kernel::Tukey,
            Kernel::Cauchy,
            Kernel::GemanMcClure,
        ] {
            assert_eq!(k.factor(0.0), 1.0, "{k:?}");
        }
        assert_eq!(Kernel::Huber.factor(4.0), 0.25);
        assert_eq!(Kernel::Tukey.factor(0.5), 0.5625); // (1 - 0.25)^2
        assert_eq!(Kernel::Tukey.factor(1.0), 0.0);
        assert_eq!(Kernel::Cauchy.factor(2.0), 0.2);
        assert_eq!(Kernel::GemanMcClure.factor(2.0), 0.04);
        // Tukey with c = 4 on distances whose median is 0.3: k = 1.2, so 5.0 is rejected.
        let p = [0.1, 0.2, 0.3, 0.4, 5.0];
        let mut w = vec![1.0; 5];
        MedianScaled {
            kernel: Kernel::Tukey,
            c: 4.0,
            scale_from: ScaleFrom::PairDistance,
        }
        .reweight(&p, &p, &mut w, &mut Vec::new());
        assert_eq!(w[4], 0.0);
        assert!((w[0] - (1.0 - (0.1f64 / 1.2).powi(2)).powi(2)).abs() < 1e-15);
    }

    #[test]
    fn zero_median_keeps_only_the_coincident_pairs() {
        let p = [0.0, 0.0, 0.0, 0.5];
        let mut w = vec![1.0; 4];
        MedianScaled::paper_huber().reweight(&p, &p, &mut w, &mut Vec::new());
        assert_eq!(w, vec![1.0, 1.0, 1.0, 0.0]);
    }

    #[test]
    fn the_scale_is_taken_over_the_chosen_distance_of_usable_pairs() {
        // Pair distances 0.1..0.5 and 9; residuals a tenth of them, the last pair unusable.
        let d = [0.1, 0.2, 0.3, 0.4, 0.5, 9.0];
        let r = [0.01, 0.02, 0.03, 0.04, 0.05, f64::NAN];
        let mut w = vec![1.0, 1.0, 1.0, 1.0, 1.0, 0.0];
        // Over the usable pair distances: median 0.3, k = 0.6; only 9.0 is beyond, and unusable.
        MedianScaled::paper_huber().reweight(&d, &r, &mut w, &mut Vec::new());
        assert_eq!(w, vec![1.0, 1.0, 1.0, 1.0, 1.0, 0.0]);
        // Over the residuals: median 0.03, k = 2 · 0.03 = 0.06 with c = 2; none beyond.
        let huber = MedianScaled {
            c: 2.0,
            scale_from: ScaleFrom::Residual,
            ..MedianScaled::paper_huber()
        };
        let (mut w2, r2) = (vec![1.0; 3], [0.01, 0.02, 0.2]);
        huber.reweight(&[5.0, 5.0, 5.0], &r2, &mut w2, &mut Vec::new());
        // median 0.02, k = 0.04: the third factor is 0.04 / 0.2.
        assert_eq!(&w2[..2], &[1.0, 1.0]);
        assert!((w2[2] - 0.2).abs() < 1e-15, "{}", w2[2]);
    }

    #[test]
    fn no_robust_leaves_weights() {
        let p = [0.1, 100.0];
        let mut w = vec![1.5, 0.5];
        NoRobust.reweight(&p, &p, &mut w, &mut Vec::new());
        assert_eq!(w, vec![1.5, 0.5]);
    }
}
