//! Whether the registrations' covariances are honest (the modes they come from are
//! `run::covariance`'s): NEES per
//! pair where the reference is a rigid pose, ANEES and its χ² bounds per variant, and the
//! standardised SOG and ΔCOG errors where the reference gives only the movement parameters.
//!
//! # NEES and ANEES
//! For a pair with estimate `ĝ = (tx, ty, θ)`, truth `g` and covariance `C`, the normalised
//! estimation error squared is `ε = (ĝ − g)ᵀ C⁻¹ (ĝ − g)` (θ difference wrapped). If `C` is the
//! true covariance of a Gaussian error, `ε ~ χ²(3)`: 95 % of pairs fall in
//! `[χ²₃(0.025), χ²₃(0.975)] = [0.216, 9.348]`, and the mean over `N` independent pairs (ANEES)
//! has `N·ANEES ~ χ²(3N)`, so its 95 % interval is `[χ²₃ₙ(0.025), χ²₃ₙ(0.975)]/N` (Bar-Shalom,
//! Li & Kirubarajan 2001, §5.4). The quantiles are computed ([`chi2_quantile`]), not tabled.
//!
//! # SOG-only references
//! Where the reference is not a pose (marina: GNSS speed and course), the standardised error
//! `z = e/σ` of SOG and ΔCOG is reported: its spread (1 if `σ` is honest) and the fraction with
//! `|z| ≤ 2` (95.4 % for a Gaussian). The reference is noisy itself, so `e` carries its noise
//! too: its own standard error (`reference.noise`, the `reference_noise` module) is added,
//! `z = e/√(σ² + σ_ref²)`, beside the raw one; the NEES gets the same twin where the
//! reference is a measured rigid pose, and a twin over the pairs whose status is `ok` alone.

use icp_core::{Covariance, MovementSigmas, Registration};
use nalgebra::{Isometry2, Matrix3, Vector3};
use serde::{Deserialize, Serialize};

use crate::measure::record::PairRecord;
use crate::run::covariance::{pose_error, CovarianceMode};
use crate::run::extended;

/// The NEES `eᵀ C⁻¹ e` of the error `e` under `cov`; `None` when `cov` is not positive
/// definite (a Cholesky factor does not exist) or the result is not finite.
pub fn nees(error: &Vector3<f64>, cov: &Matrix3<f64>) -> Option<f64> {
    let chol = cov.cholesky()?;
    let v = error.dot(&chol.solve(error));
    v.is_finite().then_some(v)
}

/// The regularised lower incomplete gamma function `P(a, x)` (series below `a + 1`, Lentz's
/// continued fraction above; Numerical Recipes §6.2), for `a > 0`, `x ≥ 0`.
fn gamma_p(a: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 0.0;
    }
    let log_prefix = a * x.ln() - x - ln_gamma(a);
    if x < a + 1.0 {
        let (mut term, mut sum, mut ap) = (1.0 / a, 1.0 / a, a);
        for _ in 0..10_000 {
            ap += 1.0;
            term *= x / ap;
            sum += term;
            if term.abs() < sum.abs() * 1e-16 {
                break;
            }
        }
        sum * log_prefix.exp()
    } else {
        let tiny = 1e-300;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / tiny;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..10_000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < tiny {
                d = tiny;
            }
            c = b + an / c;
            if c.abs() < tiny {
                c = tiny;
            }
            d = 1.0 / d;
            let delta = d * c;
            h *= delta;
            if (delta - 1.0).abs() < 1e-16 {
                break;
            }
        }
        1.0 - log_prefix.exp() * h
    }
}

/// `ln Γ(x)`, `x > 0` (Lanczos, g = 7, 9 terms: ~1e-15 relative).
fn ln_gamma(x: f64) -> f64 {
    const G: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    let x = x - 1.0;
    let t = x + 7.5;
    let sum = G[1..]
        .iter()
        .enumerate()
        .fold(G[0], |s, (i, g)| s + g / (x + 1.0 + i as f64));
    0.5 * std::f64::consts::TAU.ln() + (x + 0.5) * t.ln() - t + sum.ln()
}

/// The CDF of χ²(`dof`) at `x`: `P(dof/2, x/2)`.
pub fn chi2_cdf(dof: f64, x: f64) -> f64 {
    gamma_p(dof / 2.0, x / 2.0)
}

/// The `p` quantile of χ²(`dof`): the `x` with `P(dof/2, x/2) = p`, by bisection to
/// 1e-12 relative. `dof > 0`, `p` in (0, 1).
pub fn chi2_quantile(dof: f64, p: f64) -> f64 {
    let cdf = |x: f64| chi2_cdf(dof, x);
    let (mut lo, mut hi) = (0.0, dof.max(1.0));
    while cdf(hi) < p {
        hi *= 2.0;
    }
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if cdf(mid) < p {
            lo = mid;
        } else {
            hi = mid;
        }
        if hi - lo <= 1e-12 * hi {
            break;
        }
    }
    0.5 * (lo + hi)
}

