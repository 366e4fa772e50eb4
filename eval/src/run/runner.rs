//! Runs registrars over scan pairs in parallel, a block of pairs at a time. The surface
//! estimates of a block's scans are made once (per distinct set of parameters among the
//! variants), shared by every registration that uses the scan, and dropped after the block
//! (a scan shared with the next block is kept), so memory follows the block, not the dataset.
//! Within a block rayon runs the pairs, each pair's variants one after the other in one
//! workspace. Results are collected by index, so they do not depend on the thread count.
//! External estimates ([`crate::run::estimates`]) run as methods too: each pair's estimate is
//! assessed at its pose ([`icp_core::assess()`]) and checked like a registration.

use std::collections::BTreeMap;
use std::ops::Range;
use std::sync::{Mutex, PoisonError};
use std::time::Instant;

use datasets::{Dataset, ScanPair};
use icp_core::global::ambiguity::{Ambiguity, AmbiguityProblem};
use icp_core::global::{GlobalGuess, GlobalParams, GlobalWorkspace, GridPool};
use icp_core::{IcpError, Prepared, Registrar, Registration, SurfaceParams, Surfaces, Workspace};
use indicatif::ProgressBar;
use rand::seq::SliceRandom;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

use crate::run::estimates::ExternalEstimates;
use crate::run::init;
use crate::run::init::InitChain;
use crate::run::init::InitMode;
use crate::run::init::Previous;
use crate::run::left_out::LeftOut;
use crate::run::pair_search::Searched;
use crate::run::status::GlobalCheck;
use crate::run::status::PairStatus;

/// One registration's outcome and its wall time (serialized whole into the part files of a
/// sharded run, see the `shard` module).
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct PairRun {
    /// The registration, or why it failed.
    pub result: Result<Registration, IcpError>,
    /// The verdict on it.
    pub status: PairStatus,
    /// What the pair's global search says about the result, when results are checked.
    pub check: Option<GlobalCheck>,
    /// The poses around the result that the pair's likelihood grid scores almost as well
    /// (`icp_core::global::ambiguity`), under the extended covariance modes: the ambiguity
    /// term of the covariance, or why it cannot be assessed (`None`: not asked, no grid, or
    /// no registration).
    #[serde(default)]
    pub ambiguity: Option<Result<Ambiguity, AmbiguityProblem>>,
    /// The initial-guess mode whose start gave the result kept (`None`: an external
    /// estimate, not started here).
    pub init: Option<InitMode>,
    /// Registrations made along the init chain (the result kept is the last of them; 0 for
    /// an external estimate).
    pub attempts: usize,
    /// Wall time of the registrations made along the init chain, their scans' surface
    /// estimates and the pair's global search aside, microseconds (not reproducible: kept
    /// apart; `None` for an external estimate, whose time is not known here).
    pub time_us: Option<f64>,
    /// What its variant's detector of moving returns left out of the pair's scans (`None`:
    /// the variant has none; see `run::moving`).
    #[serde(default)]
    pub left_out: Option<LeftOut>,
}

/// The global search of one pair (made once, shared by every variant).
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct PairSearch {
    /// Its best pose and score (`None`: not searched for, only the results are checked), or
    /// why it could not run (the pair's registrations then start at the identity where the
    /// chain says global, and are not checked).
    pub result: Result<Option<GlobalGuess>, IcpError>,
    /// Wall time of the grid, the search and the checks of the pair's results, microseconds
    /// (see [`crate::run::pair_search`]).
    pub time_us: f64,
}

/// Every registration of a run.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct Runs {
    /// `per_variant[method][pair]`, the methods in [`Methods`]' order (the registrars, then
    /// the external estimates).
    pub per_variant: Vec<Vec<PairRun>>,
    /// Per scan that takes part in a pair, the wall time of its surface estimates (all the
    /// parameter sets the variants use), microseconds: made once, shared by every variant and
    /// by both pairs that use the scan.
    pub prepare_us: Vec<f64>,
    /// Per pair, its global search, when the chain starts at one or results are checked.
    pub searches: Vec<PairSearch>,
}

impl Runs {
    /// A run of `methods` methods with no pair.
    pub fn empty(methods: usize) -> Self {
        Self {
            per_variant: vec![Vec::new(); methods],
            prepare_us: Vec::new(),
            searches: Vec::new(),
        }
    }

