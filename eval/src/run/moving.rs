//! The second pass of a variant with a detector of moving returns ([`icp_core::moving`]): once
//! every consecutive pair is registered, each scan's detector runs against its neighbours
//! (k−L..k+L, chained through the same variant's registrations whose status is `ok`, and over
//! its `dynamic` ones by registrations that skip them, `moving::bridges`, or where none holds
//! by the trusted steps on either side, [`icp_core::moving::predicted`]), each
//! scan's detection is completed from what the scans on either side left out
//! ([`MovingReturns::fill_between`]), and
//! every pair whose scans have returns left out is registered again without them, starting
//! from its first result (`again`). The first result's global check and ambiguity are kept
//! (the second starts in its basin). A pair whose evidence is split is flagged `dynamic`,
//! with both motions in its reason: more of a scan's scene moves than the detector's bar (the
//! result without the moving returns is kept), or the motion without them lies farther from
//! the one the round started from than the global check's
//! [`SUSPECT_APART_M`](crate::run::status::SUSPECT_APART_M) or
//! [`SUSPECT_APART_DEG`](crate::run::status::SUSPECT_APART_DEG) (the second registration
//! found another basin; the start is kept) while the kept returns themselves pull the start
//! away ([`PULL_APART_M`], [`PULL_APART_DEG`]). A jump from a start that the kept returns fit
//! is the second registration wandering off, not split evidence: the
//! pair keeps its start and its status.
//!
//! A detection depends on the variant's registrations of the whole sequence, so a sharded run
//! gives each shard whole variants (the variant cut of the `shard` module), as for starts
//! that chain pairs.

mod again;
mod bridges;

use std::collections::{BTreeMap, BTreeSet};
use std::time::Instant;

use datasets::{Dataset, ScanPair};
use icp_core::moving::{
    beside, left_out_points, predicted, Detection, MovingReturns, Neighbour, Placement, RangeImage,
    Step,
};
use icp_core::registry::StageSpec;
use icp_core::spec::VariantSpec;
use icp_core::variants::placement_chain;
use icp_core::Icp;
use icp_core::Registrar;
use indicatif::ProgressBar;
use nalgebra::Matrix3;
use rayon::prelude::*;

pub use again::{register_again, Made};
use bridges::{link, Bridging, Link};

use crate::run::covariance::closed_form_inflation;
use crate::run::extended::extended;
use crate::run::lags::LagRuns;
use crate::run::left_out::DrawnScan;
use crate::run::runner::{self, run_scans, Methods, PairRun, RunPlan, Runs};
use crate::run::status::PairStatus;

/// A jump is split evidence only when the kept returns alone, paired once at the start
/// ([`local_fit`](icp_core::assess::local_fit)), pull it farther than this, m…
///
/// Chosen on `synthetic:rough` seeds 7, 11 and 13 and `synthetic:corridor` seeds 5 and 21
/// (the corridor with `--init global --lags 2`), never on seed 2022 or aces, which are the
/// checks. There the local fit pulls a jump's start about as far as the start is off the
/// truth: of the consecutive pairs' jumps, the 37 from wrong starts (more than 0.1 m or 1°
/// off) were pulled 0.046 m or more, so none loses its flag; of the 33 from right starts, 21
/// were pulled less than 0.04 m and 0.4° (the largest turn among them 0.35°). A bar nearer
/// 0.1 m would free more right starts but unflag wrong ones (pulls of 0.046 and 0.095 m).
pub const PULL_APART_M: f64 = 0.04;
/// …or than this, degrees (chosen with [`PULL_APART_M`]).
pub const PULL_APART_DEG: f64 = 0.4;

/// The scan to draw: of the first method (in `names`' order, `runs`' methods) whose detector
/// left returns out, the source scan of the pair whose source lost the most (the earliest
/// such pair on a tie).
pub fn drawn_scan(names: &[&str], pairs: &[ScanPair], runs: &Runs) -> Option<DrawnScan> {
    names
        .iter()
        .zip(&runs.per_variant)
        .find_map(|(name, variant_runs)| {
            let (pair, left_out) = pairs
                .iter()
                .zip(variant_runs)
                .filter_map(|(p, r)| Some((p, r.left_out.as_ref()?)))
                .filter(|(_, l)| !l.source_indices.is_empty())
                .rev()
                .max_by_key(|(_, l)| l.source_indices.len())?;
            Some(DrawnScan {
                variant: (*name).to_owned(),
                scan: pair.source,
                left_out: left_out.source_indices.clone(),
            })
        })
}

