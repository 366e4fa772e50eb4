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
//! whole run (a vessel would carry them over from earlier data). Smoothing runs where the report is made (`pipeline::report`), so a
//! sharded run smooths at the merge, on the same registrations as a single run.

use datasets::{Dataset, ScanPair};
use icp_core::motion::{wrap_360, wrap_deg};
use icp_core::sequence::{
    self, Mode, ProcessNoise, ScanErrors, SequenceRegistration, Smoothed, SmootherOptions,
};
use icp_core::termination::StopReason;
use icp_core::BearingSense;
use icp_core::{Covariance, IcpError, Registration};
use nalgebra::{Matrix3, Vector3};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::time::Instant;

use crate::data;
use crate::measure::cycles;
use crate::run::covariance::closed_form_inflation;
use crate::run::extended;
use crate::run::lags::LagRuns;
use crate::run::runner::{run_scans, PairRun, Runs};
use crate::run::sequence_setup::SequenceMode;
use crate::run::setup::EvalSetup;
use crate::run::status::{apart, PairStatus, CHI2_3_AT_999};

/// One row of `sequence.csv`: a scan's fused state as one smoothed estimator has it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SequenceRecord {
    /// The estimator, `V+batch` or `V+causal`.
    pub method: String,
    /// Scan index in the dataset.
    pub scan: usize,
    /// Scan time, s.
    pub time_s: f64,
    /// Whether an unflagged registration reaches the scan's estimate: for `V+causal` one
    /// spanning the step into the scan (scan 0: the first step), for `V+batch` one spanning a
    /// step next to it. Else the estimate is the prior's extrapolation alone.
    pub supported: bool,
    /// Position in the first scan's frame, m.
    pub x_m: f64,
    pub y_m: f64,
    pub x_sigma_m: f64,
    pub y_sigma_m: f64,
    /// Heading: the first pair's reference heading (0 without a reference) plus the fused turn
    /// since the first scan, degrees in [0, 360), clockwise.
    pub hdg_deg: f64,
    pub hdg_sigma_deg: f64,
    /// Speed over ground from the fused twist, m/s.
    pub sog_mps: f64,
    pub sog_sigma_mps: f64,
    /// Course over ground: the heading plus the drift angle of the fused twist, degrees.
    pub cog_deg: f64,
    pub cog_sigma_deg: f64,
    /// Rate of turn, degrees per second, clockwise positive.
    pub rot_dps: f64,
    pub rot_sigma_dps: f64,
    /// The fused twist along the scan frame's x and y, m/s.
    pub surge_mps: f64,
    pub sway_mps: f64,
}

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
    /// The prior's process noise `[surge m²/s³, sway m²/s³, yaw rad²/s³]`, estimated from the
    /// run (expectation–maximisation, the batch smoother's).
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
    /// of the scans' share, the causal one's own pass (it takes those from the batch one).
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
            let (regs, left_out) = registrations(pairs, &scans, runs, lagged, v, &cov_of);
            let run = Scans {
                ds,
                pairs,
                scans: &scans,
                times: &times,
            };
            smooth_variant(
                &run,
                setup,
                &runs.per_variant[v],
                v,
                &regs,
                left_out,
                &cov_of,
            )
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

/// Variant `v` (its own runs `own`) smoothed from `regs` in each mode: the batch solve
/// estimates `Qc`, which the causal one takes.
fn smooth_variant(
    run: &Scans<'_>,
    setup: &EvalSetup,
    own: &[PairRun],
    v: usize,
    regs: &[SequenceRegistration],
    left_out: LeftOut,
    cov_of: &dyn Fn(&PairRun) -> Option<Matrix3<f64>>,
) -> Vec<Estimator> {
    let options = SmootherOptions::default();
    let started = Instant::now();
    let batch = sequence::smooth(run.times, regs, Mode::Batch, &options);
    let batch_ms = started.elapsed().as_secs_f64() * 1e3;
    setup
        .sequence
        .modes()
        .iter()
        .map(|&mode| {
            let name = format!("{}{}", setup.variants[v].name(), mode.suffix());
            let started = Instant::now();
            let out = match (mode, &batch) {
                (SequenceMode::Batch, _) | (_, Err(_)) => batch.clone(),
                (SequenceMode::Causal, Ok(b)) => sequence::smooth(
                    run.times,
                    regs,
                    Mode::Causal { lag_scans: 0 },
                    &SmootherOptions {
                        process_noise: ProcessNoise::Fixed(b.qc),
                        scan_errors: ScanErrors::Share(b.scan_share.share),
                        ..options
                    },
                ),
            };
            let time_ms = match mode {
                SequenceMode::Batch => batch_ms,
                SequenceMode::Causal => started.elapsed().as_secs_f64() * 1e3,
            };
            Estimator {
                runs: pair_runs(run.pairs, run.scans, own, &out, cov_of),
                records: match &out {
                    Ok(s) => records(run, &name, mode, s),
                    Err(_) => Vec::new(),
                },
                summary: SequenceSummary {
                    method: name,
                    registrations: regs.len(),
                    left_out: left_out.flagged + left_out.loop_open,
                    left_out_loop_open: left_out.loop_open,
                    qc: batch.as_ref().ok().map(|b| b.qc),
                    em_rounds: batch.as_ref().map_or(0, |b| b.em_iterations),
                    scan_share: batch.as_ref().ok().map(|b| b.scan_share.share),
                    scan_share_loops: batch.as_ref().map_or(0, |b| b.scan_share.loops),
                    solve_stop: out.as_ref().ok().map(|s| s.stop.name().to_owned()),
                    time_ms: Some(time_ms),
                    heading_from_reference: first_heading_deg(run).is_some(),
                    error: out.as_ref().err().map(|e| e.to_string()),
                },
            }
        })
        .collect()
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
    Some(match extended::added_terms(None, run, setup.covariance) {
        Some(term) => cov + term,
        None => cov,
    })
}

