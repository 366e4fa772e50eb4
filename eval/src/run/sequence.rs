//! `--sequence batch,causal`: each variant's registrations of the run (consecutive pairs and,
//! with `--lags`, those across lags) smoothed over the whole scan sequence by
//! [`icp_core::sequence`], as estimators `V+batch` and `V+causal` of their own. Their pairs
//! carry the fused motion `k → k+1` and its covariance (the marginal of the relative pose), so
//! every statistic, table, NEES and gate applies to them unchanged; `sequence.csv` has per scan
//! the fused pose, SOG, COG, ROT and HDG with their σ.
//!
//! Only variants whose metric gives a covariance are smoothed (not the point-to-point ones:
//! their registrations have none to weigh them by).
//!
//! A registration the run flagged (any status but ok, loops included) or without a bounded
//! covariance is left out of the smoother, and so is one across a lag whose loop through ok
//! consecutive registrations does not close (`measure::cycles::loop_open`: one of them is
//! wrong, and the consecutive ones are judged on their own). Each registration is weighed by
//! its covariance as the report takes it, with the ambiguity term in the extended modes. A
//! step that no registration left spans rests on the prior alone: it is a failure of the
//! estimator, with that reason. A fused step keeps its variant's flag on the pair, and one
//! whose variant's registration was ok but lies outside that registration's covariance is
//! flagged `contradicted` ([`PairStatus::Contradicted`]): smoothing never clears a flag, and
//! never hides a disagreement it cannot resolve. The causal estimator uses
//! the `Qc` and the scans' share of the registrations' errors the batch one estimated from the
//! whole run (a vessel would carry them over from earlier data). `V+deskew` smooths in batch
//! again the registrations made once more on scans deskewed by the batch estimator's twists
//! (the `deskew` module). Smoothing runs where the report is made (`pipeline::report`), so a
//! sharded run smooths at the merge, on the same registrations as a single run.

use std::borrow::Cow;

use datasets::{Dataset, ScanPair};
use icp_core::sequence::{
    self, Mode, PriorChoice, ProcessNoise, ScanErrors, SequenceRegistration, Smoothed,
    SmootherOptions,
};
use icp_core::termination::StopReason;
use icp_core::{Covariance, IcpError, Registration};
use nalgebra::{Matrix3, Vector3};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::time::Instant;

use crate::data;
use crate::measure::cycles;
use crate::run::covariance::closed_form_inflation;
use crate::run::deskew;
use crate::run::extended;
use crate::run::lags::{LagPair, LagRuns};
use crate::run::runner::{run_scans, PairRun, Runs};
use crate::run::sequence_records::records;
pub use crate::run::sequence_records::SequenceRecord;
use crate::run::sequence_setup::{SequenceMode, SequencePrior};
use crate::run::setup::EvalSetup;
use crate::run::status::{apart, PairStatus, CHI2_3_AT_999};

