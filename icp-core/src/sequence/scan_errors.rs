//! What a scan shares with every registration that uses it.
//!
//! A registration's error is not its own alone: a scan's range noise, its motion distortion and
//! whatever moved in it shift every registration that uses the scan (the consecutive ones before
//! and after it and those across lags) nearly alike. Taken as independent, the registrations
//! across lags confirm the error they share, so the fused motion's σ is too small and the prior
//! smooths too little; and the two consecutive registrations of a scan, which see its error with
//! opposite signs, cancel along the track where the smoother adds them up, so its σ is too
//! large there. Measured before this model (`docs/sequence.md`): smoothing lags 1–3 gave a worse
//! SOG RMSE than lag 1 alone on the rough harbour (GICP 0.060 against 0.047 m/s) with ANEES/3
//! 1.54, and lag 1 alone gave ANEES/3 0.14 on the paper harbour.
//!
//! **The model.** Each scan k has an error `e_k` (`x m, y m, θ rad`, added to its pose where its
//! registrations see it: [`super::system::Model::add_reg`]), zero-mean with covariance `S_k`;
//! a registration `i → j` is predicted between `T_i + e_i` and `T_j + e_j` and keeps an
//! independent part `N_ij` of its own. Its covariance as given, `Σ_ij`, is split by a share ρ:
//! `N_ij = (1 − ρ) Σ_ij`, and `S_k = ρ/2 ×` the harmonic mean of the covariances (turned into
//! the world frame by the start's headings) of the registrations of the shortest lag that use
//! scan k, so that a consecutive registration's whole covariance stays about `Σ`. Harmonic
//! (the inverse of the mean information), because a scan's error is bounded by its best
//! registration's covariance (`S_i + S_j + N_ij = Σ_ij`): the arithmetic mean let one
//! registration that may have slid along a corridor (a wide ambiguity term) widen its scans'
//! errors, which loosened every other registration of those scans; on the aces log the fused
//! steps then left 17–41 ok registrations per estimator outside their covariance
//! (`contradicted`), against 2–13 with the harmonic mean.
//!
//! **The share, from the loops the registrations close** (no truth). A registration across a lag
//! and the chain of consecutive registrations over its span see the same two end scans, whose
//! errors cancel in their difference, as do the inner scans' (once in, once out, within the
//! chain): the difference carries the independent parts alone. Its NEES under the covariance
//! independence predicts (the chain's and the registration's, summed) is then `(1 − ρ) χ²₃`, so
//! `ρ = 1 − median(NEES) / median(χ²₃)`: the median, because the flags miss some wrong
//! registrations and a mean would follow them. Measured on the loops of the runs of
//! `docs/sequence.md` (cycles.csv, lags 2 and 3): `1 − ρ` ≈ 0.06 on the paper harbour, 0.15–0.30
//! on the rough one, 0.02–0.09 on marina: most of a registration's error is its scans'.

use nalgebra::{Cholesky, Matrix3};

use super::factors;
use super::system::Reg;
use super::Geometry;

/// The median of χ²₃.
const CHI2_3_MEDIAN: f64 = 2.365_973_884_375_338;

/// Loops needed to estimate the share: below, the median's own spread (about ±25 % at 20) is as
/// large as what it measures, and the registrations are taken as independent.
const MIN_LOOPS: usize = 20;

/// The largest share: each registration keeps at least a twentieth of its covariance as its
/// own, so its factor's information stays within 20× the given one and the normal equations
/// well conditioned. Set by that bound, not fitted to data; it binds on the paper harbour and
/// marina (the smoother reports 0.95 there; cycles.csv's loops put 1 − ρ at 0.06 and 0.02–0.09).
pub const MAX_SHARE: f64 = 0.95;

/// How the registrations' errors are modelled.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ScanErrors {
    /// Independent: no scan errors (the smoother as it was before them).
    Independent,
    /// A given share ρ in `[0, MAX_SHARE]` of each registration's covariance is its scans'.
    Share(f64),
    /// The share estimated from the loops the registrations close (the default).
    Estimate,
}

/// The share of the registrations' covariance given to their scans' errors, and the loops it
/// was estimated from (0 when given or when too few loops: then it is 0).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScanShare {
    pub share: f64,
    pub loops: usize,
}