/// The registrations a smoother left out: flagged (or without a bounded covariance), and
/// across lags with their loop open.
#[derive(Clone, Copy, Debug, Default)]
struct LeftOut {
    flagged: usize,
    loop_open: usize,
}

/// Variant `v`'s registrations usable by the smoother (status ok, bounded covariance by
/// `cov_of`, and across lags a loop through ok consecutive registrations that closes or says
/// nothing: `cycles::loop_open`), in the run's scan numbering, and how many were left out.
fn registrations(
    pairs: &[ScanPair],
    scans: &[usize],
    runs: &Runs,
    lagged: Option<&LagRuns>,
    v: usize,
    cov_of: &dyn Fn(&PairRun) -> Option<Matrix3<f64>>,
) -> (Vec<SequenceRegistration>, LeftOut) {
    let local = |k: usize| scans.binary_search(&k).ok();
    let lag1 = &runs.per_variant[v];
    let consecutive = pairs.iter().zip(lag1).map(|(p, r)| (*p, None, r));
    let across = lagged.into_iter().flat_map(|l| {
        l.pairs
            .iter()
            .zip(&l.runs.per_variant[v])
            .map(|(p, r)| (p.pair, Some(p), r))
    });
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
    out: &Result<Smoothed, sequence::SequenceError>,
    cov_of: &dyn Fn(&PairRun) -> Option<Matrix3<f64>>,
) -> Vec<PairRun> {
    pairs
        .iter()
        .zip(own)
        .map(|(pair, own)| {
            let step = scans.binary_search(&pair.source).unwrap_or(0);
            let result = match out {
                Err(e) => Err(IcpError::NoEstimate {
                    why: format!("the sequence smoother: {e}"),
                }),
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

/// Whether scan `k`'s estimate in `mode` rests on a registration (see
/// [`SequenceRecord::supported`]).
fn scan_supported(s: &Smoothed, mode: SequenceMode, k: usize) -> bool {
    let step = |i: usize| s.steps.get(i).is_some_and(|e| e.supported);
    match mode {
        SequenceMode::Causal => step(k.max(1) - 1),
        SequenceMode::Batch => step(k) || (k > 0 && step(k - 1)),
    }
}

/// `sequence.csv`'s rows of one estimator.
fn records(run: &Scans<'_>, name: &str, mode: SequenceMode, s: &Smoothed) -> Vec<SequenceRecord> {
    let (ds, scans, times) = (run.ds, run.scans, run.times);
    // Heading clockwise: a turn θ of the scan frame (counter-clockwise bearings) is −θ.
    let sign = match ds.bearing_sense {
        BearingSense::CounterClockwise => -1.0,
        BearingSense::Clockwise => 1.0,
    };
    let hdg0 = first_heading_deg(run).unwrap_or(0.0);
    scans
        .iter()
        .zip(times)
        .zip(&s.scans)
        .enumerate()
        .map(|(k, ((&scan, &time_s), e))| {
            let c = &e.cov;
            let (u, v) = (e.twist.x, e.twist.y);
            let speed = u.hypot(v);
            let (var_sog, var_drift) = if speed > 0.0 {
                let (gu, gv) = (u / speed, v / speed);
                let (du, dv) = (-v / (speed * speed), u / (speed * speed));
                (
                    gu * gu * c[(3, 3)] + 2.0 * gu * gv * c[(3, 4)] + gv * gv * c[(4, 4)],
                    du * du * c[(3, 3)] + 2.0 * du * dv * c[(3, 4)] + dv * dv * c[(4, 4)],
                )
            } else {
                (c[(3, 3)] + c[(4, 4)], 0.0)
            };
            let hdg_deg = wrap_360(hdg0 + sign * e.pose.z.to_degrees());
            let drift_deg = sign * v.atan2(u).to_degrees();
            SequenceRecord {
                method: name.to_owned(),
                scan,
                time_s,
                supported: scan_supported(s, mode, k),
                x_m: e.pose.x,
                y_m: e.pose.y,
                x_sigma_m: c[(0, 0)].max(0.0).sqrt(),
                y_sigma_m: c[(1, 1)].max(0.0).sqrt(),
                hdg_deg,
                hdg_sigma_deg: c[(2, 2)].max(0.0).sqrt().to_degrees(),
                sog_mps: speed,
                sog_sigma_mps: var_sog.max(0.0).sqrt(),
                cog_deg: wrap_360(hdg_deg + wrap_deg(drift_deg)),
                // The heading and the drift angle, taken as independent.
                cog_sigma_deg: (c[(2, 2)] + var_drift).max(0.0).sqrt().to_degrees(),
                rot_dps: sign * e.twist.z.to_degrees(),
                rot_sigma_dps: c[(5, 5)].max(0.0).sqrt().to_degrees(),
                surge_mps: u,
                sway_mps: v,
            }
        })
        .collect()
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
            qc: [1.0; 3],
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
