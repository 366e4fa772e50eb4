//! The global initial-guess search (`icp_core::global`) on 20 pairs of the CARMEN aces log
//! spread over the log, and on the first 20 pairs of the synthetic harbour, centred at the
//! identity, with the scans' surface estimates made beforehand as the runner does. Each
//! iteration runs all 20 pairs (the throughput is in pairs): the whole cost of a pair (the
//! reference's grid, then the search), the default histogram mode and the full mode, and on
//! aces the grid and the search apart. On aces the default search is also timed pair by pair
//! (`global/aces-pairs/<k>`, `k` the source scan), for the median over pairs.
//!
//! The check of a result (`global/<data>-check`): HD_GICP's result of each pair (registered
//! beforehand from the identity) checked as `icp-eval run` checks it, the whole cost of a pair
//! (the grid in storage reused from the pair before, as the runner does, the source's
//! preparation, the search above the result's bar: `check`) against the check by the full search
//! it replaces (`search`), the grid alone (`grid`), and the check alone on a prepared source
//! (`check-only`).
//!
//! The ambiguity of a result (`global/<data>-check/ambiguity`, issue 36): HD_GICP's result of
//! each pair scored on the lattice around it on a grid built beforehand (what the extended
//! covariance adds per registration, `icp_core::global::ambiguity`), beside HD_GICP's
//! registration of the pair from the identity (`register`) for its scale; and the results of
//! the four point-to-line and GICP variants of each pair, started at the global search's best
//! pose as `--init global` starts them, each on a lattice of its own (`ambiguity-four`) and on
//! the pair's shared scores as `icp-eval run` scores them (`ambiguity-four-shared`,
//! `icp_core::global::ambiguity::LatticeScores`).
//!
//! The aces log is looked for as `$ICP_DATA_DIR/carmen/aces.log.gz` or
//! `$ICP_DATA_DIR/aces.log.gz` (a relative `ICP_DATA_DIR` from the workspace root), then in
//! `../shared/datasets/carmen/` beside the workspace; without it the aces benchmarks are
//! skipped, said on the terminal.
//!
//!   ICP_DATA_DIR=/path/to/datasets cargo bench -p eval --bench global

use std::path::{Path, PathBuf};
use std::time::Duration;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use datasets::carmen::{load, CarmenOptions};
use datasets::synthetic::{generate, Scenario};
use eval::run::status::clearly_better;
use icp_core::global::ambiguity::{ambiguity, AmbiguityParams, LatticeScores};
use icp_core::global::{
    score_at, GlobalMatcher, GlobalParams, GlobalWorkspace, GridPool, RotationMode,
};
use icp_core::variants::builtin;
use icp_core::{Prepared, Registrar, Scan, SurfaceParams, Surfaces, Workspace};
use nalgebra::Isometry2;

/// Pairs per iteration.
const PAIRS: usize = 20;

/// A scan with its surface estimates.
struct Owned {
    scan: Scan,
    surfaces: Surfaces,
}

impl Owned {
    fn new(scan: &Scan) -> Self {
        Self {
            scan: scan.clone(),
            surfaces: Surfaces::estimate(scan, &SurfaceParams::default()),
        }
    }

    fn prepared(&self) -> Prepared<'_> {
        Prepared::new(&self.scan, &self.surfaces)
    }
}

/// The pairs `(k, k + 1)` for the given `k`.
fn pairs(scans: &[Scan], picked: &[usize]) -> Vec<(Owned, Owned)> {
    picked
        .iter()
        .map(|&k| (Owned::new(&scans[k]), Owned::new(&scans[k + 1])))
        .collect()
}

/// The aces log, when it is found.
fn aces_path() -> Option<PathBuf> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let mut looked = Vec::new();
    if let Some(dir) = std::env::var_os(datasets::marina::DATA_DIR_ENV) {
        let dir = root.join(dir);
        looked.push(dir.join("carmen").join("aces.log.gz"));
        looked.push(dir.join("aces.log.gz"));
    }
    looked.push(root.join("../shared/datasets/carmen/aces.log.gz"));
    let found = looked.iter().find(|p| p.is_file()).cloned();
    if found.is_none() {
        eprintln!("aces log absent (looked at {looked:?}); skipping the aces benchmarks");
    }
    found
}

