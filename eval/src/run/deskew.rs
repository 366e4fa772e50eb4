//! `--sequence deskew` (issue 35, item 5): a variant's registrations made again on scans whose
//! motion distortion the batch smoother's twists take out, for the estimator `V+deskew`.
//!
//! After the batch smoother of a variant, every scan of the run is deskewed with that scan's
//! smoothed body twist ([`icp_core::deskew`]): each return moved to where the scanner saw it
//! from at the scan's time. Every pair the variant registered (consecutive and across lags)
//! is registered once more on the deskewed scans, from its first result and as that result
//! was registered: without the returns its detector of moving returns left out where the
//! result is the registration without them (`run::moving`; where that registration jumped and
//! the start stood, with every return), and the sequence module
//! smooths those registrations again in batch. A pair the variant flagged keeps its run (the
//! smoother leaves it out, and the estimator's pair keeps the flag); an ok pair takes the
//! second registration and its own verdict ([`PairStatus::of`], with the first's global check
//! and ambiguity while it stays within the first's peak, else with those of its own pose on the
//! deskewed scans: [`crate::run::pair_search::answers_for_second`]), so a second registration
//! that fails or turns degenerate is flagged rather than smoothed.
//!
//! # When each return was taken
//! The datasets state a sweep only as `sweep_s` (`datasets::Dataset::sweep_s`). The synthetic
//! scanners (`datasets::synthetic`, the rough harbour's among them) take beam `j` of a
//! revolution's `N` at `t + T·j/N`, at bearing `φ₀ + 2πj/N` counter-clockwise from the scan
//! frame's `+x` (`φ₀` a random phase below one beam), and stamp the scan with the revolution's
//! start `t`; their `sweep_s` is the rotation period `T`. Deskew takes that convention
//! ([`Sweep::revolution`]): a return at bearing `α ∈ [0, 2π]` was taken `sweep_s · α/2π` after
//! the scan's timestamp, read from the bearing rather than the index (dropped returns leave
//! no index), late by less than one beam's time (`T/N`, 0.27 ms on the rough harbour). With a
//! sweep (`sweep_s` > 0), a scan with a bearing outside `[0, 2π]` (a fan from a negative
//! bearing, as a ROS scan's `angle_min` gives) is refused with the scan named rather than timed
//! by a guess, and so is a dataset that states no sweep (CARMEN, marina); `sweep_s` 0 (the
//! paper harbour, the corridor's fan) moves nothing.
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
use crate::run::pair_search::answers_for_second;
use crate::run::runner::{PairRun, RunPlan};
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
/// first result; a flagged pair keeps its run. `covariance` is the run's mode
/// (see the module docs); `plan`, the run's (a second result off the first's peak is checked
/// and assessed again as it asks).
pub fn register_again(
    registrar: &dyn Registrar,
    (covariance, plan): (CovarianceMode, &RunPlan<'_>),
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
                (Some(source), Some(reference)) => again(
                    registrar,
                    (covariance, plan),
                    workspace,
                    (source, reference),
                    run,
                ),
                _ => run.clone(),
            }
        })
        .collect()
}

