//! Bridges over the consecutive registrations a detector's chain does not trust
//! ([`icp_core::moving::Bridges`]). Where the hulls pass, consecutive pairs get flagged
//! `dynamic` (the moving returns split their evidence), and a chain that stops at them cannot
//! place the scans beyond: a scan near such a step is judged by the neighbours of one side,
//! and misses what moves there. A registration of the scan the flagged steps start from onto
//! the scan one trusted step beyond them (skipping the scans the flags fall on), made as a
//! pair across lags is (`--lags`: the same init chain and checks, the search window scaled to
//! its lag) and trusted only where its own status is `ok`, carries the chain over them.
//!
//! Steps flagged as not seeing one scene (no overlap, suspect, failed) are not bridged: on
//! aces (`--init global --lags 2`) bridges over them were `ok` and wrong along the corridor,
//! and the neighbours placed through them saw its walls move (docs/moving-returns.md).

use datasets::{Dataset, ScanPair};
use icp_core::moving::{Bridges, Step, MAX_UNTRUSTED_STEPS};
use icp_core::Registrar;
use indicatif::ProgressBar;

use super::{is_step, own_detector, register_again, Detections};
use crate::run::lags::{self, LagPair, LagRuns};
use crate::run::runner::{Methods, PairRun, RunPlan, Runs};
use crate::run::status::PairStatus;

/// What a chain makes of a pair of the run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Link {
    /// A step it takes.
    Trusted,
    /// A consecutive pair flagged `dynamic`: moving returns split its evidence, and a bridge
    /// may span it (or, where none holds, the trusted steps on either side predict it).
    Split,
    /// Neither: not consecutive, or flagged otherwise (no overlap, suspect and failed say its
    /// scans may not see one scene, where a registration across them cannot be trusted
    /// either; degenerate and ambiguous, weak geometry, which a bridge would share).
    Absent,
}

/// What a chain makes of `pair`, registered as `run`.
pub fn link(pair: ScanPair, run: &PairRun) -> Link {
    if pair.reference != pair.source + 1 {
        Link::Absent
    } else if is_step(run) {
        Link::Trusted
    } else if matches!(run.status, PairStatus::Dynamic { .. }) {
        Link::Split
    } else {
        Link::Absent
    }
}

/// The bridges a chain through the run's consecutive `pairs` asks for (`link`: what it makes
/// of the pair at a position): per maximal run of at most [`MAX_UNTRUSTED_STEPS`] `Split`
/// steps `a → … → c` followed by a trusted step `c → c+1`, the pair `a → c+1` (a bridge
/// skips the steps' scans but the first and lands one trusted step beyond them: a pair
/// across at most 3 scans).
pub fn wanted(pairs: &[ScanPair], link: impl Fn(usize) -> Link) -> Vec<LagPair> {
    let joined = |i: usize, j: usize| pairs[j].source == pairs[i].reference;
    let mut out = Vec::new();
    let mut first = 0;
    while first < pairs.len() {
        if link(first) != Link::Split {
            first += 1;
            continue;
        }
        let mut last = first;
        while last + 1 < pairs.len() && joined(last, last + 1) && link(last + 1) == Link::Split {
            last += 1;
        }
        let next = last + 1;
        let lands = next < pairs.len() && joined(last, next) && link(next) == Link::Trusted;
        if lands && last - first < MAX_UNTRUSTED_STEPS {
            out.push(LagPair {
                pair: ScanPair {
                    source: pairs[first].source,
                    reference: pairs[next].reference,
                },
                lag: next - first + 1,
                first,
            });
        }
        first = next;
    }
    out
}

/// The bridges of a detector's rounds, per registrar (each registers its own): those its
/// chain asks for now, and every one it registered so far (again without what each round
/// found, as its consecutive pairs are).
#[derive(Default)]
pub struct Bridging {
    chains: Vec<Chain>,
}

/// One registrar's bridges.
#[derive(Default)]
struct Chain {
    /// The bridges it asks for in this round.
    wanted: Vec<LagPair>,
    /// Every bridge it registered so far.
    made: Option<LagRuns>,
}