/// What one smoothed estimator did, in `summary.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SequenceSummary {
    /// The estimator, `V+batch` or `V+causal`.
    pub method: String,
    /// Registrations it used (consecutive and across lags), and those left out as flagged or
    /// without a bounded covariance.
    pub registrations: usize,
    pub left_out: usize,
    /// Of those left out, the registrations across lags whose loop through ok consecutive
    /// registrations does not close (`measure::cycles::loop_open`).
    #[serde(default)]
    pub left_out_loop_open: usize,
    /// The motion prior it used (`--motion-prior`; under `likelier`, the one chosen).
    #[serde(default)]
    pub motion_prior: SequencePrior,
    /// Under `--motion-prior likelier`: each prior's log-likelihood of the registrations
    /// beyond the first scans given those, `[white_acceleration, white_jerk]`, nats (the
    /// batch smoother's).
    #[serde(default)]
    pub prior_evidence: Option<[f64; 2]>,
    /// The prior's process noise `[surge m²/s³, sway m²/s³, yaw rad²/s³]` (white noise on
    /// jerk: per s⁵), estimated from the run (expectation–maximisation, the batch smoother's).
    pub qc: Option<[f64; 3]>,
    /// Expectation–maximisation rounds.
    pub em_rounds: usize,
    /// The share of each registration's covariance given to its scans' errors (shared with
    /// their other registrations), estimated from the loops the registrations close (the
    /// batch smoother's; 0 with fewer than 20 loops), and the loops it came from.
    #[serde(default)]
    pub scan_share: Option<f64>,
    #[serde(default)]
    pub scan_share_loops: usize,
    /// How the solve that gave its estimates stopped (the causal estimator: the worst of its
    /// windows'): `converged`, `no_descent` (no step lowered the cost: a minimum to within
    /// rounding) or `iteration_cap` (the estimates may lie short of their minimum). None when
    /// it gave nothing.
    #[serde(default)]
    pub solve_stop: Option<String>,
    /// Wall time of its smoothing, ms: the batch estimator's with the estimation of `Qc` and
    /// of the scans' share, the causal one's own pass (it takes those from the batch one), the
    /// deskew one's deskewing, registrations again and smoothing.
    #[serde(default)]
    pub time_ms: Option<f64>,
    /// Whether `sequence.csv`'s headings and courses start from the reference's heading at the
    /// first scan (else from 0: the first scan's heading, not a true one).
    #[serde(default)]
    pub heading_from_reference: bool,
    /// Why it gave nothing, if so.
    pub error: Option<String>,
}

/// The smoothed estimators of a run: per estimator (variant-major, modes in the order given)
/// its pair runs, and the rows of `sequence.csv` and the summaries.
pub struct SequenceRuns {
    pub runs: Vec<Vec<PairRun>>,
    pub records: Vec<SequenceRecord>,
    pub summaries: Vec<SequenceSummary>,
}

/// One smoothed estimator's outputs.
struct Estimator {
    runs: Vec<PairRun>,
    records: Vec<SequenceRecord>,
    summary: SequenceSummary,
}

/// Smooths each variant's registrations `runs` of `pairs` (and `lagged`) in every mode of
/// `setup.sequence`; the variants in parallel, collected in order.
pub fn smooth(
    ds: &Dataset,
    pairs: &[ScanPair],
    setup: &EvalSetup,
    runs: &Runs,
    lagged: Option<&LagRuns>,
) -> SequenceRuns {
    let scans = run_scans(pairs);
    let times = times_s(ds, &scans);
    let per_variant: Vec<Vec<Estimator>> = setup
        .sequence
        .variants()
        .par_iter()
        .map(|&v| {
            let inflation = closed_form_inflation(&setup.variants[v].spec().metric);
            let cov_of = |run: &PairRun| covariance_of(setup, inflation, run);
            let own = VariantRuns {
                lag1: &runs.per_variant[v],
                across: lagged.map(|l| (&l.pairs[..], &l.runs.per_variant[v][..])),
            };
            let run = Scans {
                ds,
                pairs,
                scans: &scans,
                times: &times,
            };
            smooth_variant(&run, setup, own, v, &cov_of)
        })
        .collect();
    let mut out = SequenceRuns {
        runs: Vec::new(),
        records: Vec::new(),
        summaries: Vec::new(),
    };
    for e in per_variant.into_iter().flatten() {
        out.runs.push(e.runs);
        out.records.extend(e.records);
        out.summaries.push(e.summary);
    }
    out
}

/// The run's scans and their times.
struct Scans<'a> {
    ds: &'a Dataset,
    pairs: &'a [ScanPair],
    scans: &'a [usize],
    times: &'a [f64],
}

/// A variant's own registrations: consecutive (`lag1`, by the run's pairs) and across lags.
#[derive(Clone, Copy)]
struct VariantRuns<'a> {
    lag1: &'a [PairRun],
    across: Option<(&'a [LagPair], &'a [PairRun])>,
}

/// Why a smoothed estimator gave nothing: its smoother's error (as `summary.json` has it), or
/// the deskew's.
#[derive(Clone, Debug, thiserror::Error)]
enum Failure {
    #[error("{0}")]
    Smoother(sequence::SequenceError),
    #[error("deskew: {0}")]
    Deskew(String),
}

