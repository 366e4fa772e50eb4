//! Runs registrars over scan pairs in parallel: rayon over (variant × pair), results
//! collected by index so they do not depend on the thread count.

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
    /// Wall time of the registration, microseconds (not reproducible: kept apart).
    pub time_us: f64,
}

/// Registers every pair with every registrar, from the identity (as the paper does).
/// Returns `runs[variant][pair]`.
pub fn run_all(
    ds: &Dataset,
    pairs: &[ScanPair],
    registrars: &[Box<dyn Registrar>],
    progress: &ProgressBar,
) -> Vec<Vec<PairRun>> {
    let n_pairs = pairs.len();
    let flat: Vec<PairRun> = (0..registrars.len() * n_pairs)
        .into_par_iter()
        // One workspace per rayon job: buffers are reused across the pairs a thread runs
        // (results never depend on what a workspace held before).
        .map_init(Workspace::default, |workspace, i| {
            let (reg, pair) = (&registrars[i / n_pairs], pairs[i % n_pairs]);
            let start = Instant::now();
            let result = reg.register_in(
                workspace,
                &ds.scans[pair.source],
                &ds.scans[pair.reference],
                Isometry2::identity(),
            );
            let time_us = start.elapsed().as_secs_f64() * 1e6;
            progress.inc(1);
            PairRun { result, time_us }
        })
        .collect();
    let mut flat = flat.into_iter();
    (0..registrars.len())
        .map(|_| flat.by_ref().take(n_pairs).collect())
        .collect()
}