impl Bridging {
    /// Asks, per registrar detecting in `round` by its own `runs` of the consecutive `pairs`,
    /// for the bridges its chain wants ([`wanted`]), and registers those it has not made yet
    /// as `plan` says, then again without what the rounds before found (`found`; none in the
    /// first round).
    pub fn ask(
        &mut self,
        (ds, pairs): (&Dataset, &[ScanPair]),
        (registrars, plan): (&[Box<dyn Registrar>], &RunPlan<'_>),
        (runs, round): (&Runs, usize),
        found: &[Option<Detections>],
    ) {
        self.chains.resize_with(registrars.len(), Chain::default);
        for (v, chain) in self.chains.iter_mut().enumerate() {
            chain.wanted = match own_detector(registrars[v].as_ref(), round) {
                Some(_) => {
                    let variant_runs = &runs.per_variant[v];
                    wanted(pairs, |i| link(pairs[i], &variant_runs[i]))
                }
                None => Vec::new(),
            };
            let one = (std::slice::from_ref(&registrars[v]), plan);
            chain.register(ds, one, std::slice::from_ref(&found[v]));
        }
    }

    /// Registrar `v`'s bridges that its chain takes: those it asks for whose registration is
    /// a step (`step`; `ok`).
    pub fn of(&self, v: usize, step: impl Fn(&PairRun) -> Option<Step>) -> Bridges {
        let Some(Chain {
            wanted,
            made: Some(made),
        }) = self.chains.get(v)
        else {
            return Bridges::new();
        };
        wanted
            .iter()
            .filter_map(|w| {
                let i = made.pairs.iter().position(|p| p == w)?;
                Some((
                    w.pair.source,
                    (w.pair.reference, step(&made.runs.per_variant[0][i])?),
                ))
            })
            .collect()
    }

    /// Every bridge registered again, per registrar, without what `found` left out (a
    /// registrar without a detection keeps its bridges as they are).
    pub fn again(
        &mut self,
        ds: &Dataset,
        (registrars, plan): (&[Box<dyn Registrar>], &RunPlan<'_>),
        found: &[Option<Detections>],
    ) {
        for (v, chain) in self.chains.iter_mut().enumerate() {
            let (Some(made), Some(_)) = (chain.made.as_mut(), &found[v]) else {
                continue;
            };
            let pairs: Vec<ScanPair> = made.pairs.iter().map(|p| p.pair).collect();
            let one = (std::slice::from_ref(&registrars[v]), plan);
            register_again(
                ds,
                &pairs,
                one,
                std::slice::from_ref(&found[v]),
                &[],
                &mut made.runs,
            );
        }
    }

    /// Adds each bridge's registration time to its registrar's time of the pair its flagged
    /// steps start at (`runs` of the run's pairs): the chain's cost of the bridge.
    pub fn charge(&self, runs: &mut Runs) {
        for (chain, variant_runs) in self.chains.iter().zip(&mut runs.per_variant) {
            let Some(made) = &chain.made else { continue };
            for (bridge, run) in made.pairs.iter().zip(&made.runs.per_variant[0]) {
                let at = variant_runs.get_mut(bridge.first);
                if let (Some(t), Some(us)) = (at.and_then(|r| r.time_us.as_mut()), run.time_us) {
                    *t += us;
                }
            }
        }
    }
}

impl Chain {
    /// Registers the bridges it asks for and has not made (`registrar`: its own, alone), then
    /// again without what the rounds before found (`found`, its own).
    fn register(
        &mut self,
        ds: &Dataset,
        (registrar, plan): (&[Box<dyn Registrar>], &RunPlan<'_>),
        found: &[Option<Detections>],
    ) {
        let made = &self.made;
        let new: Vec<LagPair> = self
            .wanted
            .iter()
            .filter(|w| made.as_ref().is_none_or(|m| !m.pairs.contains(w)))
            .copied()
            .collect();
        let Some(lags) = new.iter().map(|p| p.lag).max() else {
            return;
        };
        let methods = Methods::registrars(registrar);
        let progress = ProgressBar::hidden();
        // `wanted` is in the run's order; `lags::run` takes each lag's pairs together.
        let mut by_lag = new;
        by_lag.sort_by_key(|p| (p.lag, p.first));
        let Some(mut fresh) = lags::run(ds, by_lag, lags, methods, plan, &progress) else {
            return;
        };
        if found.iter().any(Option::is_some) {
            let pairs: Vec<ScanPair> = fresh.pairs.iter().map(|p| p.pair).collect();
            register_again(ds, &pairs, (registrar, plan), found, &[], &mut fresh.runs);
        }
        match self.made.as_mut() {
            Some(made) => {
                made.pairs.extend(fresh.pairs);
                made.runs.append_pairs(fresh.runs);
            }
            None => self.made = Some(fresh),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn consecutive(scans: std::ops::Range<usize>) -> Vec<ScanPair> {
        scans
            .map(|k| ScanPair {
                source: k,
                reference: k + 1,
            })
            .collect()
    }

    #[test]
    fn bridges_span_short_runs_of_split_steps_to_a_trusted_one() {
        let pairs = consecutive(0..14);
        // Split: 2 (one step), 5–6 (two), 8–10 (three: too many), 13 (the last step: nothing
        // to land on); 12 is absent (suspect, say), so the split step 11 before it is not
        // bridged either.
        let spans: Vec<_> = wanted_of(&pairs, &[2, 5, 6, 8, 9, 10, 11, 13], &[12])
            .iter()
            .map(|w| (w.pair.source, w.pair.reference, w.lag, w.first))
            .collect();
        assert_eq!(spans, vec![(2, 4, 2, 2), (5, 8, 3, 5)]);
        // A run of a split and an absent step is not bridged: the bridge would cross a pair
        // whose scans may not see one scene.
        assert!(wanted_of(&pairs, &[3], &[4]).is_empty());
        // A gap in the run's pairs (scan 4 missing) is not bridged over.
        let mut holed = consecutive(0..4);
        holed.extend(consecutive(5..8));
        assert!(wanted_of(&holed, &[3], &[]).is_empty());
        let spans: Vec<_> = wanted_of(&holed, &[1], &[])
            .iter()
            .map(|w| w.pair)
            .collect();
        assert_eq!(
            spans,
            vec![ScanPair {
                source: 1,
                reference: 3
            }]
        );
    }

    /// A registrar's chain takes the bridges it asks for whose registration is a step, and
    /// each bridge's time is charged to the pair its flagged steps start at.
    #[test]
    fn a_chain_takes_its_ok_bridges_and_pays_for_all() {
        let run = |status: PairStatus, us: f64| PairRun {
            result: Err(icp_core::IcpError::NonFiniteTransform),
            status,
            check: None,
            ambiguity: None,
            init: None,
            attempts: 0,
            time_us: Some(us),
            left_out: None,
        };
        let dynamic = || PairStatus::Dynamic {
            source_share: 0.1,
            reference_share: 0.1,
            without: nalgebra::Isometry2::identity(),
            with: nalgebra::Isometry2::identity(),
        };
        let pairs = consecutive(0..10);
        let wanted = wanted_of(&pairs, &[2, 6], &[]);
        let made = LagRuns {
            pairs: wanted.clone(),
            runs: Runs {
                per_variant: vec![vec![run(PairStatus::Ok, 7.0), run(dynamic(), 11.0)]],
                prepare_us: Vec::new(),
                searches: Vec::new(),
            },
        };
        let bridging = Bridging {
            chains: vec![Chain {
                wanted,
                made: Some(made),
            }],
        };
        let step = |r: &PairRun| {
            (r.status == PairStatus::Ok)
                .then(|| (nalgebra::Isometry2::identity(), nalgebra::Matrix3::zeros()))
        };
        let taken = bridging.of(0, step);
        assert_eq!(taken.keys().copied().collect::<Vec<_>>(), vec![2]);
        assert_eq!(taken[&2].0, 4);
        assert!(
            bridging.of(1, step).is_empty(),
            "a registrar that asked for none"
        );
        let mut runs = Runs {
            per_variant: vec![(0..10).map(|_| run(PairStatus::Ok, 100.0)).collect()],
            prepare_us: Vec::new(),
            searches: Vec::new(),
        };
        bridging.charge(&mut runs);
        let times: Vec<f64> = runs.per_variant[0]
            .iter()
            .filter_map(|r| r.time_us)
            .collect();
        assert_eq!(times[2], 107.0);
        assert_eq!(times[6], 111.0);
        assert_eq!(times.iter().sum::<f64>(), 1018.0);
    }

    fn wanted_of(pairs: &[ScanPair], split: &[usize], absent: &[usize]) -> Vec<LagPair> {
        let consecutive = |i: usize| pairs[i].reference == pairs[i].source + 1;
        wanted(pairs, |i| match i {
            _ if !consecutive(i) || absent.contains(&i) => Link::Absent,
            _ if split.contains(&i) => Link::Split,
            _ => Link::Trusted,
        })
    }
}
