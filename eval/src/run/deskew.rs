//! `--sequence deskew` (issue 35, item 5): a variant's registrations made again on scans whose
//! motion distortion the batch smoother's twists take out, for the estimator `V+deskew`.
//!
//! After the batch smoother of a variant, every scan of the run is deskewed with that scan's
//! smoothed body twist ([`icp_core::deskew`]): each return moved to where the scanner saw it
//! from at the scan's time. Every pair the variant registered (consecutive and across lags)
//! is registered once more on the deskewed scans, from its first result and without the
//! returns its detector of moving returns left out (`run::moving`), and the sequence module
//! smooths those registrations again in batch. A pair the variant flagged keeps its flag
//! whatever the second registration gives; an ok pair takes the second registration's own
//! verdict ([`PairStatus::of`], with the first's global check and ambiguity: it starts in the
//! first's basin).
//!
//! # When each return was taken
//! The datasets state a sweep only as `sweep_s` (`datasets::Dataset::sweep_s`). The synthetic
//! scanners (`datasets::synthetic`, the rough harbour's among them) take beam `j` of a
//! revolution's `N` at `t + T·j/N`, at bearing `φ₀ + 2πj/N` counter-clockwise from the scan
//! frame's `+x` (`φ₀` a random phase below one beam), and stamp the scan with the revolution's
//! start `t`; their `sweep_s` is the rotation period `T`. Deskew takes that convention
//! ([`Sweep::revolution`]): a return at bearing `α ∈ [0, 2π]` was taken `sweep_s · α/2π` after
//! the scan's timestamp, read from the bearing rather than the index (dropped returns leave
//! no index), late by less than one beam's time (`T/N`, 0.27 ms on the rough harbour). A scan
//! with a bearing outside `[0, 2π]` (a fan from a negative bearing, as a ROS scan's
//! `angle_min` gives) is refused with the scan named rather than timed by a guess, and so is a
//! dataset that states no sweep (CARMEN, marina).
//!
//! # Covariances
//! The second registration's covariance is its own (closed form, and jackknife where its
//! variant computes one), as the report takes it (`--covariance`); under `sampled` and
//! `restarts`, whose covariances come from registrations made after the run and not repeated
//! here, the first registration's covariance is kept.

use datasets::{Dataset, ScanPair};
use icp_core::deskew::{deskew, BodyTwist, Sweep};
use icp_core::sequence::Smoothed;
use icp_core::{Prepared, Registrar, Scan, Surfaces, Workspace};
use rayon::prelude::*;

use crate::run::covariance::CovarianceMode;
use crate::run::runner::PairRun;
use crate::run::status::PairStatus;

/// The dataset's sweep, or why none can be used.
fn sweep_of(ds: &Dataset) -> Result<Sweep, String> {
    match ds.sweep_s {
        Some(sweep_s) => Ok(Sweep::revolution(sweep_s)),
        None => Err(format!(
            "{} states no sweep time (sweep_s): when each return was taken is not known",
            ds.provenance.name
        )),
    }
}

/// The run's scans (dataset indices `scans`, in the smoother's order) each deskewed by its
/// smoothed twist in `batch`, or why not (no sweep; a scan whose bearings the sweep does not
/// time, named).
pub fn deskewed_scans(
    ds: &Dataset,
    scans: &[usize],
    batch: &Smoothed,
) -> Result<Vec<Scan>, String> {
    let sweep = sweep_of(ds)?;
    scans
        .par_iter()
        .zip(&batch.scans)
        .map(|(&k, estimate)| {
            let scan = &ds.scans[k];
            sweep
                .offsets_s(scan)
                .and_then(|offsets| {
                    deskew(scan, &offsets, &BodyTwist::from_vector(&estimate.twist))
                })
                .map_err(|e| format!("scan {k}: {e}"))
        })
        .collect()
}

/// Each of a variant's registrations `runs` of `pairs` made again with `registrar` on the
/// `deskewed` scans (indexed by position in `scans`, the run's dataset indices), from its
/// first result; a pair without a first result keeps its run. `covariance` is the run's mode
/// (see the module docs).
pub fn register_again(
    registrar: &dyn Registrar,
    covariance: CovarianceMode,
    (scans, deskewed): (&[usize], &[Scan]),
    pairs: &[ScanPair],
    runs: &[PairRun],
) -> Vec<PairRun> {
    let of = |k: usize| scans.binary_search(&k).ok().map(|i| &deskewed[i]);
    pairs
        .par_iter()
        .zip(runs)
        .map_init(Workspace::default, |workspace, (pair, run)| {
            match (of(pair.source), of(pair.reference)) {
                (Some(source), Some(reference)) => {
                    again(registrar, covariance, workspace, (source, reference), run)
                }
                _ => run.clone(),
            }
        })
        .collect()
}

/// `run`'s pair registered again on the deskewed `source` and `reference`.
fn again(
    registrar: &dyn Registrar,
    covariance: CovarianceMode,
    workspace: &mut Workspace,
    (source, reference): (&Scan, &Scan),
    run: &PairRun,
) -> PairRun {
    let Ok(first) = &run.result else {
        return run.clone();
    };
    let (source, reference) = match &run.left_out {
        Some(l) => (
            source.without(&mask(&l.source_indices, source.len())),
            reference.without(&mask(&l.reference_indices, reference.len())),
        ),
        None => (source.clone(), reference.clone()),
    };
    let params = registrar.surface_params();
    let (ss, rs) = (
        Surfaces::estimate(&source, &params),
        Surfaces::estimate(&reference, &params),
    );
    let mut result = registrar.register_prepared(
        workspace,
        Prepared::new(&source, &ss),
        Prepared::new(&reference, &rs),
        first.t_ref_src,
    );
    if let (Ok(second), CovarianceMode::Sampled | CovarianceMode::Restarts) =
        (result.as_mut(), covariance)
    {
        second.covariance = first.covariance;
        second.jackknife_covariance = first.jackknife_covariance;
    }
    PairRun {
        status: if run.status == PairStatus::Ok {
            PairStatus::of(&result, run.check.as_ref(), run.ambiguity.as_ref())
        } else {
            run.status.clone()
        },
        result,
        ..run.clone()
    }
}

/// `indices` as a mask over `len` returns.
fn mask(indices: &[u32], len: usize) -> Vec<bool> {
    let mut out = vec![false; len];
    for &i in indices {
        if let Some(m) = out.get_mut(i as usize) {
            *m = true;
        }
    }
    out
}