    /// Appends `more`, the same methods' registrations of the pairs that follow (a run made
    /// in parts, pairs after pairs).
    pub fn append_pairs(&mut self, more: Runs) {
        if self.per_variant.is_empty() {
            self.per_variant = more.per_variant;
        } else {
            for (variant, runs) in self.per_variant.iter_mut().zip(more.per_variant) {
                variant.extend(runs);
            }
        }
        self.searches.extend(more.searches);
        // The surface-estimate times of a scan at the parts' edge are counted in both: a
        // timing, like every field that differs from a single run.
        self.prepare_us.extend(more.prepare_us);
    }
}

/// What a run does besides registering: where registrations start, and whether a global
/// search checks every result.
#[derive(Clone)]
pub struct RunPlan<'a> {
    /// The init chain.
    pub chain: &'a InitChain,
    /// The global search's parameters.
    pub global: &'a GlobalParams,
    /// Whether every result is checked against the pair's global search.
    pub check: bool,
    /// Whether every result's ambiguity is assessed on the pair's likelihood grid (the
    /// extended covariance modes' term, and the `ambiguous` flag).
    pub ambiguity: bool,
}

impl RunPlan<'_> {
    /// True when each pair needs its global search.
    fn searches(&self) -> bool {
        self.check || self.ambiguity || self.chain.global()
    }
}

/// The methods a run evaluates, in the order of their results: the registrars, then the
/// external estimates.
#[derive(Clone, Copy)]
pub struct Methods<'a> {
    /// The registration methods.
    pub registrars: &'a [Box<dyn Registrar>],
    /// Per registrar (same order), the one a close start (the global search's pose, the
    /// reference) uses instead, when such starts gate their correspondences
    /// ([`crate::run::start_gate`]); empty: none does.
    pub close: &'a [Option<Box<dyn Registrar>>],
    /// Estimates made elsewhere, per pair of the run.
    pub external: &'a [ExternalEstimates],
}

impl<'a> Methods<'a> {
    /// The registrars alone, none gated.
    pub fn registrars(registrars: &'a [Box<dyn Registrar>]) -> Self {
        Self {
            registrars,
            close: &[],
            external: &[],
        }
    }

    /// How many methods.
    pub fn len(&self) -> usize {
        self.registrars.len() + self.external.len()
    }

    /// True without any method.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Methods `range` (numbered in result order), each with its own gated twin: what a shard
    /// that runs some methods runs.
    pub fn slice(&self, range: Range<usize>) -> Self {
        let n = self.registrars.len();
        let clip = |r: &Range<usize>, len: usize| r.start.min(len)..r.end.min(len);
        let registrars = clip(&range, n);
        let external = range.start.saturating_sub(n)..range.end.saturating_sub(n);
        Self {
            registrars: &self.registrars[registrars.clone()],
            close: if self.close.is_empty() {
                &[]
            } else {
                &self.close[registrars]
            },
            external: &self.external[clip(&external, self.external.len())],
        }
    }

    /// The registrar a close start of registrar `v` uses, when it is another one.
    fn gated(&self, v: usize) -> Option<&'a dyn Registrar> {
        self.close.get(v).and_then(|r| r.as_deref())
    }
}

/// Pairs searched at once where starts chain pairs: their grids are held while every variant
/// registers them (~2 MB each on the synthetic harbour).
const CHAINED_PAIRS: usize = 16;

/// Pairs per block. The surface estimates of the block's scans (one more than its pairs when
/// they are consecutive) are held at once: ~12 MB for scans of ~650 returns. A block is long
/// enough for the threads' barrier at its end to cost nothing measurable.
const BLOCK_PAIRS: usize = 256;

/// The surface estimates of the current block's scans, per distinct parameter set.
struct PreparedScans<'a> {
    params: &'a [SurfaceParams],
    /// Scan index → one estimate per parameter set.
    per_scan: BTreeMap<usize, Vec<Surfaces>>,
}

