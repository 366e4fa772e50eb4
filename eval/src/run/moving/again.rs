//! The pairs registered again without the returns a detection left out of their scans, each
//! from its first result, with the verdict on a second registration that jumps (see the
//! module above).
//!
//! A masked scan and its surface estimates are made once per scan, detection and parameter
//! set, and shared by both pairs the scan belongs to and by every variant whose detections
//! and surface parameters are the same (the variants placed by one chain share its
//! detections): made per pair and variant, they were the larger part of the second
//! registrations' cost. They are made a block of pairs at a time, so that a long sequence
//! holds a block's scans, not all of them.

use std::collections::BTreeMap;
use std::time::Instant;

use datasets::{Dataset, ScanPair};
use icp_core::assess::local_fit;
use icp_core::moving::Detection;
use icp_core::{Prepared, Registrar, Scan, SurfaceParams, Surfaces, Workspace};
use nalgebra::Isometry2;
use rayon::prelude::*;

use super::{Detections, PULL_APART_DEG, PULL_APART_M};
use crate::run::left_out::{Confusion, LeftOut};
use crate::run::pair_search::answers_for_second;
use crate::run::runner::{PairRun, RunPlan, Runs};
use crate::run::status::{apart, PairStatus, SUSPECT_APART_DEG, SUSPECT_APART_M};

/// Pairs whose masked scans are held at once (as the runner's blocks of first registrations).
const BLOCK_PAIRS: usize = 256;

/// A scan without the returns its detection left out, with its surface estimates, and the
/// wall time of both, µs.
pub(super) struct Masked {
    scan: Scan,
    surfaces: Surfaces,
    us: f64,
}

impl Masked {
    pub(super) fn new(scan: &Scan, detection: &Detection, params: &SurfaceParams) -> Self {
        let clock = Instant::now();
        let scan = scan.without(&detection.left_out);
        let surfaces = Surfaces::estimate(&scan, params);
        let us = clock.elapsed().as_secs_f64() * 1e6;
        Self { scan, surfaces, us }
    }

    pub(super) fn prepared(&self) -> Prepared<'_> {
        Prepared::new(&self.scan, &self.surfaces)
    }
}

/// A registrar's `runs` of the pairs already registered again, each once from the first
/// result the registrar has now, without what `detections` left out (by a chain that
/// registers as the registrar does: its twin).
#[derive(Clone)]
pub struct Made {
    /// What was left out of the scans.
    pub detections: Detections,
    /// Per pair, in the order of the pairs registered again.
    pub runs: Vec<PairRun>,
}