/// The share as `how` says, from `regs`' loops where it is estimated.
pub(crate) fn share(geometry: Geometry, regs: &[Reg], how: ScanErrors) -> ScanShare {
    match how {
        ScanErrors::Independent => ScanShare {
            share: 0.0,
            loops: 0,
        },
        ScanErrors::Share(share) => ScanShare { share, loops: 0 },
        ScanErrors::Estimate => estimate(geometry, regs),
    }
}

/// The share from the loops of `regs`: every registration across a lag whose steps each have a
/// consecutive registration.
fn estimate(geometry: Geometry, regs: &[Reg]) -> ScanShare {
    let last = regs.iter().map(|r| r.reference).max().unwrap_or(0);
    let mut consecutive = vec![None; last + 1];
    for r in regs.iter().filter(|r| r.reference == r.source + 1) {
        consecutive[r.source] = Some(r);
    }
    let mut nees: Vec<f64> = regs
        .iter()
        .filter(|r| r.reference > r.source + 1)
        .filter_map(|r| {
            let mut chain = consecutive[r.source]?;
            let (mut z, mut cov) = (chain.z, chain.cov);
            for next in &consecutive[r.source + 1..r.reference] {
                chain = (*next)?;
                let (next, j_outer, j_inner) = factors::compose(geometry, &chain.z, &z);
                cov =
                    j_inner * cov * j_inner.transpose() + j_outer * chain.cov * j_outer.transpose();
                z = next;
            }
            let d = factors::pose_minus(geometry, &z, &r.z);
            let info = Cholesky::new(cov + r.cov)?.inverse();
            Some(d.dot(&(info * d)))
        })
        .filter(|v| v.is_finite())
        .collect();
    let loops = nees.len();
    if loops < MIN_LOOPS {
        return ScanShare { share: 0.0, loops };
    }
    nees.sort_by(f64::total_cmp);
    let median = if loops % 2 == 1 {
        nees[loops / 2]
    } else {
        0.5 * (nees[loops / 2 - 1] + nees[loops / 2])
    };
    ScanShare {
        share: (1.0 - median / CHI2_3_MEDIAN).clamp(0.0, MAX_SHARE),
        loops,
    }
}

/// The registrations as the model weighs them under `share`: by their own part,
/// `N = (1 − ρ) Σ`.
pub(crate) fn own_parts(regs: &[Reg], share: f64) -> Vec<Reg> {
    regs.iter()
        .map(|r| Reg {
            info: r.info / (1.0 - share),
            ..*r
        })
        .collect()
}

/// The information of each of the `n` scans' errors under `share` (> 0), in the world frame of
/// the poses whose headings are `headings_rad`: `S_k = ρ/2 ×` the harmonic mean of the
/// covariances of the registrations of the shortest lag that use scan k (each turned by its
/// reference's heading), or, for a scan no registration uses, of every scan's.
pub(crate) fn information(
    geometry: Geometry,
    regs: &[Reg],
    headings_rad: &[f64],
    share: f64,
) -> Vec<Matrix3<f64>> {
    let n = headings_rad.len();
    let mut shortest = vec![usize::MAX; n];
    for r in regs {
        let lag = r.reference - r.source;
        for k in [r.source, r.reference] {
            shortest[k] = shortest[k].min(lag);
        }
    }
    // Σ⁻¹ summed per scan; the harmonic mean's inverse is their mean.
    let mut sum = vec![Matrix3::zeros(); n];
    let mut count = vec![0usize; n];
    for r in regs {
        let lag = r.reference - r.source;
        let world = to_world(geometry, &r.info, headings_rad[r.reference]);
        for k in [r.source, r.reference] {
            if lag == shortest[k] {
                sum[k] += world;
                count[k] += 1;
            }
        }
    }
    let mean = |k: usize| sum[k] / count[k] as f64;
    let used: Vec<usize> = (0..n).filter(|&k| count[k] > 0).collect();
    let all = used.iter().map(|&k| mean(k)).sum::<Matrix3<f64>>() / used.len().max(1) as f64;
    (0..n)
        .map(|k| {
            let info = if count[k] > 0 { mean(k) } else { all };
            (info + info.transpose()) * (1.0 / share)
        })
        .collect()
}

/// A covariance (or information) of `(x, y, θ)` in a frame whose heading is `heading_rad`, in
/// the world's.
fn to_world(geometry: Geometry, cov: &Matrix3<f64>, heading_rad: f64) -> Matrix3<f64> {
    match geometry {
        Geometry::Se2 => {
            let (s, c) = heading_rad.sin_cos();
            let g = Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0);
            g * cov * g.transpose()
        }
        Geometry::Linear => *cov,
    }
}