impl PreparedScans<'_> {
    fn get(&self, params: &SurfaceParams, scan: usize) -> &Surfaces {
        let set = self
            .params
            .iter()
            .position(|p| p == params)
            .expect("every variant's parameters were prepared");
        &self
            .per_scan
            .get(&scan)
            .expect("every scan of the block was prepared")[set]
    }

    /// Keeps the estimates of the scans of `block` already made, drops the others, makes the
    /// missing ones in parallel, and appends their times (in scan order) to `times_us`.
    fn advance(&mut self, ds: &Dataset, block: &[ScanPair], times_us: &mut Vec<f64>) {
        let wanted = run_scans(block);
        // The previous block's other estimates are dropped before the new ones are made.
        let mut previous = std::mem::take(&mut self.per_scan);
        for k in &wanted {
            if let Some(surfaces) = previous.remove(k) {
                self.per_scan.insert(*k, surfaces);
            }
        }
        drop(previous);
        let missing: Vec<usize> = wanted
            .into_iter()
            .filter(|k| !self.per_scan.contains_key(k))
            .collect();
        let params = self.params;
        let made: Vec<(Vec<Surfaces>, f64)> = missing
            .par_iter()
            .map(|&k| {
                let start = Instant::now();
                let s = params
                    .iter()
                    .map(|p| Surfaces::estimate(&ds.scans[k], p))
                    .collect();
                (s, start.elapsed().as_secs_f64() * 1e6)
            })
            .collect();
        for (k, (surfaces, time_us)) in missing.into_iter().zip(made) {
            self.per_scan.insert(k, surfaces);
            times_us.push(time_us);
        }
    }
}

/// Registers every pair with every registrar, each starting as `plan` says (its chain checked
/// against `ds` by the caller).
pub fn run_all(
    ds: &Dataset,
    pairs: &[ScanPair],
    methods: Methods<'_>,
    plan: &RunPlan<'_>,
    progress: &ProgressBar,
) -> Runs {
    run_blocks(ds, pairs, methods, plan, progress, BLOCK_PAIRS, 0)
}

/// [`run_all`] over `pairs`, the run's pairs from position `first` on (a shard of a run,
/// see the `shard` module): each pair runs its variants in the order it has in the whole run,
/// so a shard repeats the whole run's registrations exactly.
pub fn run_from(
    ds: &Dataset,
    pairs: &[ScanPair],
    first: usize,
    methods: Methods<'_>,
    plan: &RunPlan<'_>,
    progress: &ProgressBar,
) -> Runs {
    run_blocks(ds, pairs, methods, plan, progress, BLOCK_PAIRS, first)
}

/// The buffers of one pair's registrations and global search, reused from pair to pair.
#[derive(Default)]
struct PairBuffers {
    workspace: Workspace,
    global: GlobalWorkspace,
    pool: GridPool,
}

/// The scans of `pairs`, in order.
pub fn run_scans(pairs: &[ScanPair]) -> Vec<usize> {
    let mut scans: Vec<usize> = pairs.iter().flat_map(|p| [p.source, p.reference]).collect();
    scans.sort_unstable();
    scans.dedup();
    scans
}

/// Each of the run's threads' [`PairBuffers`], kept across blocks and rayon's splits of them
/// (`map_init` would make them afresh for every split, and a fresh grid costs a page fault
/// per page). A pair takes its thread's and puts them back: a pair that runs on the same
/// thread meanwhile (work stealing) finds none and makes its own, and results never depend
/// on what a buffer held before.
struct ThreadBuffers(Vec<Mutex<PairBuffers>>);

impl ThreadBuffers {
    /// One slot per thread of the pool the run is in.
    fn new() -> Self {
        Self(
            (0..rayon::current_num_threads())
                .map(|_| Mutex::default())
                .collect(),
        )
    }

    /// The slot of the thread that calls.
    fn of_this_thread(&self) -> &Mutex<PairBuffers> {
        let thread = rayon::current_thread_index().unwrap_or(0);
        &self.0[thread % self.0.len()]
    }
}

/// A variant as a pair's registrations use it: its registrar, the one a close start uses
/// when that differs, and its result on the pair before where starts chain pairs.
#[derive(Clone, Copy)]
struct Variant<'a> {
    registrar: &'a dyn Registrar,
    close: Option<&'a dyn Registrar>,
    previous: Option<&'a Previous>,
}

/// What the registrations of a block need besides the registrar and the pair.
struct BlockJob<'a> {
    ds: &'a Dataset,
    prepared: &'a PreparedScans<'a>,
    plan: &'a RunPlan<'a>,
}