/// The second pass over a run: detections in the scans of the consecutive `pairs`, then those
/// pairs and the ones across lags (`lagged`) registered again without what was found.
///
/// A detector that places its neighbours by the stage's own point-to-line registrations
/// ([`Placement::PointToLine`]) gets them here: the chain (`icp_core::variants::placement_chain`)
/// registers `pairs` as `plan` says (or, when a variant of `methods` registers exactly as the
/// chain does, its first results are taken: the same numbers, made once), runs its detector's
/// rounds on itself, and its last round's detections serve every variant whose chain is the
/// same (one chain per distinct one, so a shard that holds some of the variants makes the
/// same); each such variant registers its pairs once more without them. A detector placing by
/// its variant's own registrations runs as many rounds as it asks, each from the results of
/// the round before.
pub fn apply(
    ds: &Dataset,
    pairs: &[ScanPair],
    methods: Methods<'_>,
    runs: &mut Runs,
    lagged: Option<&mut LagRuns>,
    plan: &RunPlan<'_>,
) {
    let registrars = methods.registrars;
    let images = images(ds, pairs, registrars);
    let mut placed = vec![None; registrars.len()];
    // A twin's pairs that its chain registered again with the detections it gets now.
    let mut made: Vec<Option<Made>> = vec![None; registrars.len()];
    let mut unjudged: Vec<BTreeMap<usize, PairStatus>> = vec![BTreeMap::new(); registrars.len()];
    for (spec, chain, users) in placement_chains(registrars) {
        let twin = registrars.iter().enumerate().position(|(v, r)| {
            let gated = methods.close.get(v).is_some_and(Option::is_some);
            !gated && registers_as(&r.spec(), &spec)
        });
        let chain: [Box<dyn Registrar>; 1] = [Box::new(chain)];
        let mut chain_runs = match twin {
            Some(v) => Runs {
                // Their time is the variant's own; the chain's adds what follows.
                per_variant: vec![runs.per_variant[v]
                    .iter()
                    .map(|r| PairRun {
                        time_us: r.time_us.map(|_| 0.0),
                        ..r.clone()
                    })
                    .collect()],
                prepare_us: Vec::new(),
                searches: Vec::new(),
            },
            None => runner::run_all(
                ds,
                pairs,
                Methods::registrars(&chain),
                plan,
                &ProgressBar::hidden(),
            ),
        };
        let (mut last, once) = rounds(ds, pairs, &images, (&chain, plan), &mut chain_runs);
        let mut last = last.pop().flatten();
        if let Some(last) = last.as_mut() {
            // Each scan's share of the chain's work: its pair's registrations and detections.
            for (pair, run) in pairs.iter().zip(&chain_runs.per_variant[0]) {
                if let Some((_, us)) = last.get_mut(&pair.source) {
                    *us = run.time_us.unwrap_or(0.0);
                }
            }
        }
        let isolated = isolated(pairs, &chain_runs.per_variant[0]);
        for v in users {
            placed[v].clone_from(&last);
            unjudged[v].clone_from(&isolated);
        }
        if let (Some(v), Some(Some(detections))) = (twin, once.into_iter().next()) {
            // The chain's runs are the twin's first results registered again once.
            made[v] = Some(Made {
                detections,
                runs: chain_runs.per_variant.swap_remove(0),
            });
        }
    }
    let (mut found, _) = rounds(ds, pairs, &images, (registrars, plan), runs);
    for (f, p) in found.iter_mut().zip(placed) {
        if p.is_some() {
            *f = p;
        }
    }
    register_again(ds, pairs, (registrars, plan), &found, &made, runs);
    let unjudged = confirmed(pairs, unjudged, runs);
    flag_isolated(pairs, &unjudged, runs);
    if let Some(lagged) = lagged {
        let lag_pairs: Vec<ScanPair> = lagged.pairs.iter().map(|p| p.pair).collect();
        register_again(
            ds,
            &lag_pairs,
            (registrars, plan),
            &found,
            &[],
            &mut lagged.runs,
        );
    }
}

