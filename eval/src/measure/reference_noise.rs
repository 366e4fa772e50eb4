//! How far the reference reaches: its own noise, estimated from the reference alone.
//!
//! # The estimator
//! A measured reference pose is the true pose plus its own error: `x_k = s_k + n_k` per
//! coordinate (x, y, the unwrapped heading). Against smooth motion `s`, an `m`-th order
//! difference removes the motion (exactly for a polynomial of degree below `m`) and keeps the
//! noise: with the divided-difference weights `w_i = 1/Π_{l≠i}(t_i − t_l)` of `m + 1`
//! consecutive poses, the residual `r = Σ w_i x_i / √(Σ w_i²)` has the standard deviation `σ`
//! of independent per-pose noise, whatever the time steps (for equal steps it is
//! `Δᵐx/√C(2m, m)`: `Δ²x/√6`, `Δ³x/√20`). Its robust spread `1.4826 · MAD(r)` (median-centred,
//! so a steady acceleration or turn rate drops out, and robust to the reference's glitches)
//! estimates `σ` from orders 2 and 3; order 3 is reported. One step's displacement then carries the reference's
//! error `n_{k+1} − n_k`, of variance `2σ²` per coordinate: what a perfect estimator shows
//! against it.
//!
//! Noise correlated from pose to pose (lag-1 correlation `ρ`) shrinks the step error to
//! `2σ²(1 − ρ)`; the order-3 estimate `2σ̂²` then reads `1 − ρ/2 + ρ²/10` of it in variance
//! (0.88 in standard deviation at `ρ = 0.5`; order 2 `1 − ρ/3`, 0.91). Order 2 is less biased
//! there but more by motion: at 1 s steps of the synthetic harbour with 0.2° of heading noise,
//! order 2 reads 24 % high and order 3 1 %.
//!
//! # When it is only an upper bound
//! True motion that is not smooth at the step (a hull's yaw in a chop sampled once a second,
//! turns sampled coarsely) adds to the differences, far more to order 2 than to order 3 (a
//! sinusoid of phase step `φ` adds `(2 sin φ/2)ᵐ`, normalised by `√C(2m, m)`). Noise alone
//! gives the two orders the same `σ`. When they differ by more than
//! [`ORDERS_AGREE_RATIO`], the motion dominates: the smaller of the two is reported, as an
//! upper bound of the noise (`upper_bound`), and the disagreement is said.
//!
//! Motion whose accelerations are random at the sampling (a robot turning tens of degrees
//! between scans a second apart) looks like noise to both orders alike. What tells them apart
//! is how the 2nd differences correlate from one step to the next ([`MAX_NOISE_LAG1`]): −2/3
//! for noise, 0 for such motion. Above the threshold the figures are an upper bound too.
//!
//! Ground truth has no noise to estimate (`None`).

use datasets::{Dataset, ReferenceKind};
use icp_core::motion::wrap_deg;
use nalgebra::{Isometry2, Matrix3, Vector2, Vector3};
use serde::{Deserialize, Serialize};

use crate::data::scan_time_s;
use crate::measure::consistency::nees;
use crate::measure::record::PairRecord;
use crate::measure::stats::robust_sd;
use crate::run::covariance::pose_error;

/// Orders 2 and 3 agree when the larger of their estimates is at most this multiple of the
/// smaller: noise dominates both. Chosen on the synthetic harbour (its reference perturbed by
/// known white and correlated noise, where the two orders agree within 5 %, and its 1 s
/// `marina-like` sampling with little noise, where they differ by a factor of 2 or more); see
/// `eval/tests/reference_noise.rs`.
pub const ORDERS_AGREE_RATIO: f64 = 1.25;

impl ReferenceNoise {
    /// The covariance of the reference's error in one step's `t_ref_src` `(x m, y m, θ rad)`:
    /// the translation error isotropic (half its mean square per axis), the rotation's
    /// independent of it. The heading error's lever on the step (step length × heading
    /// error, a few tenths of a millimetre for the logs' steps) is left out.
    pub fn step_covariance(&self) -> Matrix3<f64> {
        let t2 = 0.5 * self.step_trans_m.powi(2);
        Matrix3::from_diagonal(&Vector3::new(
            t2,
            t2,
            self.step_rot_deg.to_radians().powi(2),
        ))
    }