impl BlockJob<'_> {
    /// The global search of `pair` (surfaces of the default parameters, which the runner
    /// always prepares when searches are made), its grid in storage from `pool`.
    fn search<'w>(
        &self,
        pair: ScanPair,
        workspace: &'w mut GlobalWorkspace,
        pool: &mut GridPool,
    ) -> (Option<Searched<'w>>, PairSearch) {
        let params = SurfaceParams::default();
        let prepared_scan =
            |k: usize| Prepared::new(&self.ds.scans[k], self.prepared.get(&params, k));
        let clock = Instant::now();
        let searched = Searched::new(
            prepared_scan(pair.reference),
            prepared_scan(pair.source),
            self.plan.global,
            self.plan.chain.global(),
            workspace,
            pool,
        );
        let time_us = clock.elapsed().as_secs_f64() * 1e6;
        match searched {
            Ok(s) => {
                let info = PairSearch {
                    result: Ok(s.guess().copied()),
                    time_us,
                };
                (Some(s), info)
            }
            Err(e) => (
                None,
                PairSearch {
                    result: Err(e),
                    time_us,
                },
            ),
        }
    }

    /// Registers `pair` with each of `variants`, in their order, from each start of the chain
    /// in turn, until its result is not flagged (else its last one is kept). The results of
    /// one start are checked together against the pair's global search (`searched`), lowest
    /// bar first (see [`Searched::check_all`]).
    fn run(
        &self,
        variants: &[Variant<'_>],
        workspace: &mut Workspace,
        pair: ScanPair,
        searched: Option<&Searched>,
    ) -> Vec<PairRun> {
        let dt_s = self.ds.pair_dt_s(pair);
        let mut time_us = vec![0.0; variants.len()];
        let mut kept: Vec<Option<PairRun>> = variants.iter().map(|_| None).collect();
        let mut pending: Vec<usize> = (0..variants.len()).collect();
        for (attempt, &mode) in self.plan.chain.modes().iter().enumerate() {
            let guess = searched.and_then(|s| s.guess());
            let mut results = Vec::with_capacity(pending.len());
            for &v in &pending {
                let Variant {
                    registrar,
                    close,
                    previous,
                } = variants[v];
                let params = registrar.surface_params();
                let prepared_scan =
                    |k: usize| Prepared::new(&self.ds.scans[k], self.prepared.get(&params, k));
                let (start, used) = init::start(mode, self.ds, pair, dt_s, previous, guess);
                let chosen = match close {
                    Some(gated) if used.is_close() => gated,
                    _ => registrar,
                };
                let clock = Instant::now();
                let result = chosen.register_prepared(
                    workspace,
                    prepared_scan(pair.source),
                    prepared_scan(pair.reference),
                    start,
                );
                time_us[v] += clock.elapsed().as_secs_f64() * 1e6;
                results.push((result, used));
            }
            let registrations: Vec<_> = results.iter().map(|(r, _)| r).collect();
            let checks = self.checks(&registrations, searched, pair);
            for ((&v, (result, used)), check) in pending.iter().zip(results).zip(checks) {
                let ambiguity = self.ambiguity(&result, check.as_ref(), searched, pair);
                kept[v] = Some(PairRun {
                    status: PairStatus::of(&result, check.as_ref(), ambiguity.as_ref()),
                    result,
                    check,
                    ambiguity,
                    init: Some(used),
                    attempts: attempt + 1,
                    time_us: Some(time_us[v]),
                    left_out: None,
                });
            }
            pending.retain(|&v| kept[v].as_ref().is_some_and(|r| r.status.is_failure()));
            if pending.is_empty() {
                break;
            }
        }
        kept.into_iter()
            .map(|run| run.expect("a chain has at least one mode"))
            .collect()
    }

    /// What the pair's global search says about each of `results` of `pair`'s source scan,
    /// when results are checked (`None` for a failed registration).
    fn checks(
        &self,
        results: &[&Result<Registration, IcpError>],
        searched: Option<&Searched>,
        pair: ScanPair,
    ) -> Vec<Option<GlobalCheck>> {
        let ok: Vec<&Registration> = results.iter().filter_map(|r| r.as_ref().ok()).collect();
        let mut answers = match searched {
            Some(s) if self.plan.check => s.check_all(&ok, &self.ds.scans[pair.source]),
            _ => Vec::new(),
        }
        .into_iter();
        results
            .iter()
            .map(|r| r.as_ref().ok().and_then(|_| answers.next()))
            .collect()
    }

    /// The ambiguity of `result` of `pair` on the pair's likelihood grid, when the plan asks
    /// for it, the grid was built and the result is weakly conditioned ([`Searched::ambiguity`];
    /// `None` for a failed registration).
    fn ambiguity(
        &self,
        result: &Result<Registration, IcpError>,
        check: Option<&GlobalCheck>,
        searched: Option<&Searched>,
        pair: ScanPair,
    ) -> Option<Result<Ambiguity, AmbiguityProblem>> {
        let (reg, searched) = (result.as_ref().ok()?, searched?);
        if !self.plan.ambiguity {
            return None;
        }
        searched.ambiguity(reg, check, &self.ds.scans[pair.source])
    }

    /// The external estimate of the pair at `position` in the run, assessed at its pose and
    /// checked as a registration is; a pair the file has no estimate for is a failure of
    /// the estimator.
    fn assess(
        &self,
        external: &ExternalEstimates,
        position: usize,
        pair: ScanPair,
        searched: Option<&Searched>,
    ) -> PairRun {
        let params = SurfaceParams::default();
        let prepared_scan =
            |k: usize| Prepared::new(&self.ds.scans[k], self.prepared.get(&params, k));
        let source = prepared_scan(pair.source);
        let result = match external.per_pair.get(position).copied().flatten() {
            Some(t_ref_src) => icp_core::assess(source, prepared_scan(pair.reference), t_ref_src),
            None => Err(IcpError::NoEstimate {
                why: format!(
                    "{} has none for scans {} → {}",
                    external.source.path.display(),
                    pair.source,
                    pair.reference
                ),
            }),
        };
        let check = self.checks(&[&result], searched, pair).remove(0);
        let ambiguity = self.ambiguity(&result, check.as_ref(), searched, pair);
        PairRun {
            status: PairStatus::of(&result, check.as_ref(), ambiguity.as_ref()),
            result,
            check,
            ambiguity,
            init: None,
            attempts: 0,
            time_us: None,
            left_out: None,
        }
    }
}