impl Failure {
    /// The reason a pair of the estimator gives.
    fn why(&self) -> String {
        match self {
            Self::Smoother(e) => format!("the sequence smoother: {e}"),
            Self::Deskew(_) => self.to_string(),
        }
    }
}

/// One estimator's solve: its estimates (or why none), the variant's registrations it rests
/// on (the consecutive ones: the pairs' own) and how many it used and left out.
struct Solve<'a> {
    out: Result<Smoothed, Failure>,
    own: Cow<'a, [PairRun]>,
    registrations: usize,
    left_out: LeftOut,
}

/// Variant `v` (its own runs `own`) smoothed in each mode: the batch solve estimates `Qc` and
/// the scans' share of the registrations' errors, which the causal one takes; the deskew one
/// starts from the batch one's twists and estimates its own.
fn smooth_variant(
    run: &Scans<'_>,
    setup: &EvalSetup,
    own: VariantRuns<'_>,
    v: usize,
    cov_of: &dyn Fn(&PairRun) -> Option<Matrix3<f64>>,
) -> Vec<Estimator> {
    let (regs, left_out) = registrations(run.pairs, run.scans, own, cov_of);
    let options = smoother_options(setup);
    let started = Instant::now();
    let batch = sequence::smooth(run.times, &regs, Mode::Batch, &options);
    let batch_ms = started.elapsed().as_secs_f64() * 1e3;
    let solve = |out| Solve {
        out,
        own: Cow::Borrowed(own.lag1),
        registrations: regs.len(),
        left_out,
    };
    setup
        .sequence
        .modes()
        .iter()
        .map(|&mode| {
            let name = format!("{}{}", setup.variants[v].name(), mode.suffix());
            let started = Instant::now();
            let solved = match (mode, &batch) {
                (_, Err(e)) => solve(Err(Failure::Smoother(e.clone()))),
                (SequenceMode::Batch, Ok(b)) => solve(Ok(b.clone())),
                (SequenceMode::Causal, Ok(b)) => solve(
                    sequence::smooth(
                        run.times,
                        &regs,
                        Mode::Causal { lag_scans: 0 },
                        &SmootherOptions {
                            motion_prior: PriorChoice::Given(b.motion_prior),
                            process_noise: ProcessNoise::Fixed(b.qc),
                            scan_errors: ScanErrors::Share(b.scan_share.share),
                            ..options
                        },
                    )
                    .map_err(Failure::Smoother),
                ),
                (SequenceMode::Deskew, Ok(b)) => deskewed(run, setup, own, v, b, cov_of),
            };
            let time_ms = match mode {
                SequenceMode::Batch => batch_ms,
                _ => started.elapsed().as_secs_f64() * 1e3,
            };
            // What the batch solve estimated, the causal estimator's; the deskew one's own.
            let em = match mode {
                SequenceMode::Deskew => solved.out.as_ref().ok(),
                _ => batch.as_ref().ok(),
            };
            let out = &solved.out;
            Estimator {
                runs: pair_runs(run.pairs, run.scans, &solved.own, out, cov_of),
                records: match out {
                    Ok(s) => records(
                        run.ds,
                        (run.scans, run.times),
                        first_heading_deg(run),
                        (&name, mode),
                        s,
                    ),
                    Err(_) => Vec::new(),
                },
                summary: SequenceSummary {
                    method: name,
                    registrations: solved.registrations,
                    left_out: solved.left_out.flagged + solved.left_out.loop_open,
                    left_out_loop_open: solved.left_out.loop_open,
                    motion_prior: match (em, out) {
                        (Some(b), _) | (None, Ok(b)) => SequencePrior::of(b.motion_prior),
                        (None, Err(_)) => setup.sequence.prior(),
                    },
                    prior_evidence: em.and_then(|b| b.prior_evidence),
                    qc: em.map(|b| b.qc),
                    em_rounds: em.map_or(0, |b| b.em_iterations),
                    scan_share: em.map(|b| b.scan_share.share),
                    scan_share_loops: em.map_or(0, |b| b.scan_share.loops),
                    solve_stop: out.as_ref().ok().map(|s| s.stop.name().to_owned()),
                    time_ms: Some(time_ms),
                    heading_from_reference: first_heading_deg(run).is_some(),
                    error: out.as_ref().err().map(|e| e.to_string()),
                },
            }
        })
        .collect()
}