/// The scans that fit neither neighbour by the registrations `runs` of the consecutive
/// `pairs`: both of theirs are flagged as not seeing one scene (no overlap, suspect, dynamic,
/// failed; a degenerate or ambiguous registration is weak geometry, not another scene), each
/// with its flag. A variant's pairs with such a scan are flagged where its own registration
/// onto or from the scan is flagged too ([`confirmed`]).
fn isolated(pairs: &[ScanPair], runs: &[PairRun]) -> BTreeMap<usize, PairStatus> {
    let steps: BTreeMap<usize, &PairStatus> = pairs
        .iter()
        .zip(runs)
        .filter(|(p, _)| p.reference == p.source + 1)
        .map(|(p, r)| (p.source, &r.status))
        .collect();
    let said = |s: &PairStatus| {
        let kind = serde_json::to_value(s.kind()).expect("a kind serializes");
        format!("{} ({s})", kind.as_str().unwrap_or_default())
    };
    steps
        .iter()
        .filter_map(|(&k, &after)| {
            let before = *steps.get(&k.checked_sub(1)?)?;
            (another_scene(before) && another_scene(after)).then(|| {
                let status = PairStatus::Isolated {
                    scan: k,
                    before: said(before),
                    after: said(after),
                };
                (k, status)
            })
        })
        .collect()
}

/// Whether a registration's flag says its scans do not see one scene (no overlap, suspect,
/// dynamic, failed); a degenerate or ambiguous registration is weak geometry, not another
/// scene, and a flag from the loops or the smoother is not the registration's own.
fn another_scene(status: &PairStatus) -> bool {
    matches!(
        status,
        PairStatus::NoOverlap { .. }
            | PairStatus::Suspect { .. }
            | PairStatus::Dynamic { .. }
            | PairStatus::Failed { .. }
    )
}

/// Of each registrar's `unjudged` scans, those where its own registration onto or from the
/// scan (`runs` of the consecutive `pairs`) is flagged too, as not seeing one scene
/// ([`another_scene`]): the placing registrations alone can be wrong where the variant is
/// right (on aces they are, at 7 scans of 440), and the variant's weak geometry on one side
/// (degenerate, ambiguous) says nothing of what the scan sees.
fn confirmed(
    pairs: &[ScanPair],
    unjudged: Vec<BTreeMap<usize, PairStatus>>,
    runs: &Runs,
) -> Vec<BTreeMap<usize, PairStatus>> {
    unjudged
        .into_iter()
        .zip(&runs.per_variant)
        .map(|(scans, variant_runs)| {
            let flagged: BTreeSet<usize> = pairs
                .iter()
                .zip(variant_runs)
                .filter(|(p, r)| p.reference == p.source + 1 && another_scene(&r.status))
                .flat_map(|(p, _)| [p.source, p.reference])
                .collect();
            scans
                .into_iter()
                .filter(|(k, _)| flagged.contains(k))
                .collect()
        })
        .collect()
}

/// Flags, per registrar, its `ok` registrations `runs` of `pairs` that have a scan in its
/// `unjudged` ones (the consecutive pairs: a pair across lags is judged by its loops).
fn flag_isolated(pairs: &[ScanPair], unjudged: &[BTreeMap<usize, PairStatus>], runs: &mut Runs) {
    for (scans, variant_runs) in unjudged.iter().zip(runs.per_variant.iter_mut()) {
        for (pair, run) in pairs.iter().zip(variant_runs.iter_mut()) {
            let flag = scans
                .get(&pair.source)
                .or_else(|| scans.get(&pair.reference));
            if let (Some(flag), PairStatus::Ok) = (flag, &run.status) {
                run.status = flag.clone();
            }
        }
    }
}

/// The distinct chains of registrations that place the neighbours of `registrars`' detectors
/// asking for the stage's own ([`Placement::PointToLine`]), built, each with the registrars
/// (indices) it serves, in the order of their first user.
fn placement_chains(registrars: &[Box<dyn Registrar>]) -> Vec<(VariantSpec, Icp, Vec<usize>)> {
    let mut chains: Vec<(VariantSpec, Icp, Vec<usize>)> = Vec::new();
    for (v, reg) in registrars.iter().enumerate() {
        let Ok(Some(spec)) = placement_chain(&reg.spec()) else {
            continue;
        };
        match chains.iter_mut().find(|(s, ..)| *s == spec) {
            Some((_, _, users)) => users.push(v),
            None => {
                let built = spec.build().expect("PL_ICP's configuration builds");
                chains.push((spec, built, vec![v]));
            }
        }
    }
    chains
}