/// [`run_all`] with blocks of `block_pairs` pairs, the first of `pairs` at position `first`
/// of the run.
fn run_blocks(
    ds: &Dataset,
    pairs: &[ScanPair],
    methods: Methods<'_>,
    plan: &RunPlan<'_>,
    progress: &ProgressBar,
    block_pairs: usize,
    first: usize,
) -> Runs {
    let searches = plan.searches();
    let registrars = methods.registrars;
    // The searches and the external estimates' assessment use the default surfaces.
    let default_surfaces = searches || !methods.external.is_empty();
    let params = distinct_surface_params(
        registrars
            .iter()
            .map(|r| r.surface_params())
            .chain(default_surfaces.then(SurfaceParams::default)),
    );
    let mut prepared = PreparedScans {
        params: &params,
        per_scan: BTreeMap::new(),
    };
    let mut prepare_us = Vec::new();
    let mut pair_searches = Vec::new();
    let n = registrars.len();
    let mut per_variant: Vec<Vec<PairRun>> = (0..methods.len())
        .map(|_| Vec::with_capacity(pairs.len()))
        .collect();
    let thread_buffers = ThreadBuffers::new();
    // Where starts chain pairs: the searches of the pairs in flight and their grids' storage,
    // and each variant's registration buffers.
    let mut chained: Vec<GlobalWorkspace> = Vec::new();
    let mut chained_pools: Vec<GridPool> = Vec::new();
    let mut variant_workspaces: Vec<Workspace> = Vec::new();
    if plan.chain.sequential() {
        chained.resize_with(CHAINED_PAIRS, GlobalWorkspace::default);
        chained_pools.resize_with(CHAINED_PAIRS, GridPool::default);
        variant_workspaces.resize_with(n, Workspace::default);
    }
    for (b, block) in pairs.chunks(block_pairs).enumerate() {
        prepared.advance(ds, block, &mut prepare_us);
        let job = BlockJob {
            ds,
            prepared: &prepared,
            plan,
        };
        let position = |i: usize| first + b * block_pairs + i;
        // The external estimates of one pair, after its registrations.
        let assess_all = |i: usize, pair: ScanPair, searched: Option<&Searched>| {
            methods
                .external
                .iter()
                .map(|e| {
                    let run = job.assess(e, position(i), pair, searched);
                    progress.inc(1);
                    run
                })
                .collect::<Vec<PairRun>>()
        };
        if plan.chain.sequential() {
            // A start depends on the same variant's previous result: each variant runs the
            // pairs in order, the variants in parallel. The pairs' searches are made a few
            // pairs at a time, in parallel, and shared by every variant (one grid per pair);
            // the variants' checks ask them in any order, which changes no answer.
            for (p, part) in block.chunks(CHAINED_PAIRS).enumerate() {
                let built: Vec<(Option<Searched>, Option<PairSearch>)> = part
                    .par_iter()
                    .zip(chained.par_iter_mut())
                    .zip(chained_pools.par_iter_mut())
                    .map(|((&pair, gws), pool)| {
                        if !searches {
                            return (None, None);
                        }
                        let (searched, info) = job.search(pair, gws, pool);
                        (searched, Some(info))
                    })
                    .collect();
                let runs: Vec<Vec<PairRun>> = registrars
                    .par_iter()
                    .zip(per_variant.par_iter())
                    .zip(variant_workspaces.par_iter_mut())
                    .enumerate()
                    .map(|(v, ((reg, done), workspace))| {
                        // Carried over from the pairs before.
                        let mut previous = done
                            .last()
                            .map(|run| previous_of(ds, pairs[done.len() - 1], run));
                        part.iter()
                            .zip(&built)
                            .map(|(&pair, (searched, _))| {
                                let variant = Variant {
                                    registrar: reg.as_ref(),
                                    close: methods.gated(v),
                                    previous: previous.as_ref(),
                                };
                                let run = job
                                    .run(&[variant], workspace, pair, searched.as_ref())
                                    .remove(0);
                                progress.inc(1);
                                previous = Some(previous_of(ds, pair, &run));
                                run
                            })
                            .collect()
                    })
                    .collect();
                for (variant, part_runs) in per_variant.iter_mut().zip(runs) {
                    variant.extend(part_runs);
                }
                let assessed: Vec<Vec<PairRun>> = part
                    .par_iter()
                    .zip(built.par_iter())
                    .enumerate()
                    .map(|(i, (&pair, (searched, _)))| {
                        assess_all(p * CHAINED_PAIRS + i, pair, searched.as_ref())
                    })
                    .collect();
                for pair_runs in assessed {
                    for (variant, run) in per_variant[n..].iter_mut().zip(pair_runs) {
                        variant.push(run);
                    }
                }
                for ((searched, info), pool) in built.into_iter().zip(&mut chained_pools) {
                    pair_searches.extend(finish_search(searched, info, pool));
                }
            }
            continue;
        }
        let runs: Vec<(Vec<PairRun>, Option<PairSearch>)> = block
            .par_iter()
            .enumerate()
            .map(|(i, &pair)| {
                let slot = thread_buffers.of_this_thread();
                let mut buffers =
                    std::mem::take(&mut *slot.lock().unwrap_or_else(PoisonError::into_inner));
                let PairBuffers {
                    workspace,
                    global: gws,
                    pool,
                } = &mut buffers;
                let (searched, search) = if searches {
                    let (s, info) = job.search(pair, gws, pool);
                    (s, Some(info))
                } else {
                    (None, None)
                };
                // A workspace hands a variant the reference index and first matching of
                // the one before it on the same pair (same selection, matcher and start):
                // the first of such a group pays for both. Each pair runs its variants in
                // its own order, so every variant comes first in its group equally often
                // and the timings compare.
                let mut order: Vec<usize> = (0..n).collect();
                order.shuffle(&mut ChaCha8Rng::seed_from_u64(position(i) as u64));
                let variants: Vec<Variant> = order
                    .iter()
                    .map(|&v| Variant {
                        registrar: registrars[v].as_ref(),
                        close: methods.gated(v),
                        previous: None,
                    })
                    .collect();
                let ran = job.run(&variants, workspace, pair, searched.as_ref());
                progress.inc(n as u64);
                let mut runs: Vec<(usize, PairRun)> = order.into_iter().zip(ran).collect();
                runs.sort_by_key(|(v, _)| *v);
                let mut runs: Vec<PairRun> = runs.into_iter().map(|(_, run)| run).collect();
                runs.extend(assess_all(i, pair, searched.as_ref()));
                let search = finish_search(searched, search, pool);
                *slot.lock().unwrap_or_else(PoisonError::into_inner) = buffers;
                (runs, search)
            })
            .collect();
        for (pair_runs, search) in runs {
            for (variant, run) in per_variant.iter_mut().zip(pair_runs) {
                variant.push(run);
            }
            pair_searches.extend(search);
        }
    }
    Runs {
        per_variant,
        prepare_us,
        searches: pair_searches,
    }
}

