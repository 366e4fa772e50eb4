//! Covariances made after the run, pair by pair ([`replace_covariances`]): the loop over the
//! registered pairs and the write-back that the `sampled` and `restarts` modes share.

use datasets::ScanPair;
use icp_core::{Covariance, Registrar, Registration, Workspace};
use rayon::prelude::*;

use crate::run::runner::Runs;

/// Replaces the covariance of every successful registration of `runs` (the first
/// `registrars.len()` methods) by `estimate(reg, workspace, position, registration, pair)`,
/// `position` the pair's place in the run (a seed that does not depend on the thread count). The pairs run in
/// parallel, a workspace per thread. What replaces the covariance is the final one: the
/// registration's jackknife, an ingredient of the extended mode, is dropped.
pub fn replace_covariances(
    pairs: &[ScanPair],
    registrars: &[Box<dyn Registrar>],
    runs: &mut Runs,
    estimate: impl Fn(&dyn Registrar, &mut Workspace, usize, &Registration, &ScanPair) -> Option<Covariance>
        + Sync,
) {
    for (reg, variant_runs) in registrars.iter().zip(runs.per_variant.iter_mut()) {
        let reg = reg.as_ref();
        let estimates: Vec<Option<Covariance>> = variant_runs
            .par_iter()
            .zip(pairs.par_iter())
            .enumerate()
            .map_init(Workspace::default, |workspace, (position, (run, pair))| {
                let out = run.result.as_ref().ok()?;
                estimate(reg, workspace, position, out, pair)
            })
            .collect();
        for (run, estimate) in variant_runs.iter_mut().zip(estimates) {
            if let Ok(r) = run.result.as_mut() {
                r.covariance = estimate;
                r.jackknife_covariance = None;
            }
        }
    }
}
