//! Runs registrars over scan pairs in parallel. The surface estimates of every scan are made
//! once (per distinct set of parameters among the variants) and shared by every registration
//! that uses the scan; then rayon runs the pairs, each pair's variants one after the other in
//! one workspace. Results are collected by index, so they do not depend on the thread count.

use std::time::Instant;

use datasets::{Dataset, ScanPair};
use icp_core::{IcpError, Prepared, Registrar, Registration, SurfaceParams, Surfaces, Workspace};
use indicatif::ProgressBar;
use nalgebra::Isometry2;
use rand::seq::SliceRandom;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

/// One registration's outcome and its wall time.
#[derive(Clone, Debug)]
pub struct PairRun {
    /// The registration, or why it failed.
    pub result: Result<Registration, IcpError>,
    /// Wall time of the registration, its scans' surface estimates aside, microseconds (not
    /// reproducible: kept apart).
    pub time_us: f64,
}

/// Every registration of a run.
#[derive(Clone, Debug)]
pub struct Runs {
    /// `per_variant[variant][pair]`.
    pub per_variant: Vec<Vec<PairRun>>,
    /// Per scan that takes part in a pair, the wall time of its surface estimates (all the
    /// parameter sets the variants use), microseconds: made once, shared by every variant and
    /// by both pairs that use the scan.
    pub prepare_us: Vec<f64>,
}

/// The surface estimates of the scans, per distinct parameter set.
struct PreparedScans {
    params: Vec<SurfaceParams>,
    /// `per_scan[scan][set]` (`None` for a scan in no pair).
    per_scan: Vec<Option<Vec<Surfaces>>>,
}

impl PreparedScans {
    fn get(&self, params: &SurfaceParams, scan: usize) -> &Surfaces {
        let set = self
            .params
            .iter()
            .position(|p| p == params)
            .expect("every variant's parameters were prepared");
        &self.per_scan[scan]
            .as_ref()
            .expect("every scan of a pair was prepared")[set]
    }
}

/// Estimates the surfaces of every scan of a pair with each parameter set of `registrars`,
/// in parallel over scans; returns them and the time per scan.
fn prepare(
    ds: &Dataset,
    pairs: &[ScanPair],
    registrars: &[Box<dyn Registrar>],
) -> (PreparedScans, Vec<f64>) {
    let mut params: Vec<SurfaceParams> = Vec::new();
    for r in registrars {
        let p = r.surface_params();
        if !params.contains(&p) {
            params.push(p);
        }
    }
    let mut used = vec![false; ds.scans.len()];
    for p in pairs {
        used[p.source] = true;
        used[p.reference] = true;
    }
    let timed: Vec<Option<(Vec<Surfaces>, f64)>> = ds
        .scans
        .par_iter()
        .zip(&used)
        .map(|(scan, &used)| {
            used.then(|| {
                let start = Instant::now();
                let s = params.iter().map(|p| Surfaces::estimate(scan, p)).collect();
                (s, start.elapsed().as_secs_f64() * 1e6)
            })
        })
        .collect();
    let times = timed.iter().flatten().map(|(_, t)| *t).collect();
    let per_scan = timed.into_iter().map(|t| t.map(|(s, _)| s)).collect();
    (PreparedScans { params, per_scan }, times)
}

/// Registers every pair with every registrar, from the identity (as the paper does).
pub fn run_all(
    ds: &Dataset,
    pairs: &[ScanPair],
    registrars: &[Box<dyn Registrar>],
    progress: &ProgressBar,
) -> Runs {
    let init = Isometry2::identity();
    let (prepared, prepare_us) = prepare(ds, pairs, registrars);
    let n = registrars.len();
    let per_pair: Vec<Vec<PairRun>> = pairs
        .par_iter()
        .enumerate()
        // One workspace per rayon job: buffers are reused across the pairs a thread runs
        // (results never depend on what a workspace held before).
        .map_init(Workspace::default, |workspace, (position, pair)| {
            // A workspace hands a variant the reference index and first matching of the one
            // before it on the same pair (same selection, matcher and start): the first of
            // such a group pays for both. Each pair runs its variants in its own order, so
            // every variant comes first in its group equally often and the timings compare.
            let mut order: Vec<usize> = (0..n).collect();
            order.shuffle(&mut ChaCha8Rng::seed_from_u64(position as u64));
            let mut runs: Vec<(usize, PairRun)> = order
                .into_iter()
                .map(|v| {
                    let reg = &registrars[v];
                    let params = reg.surface_params();
                    let prepared_scan =
                        |k: usize| Prepared::new(&ds.scans[k], prepared.get(&params, k));
                    let (source, reference) =
                        (prepared_scan(pair.source), prepared_scan(pair.reference));
                    let start = Instant::now();
                    let result = reg.register_prepared(workspace, source, reference, init);
                    let time_us = start.elapsed().as_secs_f64() * 1e6;
                    progress.inc(1);
                    (v, PairRun { result, time_us })
                })
                .collect();
            runs.sort_by_key(|(v, _)| *v);
            runs.into_iter().map(|(_, run)| run).collect()
        })
        .collect();
    let mut per_variant: Vec<Vec<PairRun>> = registrars
        .iter()
        .map(|_| Vec::with_capacity(pairs.len()))
        .collect();
    for runs in per_pair {
        for (variant, run) in per_variant.iter_mut().zip(runs) {
            variant.push(run);
        }
    }
    Runs {
        per_variant,
        prepare_us,
    }
}