/// Whether a variant `spec` registers exactly as `chain` does: the same configuration but for
/// the name and the detector (which acts only after the first registrations).
fn registers_as(spec: &VariantSpec, chain: &VariantSpec) -> bool {
    let registration = |s: &VariantSpec| VariantSpec {
        name: String::new(),
        moving: StageSpec::kind("none"),
        ..s.clone()
    };
    registration(spec) == registration(chain)
}

/// The rounds of the detectors of `registrars` that place their neighbours by the variant's
/// own registrations `runs` of `pairs` (the scans' range `images`): each round detects from
/// the results of the round before and registers the consecutive pairs again. Per
/// registrar, the last round's detections (`None` without such a detector), and those its
/// `runs` were registered again with where that was once (`None`: never, or more than once,
/// each time from the last).
fn rounds(
    ds: &Dataset,
    pairs: &[ScanPair],
    images: &BTreeMap<usize, RangeImage>,
    (registrars, plan): (&[Box<dyn Registrar>], &RunPlan<'_>),
    runs: &mut Runs,
) -> (Vec<Option<Detections>>, Vec<Option<Detections>>) {
    let own = |r: &dyn Registrar| own_detector(r, 0).map_or(0, |m| m.rounds());
    let rounds = registrars
        .iter()
        .map(|r| own(r.as_ref()))
        .max()
        .unwrap_or(0);
    let mut last: Vec<Option<Detections>> = vec![None; registrars.len()];
    // Per registrar, how many times its runs were registered again, and with what the last
    // time (what the rounds before left out; the bridges are registered again with it too).
    let mut times = vec![0usize; registrars.len()];
    let mut found: Vec<Option<Detections>> = vec![None; registrars.len()];
    // The bridges over the steps each chain does not trust, registered as they are asked for.
    let mut bridging = Bridging::default();
    for round in 0..rounds {
        bridging.ask((ds, pairs), (registrars, plan), (runs, round), &found);
        let detections = detect((ds, pairs), images, (registrars, runs), round, &bridging);
        // The last round's registrations are made by the caller, with the lag pairs'.
        let later: Vec<Option<Detections>> = detections
            .iter()
            .zip(registrars)
            .map(|(d, r)| d.clone().filter(|_| own(r.as_ref()) > round + 1))
            .collect();
        register_again(ds, pairs, (registrars, plan), &later, &[], runs);
        bridging.again(ds, (registrars, plan), &later);
        for ((t, f), d) in times.iter_mut().zip(&mut found).zip(&later) {
            if d.is_some() {
                *t += 1;
                f.clone_from(d);
            }
        }
        for (l, d) in last.iter_mut().zip(detections) {
            if d.is_some() {
                *l = d;
            }
        }
    }
    bridging.charge(runs);
    let once = found
        .into_iter()
        .zip(times)
        .map(|(with, t)| with.filter(|_| t == 1))
        .collect();
    (last, once)
}

/// Per scan, a variant's detection, and its wall time, µs.
pub type Detections = BTreeMap<usize, (Detection, f64)>;

/// The range images of the scans of `pairs` where one of `registrars` detects (none
/// otherwise), made once per run: every round and every chain asks the same scans, and an
/// image keeps the window minima its first detection made.
fn images(
    ds: &Dataset,
    pairs: &[ScanPair],
    registrars: &[Box<dyn Registrar>],
) -> BTreeMap<usize, RangeImage> {
    if !registrars.iter().any(|r| r.moving().is_some()) {
        return BTreeMap::new();
    }
    run_scans(pairs)
        .par_iter()
        .map(|&k| (k, RangeImage::new(&ds.scans[k])))
        .collect()
}

/// Per registrar (in order), its detections in the scans of `pairs` (whose range `images`
/// they read) from its registrations `runs` of them and the `bridging` ones over the steps it
/// does not trust (`None`: the registrar has no detector, or one of no more than `round`
/// rounds).
fn detect(
    (ds, pairs): (&Dataset, &[ScanPair]),
    images: &BTreeMap<usize, RangeImage>,
    (registrars, runs): (&[Box<dyn Registrar>], &Runs),
    round: usize,
    bridging: &Bridging,
) -> Vec<Option<Detections>> {
    let scans = run_scans(pairs);
    registrars
        .iter()
        .zip(&runs.per_variant)
        .enumerate()
        .map(|(v, (reg, variant_runs))| {
            let detector = own_detector(reg.as_ref(), round)?;
            let sensor = reg.spec().sensor;
            let inflation = closed_form_inflation(&reg.spec().metric);
            let steps = steps(ds.scans.len(), pairs, variant_runs, inflation);
            let bridges = bridging.of(v, |run| step_of(run, inflation));
            let split = splits(ds.scans.len(), pairs, variant_runs);
            let max_turn_rad = sensor.bearing_difference_sd_rad();
            let steps = predicted(&steps, &bridges, |i| split[i], max_turn_rad);
            let detected: Detections = scans
                .par_iter()
                .map(|&k| {
                    let clock = Instant::now();
                    let chain = (&steps[..], &bridges);
                    let neighbours =
                        Neighbour::placed(chain, k, detector.lag_scans(), |j| images.get(&j));
                    let detection = detector.detect(&ds.scans[k], &neighbours, &sensor);
                    (k, (detection, clock.elapsed().as_secs_f64() * 1e6))
                })
                .collect();
            Some(fill_between(ds, detector, &steps, &detected))
        })
        .collect()
}

/// `reg`'s detector where it places by the variant's own registrations and runs more than
/// `round` rounds.
fn own_detector(reg: &dyn Registrar, round: usize) -> Option<&dyn MovingReturns> {
    reg.moving()
        .filter(|m| m.placement() == Placement::Own && m.rounds() > round)
}

/// Each scan's detection in `detected` completed from what the scans on either side left out
/// (placed by `steps`; [`MovingReturns::fill_between`]), each from the detections before any
/// was completed.
fn fill_between(
    ds: &Dataset,
    detector: &dyn MovingReturns,
    steps: &[Option<Step>],
    detected: &Detections,
) -> Detections {
    detected
        .par_iter()
        .map(|(&k, (detection, us))| {
            let clock = Instant::now();
            let [before, after] = beside(k, steps, |j, t_k_j| {
                detected
                    .get(&j)
                    .map_or_else(Vec::new, |(d, _)| left_out_points(&ds.scans[j], d, t_k_j))
            });
            let filled = detector.fill_between(&ds.scans[k], detection.clone(), &before, &after);
            (k, (filled, us + clock.elapsed().as_secs_f64() * 1e6))
        })
        .collect()
}

/// Per scan i, the registration of scan i onto i+1 where it is among `pairs` and a step
/// ([`step_of`]).
fn steps(scans: usize, pairs: &[ScanPair], runs: &[PairRun], inflation: f64) -> Vec<Option<Step>> {
    let mut steps = vec![None; scans];
    for (pair, run) in pairs.iter().zip(runs) {
        if pair.reference == pair.source + 1 {
            if let Some(step) = step_of(run, inflation) {
                steps[pair.source] = Some(step);
            }
        }
    }
    steps
}

/// Per scan i, whether the consecutive pair i → i+1 is among `pairs` and flagged `dynamic`
/// ([`Link::Split`]): the steps a bridge may span or, where none holds, the trusted steps on
/// either side predict ([`predicted`]; steps flagged as not seeing one scene, or of weak
/// geometry, are neither: on the corridor their predictions left out twice the static returns,
/// docs/moving-returns.md).
fn splits(scans: usize, pairs: &[ScanPair], runs: &[PairRun]) -> Vec<bool> {
    let mut split = vec![false; scans];
    for (&pair, run) in pairs.iter().zip(runs) {
        if link(pair, run) == Link::Split {
            split[pair.source] = true;
        }
    }
    split
}

/// A registration `run` as a step of a chain, where it is one ([`is_step`]): its motion with
/// its extended covariance (the closed form times `inflation`, lifted to what its residuals
/// show: [`extended`]; zero where it has none, and the detector's floor then speaks).
fn step_of(run: &PairRun, inflation: f64) -> Option<Step> {
    let reg = run.result.as_ref().ok().filter(|_| is_step(run))?;
    let covariance = extended(reg, inflation)
        .and_then(|c| c.bounded().copied())
        .unwrap_or_else(Matrix3::zeros);
    Some((reg.t_ref_src, covariance))
}

/// Whether a chain takes a registration `run` as a step: it has a result, and its status is
/// `ok`.
fn is_step(run: &PairRun) -> bool {
    run.result.is_ok() && run.status == PairStatus::Ok
}

#[cfg(test)]
mod tests;