/// The two-sided 95 % interval of χ²(`dof`).
pub fn chi2_interval_95(dof: f64) -> [f64; 2] {
    [chi2_quantile(dof, 0.025), chi2_quantile(dof, 0.975)]
}

/// A variant's consistency figures over the pairs with a NEES.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Consistency {
    /// Pairs with a NEES (registered by every variant, a rigid reference pose, a bounded
    /// covariance).
    pub pairs: usize,
    /// Pairs whose covariance is unbounded (no NEES; counted apart).
    pub unbounded_pairs: usize,
    /// Mean NEES over the pairs.
    pub anees: f64,
    /// ANEES / 3: 1 for an honest covariance, above 1 over-confident.
    pub anees_per_dof: f64,
    /// The 95 % interval of ANEES for that many pairs, `[χ²₃ₙ(0.025), χ²₃ₙ(0.975)]/N`.
    pub anees_bounds_95: [f64; 2],
    /// The two-sided 95 % interval of χ²(3) each pair's NEES is checked against.
    pub nees_interval_95: [f64; 2],
    /// Fraction of the pairs whose NEES is inside it (0.95 for an honest covariance).
    pub inside_95_fraction: f64,
}

impl Consistency {
    /// The figures of the NEES values `nees`, `unbounded` pairs apart; `None` without any.
    pub fn of(nees: &[f64], unbounded: usize) -> Option<Self> {
        if nees.is_empty() {
            return None;
        }
        let n = nees.len() as f64;
        let anees = nees.iter().sum::<f64>() / n;
        let [lo, hi] = chi2_interval_95(3.0 * n);
        let interval = chi2_interval_95(3.0);
        let inside = nees
            .iter()
            .filter(|&&e| e >= interval[0] && e <= interval[1])
            .count();
        Some(Self {
            pairs: nees.len(),
            unbounded_pairs: unbounded,
            anees,
            anees_per_dof: anees / 3.0,
            anees_bounds_95: [lo / n, hi / n],
            nees_interval_95: interval,
            inside_95_fraction: inside as f64 / n,
        })
    }
}

/// Standardised errors `z = e/σ` of one movement parameter.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Standardised {
    /// Pairs counted.
    pub pairs: usize,
    /// Mean of `z` (0 when unbiased).
    pub mean: f64,
    /// Standard deviation of `z` (1 when `σ` is honest).
    pub sd: f64,
    /// `1.4826 · MAD(z)`: the spread without the tails (1 when `σ` is honest).
    pub mad_sd: f64,
    /// Fraction with `|z| ≤ 2` (0.954 for a Gaussian).
    pub within_2sigma_fraction: f64,
}

impl Standardised {
    /// The figures of `z`; `None` when empty.
    pub fn of(z: &[f64]) -> Option<Self> {
        if z.is_empty() {
            return None;
        }
        let n = z.len() as f64;
        let mean = z.iter().sum::<f64>() / n;
        let sd = if z.len() > 1 {
            (z.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt()
        } else {
            0.0
        };
        Some(Self {
            pairs: z.len(),
            mean,
            sd,
            mad_sd: crate::measure::stats::robust_sd(z),
            within_2sigma_fraction: z.iter().filter(|v| v.abs() <= 2.0).count() as f64 / n,
        })
    }
}

/// The reference's own noise in the movement parameters (SOG, ΔCOG) that the z-scores'
/// twins add: the part of the reference's one noise estimate
/// (`reference_noise::ReferenceNoise`, `reference.noise`) they use.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct MovementNoise {
    /// SOG, m/s.
    pub sog_mps: f64,
    /// ΔCOG, degrees.
    pub dcog_deg: f64,
}