/// Every pair searched, each with a grid built for it (the whole cost of a pair).
fn run_all(params: &GlobalParams, pairs: &[(Owned, Owned)], workspace: &mut GlobalWorkspace) {
    for (source, reference) in pairs {
        let matcher = GlobalMatcher::new(reference.prepared(), params).expect("a grid");
        matcher
            .search(workspace, source.prepared(), Isometry2::identity())
            .expect("a guess");
    }
}

/// The default (histogram) and full modes on `pairs`, each iteration all of them.
fn modes(c: &mut Criterion, name: &str, pairs: &[(Owned, Owned)]) {
    let mut group = c.benchmark_group(format!("global/{name}"));
    group.throughput(Throughput::Elements(pairs.len() as u64));
    let mut workspace = GlobalWorkspace::default();
    let default = GlobalParams::default();
    group.bench_function("default", |b| {
        b.iter(|| run_all(&default, pairs, &mut workspace))
    });
    let full = GlobalParams {
        rotation: RotationMode::Full,
        ..default
    };
    group.sample_size(10);
    group.bench_function("full", |b| b.iter(|| run_all(&full, pairs, &mut workspace)));
    group.finish();
}

/// The variants whose results `ambiguity-four` scores.
const FOUR: [&str; 4] = ["PL_ICP", "HD_PL_ICP", "GICP", "HD_GICP"];

/// `variant`'s result of each pair, registered from `starts` (one per pair; the start where
/// the registration fails: the lattice is timed there).
fn results(
    variant: &str,
    pairs: &[(Owned, Owned)],
    starts: &[Isometry2<f64>],
) -> Vec<Isometry2<f64>> {
    let reg = builtin(variant).expect("built in").build().expect("valid");
    let mut workspace = Workspace::default();
    pairs
        .iter()
        .zip(starts)
        .map(|((source, reference), &start)| {
            reg.register_prepared(
                &mut workspace,
                source.prepared(),
                reference.prepared(),
                start,
            )
            .map_or(start, |r| r.t_ref_src)
        })
        .collect()
}

/// The check of HD_GICP's results on `pairs` (see the module doc).
fn check(c: &mut Criterion, name: &str, pairs: &[(Owned, Owned)]) {
    let params = GlobalParams::default();
    // As `--init global` starts them: at the global search's best pose.
    let mut workspace = GlobalWorkspace::default();
    let guesses: Vec<Isometry2<f64>> = pairs
        .iter()
        .map(|(source, reference)| {
            GlobalMatcher::new(reference.prepared(), &params)
                .expect("a grid")
                .search(&mut workspace, source.prepared(), Isometry2::identity())
                .expect("a guess")
                .t_ref_src
        })
        .collect();
    let four: Vec<Vec<Isometry2<f64>>> = FOUR.iter().map(|v| results(v, pairs, &guesses)).collect();
    let results = results("HD_GICP", pairs, &vec![Isometry2::identity(); pairs.len()]);
    let mut group = c.benchmark_group(format!("global/{name}-check"));
    group.throughput(Throughput::Elements(pairs.len() as u64));
    let mut pool = GridPool::default();
    group.bench_function("check", |b| {
        b.iter(|| {
            for ((source, reference), result) in pairs.iter().zip(&results) {
                let matcher = GlobalMatcher::new_in(reference.prepared(), &params, &mut pool)
                    .expect("a grid");
                let mut prepared = matcher
                    .prepare(&mut workspace, source.prepared(), Isometry2::identity())
                    .expect("a source");
                let result_score = score_at(matcher.grid(), &source.scan, result);
                matcher.best_above(&mut prepared, |s| clearly_better(s, result_score));
                matcher.recycle(&mut pool);
            }
        })
    });
    group.bench_function("grid", |b| {
        b.iter(|| {
            for (_, reference) in pairs {
                GlobalMatcher::new_in(reference.prepared(), &params, &mut pool)
                    .expect("a grid")
                    .recycle(&mut pool);
            }
        })
    });
    group.bench_function("search", |b| {
        b.iter(|| {
            for ((source, reference), result) in pairs.iter().zip(&results) {
                let matcher = GlobalMatcher::new(reference.prepared(), &params).expect("a grid");
                matcher
                    .search(&mut workspace, source.prepared(), Isometry2::identity())
                    .expect("a guess");
                score_at(matcher.grid(), &source.scan, result);
            }
        })
    });
    let matchers: Vec<GlobalMatcher> = pairs
        .iter()
        .map(|(_, r)| GlobalMatcher::new(r.prepared(), &params).expect("a grid"))
        .collect();
    group.bench_function("check-only", |b| {
        b.iter(|| {
            for (((source, _), result), matcher) in pairs.iter().zip(&results).zip(&matchers) {
                let mut prepared = matcher
                    .prepare(&mut workspace, source.prepared(), Isometry2::identity())
                    .expect("a source");
                let result_score = score_at(matcher.grid(), &source.scan, result);
                matcher.best_above(&mut prepared, |s| clearly_better(s, result_score));
            }
        })
    });
    let ambiguity_params = AmbiguityParams::default();
    group.bench_function("ambiguity", |b| {
        b.iter(|| {
            for (((source, _), result), matcher) in pairs.iter().zip(&results).zip(&matchers) {
                // A problem is an answer too: timed either way.
                let _ = ambiguity(matcher.grid(), &source.scan, result, &ambiguity_params);
            }
        })
    });
    group.bench_function("ambiguity-four", |b| {
        b.iter(|| {
            for (k, ((source, _), matcher)) in pairs.iter().zip(&matchers).enumerate() {
                for variant in &four {
                    let _ = ambiguity(matcher.grid(), &source.scan, &variant[k], &ambiguity_params);
                }
            }
        })
    });
    group.bench_function("ambiguity-four-shared", |b| {
        b.iter(|| {
            for (k, ((source, _), matcher)) in pairs.iter().zip(&matchers).enumerate() {
                let mut scores = LatticeScores::default();
                for variant in &four {
                    let _ = scores.ambiguity(
                        matcher.grid(),
                        &source.scan,
                        &variant[k],
                        &ambiguity_params,
                    );
                }
            }
        })
    });
    let reg = builtin("HD_GICP")
        .expect("built in")
        .build()
        .expect("valid");
    let mut registration = Workspace::default();
    group.bench_function("register", |b| {
        b.iter(|| {
            for (source, reference) in pairs {
                reg.register_prepared(
                    &mut registration,
                    source.prepared(),
                    reference.prepared(),
                    Isometry2::identity(),
                )
                .expect("a registration");
            }
        })
    });
    group.finish();
}