    /// What the reference can resolve, in one line.
    pub fn floor_line(&self) -> String {
        format!(
            "its own error in one step is {}{:.1} mm and {:.3}° (SOG {:.3} m/s, ΔCOG {:.3}°){}: \
             a difference between methods below that is the reference talking",
            if self.upper_bound { "at most " } else { "" },
            1e3 * self.step_trans_m,
            self.step_rot_deg,
            self.sog_mps,
            self.dcog_deg,
            if self.upper_bound {
                " (an upper bound: the motion dominates its differences)"
            } else {
                ""
            }
        )
    }
}

/// The NEES of `row`'s registration against the rigid reference step `truth` under its
/// reported covariance plus the reference's step covariance `reference` (see
/// [`ReferenceNoise::step_covariance`]); `None` without a bounded covariance.
pub fn nees_with_reference(
    row: &PairRecord,
    truth: &Isometry2<f64>,
    reference: &Matrix3<f64>,
) -> Option<f64> {
    let est = Isometry2::new(
        Vector2::new(row.tx_m?, row.ty_m?),
        row.theta_deg?.to_radians(),
    );
    let c = Matrix3::new(
        row.cov_xx_m2?,
        row.cov_xy_m2?,
        row.cov_xt_m_rad?,
        row.cov_xy_m2?,
        row.cov_yy_m2?,
        row.cov_yt_m_rad?,
        row.cov_xt_m_rad?,
        row.cov_yt_m_rad?,
        row.cov_tt_rad2?,
    );
    nees(&pose_error(&est, truth), &(c + reference))
}

/// The 2nd differences of independent per-pose noise correlate −2/3 from one step to the next
/// (`(1, −2, 1)` against itself shifted: −4/6), those of motion with random accelerations 0,
/// of smooth motion more. Above this the motion's share of their variance exceeds a third,
/// and the noise cannot be told from it: the figures are an upper bound. Noise correlated
/// from pose to pose (lag-1 `ρ`) moves the −2/3 to −0.55 at `ρ = 0.5` and −0.52 at `ρ = 0.7`,
/// still below. Chosen from these figures and checked on the synthetic harbour (noise
/// recovered, not flagged; coarse steps flagged), on aces (turns of tens of degrees between
/// scans a second apart: flagged) and marina; see `eval/tests/reference_noise.rs`.
pub const MAX_NOISE_LAG1: f64 = -0.45;

/// Fewest residuals of order 3 (poses − 3) from which a robust spread is taken.
pub const MIN_RESIDUALS: usize = 20;

/// The reference's own noise (summary.json `reference.noise`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ReferenceNoise {
    /// How it was estimated, in words.
    pub method: String,
    /// RMS length of the reference's own error in one step's displacement, m: the translation
    /// error a perfect estimator shows against it.
    pub step_trans_m: f64,
    /// The same for the step's rotation, degrees.
    pub step_rot_deg: f64,
    /// The same in speed over ground (the along-track part of the step error over the step's
    /// median time), m/s.
    pub sog_mps: f64,
    /// The same in the heading change ΔCOG, degrees (the step's rotation error).
    pub dcog_deg: f64,
    /// True when orders 2 and 3 disagree: the motion dominates the differences and the
    /// figures are an upper bound of the noise, not an estimate.
    pub upper_bound: bool,
    /// Why the figures are an upper bound: the orders that disagree, with their figures, and
    /// the 2nd differences that do not correlate like noise (`None` when they are not).
    #[serde(default)]
    pub why_upper_bound: Option<String>,
    /// Per-pose standard deviation per order `[2, 3]`: position (one coordinate), m.
    pub pose_sigma_m: [f64; 2],
    /// The same for the heading, degrees.
    pub pose_sigma_deg: [f64; 2],
    /// The step-to-step correlation of the 2nd differences of x, y and the heading: −2/3 for
    /// noise alone, 0 where random accelerations dominate, positive for smooth motion.
    pub lag1_correlation: [f64; 3],
    /// Reference poses the estimate is taken over.
    pub poses: usize,
}

/// Why the reference's noise could not be estimated.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum ReferenceNoiseError {
    /// Too few poses for a robust spread of third differences.
    #[error(
        "the reference has {poses} poses with distinct times; its noise needs at least {needed}"
    )]
    TooShort {
        /// Usable poses.
        poses: usize,
        /// Poses needed.
        needed: usize,
    },
}