/// The distinct parameter sets among `wanted`, in first-seen order: one surface estimate per
/// scan and set.
pub(crate) fn distinct_surface_params(
    wanted: impl Iterator<Item = SurfaceParams>,
) -> Vec<SurfaceParams> {
    let mut params: Vec<SurfaceParams> = Vec::new();
    for p in wanted {
        if !params.contains(&p) {
            params.push(p);
        }
    }
    params
}

/// A pair's search once its checks are done: its report with the checks' time added, its
/// grid's storage given back to `pool`.
fn finish_search(
    searched: Option<Searched>,
    info: Option<PairSearch>,
    pool: &mut GridPool,
) -> Option<PairSearch> {
    let check_us = searched.as_ref().map_or(0.0, Searched::check_us);
    if let Some(searched) = searched {
        searched.recycle(pool);
    }
    info.map(|info| PairSearch {
        time_us: info.time_us + check_us,
        ..info
    })
}

/// What a constant-velocity start of the next pair takes from `run` of `pair`: its estimate
/// unless it was flagged.
fn previous_of(ds: &Dataset, pair: ScanPair, run: &PairRun) -> Previous {
    Previous {
        pair,
        dt_s: ds.pair_dt_s(pair),
        t_ref_src: match (&run.result, &run.status) {
            (Ok(reg), PairStatus::Ok) => Some(reg.t_ref_src),
            _ => None,
        },
    }
}