/// The smoothers' options in `setup`: the defaults under its motion prior.
fn smoother_options(setup: &EvalSetup) -> SmootherOptions {
    SmootherOptions {
        motion_prior: setup.sequence.prior().choice(),
        ..SmootherOptions::default()
    }
}

/// `V+deskew`: the run's scans deskewed by the twists of `batch`, the variant's registrations
/// `own` made again on them once (the `deskew` module), smoothed again in batch.
fn deskewed<'a>(
    run: &Scans<'_>,
    setup: &EvalSetup,
    own: VariantRuns<'_>,
    v: usize,
    batch: &Smoothed,
    cov_of: &dyn Fn(&PairRun) -> Option<Matrix3<f64>>,
) -> Solve<'a> {
    let scans = match deskew::deskewed_scans(run.ds, run.scans, batch) {
        Ok(scans) => scans,
        Err(why) => {
            return Solve {
                out: Err(Failure::Deskew(why)),
                own: Cow::Owned(own.lag1.to_vec()),
                registrations: 0,
                left_out: LeftOut::default(),
            }
        }
    };
    let registrar = setup.variants[v].as_ref();
    let again = |pairs: &[ScanPair], runs: &[PairRun]| {
        deskew::register_again(
            registrar,
            (setup.covariance, &setup.run_plan()),
            (run.scans, &scans),
            pairs,
            runs,
        )
    };
    let lag1 = again(run.pairs, own.lag1);
    let across = own.across.map(|(lagged, runs)| {
        let pairs: Vec<ScanPair> = lagged.iter().map(|p| p.pair).collect();
        (lagged, again(&pairs, runs))
    });
    let again = VariantRuns {
        lag1: &lag1,
        across: across.as_ref().map(|(l, r)| (*l, &r[..])),
    };
    let (regs, left_out) = registrations(run.pairs, run.scans, again, cov_of);
    let out = sequence::smooth(run.times, &regs, Mode::Batch, &smoother_options(setup));
    Solve {
        out: out.map_err(Failure::Smoother),
        registrations: regs.len(),
        left_out,
        own: Cow::Owned(lag1),
    }
}

/// The scans' times: their timestamps where every scan has one, else their index times the
/// dataset's nominal Δt.
fn times_s(ds: &Dataset, scans: &[usize]) -> Vec<f64> {
    let stamped: Option<Vec<f64>> = scans.iter().map(|&k| ds.scans[k].timestamp_s()).collect();
    stamped.unwrap_or_else(|| scans.iter().map(|&k| k as f64 * ds.dt_s).collect())
}

/// The covariance the smoother weighs `run`'s registration by: as the report takes it
/// (`setup.covariance`, closed form times `inflation`), plus, in the extended modes, the
/// ambiguity term (the spread of the poses the scene scores almost as well: a registration
/// that may have slid along a corridor is weighed as such). `None` where not bounded.
fn covariance_of(setup: &EvalSetup, inflation: f64, run: &PairRun) -> Option<Matrix3<f64>> {
    let reg = run.result.as_ref().ok()?;
    let Covariance::Bounded(cov) = extended::of_registration(reg, setup.covariance, inflation)?
    else {
        return None;
    };
    // The motion term needs the run's motion, which the smoother estimates: none here.
    Some(
        match extended::added_terms(None, run, setup.covariance, inflation) {
            Some(term) => cov + term,
            None => cov,
        },
    )
}

/// The registrations a smoother left out: flagged (or without a bounded covariance), and
/// across lags with their loop open.
#[derive(Clone, Copy, Debug, Default)]
struct LeftOut {
    flagged: usize,
    loop_open: usize,
}