/// One reference pose: time s, position m, heading rad (any sense: only differences count).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TimedPose {
    /// Time, s.
    pub t_s: f64,
    /// Position, m.
    pub x_m: f64,
    /// See `x_m`.
    pub y_m: f64,
    /// Heading, radians.
    pub heading_rad: f64,
}

/// The noise of `ds`'s reference over all its poses: `None` without a reference or for
/// ground truth, which has none.
pub fn of_dataset(ds: &Dataset) -> Option<Result<ReferenceNoise, ReferenceNoiseError>> {
    let reference = ds.reference.as_ref()?;
    if ds.reference_kind == Some(ReferenceKind::GroundTruth) {
        return None;
    }
    let poses: Vec<TimedPose> = reference
        .iter()
        .enumerate()
        .map(|(k, p)| TimedPose {
            t_s: scan_time_s(ds, k),
            x_m: p.x_m,
            y_m: p.y_m,
            heading_rad: p.heading_rad,
        })
        .collect();
    Some(estimate(&poses))
}

/// The noise of the reference `poses` (in time order; poses with a non-finite value or a time
/// not after the one before are left out).
pub fn estimate(poses: &[TimedPose]) -> Result<ReferenceNoise, ReferenceNoiseError> {
    let mut kept: Vec<TimedPose> = Vec::with_capacity(poses.len());
    for p in poses {
        let finite = [p.t_s, p.x_m, p.y_m, p.heading_rad]
            .iter()
            .all(|v| v.is_finite());
        if finite && kept.last().is_none_or(|q| p.t_s > q.t_s) {
            kept.push(*p);
        }
    }
    let needed = MIN_RESIDUALS + 3;
    if kept.len() < needed {
        return Err(ReferenceNoiseError::TooShort {
            poses: kept.len(),
            needed,
        });
    }
    let t: Vec<f64> = kept.iter().map(|p| p.t_s).collect();
    let x: Vec<f64> = kept.iter().map(|p| p.x_m).collect();
    let y: Vec<f64> = kept.iter().map(|p| p.y_m).collect();
    // The heading unwrapped through its wrapped successive changes.
    let mut heading_deg = Vec::with_capacity(kept.len());
    let mut h = kept[0].heading_rad.to_degrees();
    heading_deg.push(h);
    for w in kept.windows(2) {
        h += wrap_deg((w[1].heading_rad - w[0].heading_rad).to_degrees());
        heading_deg.push(h);
    }
    let sigma = |v: &[f64], order: usize| robust_sd(&residuals(&t, v, order));
    // One coordinate's position sigma: the two coordinates pooled in variance.
    let pos = |order: usize| (0.5 * (sigma(&x, order).powi(2) + sigma(&y, order).powi(2))).sqrt();
    let pose_sigma_m = [pos(2), pos(3)];
    let pose_sigma_deg = [sigma(&heading_deg, 2), sigma(&heading_deg, 3)];
    let disagree = |name: &str, unit: &str, v: [f64; 2]| {
        let (lo, hi) = (v[0].min(v[1]), v[0].max(v[1]));
        (hi > ORDERS_AGREE_RATIO * lo).then(|| {
            format!(
                "{name}: order 2 gives {:.4} {unit}, order 3 {:.4} {unit} per pose",
                v[0], v[1]
            )
        })
    };
    let lag1 = [&x, &y, &heading_deg].map(|v| lag1_correlation(&residuals(&t, v, 2)));
    let moving = ["x", "y", "heading"]
        .iter()
        .zip(lag1)
        // NaN (no spread) cannot show noise either.
        .filter(|(_, c)| c.is_nan() || *c > MAX_NOISE_LAG1)
        .map(|(name, c)| format!("{name}: 2nd differences correlate {c:.2} from step to step"))
        .collect::<Vec<String>>();
    let notes: Vec<String> = [
        disagree("position", "m", pose_sigma_m),
        disagree("heading", "deg", pose_sigma_deg),
    ]
    .into_iter()
    .flatten()
    .chain(moving)
    .collect();
    // Order 3 where the orders agree (less biased by motion), else the smaller.
    let pick = |v: [f64; 2]| {
        if notes.is_empty() {
            v[1]
        } else {
            v[0].min(v[1])
        }
    };
    let (sp, sh) = (pick(pose_sigma_m), pick(pose_sigma_deg));
    let mut dts: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
    let dt_s = icp_core::robust::median_in_place(&mut dts).unwrap_or(f64::NAN);
    let step_rot_deg = std::f64::consts::SQRT_2 * sh;
    Ok(ReferenceNoise {
        method: "robust (1.4826 MAD) 2nd and 3rd divided differences of the reference's \
                 positions and heading, independent per-pose noise against smooth motion"
            .to_owned(),
        // Two coordinates, each step error of variance 2σ².
        step_trans_m: 2.0 * sp,
        step_rot_deg,
        // The along-track coordinate alone.
        sog_mps: std::f64::consts::SQRT_2 * sp / dt_s,
        dcog_deg: step_rot_deg,
        upper_bound: !notes.is_empty(),
        why_upper_bound: (!notes.is_empty()).then(|| notes.join("; ")),
        pose_sigma_m,
        pose_sigma_deg,
        lag1_correlation: lag1,
        poses: kept.len(),
    })
}