/// `run`'s pair registered again on the deskewed `whole` scans (source, reference).
fn again(
    registrar: &dyn Registrar,
    (covariance, plan): (CovarianceMode, &RunPlan<'_>),
    workspace: &mut Workspace,
    whole: (&Scan, &Scan),
    run: &PairRun,
) -> PairRun {
    let (PairStatus::Ok, Ok(first)) = (&run.status, &run.result) else {
        return run.clone();
    };
    let (source, reference) = whole;
    let (source, reference) = match &run.left_out {
        Some(l) if l.result_without => (
            source.without(&mask(&l.source_indices, source.len())),
            reference.without(&mask(&l.reference_indices, reference.len())),
        ),
        _ => (source.clone(), reference.clone()),
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
    let kept = (run.check, run.ambiguity.clone());
    let (check, ambiguity) = match &result {
        Ok(second) => answers_for_second(
            (&first.t_ref_src, kept),
            second,
            whole,
            (plan.global, (plan.check, plan.ambiguity)),
        ),
        Err(_) => kept,
    };
    PairRun {
        status: PairStatus::of(&result, check.as_ref(), ambiguity.as_ref()),
        result,
        check,
        ambiguity,
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

#[cfg(test)]
mod tests {
    use datasets::synthetic::{generate, Scenario};
    use icp_core::global::GlobalParams;
    use icp_core::sequence::{MotionPrior, ScanEstimate, ScanShare, SolveStop};
    use icp_core::variants::builtin;
    use icp_core::Registration;
    use nalgebra::{Isometry2, Vector2, Vector3};

    use super::*;
    use crate::run::pair_search::assess_alone;
    use crate::run::setup::EvalSetup;

    /// A batch solve of `n` scans whose every twist is `twist`.
    fn smoothed(n: usize, twist: Vector3<f64>) -> Smoothed {
        Smoothed {
            scans: (0..n)
                .map(|_| ScanEstimate {
                    pose: Vector3::zeros(),
                    twist,
                    cov: Default::default(),
                })
                .collect(),
            steps: Vec::new(),
            motion_prior: MotionPrior::WhiteAcceleration,
            qc: [1.0; 3],
            log_likelihood: None,
            prior_evidence: None,
            em_iterations: 0,
            stop: SolveStop::Converged,
            scan_share: ScanShare {
                share: 0.0,
                loops: 0,
            },
        }
    }

    #[test]
    fn a_dataset_without_a_sweep_is_refused_and_a_scan_the_sweep_cannot_time_is_named() {
        let mut ds = generate(&Scenario {
            n_scans: 3,
            ..Scenario::rough()
        })
        .unwrap();
        let batch = smoothed(3, Vector3::new(3.0, 0.1, 0.05));
        assert!(deskewed_scans(&ds, &[0, 1, 2], &batch).is_ok());
        ds.sweep_s = None;
        let why = deskewed_scans(&ds, &[0, 1, 2], &batch).unwrap_err();
        assert!(why.contains("no sweep time (sweep_s)"), "{why}");
        // A fan from −90°: its returns before bearing 0 have no time in the revolution.
        ds.sweep_s = Some(0.2);
        ds.scans[1] = Scan::from_polar(&[5.0, 6.0, 7.0], &[-1.5, 0.0, 1.5]).unwrap();
        let why = deskewed_scans(&ds, &[0, 1, 2], &batch).unwrap_err();
        assert!(
            why.starts_with("scan 1: ") && why.contains("bearing"),
            "{why}"
        );
    }

    /// A second result within the first's peak keeps the first's check; one that leaves it
    /// (from a start 0.25 m off, back to the scans' registration) is checked at its own pose.
    #[test]
    fn a_second_result_off_the_first_ones_peak_is_checked_at_its_own_pose() {
        let ds = generate(&Scenario {
            n_scans: 2,
            ..Scenario::paper()
        })
        .unwrap();
        let scans = deskewed_scans(&ds, &[0, 1], &smoothed(2, Vector3::zeros())).unwrap();
        let pl = builtin("PL_ICP").unwrap().build().unwrap();
        let pair = ScanPair {
            source: 0,
            reference: 1,
        };
        let right = pl
            .register(&scans[0], &scans[1], Isometry2::identity())
            .unwrap();
        let global = GlobalParams::default();
        let again_from = |off_m: f64| {
            let start = Isometry2::new(Vector2::new(off_m, 0.0), 0.0) * right.t_ref_src;
            let first = Registration {
                t_ref_src: start,
                ..right
            };
            let (check, _) = assess_alone((&scans[0], &scans[1]), &global, (true, false), &first);
            let run = PairRun {
                check,
                ..PairRun::ok_for_test(start, None)
            };
            let runs = register_again(
                &pl,
                (
                    CovarianceMode::ClosedForm,
                    &EvalSetup::checking_plan(&global),
                ),
                (&[0, 1], &scans),
                &[pair],
                std::slice::from_ref(&run),
            );
            (run.check.unwrap(), runs[0].clone())
        };
        let (first, near) = again_from(0.05);
        assert_eq!(near.check, Some(first));
        let (first, far) = again_from(0.25);
        let now = far.result.as_ref().unwrap().t_ref_src;
        assert!((now.translation.vector - right.t_ref_src.translation.vector).norm() < 1e-3);
        let check = far.check.unwrap();
        assert_eq!(check.result_t_ref_src, now);
        assert!(check != first);
    }

    #[test]
    fn a_flagged_pair_keeps_its_run_and_an_ok_one_is_registered_again_from_its_first_result() {
        let ds = generate(&Scenario {
            n_scans: 3,
            ..Scenario::paper()
        })
        .unwrap();
        // Without motion the deskewed scans are the scans (to rounding).
        let scans = deskewed_scans(&ds, &[0, 1, 2], &smoothed(3, Vector3::zeros())).unwrap();
        for (a, b) in ds.scans.iter().zip(&scans) {
            for (p, q) in a.returns().iter().zip(b.returns()) {
                assert!((p.point - q.point).norm() < 1e-12 * p.range_m);
            }
        }
        let pl = builtin("PL_ICP").unwrap().build().unwrap();
        let pairs = [0, 1].map(|k| ScanPair {
            source: k,
            reference: k + 1,
        });
        // Both start 5 cm off the registration of the scans.
        let off = |k: usize| {
            let reg = pl
                .register(&ds.scans[k], &ds.scans[k + 1], Isometry2::identity())
                .unwrap();
            let start = Isometry2::new(Vector2::new(0.05, 0.0), 0.0) * reg.t_ref_src;
            (reg, PairRun::ok_for_test(start, None))
        };
        let (right, ok) = off(0);
        let (_, mut flagged) = off(1);
        flagged.status = PairStatus::Degenerate { cond_ratio: 1e-4 };
        let runs = register_again(
            &pl,
            (
                CovarianceMode::ClosedForm,
                &EvalSetup::checking_plan(&GlobalParams::default()),
            ),
            (&[0, 1, 2], &scans),
            &pairs,
            &[ok.clone(), flagged.clone()],
        );
        assert_eq!(runs[1].status, flagged.status);
        assert_eq!(runs[1].result, flagged.result);
        assert_eq!(runs[0].status, PairStatus::Ok);
        let again = runs[0].result.as_ref().unwrap().t_ref_src;
        assert!((again.translation.vector - right.t_ref_src.translation.vector).norm() < 1e-3);
        assert!(again != ok.result.as_ref().unwrap().t_ref_src);
        // Returns left out count only where the result is the registration without them.
        let left_out = |result_without: bool| PairRun {
            left_out: Some(crate::run::left_out::LeftOut {
                source_indices: (0..60).collect(),
                result_without,
                ..Default::default()
            }),
            ..ok.clone()
        };
        let t = |run: PairRun| {
            let runs = register_again(
                &pl,
                (
                    CovarianceMode::ClosedForm,
                    &EvalSetup::checking_plan(&GlobalParams::default()),
                ),
                (&[0, 1, 2], &scans),
                &pairs[..1],
                &[run],
            );
            runs[0].result.as_ref().unwrap().t_ref_src
        };
        assert_eq!(t(left_out(false)), again);
        assert!(t(left_out(true)) != again);
    }
}