/// A variant's registrations `own` usable by the smoother (status ok, bounded covariance by
/// `cov_of`, and across lags a loop through ok consecutive registrations that closes or says
/// nothing: `cycles::loop_open`), in the run's scan numbering, and how many were left out.
fn registrations(
    pairs: &[ScanPair],
    scans: &[usize],
    own: VariantRuns<'_>,
    cov_of: &dyn Fn(&PairRun) -> Option<Matrix3<f64>>,
) -> (Vec<SequenceRegistration>, LeftOut) {
    let local = |k: usize| scans.binary_search(&k).ok();
    let lag1 = own.lag1;
    let consecutive = pairs.iter().zip(lag1).map(|(p, r)| (*p, None, r));
    let across = own
        .across
        .into_iter()
        .flat_map(|(lagged, runs)| lagged.iter().zip(runs).map(|(p, r)| (p.pair, Some(p), r)));
    let mut regs = Vec::new();
    let mut left_out = LeftOut::default();
    for (pair, lag, run) in consecutive.chain(across) {
        let usable = (|| {
            if run.status != PairStatus::Ok {
                return None;
            }
            Some(SequenceRegistration {
                source: local(pair.source)?,
                reference: local(pair.reference)?,
                t_ref_src: run.result.as_ref().ok()?.t_ref_src,
                cov: cov_of(run)?,
            })
        })();
        match usable {
            Some(_) if lag.is_some_and(|p| cycles::loop_open(lag1, p, run)) => {
                left_out.loop_open += 1
            }
            Some(r) => regs.push(r),
            None => left_out.flagged += 1,
        }
    }
    (regs, left_out)
}

/// The estimator's run of each pair: the fused step where a registration spans it, else a
/// failure saying why. The fused step keeps its variant's flag on the pair (a number the
/// variant could not stand behind is not cleared by smoothing it), and where the variant's
/// registration was ok but the fused step lies outside its covariance (`cov_of`), the step
/// is flagged [`PairStatus::Contradicted`].
fn pair_runs(
    pairs: &[ScanPair],
    scans: &[usize],
    own: &[PairRun],
    out: &Result<Smoothed, Failure>,
    cov_of: &dyn Fn(&PairRun) -> Option<Matrix3<f64>>,
) -> Vec<PairRun> {
    pairs
        .iter()
        .zip(own)
        .map(|(pair, own)| {
            let step = scans.binary_search(&pair.source).unwrap_or(0);
            let result = match out {
                Err(e) => Err(IcpError::NoEstimate { why: e.why() }),
                Ok(s) if !s.steps[step].supported => Err(IcpError::NoEstimate {
                    why: "the sequence smoother: no registration left spans the step (prior only)"
                        .to_owned(),
                }),
                Ok(s) => Ok(fused(&s.steps[step], own)),
            };
            PairRun {
                status: match &result {
                    Err(error) => PairStatus::Failed {
                        error: error.clone(),
                    },
                    Ok(_) if own.status.is_failure() => own.status.clone(),
                    Ok(f) => contradiction(own, f, cov_of).unwrap_or(PairStatus::Ok),
                },
                result,
                check: None,
                init: None,
                attempts: 0,
                time_us: None,
                ambiguity: None,
                left_out: None,
            }
        })
        .collect()
}

/// [`PairStatus::Contradicted`] when the variant's own registration of the pair (`own`)
/// lies farther from the fused step than its covariance allows.
fn contradiction(
    own: &PairRun,
    fused: &Registration,
    cov_of: &dyn Fn(&PairRun) -> Option<Matrix3<f64>>,
) -> Option<PairStatus> {
    let reg = own.result.as_ref().ok()?;
    let info = cov_of(own)?.try_inverse()?;
    let (a, b) = (reg.t_ref_src, fused.t_ref_src);
    let d = Vector3::new(
        a.translation.x - b.translation.x,
        a.translation.y - b.translation.y,
        b.rotation.angle_to(&a.rotation),
    );
    let nees = d.dot(&(info * d));
    (nees > CHI2_3_AT_999).then(|| {
        let (apart_m, apart_deg) = apart(&a, &b);
        PairStatus::Contradicted {
            apart_m,
            apart_deg,
            nees,
        }
    })
}

