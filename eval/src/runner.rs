//! Runs registrars over scan pairs in parallel: rayon over pairs, each pair's variants one
//! after the other on one thread (so they share its reference index and first matching),
//! results collected by index so they do not depend on the thread count.

use std::time::Instant;

use datasets::{Dataset, ScanPair};
use icp_core::{IcpError, Registrar, Registration, Workspace};
use indicatif::ProgressBar;
use nalgebra::Isometry2;
use rayon::prelude::*;

/// One registration's outcome and its wall time.
#[derive(Clone, Debug)]
pub struct PairRun {
    /// The registration, or why it failed.
    pub result: Result<Registration, IcpError>,
    /// Wall time of the registration after its pair's shared preparation, microseconds (not
    /// reproducible: kept apart).
    pub time_us: f64,
}

/// Every registration of a run.
#[derive(Clone, Debug)]
pub struct Runs {
    /// `per_variant[variant][pair]`.
    pub per_variant: Vec<Vec<PairRun>>,
    /// Per pair, the wall time of the work its variants share, microseconds: the selection,
    /// the reference index and the first matching of the first variant (the others take them
    /// when their selection and matcher are the same; otherwise their own is in their time).
    pub prepare_us: Vec<f64>,
}

/// Registers every pair with every registrar, from the identity (as the paper does).
pub fn run_all(
    ds: &Dataset,
    pairs: &[ScanPair],
    registrars: &[Box<dyn Registrar>],
    progress: &ProgressBar,
) -> Runs {
    let init = Isometry2::identity();
    let per_pair: Vec<(f64, Vec<PairRun>)> = pairs
        .par_iter()
        // One workspace per rayon job: buffers are reused across the pairs a thread runs
        // (results never depend on what a workspace held before).
        .map_init(Workspace::default, |workspace, pair| {
            let (source, reference) = (&ds.scans[pair.source], &ds.scans[pair.reference]);
            let start = Instant::now();
            // A pair the preparation refuses is refused again, with the same error, by each
            // registration below: that is where it is reported.
            if let Some(first) = registrars.first() {
                let _ = first.prepare_in(workspace, source, reference, init);
            }
            let prepare_us = start.elapsed().as_secs_f64() * 1e6;
            let runs = registrars
                .iter()
                .map(|reg| {
                    let start = Instant::now();
                    let result = reg.register_in(workspace, source, reference, init);
                    let time_us = start.elapsed().as_secs_f64() * 1e6;
                    progress.inc(1);
                    PairRun { result, time_us }
                })
                .collect();
            (prepare_us, runs)
        })
        .collect();
    let mut per_variant: Vec<Vec<PairRun>> = registrars
        .iter()
        .map(|_| Vec::with_capacity(pairs.len()))
        .collect();
    let mut prepare_us = Vec::with_capacity(pairs.len());
    for (prepare, runs) in per_pair {
        prepare_us.push(prepare);
        for (variant, run) in per_variant.iter_mut().zip(runs) {
            variant.push(run);
        }
    }
    Runs {
        per_variant,
        prepare_us,
    }
}