/// Registers again, per registrar with `detections`, each of its registrations `runs` of
/// `pairs` whose scans have returns left out, from its first result, and records what was
/// left out (a pair with nothing left out keeps its result). A pair's time adds its second
/// registration, its source scan's detection and masked surfaces. Where a registrar's
/// pair was registered again already (`made`, per registrar; empty: none) with the same
/// detections in both scans, that run is taken (the same numbers, made once), its time
/// its own plus the source's detection.
pub fn register_again(
    ds: &Dataset,
    pairs: &[ScanPair],
    (registrars, plan): (&[Box<dyn Registrar>], &RunPlan<'_>),
    detections: &[Option<Detections>],
    made: &[Option<Made>],
    runs: &mut Runs,
) {
    // The distinct masks (detections, surface parameters) the registrars ask for, and each
    // registrar's.
    let mut groups: Vec<(&Detections, SurfaceParams)> = Vec::new();
    let group_of: Vec<Option<usize>> = registrars
        .iter()
        .zip(detections)
        .map(|(reg, found)| {
            let key = (found.as_ref()?, reg.surface_params());
            Some(match groups.iter().position(|g| *g == key) {
                Some(g) => g,
                None => {
                    groups.push(key);
                    groups.len() - 1
                }
            })
        })
        .collect();
    for (start, block) in (0..).step_by(BLOCK_PAIRS).zip(pairs.chunks(BLOCK_PAIRS)) {
        let masked = masked_scans(ds, block, &groups, &group_of, made);
        for (v, (reg, variant_runs)) in registrars
            .iter()
            .zip(runs.per_variant.iter_mut())
            .enumerate()
        {
            let Some(group) = group_of[v] else { continue };
            let (found, masked) = (groups[group].0, &masked[group]);
            let made = made.get(v).and_then(Option::as_ref);
            let reg = reg.as_ref();
            variant_runs[start..start + block.len()]
                .par_iter_mut()
                .zip(block.par_iter().enumerate())
                .for_each_init(Workspace::default, |workspace, (run, (i, pair))| {
                    let (Some((src, src_us)), Some((dst, _))) =
                        (found.get(&pair.source), found.get(&pair.reference))
                    else {
                        return;
                    };
                    if let Some(made) = made.filter(|m| same(&m.detections, found, pair)) {
                        let time_us = run.time_us.map(|t| t + src_us);
                        *run = PairRun {
                            time_us,
                            ..made.runs[start + i].clone()
                        };
                        return;
                    }
                    run.left_out = Some(LeftOut {
                        source: src.count(),
                        reference: dst.count(),
                        source_truth: Confusion::of(&ds.scans[pair.source], src),
                        source_indices: indices(&src.left_out),
                        reference_indices: indices(&dst.left_out),
                        result_without: false,
                    });
                    if run.result.is_ok() && src.count() + dst.count() > 0 {
                        let (ms, mr) = (&masked[&pair.source], &masked[&pair.reference]);
                        again(
                            (reg, plan),
                            workspace,
                            (src, dst),
                            (ms.prepared(), mr.prepared()),
                            (&ds.scans[pair.source], &ds.scans[pair.reference]),
                            run,
                        );
                        if let Some(t) = run.time_us.as_mut() {
                            *t += ms.us;
                        }
                    }
                    if let Some(t) = run.time_us.as_mut() {
                        *t += src_us;
                    }
                });
        }
    }
}

/// Whether `a` and `b` leave the same returns out of both scans of `pair` (what a second
/// registration reads of a detection: its share and split follow from them, and the count of
/// returns seen to move, which may differ, is not read).
fn same(a: &Detections, b: &Detections, pair: &ScanPair) -> bool {
    [pair.source, pair.reference].into_iter().all(|k| {
        let (a, b) = (a.get(&k), b.get(&k));
        a.map(|(d, _)| &d.left_out) == b.map(|(d, _)| &d.left_out)
    })
}

/// Per group (detections, surface parameters; `group_of` per registrar), the masked scans of
/// the pairs of `block` that have returns left out and that some registrar of the group has
/// not `made` already.
fn masked_scans(
    ds: &Dataset,
    block: &[ScanPair],
    groups: &[(&Detections, SurfaceParams)],
    group_of: &[Option<usize>],
    made: &[Option<Made>],
) -> Vec<BTreeMap<usize, Masked>> {
    groups
        .iter()
        .enumerate()
        .map(|(g, (found, params))| {
            // The group's registrars' runs already made, or none where one of them has none.
            let made: Option<Vec<&Made>> = group_of
                .iter()
                .enumerate()
                .filter(|(_, of)| **of == Some(g))
                .map(|(v, _)| made.get(v).and_then(Option::as_ref))
                .collect();
            let mut scans: Vec<(usize, &Detection)> = Vec::new();
            for pair in block {
                let (Some((src, _)), Some((dst, _))) =
                    (found.get(&pair.source), found.get(&pair.reference))
                else {
                    continue;
                };
                let all_made = made
                    .as_ref()
                    .is_some_and(|m| m.iter().all(|m| same(&m.detections, found, pair)));
                if src.count() + dst.count() > 0 && !all_made {
                    scans.extend([(pair.source, src), (pair.reference, dst)]);
                }
            }
            scans.sort_unstable_by_key(|(k, _)| *k);
            scans.dedup_by_key(|(k, _)| *k);
            scans
                .par_iter()
                .map(|&(k, detection)| (k, Masked::new(&ds.scans[k], detection, params)))
                .collect()
        })
        .collect()
}

/// The pair's registration again from its first result `run`, on its scans without the
/// returns `(src, dst)` left out (`masked`). A second result that left the first's peak is
/// checked and its ambiguity assessed again on the whole scans (`scans`, source and
/// reference), as `plan` asks ([`answers_for_second`]): the first result's answers describe
/// another pose.
pub(super) fn again(
    (reg, plan): (&dyn Registrar, &RunPlan<'_>),
    workspace: &mut Workspace,
    (src, dst): (&Detection, &Detection),
    (source, reference): (Prepared<'_>, Prepared<'_>),
    scans: (&Scan, &Scan),
    run: &mut PairRun,
) {
    let Ok(first) = &run.result else { return };
    let clock = Instant::now();
    let result = reg.register_prepared(workspace, source, reference, first.t_ref_src);
    if let Some(t) = run.time_us.as_mut() {
        *t += clock.elapsed().as_secs_f64() * 1e6;
    }
    let Ok(without) = &result else {
        // Too few returns left to register, say: the pair fails with the reason.
        run.status = PairStatus::of(&result, run.check.as_ref(), run.ambiguity.as_ref());
        run.result = result;
        return;
    };
    // Split evidence: the motion without the moving returns is far from the one it started
    // from (another basin, whatever its own verdict: the start, which the round before agreed
    // on, is kept), or much of a scan moves (the result without them is kept).
    let jumped = beyond(
        &first.t_ref_src,
        &without.t_ref_src,
        SUSPECT_APART_M,
        SUSPECT_APART_DEG,
    );
    let dynamic = PairStatus::Dynamic {
        source_share: src.moving_share,
        reference_share: dst.moving_share,
        without: without.t_ref_src,
        with: first.t_ref_src,
    };
    if jumped {
        // Split evidence only if the kept returns pull the start away too; if they fit it, the
        // second registration wandered into another basin, and the start (the round before's
        // result, with its status) stands. A fit that cannot be made keeps the flag.
        let pulled = local_fit(source, reference, first.t_ref_src).map_or(true, |fit| {
            beyond(&first.t_ref_src, &fit, PULL_APART_M, PULL_APART_DEG)
        });
        if pulled {
            run.status = dynamic;
        }
        return;
    }
    let clock = Instant::now();
    (run.check, run.ambiguity) = answers_for_second(
        (&first.t_ref_src, (run.check, run.ambiguity.take())),
        without,
        scans,
        (plan.global, (plan.check, plan.ambiguity)),
    );
    if let Some(t) = run.time_us.as_mut() {
        *t += clock.elapsed().as_secs_f64() * 1e6;
    }
    let status = PairStatus::of(&result, run.check.as_ref(), run.ambiguity.as_ref());
    let mut result = result;
    if let Ok(r) = result.as_mut() {
        // The work of both registrations.
        r.iterations += first.iterations;
    }
    run.status = if !status.is_failure() && (src.split || dst.split) {
        dynamic
    } else {
        status
    };
    run.result = result;
    if let Some(left_out) = run.left_out.as_mut() {
        left_out.result_without = true;
    }
}

/// The indices of the returns marked in `left_out`.
fn indices(left_out: &[bool]) -> Vec<u32> {
    (0..)
        .zip(left_out)
        .filter_map(|(i, &out)| out.then_some(i))
        .collect()
}

/// True when `b` lies farther from `a` than `m` metres or `deg` degrees ([`apart`]).
fn beyond(a: &Isometry2<f64>, b: &Isometry2<f64>, m: f64, deg: f64) -> bool {
    let (apart_m, apart_deg) = apart(a, b);
    apart_m > m || apart_deg > deg
}