/// The fused step as a registration; what describes the scans' agreement (pairs, residual,
/// overlap, conditioning) is the variant's own registration of the pair, where it has one.
fn fused(step: &sequence::StepEstimate, own: &PairRun) -> Registration {
    let base = own.result.as_ref().ok();
    Registration {
        t_ref_src: step.t_ref_src,
        iterations: 0,
        stop: StopReason::Given,
        n_pairs: base.map_or(0, |r| r.n_pairs),
        n_unusable: base.map_or(0, |r| r.n_unusable),
        weight_sum: base.map_or(0.0, |r| r.weight_sum),
        mean_residual_m: base.map_or(0.0, |r| r.mean_residual_m),
        conditioning: base.and_then(|r| r.conditioning),
        overlap: base.map_or(1.0, |r| r.overlap),
        covariance: Some(Covariance::Bounded(step.cov)),
        jackknife_covariance: None,
    }
}

/// The reference's heading at the run's first scan, degrees clockwise, if it has one.
fn first_heading_deg(run: &Scans<'_>) -> Option<f64> {
    match (run.scans, run.times) {
        ([a, b, ..], [ta, tb, ..]) => data::motion(run.ds, *a, *b, tb - ta).map(|m| m.hdg0_deg),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use icp_core::sequence::StepEstimate;
    use nalgebra::{Isometry2, Vector2};

    use super::*;

    #[test]
    fn a_fused_step_keeps_its_variants_flag_and_is_flagged_where_its_registration_disagrees() {
        let step = Isometry2::new(Vector2::new(1.0, 0.1), 0.05);
        let pairs: Vec<ScanPair> = (0..5)
            .map(|k| ScanPair {
                source: k,
                reference: k + 1,
            })
            .collect();
        let scans: Vec<usize> = (0..6).collect();
        let shifted = |dx: f64| {
            let mut t = step;
            t.translation.vector.x += dx;
            PairRun::ok_for_test(t, None)
        };
        let mut degenerate = shifted(0.0);
        degenerate.status = PairStatus::Degenerate { cond_ratio: 1e-4 };
        // Ok and 2σ off; flagged; ok and 50σ off; ok; no registration left spans the last.
        let own = vec![
            shifted(0.02),
            degenerate,
            shifted(0.5),
            shifted(0.0),
            shifted(0.0),
        ];
        let smoothed = Smoothed {
            scans: Vec::new(),
            steps: (0..5)
                .map(|k| StepEstimate {
                    t_ref_src: step,
                    cov: Matrix3::identity() * 1e-6,
                    supported: k < 4,
                })
                .collect(),
            motion_prior: icp_core::sequence::MotionPrior::WhiteAcceleration,
            qc: [1.0; 3],
            log_likelihood: None,
            prior_evidence: None,
            em_iterations: 0,
            stop: icp_core::sequence::SolveStop::Converged,
            scan_share: icp_core::sequence::ScanShare {
                share: 0.0,
                loops: 0,
            },
        };
        let cov_of = |_: &PairRun| Some(Matrix3::from_diagonal(&Vector3::new(1e-4, 1e-4, 1e-6)));
        let runs = pair_runs(&pairs, &scans, &own, &Ok(smoothed), &cov_of);
        let kinds: Vec<_> = runs.iter().map(|r| r.status.kind()).collect();
        use crate::run::status::StatusKind as K;
        assert_eq!(
            kinds,
            [K::Ok, K::Degenerate, K::Contradicted, K::Ok, K::Failed]
        );
        let PairStatus::Contradicted { apart_m, nees, .. } = runs[2].status else {
            unreachable!()
        };
        assert!((apart_m - 0.5).abs() < 1e-12 && (nees - 2500.0).abs() < 1e-6);
        // Every registered step carries the fused motion, flagged or not.
        for r in &runs[..4] {
            assert_eq!(r.result.as_ref().unwrap().t_ref_src, step);
        }
    }
}