/// A registration every test of the harness can start from.
#[cfg(test)]
impl PairRun {
    /// An ok registration at `t_ref_src` with `covariance`, as a registrar returns one.
    pub(crate) fn ok_for_test(
        t_ref_src: nalgebra::Isometry2<f64>,
        covariance: Option<icp_core::Covariance>,
    ) -> Self {
        Self {
            result: Ok(Registration {
                t_ref_src,
                iterations: 1,
                stop: icp_core::StopReason::Converged,
                n_pairs: 100,
                n_unusable: 0,
                weight_sum: 100.0,
                mean_residual_m: 0.01,
                conditioning: None,
                overlap: 1.0,
                covariance,
                jackknife_covariance: None,
            }),
            status: PairStatus::Ok,
            check: None,
            ambiguity: None,
            init: None,
            attempts: 1,
            time_us: None,
            left_out: None,
        }
    }
}

#[cfg(test)]
mod tests {
    use datasets::synthetic::{generate, Scenario};
    use icp_core::variants::builtin;

    use super::*;

    #[test]
    fn blocks_change_no_result_and_estimate_each_scan_once() {
        let ds = generate(&Scenario {
            n_scans: 12,
            ..Scenario::paper()
        })
        .unwrap();
        let (mut pairs, _) = ds.consecutive_pairs();
        // A pair out of order and a scan used far from its neighbours.
        pairs.push(ScanPair {
            source: 0,
            reference: 2,
        });
        let registrars: Vec<Box<dyn Registrar>> = ["HD_ICP", "GICP"]
            .iter()
            .map(|n| Box::new(builtin(n).unwrap().build().unwrap()) as Box<dyn Registrar>)
            .collect();
        let poses = |runs: &Runs| -> Vec<Vec<_>> {
            runs.per_variant
                .iter()
                .map(|v| {
                    v.iter()
                        .map(|r| r.result.as_ref().unwrap().t_ref_src)
                        .collect()
                })
                .collect()
        };
        let progress = ProgressBar::hidden();
        let chain = InitChain::default();
        let plan = RunPlan {
            chain: &chain,
            global: &GlobalParams::default(),
            check: true,
            ambiguity: true,
        };
        let methods = Methods::registrars(&registrars);
        let whole = run_blocks(&ds, &pairs, methods, &plan, &progress, BLOCK_PAIRS, 0);
        assert_eq!(whole.per_variant[0].len(), pairs.len());
        for block_pairs in [1, 2, 5] {
            let blocks = run_blocks(&ds, &pairs, methods, &plan, &progress, block_pairs, 0);
            assert_eq!(poses(&blocks), poses(&whole), "blocks of {block_pairs}");
            // Scans 0..12 once each, and scans 0 and 2 again for the last pair: its block
            // holds only the scans it shares with the block before (scan 10).
            let expected = if block_pairs >= pairs.len() { 12 } else { 14 };
            assert_eq!(blocks.prepare_us.len(), expected, "blocks of {block_pairs}");
        }
        assert_eq!(whole.prepare_us.len(), 12);
    }
}