/// The normalised divided differences of `order` of `v` at times `t` (one per window of
/// `order + 1` consecutive values): each has the standard deviation of independent noise on
/// `v`, and is 0 for a polynomial of degree below `order`.
fn residuals(t: &[f64], v: &[f64], order: usize) -> Vec<f64> {
    (0..v.len().saturating_sub(order))
        .map(|j| {
            let (mut sum, mut norm2) = (0.0, 0.0);
            for i in j..=j + order {
                let w = 1.0
                    / (j..=j + order)
                        .filter(|&l| l != i)
                        .map(|l| t[i] - t[l])
                        .product::<f64>();
                sum += w * v[i];
                norm2 += w * w;
            }
            sum / norm2.sqrt()
        })
        .filter(|r| r.is_finite())
        .collect()
}

/// The robust step-to-step correlation of `r`: `(s₊² − s₋²)/(s₊² + s₋²)` with `s±` the robust
/// spread of `r_k ± r_{k+1}` (NaN with fewer than two values).
fn lag1_correlation(r: &[f64]) -> f64 {
    let (plus, minus): (Vec<f64>, Vec<f64>) =
        r.windows(2).map(|w| (w[0] + w[1], w[0] - w[1])).unzip();
    let (p2, m2) = (robust_sd(&plus).powi(2), robust_sd(&minus).powi(2));
    (p2 - m2) / (p2 + m2)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn divided_differences_match_the_binomial_form_and_cancel_polynomials() {
        let t: Vec<f64> = (0..6).map(|k| 0.5 * k as f64).collect();
        // A quadratic leaves nothing at order 3, a line nothing at order 2.
        let quad: Vec<f64> = t.iter().map(|s| 1.0 + 2.0 * s - 0.7 * s * s).collect();
        assert!(residuals(&t, &quad, 3).iter().all(|r| r.abs() < 1e-12));
        let line: Vec<f64> = t.iter().map(|s| 3.0 - s).collect();
        assert!(residuals(&t, &line, 2).iter().all(|r| r.abs() < 1e-12));
        // Equal steps: (x0 − 2x1 + x2)/√6 and (−x0 + 3x1 − 3x2 + x3)/√20 (sign aside).
        let v = [1.0, 4.0, 2.0, 8.0, 0.0, 0.0];
        let r2 = residuals(&t, &v, 2);
        assert!((r2[0].abs() - (1.0 - 8.0 + 2.0f64).abs() / 6f64.sqrt()).abs() < 1e-12);
        let r3 = residuals(&t, &v, 3);
        assert!((r3[0].abs() - (-1.0 + 12.0 - 6.0 + 8.0f64).abs() / 20f64.sqrt()).abs() < 1e-12);
    }

    #[test]
    fn alternating_values_correlate_minus_one() {
        let r: Vec<f64> = (0..21)
            .map(|k| if k % 2 == 0 { 1.0 } else { -1.0 })
            .collect();
        assert_eq!(lag1_correlation(&r), -1.0);
        let same = vec![2.0; 10];
        assert!(
            lag1_correlation(&same).is_nan(),
            "no spread: no correlation"
        );
    }

    #[test]
    fn too_short_a_reference_is_an_error() {
        let poses: Vec<TimedPose> = (0..10)
            .map(|k| TimedPose {
                t_s: k as f64,
                x_m: k as f64,
                y_m: 0.0,
                heading_rad: 0.0,
            })
            .collect();
        assert_eq!(
            estimate(&poses),
            Err(ReferenceNoiseError::TooShort {
                poses: 10,
                needed: MIN_RESIDUALS + 3
            })
        );
    }
}