/// What the consistency section of a variant's summary holds.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ConsistencySummary {
    /// Where the covariances came from.
    pub mode: CovarianceMode,
    /// The inflation applied to the closed form ([`crate::run::covariance::closed_form_inflation`]; 1 for sampled).
    pub inflation: f64,
    /// NEES figures, where the reference is a rigid pose.
    #[serde(default)]
    pub nees: Option<Consistency>,
    /// The same with the reference's step covariance added to each pair's, where the
    /// reference is a measured rigid pose.
    #[serde(default)]
    pub nees_with_reference_noise: Option<Consistency>,
    /// `nees` over the pairs whose status is `ok` alone: how the pairs nothing flagged fare.
    #[serde(default)]
    pub nees_unflagged: Option<Consistency>,
    /// SOG errors over their standard errors (pairs with a plausible reference).
    #[serde(default)]
    pub sog_z: Option<Standardised>,
    /// The same with the reference's noise added to `σ` (see [`MovementNoise`]).
    #[serde(default)]
    pub sog_z_with_reference_noise: Option<Standardised>,
    /// ΔCOG errors over their standard errors.
    #[serde(default)]
    pub dcog_z: Option<Standardised>,
    /// The same with the reference's noise added.
    #[serde(default)]
    pub dcog_z_with_reference_noise: Option<Standardised>,
    /// The reference's own noise, as estimated.
    #[serde(default)]
    pub reference_noise: Option<MovementNoise>,
}

/// Fills `row`'s covariance cells, movement-parameter standard errors and NEES from the
/// registration `reg` (its `covariance`, as [`crate::run::extended::of_registration`] gives it for `mode`) and the true `t_ref_src`
/// `truth`, where known, plus `motion` (the extended modes' term for the motion within a
/// sweep, [`crate::run::motion`]) when given. Nothing with [`CovarianceMode::Off`]; an
/// unbounded covariance leaves the cells empty and says `unbounded` (never a NaN).
pub fn fill(
    row: &mut PairRecord,
    reg: Option<&Registration>,
    truth: Option<Isometry2<f64>>,
    mode: CovarianceMode,
    inflation: f64,
    motion: Option<&Matrix3<f64>>,
) {
    if mode == CovarianceMode::Off {
        return;
    }
    let Some((reg, cov)) =
        reg.and_then(|r| Some((r, extended::of_registration(r, mode, inflation)?)))
    else {
        return;
    };
    let c = match cov {
        Covariance::Unbounded { .. } => {
            row.cov_status = "unbounded".to_owned();
            return;
        }
        Covariance::Bounded(c) => motion.map_or(c, |m| c + m),
    };
    row.cov_status = "bounded".to_owned();
    row.cov_xx_m2 = Some(c[(0, 0)]);
    row.cov_xy_m2 = Some(c[(0, 1)]);
    row.cov_xt_m_rad = Some(c[(0, 2)]);
    row.cov_yy_m2 = Some(c[(1, 1)]);
    row.cov_yt_m_rad = Some(c[(1, 2)]);
    row.cov_tt_rad2 = Some(c[(2, 2)]);
    if let Ok(s) = MovementSigmas::propagate(&reg.t_ref_src, &c, row.dt_s) {
        row.sog_sigma_mps = Some(s.sog_mps);
        row.dcog_sigma_deg = Some(s.dcog_deg);
        row.rot_sigma_dps = Some(s.rot_dps);
    }
    row.nees = truth.and_then(|t| nees(&pose_error(&reg.t_ref_src, &t), &c));
}