fn aces(c: &mut Criterion) {
    let Some(path) = aces_path() else {
        return;
    };
    let ds = load(&path, &CarmenOptions::default()).expect("the aces log");
    let n = ds.scans.len() - 1;
    let picked: Vec<usize> = (0..PAIRS).map(|i| i * n / PAIRS).collect();
    let pairs = pairs(&ds.scans, &picked);
    modes(c, "aces", &pairs);
    check(c, "aces", &pairs);
    // Pair by pair: the grid and the search of one pair per iteration.
    let params = GlobalParams::default();
    let mut group = c.benchmark_group("global/aces-pairs");
    group
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2));
    let mut workspace = GlobalWorkspace::default();
    for (k, pair) in picked.iter().zip(&pairs) {
        group.bench_with_input(BenchmarkId::from_parameter(k), pair, |b, pair| {
            b.iter(|| run_all(&params, std::slice::from_ref(pair), &mut workspace))
        });
    }
    group.finish();
    // The two parts of the default search apart: the reference's grid, and the search on it.
    let mut group = c.benchmark_group("global/aces-parts");
    group.throughput(Throughput::Elements(pairs.len() as u64));
    group.bench_function("grid", |b| {
        b.iter(|| {
            for (_, reference) in &pairs {
                GlobalMatcher::new(reference.prepared(), &params).expect("a grid");
            }
        })
    });
    let matchers: Vec<GlobalMatcher> = pairs
        .iter()
        .map(|(_, r)| GlobalMatcher::new(r.prepared(), &params).expect("a grid"))
        .collect();
    let mut workspace = GlobalWorkspace::default();
    group.bench_function("search", |b| {
        b.iter(|| {
            for ((source, _), matcher) in pairs.iter().zip(&matchers) {
                matcher
                    .search(&mut workspace, source.prepared(), Isometry2::identity())
                    .expect("a guess");
            }
        })
    });
    group.finish();
}

fn synthetic(c: &mut Criterion) {
    let scenario = Scenario {
        n_scans: PAIRS + 1,
        ..Scenario::paper()
    };
    let ds = generate(&scenario).expect("synthetic data");
    let picked: Vec<usize> = (0..PAIRS).collect();
    let pairs = pairs(&ds.scans, &picked);
    modes(c, "synthetic", &pairs);
    check(c, "synthetic", &pairs);
}

criterion_group!(benches, aces, synthetic);
criterion_main!(benches);