/// A variant's consistency figures over its `rows` registered by every variant (the pairs
/// the other statistics take); `None` with [`CovarianceMode::Off`].
pub fn summarize(
    rows: &[PairRecord],
    mode: CovarianceMode,
    inflation: f64,
    reference: Option<MovementNoise>,
) -> Option<ConsistencySummary> {
    if mode == CovarianceMode::Off {
        return None;
    }
    let common: Vec<&PairRecord> = rows.iter().filter(|r| r.all_registered).collect();
    let nees: Vec<f64> = common.iter().filter_map(|r| r.nees).collect();
    let unbounded = common
        .iter()
        .filter(|r| r.cov_status == "unbounded")
        .count();
    let plausible = || common.iter().filter(|r| r.ref_plausible);
    let z = |err: fn(&PairRecord) -> Option<f64>,
             sigma: fn(&PairRecord) -> Option<f64>,
             extra: Option<f64>| {
        let v: Vec<f64> = plausible()
            .filter_map(|r| {
                let s = sigma(r)?;
                let s = extra.map_or(s, |e| s.hypot(e));
                (s > 0.0).then_some(err(r)? / s)
            })
            .collect();
        Standardised::of(&v)
    };
    Some(ConsistencySummary {
        mode,
        inflation: if matches!(
            mode,
            CovarianceMode::ClosedForm | CovarianceMode::Extended | CovarianceMode::Restarts
        ) {
            inflation
        } else {
            1.0
        },
        nees: Consistency::of(&nees, unbounded),
        nees_with_reference_noise: Consistency::of(
            &common
                .iter()
                .filter_map(|r| r.nees_with_reference_noise)
                .collect::<Vec<f64>>(),
            unbounded,
        ),
        nees_unflagged: Consistency::of(
            &common
                .iter()
                .filter(|r| r.status == crate::run::status::StatusKind::Ok)
                .filter_map(|r| r.nees)
                .collect::<Vec<f64>>(),
            common
                .iter()
                .filter(|r| r.status == crate::run::status::StatusKind::Ok)
                .filter(|r| r.cov_status == "unbounded")
                .count(),
        ),
        sog_z: z(|r| r.sog_err_mps, |r| r.sog_sigma_mps, None),
        sog_z_with_reference_noise: reference
            .and_then(|n| z(|r| r.sog_err_mps, |r| r.sog_sigma_mps, Some(n.sog_mps))),
        dcog_z: z(|r| r.dcog_err_deg, |r| r.dcog_sigma_deg, None),
        dcog_z_with_reference_noise: reference
            .and_then(|n| z(|r| r.dcog_err_deg, |r| r.dcog_sigma_deg, Some(n.dcog_deg))),
        reference_noise: reference,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chi2_quantiles_match_the_tables() {
        // Published values (Abramowitz & Stegun, Table 26.8).
        let [lo, hi] = chi2_interval_95(3.0);
        assert!((lo - 0.2158).abs() < 1e-4, "{lo}");
        assert!((hi - 9.3484).abs() < 1e-4, "{hi}");
        assert!((chi2_quantile(1.0, 0.95) - 3.8415).abs() < 1e-4);
        assert!((chi2_quantile(100.0, 0.975) - 129.561).abs() < 1e-3);
        assert!((chi2_quantile(100.0, 0.025) - 74.222).abs() < 1e-3);
        // ANEES bounds for 50 pairs narrow around 3.
        let [a, b] = chi2_interval_95(150.0);
        assert!(a / 50.0 > 2.3 && b / 50.0 < 3.8, "{a} {b}");
    }

    #[test]
    fn nees_of_a_hand_computed_case() {
        // C = diag(4e-4, 1e-4, 1e-6), e = (0.02, -0.01, 0.001):
        // 0.02²/4e-4 + 0.01²/1e-4 + 0.001²/1e-6 = 1 + 1 + 1 = 3.
        let cov = Matrix3::from_diagonal(&Vector3::new(4e-4, 1e-4, 1e-6));
        let e = Vector3::new(0.02, -0.01, 0.001);
        assert!((nees(&e, &cov).unwrap() - 3.0).abs() < 1e-12);
        // With a correlation: C = [[2, 1], [1, 2]] on (x, y), e = (1, 1, 0):
        // C⁻¹ = [[2, −1], [−1, 2]]/3, eᵀC⁻¹e = (2 − 1 − 1 + 2)/3 = 2/3.
        let cov = Matrix3::new(2.0, 1.0, 0.0, 1.0, 2.0, 0.0, 0.0, 0.0, 1.0);
        let e = Vector3::new(1.0, 1.0, 0.0);
        assert!((nees(&e, &cov).unwrap() - 2.0 / 3.0).abs() < 1e-12);
        // A singular covariance has no NEES (never NaN or infinity).
        let singular = Matrix3::from_diagonal(&Vector3::new(1.0, 0.0, 1.0));
        assert_eq!(nees(&e, &singular), None);
        // Consistency of [0.1, 3, 12] (one outside [0.216, 9.348] on each side).
        let c = Consistency::of(&[0.1, 3.0, 12.0], 2).unwrap();
        // (0.1 + 3 + 12)/3 = 15.1/3.
        assert!((c.anees - 15.1 / 3.0).abs() < 1e-12);
        assert!((c.anees_per_dof - 15.1 / 9.0).abs() < 1e-12);
        assert!((c.inside_95_fraction - 1.0 / 3.0).abs() < 1e-12);
        assert_eq!(c.unbounded_pairs, 2);
        assert_eq!(Consistency::of(&[], 1), None);
        // A pose error wraps its angle.
        let a = Isometry2::new(nalgebra::Vector2::new(1.0, 2.0), 3.1);
        let b = Isometry2::new(nalgebra::Vector2::new(0.5, 2.0), -3.1);
        let e = pose_error(&a, &b);
        assert!((e.x - 0.5).abs() < 1e-12 && (e.z - (6.2 - std::f64::consts::TAU)).abs() < 1e-12);
    }

    #[test]
    fn standardised_by_hand() {
        let z = Standardised::of(&[-3.0, -1.0, 0.0, 1.0, 3.0]).unwrap();
        assert_eq!(z.mean, 0.0);
        assert!((z.sd - 5f64.sqrt()).abs() < 1e-12);
        assert!((z.within_2sigma_fraction - 0.6).abs() < 1e-12);
        // |z − 0| = 3, 1, 0, 1, 3: median 1.
        assert!((z.mad_sd - 1.4826).abs() < 1e-12);
    }
}
