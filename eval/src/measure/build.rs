//! Builds the [`RunReport`] from a run's raw results: movement parameters, the reference at
//! its time offset, plausibility, bounds, one [`PairRecord`] per variant and pair, and the
//! summaries over them (all pure functions of the records).

use datasets::{Dataset, ScanPair, SkippedPair};
use icp_core::motion::{wrap_deg, MovementParams};
use nalgebra::Isometry2;

use crate::data::{self, scan_time_s, RefMotion};
use crate::measure::bound;
use crate::measure::bound::{OverBound, PairBound};
use crate::measure::consistency;
use crate::measure::odometry_word::OdometryWord;
use crate::measure::outcome;
use crate::measure::outcome::FlagQuality;
use crate::measure::record::{record, PairRecord};
use crate::measure::reference;
use crate::measure::reference_noise;
use crate::measure::report::*;
use crate::measure::stats::{median_p95, Stats};
use crate::measure::trajectory;
use crate::run::covariance;
use crate::run::extended;
use crate::run::motion;
use crate::run::runner::{PairRun, Runs};
use crate::run::setup::{EvalSetup, OffsetChoice, ReferenceChecks};
use crate::run::status::StatusKind;

/// Builds the report from the runs.
pub fn build(
    ds: &Dataset,
    pairs: &[ScanPair],
    skipped: Vec<SkippedPair>,
    setup: &EvalSetup,
    all_runs: &Runs,
) -> RunReport {
    let runs = &all_runs.per_variant;
    let dts: Vec<f64> = pairs.iter().map(|p| ds.pair_dt_s(*p)).collect();
    let estimates: Vec<Vec<Option<MovementParams>>> = runs
        .iter()
        .map(|rs| {
            rs.iter()
                .zip(pairs.iter().zip(&dts))
                .map(|(r, (p, &dt))| {
                    let reg = r.result.as_ref().ok()?;
                    let hdg0 =
                        data::motion(ds, p.source, p.reference, dt).map_or(0.0, |m| m.hdg0_deg);
                    MovementParams::from_registration(&reg.t_ref_src, dt, hdg0, ds.bearing_sense)
                        .ok()
                })
                .collect()
        })
        .collect();

    // The reference at lag 0, and the offset estimate.
    let ref_at = |lag: i64| -> Vec<Option<RefMotion>> {
        pairs
            .iter()
            .zip(&dts)
            .map(|(p, &dt)| {
                let a = usize::try_from(p.source as i64 + lag).ok()?;
                let b = usize::try_from(p.reference as i64 + lag).ok()?;
                data::motion(ds, a, b, dt)
            })
            .collect()
    };
    let ref0 = ref_at(0);
    // The offset is estimated from the per-pair median of the variants' estimates: no variant
    // is singled out by name, and one variant's failures do not move it. External estimates
    // are left out: adding one changes no built-in variant's figures through the offset.
    let series = |f: &dyn Fn(&MovementParams) -> f64| -> Vec<f64> {
        (0..pairs.len())
            .map(|i| {
                let mut v: Vec<f64> = estimates[..setup.variants.len()]
                    .iter()
                    .filter_map(|e| e[i].as_ref().map(f))
                    .collect();
                v.sort_by(f64::total_cmp);
                if v.is_empty() {
                    f64::NAN
                } else {
                    crate::measure::stats::quantile_sorted(&v, 0.5)
                }
            })
            .collect()
    };
    let ref_series = |f: &dyn Fn(&RefMotion) -> f64| -> Vec<f64> {
        ref0.iter()
            .map(|m| m.as_ref().map_or(f64::NAN, f))
            .collect()
    };
    let offset_estimate = reference::estimate_offset(
        &series(&|m| m.sog_mps),
        &series(&|m| m.dcog_deg),
        &ref_series(&|m| m.sog_mps),
        &ref_series(&|m| m.dcog_deg),
        ds.dt_s,
    );
    let applied = match setup.offset {
        OffsetChoice::Fixed(n) => n,
        OffsetChoice::Auto => offset_estimate.map_or(0, |o| o.scans),
    };
    let refs = ref_at(applied);
    let ref_sog: Vec<f64> = refs
        .iter()
        .map(|m| m.map_or(f64::NAN, |m| m.sog_mps))
        .collect();
    let ref_rot: Vec<f64> = refs
        .iter()
        .zip(&dts)
        .map(|(m, dt)| m.map_or(f64::NAN, |m| m.dcog_deg / dt))
        .collect();
    let flagged = match (&ds.reference, setup.reference_checks) {
        (Some(_), ReferenceChecks::On) => reference::flag_implausible(pairs, &ref_sog, &ref_rot),
        _ => Vec::new(),
    };
    let plausible: Vec<bool> = (0..pairs.len())
        .map(|i| ds.reference.is_some() && !flagged.iter().any(|f| f.pair == i))
        .collect();

    let bounds = bound::pair_bounds(ds, pairs, &ref0);
    let all_registered: Vec<bool> = (0..pairs.len())
        .map(|i| runs.iter().all(|rs| rs[i].result.is_ok()))
        .collect();
    let rigid = ds.rigid_reference();
    let noise = reference_noise::of_dataset(ds);
    let noise_ok = noise.as_ref().and_then(|n| n.as_ref().ok());
    let reference_step = noise_ok.filter(|_| rigid).map(|n| n.step_covariance());
    let (reference_trajectory, reference_tum) =
        trajectory::reference_trajectory(ds, pairs, applied);
    let mut records = Vec::new();
    let mut summaries = Vec::new();
    let mut trajectories = Vec::new();
    for (vi, name) in setup.reported_names().into_iter().enumerate() {
        let mut rows = Vec::with_capacity(pairs.len());
        let chained = chained_heading_errors(pairs, &estimates[vi], &refs);
        // An external estimate has no covariance: no inflation of one.
        let inflation = setup
            .variants
            .get(vi)
            .map_or(1.0, |v| covariance::closed_form_inflation(&v.spec().metric));
        // The extended modes' term for the scanner's motion within a sweep.
        let sweep_s = ds.sweep_s.filter(|_| setup.covariance.is_extended());
        let motion_terms = motion::motion_terms(sweep_s, pairs, &dts, &runs[vi]);
        for (i, (pair, run)) in pairs.iter().zip(&runs[vi]).enumerate() {
            rows.push(record(
                name,
                i,
                *pair,
                dts[i],
                run,
                all_registered[i],
                estimates[vi][i],
                refs[i],
                bounds[i],
                plausible[i],
            ));
            rows[i].hdg_chained_err_deg = chained[i];
            consistency::fill(
                &mut rows[i],
                run.result.as_ref().ok(),
                refs[i].and_then(|r| r.t_ref_src),
                setup.covariance,
                inflation,
                extended::added_terms(motion_terms[i], run, setup.covariance, inflation).as_ref(),
            );
            if let (Some(step), Some(truth)) = (&reference_step, refs[i].and_then(|r| r.t_ref_src))
            {
                rows[i].nees_with_reference_noise =
                    reference_noise::nees_with_reference(&rows[i], &truth, step);
            }
        }
        trajectories.push(chain(ds, pairs, &runs[vi]));
        summaries.push(VariantSummary {
            odometry_on_wrong: OdometryWord::of(&rows, ds, &refs),
            ..summarize(
                name,
                &rows,
                &runs[vi],
                ds,
                pairs,
                trajectories.last().expect("just pushed"),
                rigid,
            )
        });
        // A reference that is not one rigid frame (GNSS positions beside a separate heading)
        // has no trajectory to align to: no ATE or RPE against it (the note says why).
        if let (Some(kind), Some(summary)) = (reference_tum.filter(|_| rigid), summaries.last_mut())
        {
            let traj = trajectories.last().expect("just pushed");
            let evo = trajectory::evo_metrics(traj, &reference_trajectory, kind);
            summary.trajectory.ate_rmse_m = evo.as_ref().map(|e| e.ate_trans_m.rmse);
            summary.trajectory.evo = evo;
        }
        // An external estimate has no covariance to judge; a smoothed one (after them) has.
        let judged =
            vi < setup.variants.len() || vi >= setup.variants.len() + setup.estimates.len();
        if let Some(last) = summaries.last_mut().filter(|_| judged) {
            last.consistency = consistency::summarize(
                &rows,
                setup.covariance,
                inflation,
                // Ground truth carries no noise of its own to estimate.
                noise_ok.map(|n| consistency::MovementNoise {
                    sog_mps: n.sog_mps,
                    dcog_deg: n.dcog_deg,
                }),
            );
        }
        records.extend(rows);
    }
    RunReport {
        schema_version: SCHEMA_VERSION,
        tool: format!("icp-eval {}", env!("CARGO_PKG_VERSION")),
        dataset: DatasetInfo {
            name: ds.provenance.name.clone(),
            description: ds.provenance.description.clone(),
            files: ds.provenance.files.clone(),
            scans: ds.scans.len(),
            pairs: pairs.len(),
            skipped_pairs: skipped,
            dt_s: ds.dt_s,
            bearing_sense: ds.bearing_sense,
            reference_heading_sense: ds.reference_heading_sense,
            reference_kind: ds.reference_kind,
            warnings: ds.warnings.clone(),
            sensor: Some(ds.sensor),
            odometry: ds.odometry.is_some(),
            scanner_offset: ds.scanner_offset,
            sweep_s: ds.sweep_s,
            first_scans: ds.first_scans,
        },
        config: RunConfig {
            variants: setup.variants.iter().map(|v| v.spec()).collect(),
            init: setup.init.clone(),
            global: setup.global,
            global_check: setup.global_check,
            start_gate: setup.start_gate,
            covariance: setup.covariance,
            estimates: setup.estimates.iter().map(|e| e.source.clone()).collect(),
            lags: setup.lags,
            start_gated: setup
                .close_start_specs()
                .unwrap_or_default()
                .into_iter()
                .flatten()
                .filter_map(|s| {
                    Some((
                        s.name.clone(),
                        s.metric.params.get("max_pair_distance_m")?.as_f64()?,
                    ))
                })
                .collect(),
        },
        reference: ReferenceInfo {
            available: ds.reference.is_some(),
            rigid_pose: rigid,
            offset_estimate,
            offset_choice: setup.offset,
            offset_applied_scans: applied,
            offset_from_variant: (!setup.variants.is_empty()).then(|| {
                let names: Vec<&str> = setup.variants.iter().map(|v| v.name()).collect();
                format!("the per-pair median of {}", names.join(", "))
            }),
            plausible_pairs: plausible.iter().filter(|&&p| p).count(),
            checks: setup.reference_checks,
            flagged_pairs: flagged,
            reference_tum,
            noise_note: match &noise {
                Some(Err(e)) => Some(e.to_string()),
                _ => None,
            },
            noise: noise.and_then(Result::ok),
        },
        bound: bound::summarize(&bounds),
        population: Population {
            pairs: all_registered.iter().filter(|&&a| a).count(),
            left_out: (0..pairs.len()).filter(|&i| !all_registered[i]).collect(),
        },
        variants: summaries,
        preparation: median_p95(&all_runs.prepare_us)
            .map(|(median_us, p95_us)| Timing { median_us, p95_us }),
        global_search: (!all_runs.searches.is_empty()).then(|| SearchSummary {
            pairs: all_runs.searches.len(),
            failures: all_runs
                .searches
                .iter()
                .enumerate()
                .filter_map(|(i, s)| {
                    s.result.as_ref().err().map(|e| Failure {
                        pair: i,
                        reason: e.to_string(),
                    })
                })
                .collect(),
            timing: median_p95(
                &all_runs
                    .searches
                    .iter()
                    .map(|s| s.time_us)
                    .collect::<Vec<_>>(),
            )
            .map(|(median_us, p95_us)| Timing { median_us, p95_us }),
        }),
        pairs: records,
        trajectories,
        reference_trajectory,
        cycles: Vec::new(),
        sequence: Vec::new(),
        sequence_scans: Vec::new(),
        drawn_scan: None,
    }
}

fn error_stats<'a>(rows: impl Iterator<Item = &'a PairRecord> + Clone) -> ErrorStats {
    let col = |f: fn(&PairRecord) -> Option<f64>| -> Option<Stats> {
        let v: Vec<f64> = rows.clone().filter_map(f).collect();
        Stats::of(&v)
    };
    ErrorStats {
        pairs: rows.clone().count(),
        sog_err_mps: col(|r| r.sog_err_mps),
        dcog_err_deg: col(|r| r.dcog_err_deg),
        trans_err_m: col(|r| r.trans_err_m),
        rot_err_deg: col(|r| r.rot_err_deg),
    }
}

fn summarize(
    name: &str,
    rows: &[PairRecord],
    runs: &[PairRun],
    ds: &Dataset,
    pairs: &[ScanPair],
    traj: &[(f64, Isometry2<f64>)],
    rigid: bool,
) -> VariantSummary {
    let ok = rows.iter().filter(|r| r.status == StatusKind::Ok).count();
    // Every variant's figures over the same pairs: those every variant registered.
    let common: Vec<&PairRecord> = rows.iter().filter(|r| r.all_registered).collect();
    let with_ref = common.iter().copied().filter(|r| r.sog_ref_mps.is_some());
    let times: Vec<f64> = runs.iter().filter_map(|r| r.time_us).collect();
    let failures: Vec<Failure> = runs
        .iter()
        .enumerate()
        .filter_map(|(i, r)| {
            r.result.as_ref().err().map(|e| Failure {
                pair: i,
                reason: e.to_string(),
            })
        })
        .collect();
    let fraction = |n: usize, of: usize| if of == 0 { 0.0 } else { n as f64 / of as f64 };
    // An external estimator's runs are not started here (and not iterated).
    let iterated = runs.iter().any(|r| r.init.is_some());
    VariantSummary {
        name: name.to_owned(),
        pairs_ok: ok,
        failure_rate: fraction(rows.len() - ok, rows.len()),
        converged_fraction: iterated.then(|| {
            fraction(
                common.iter().filter(|r| r.converged == Some(true)).count(),
                common.len(),
            )
        }),
        iterations_mean: iterated.then(|| {
            fraction(
                common.iter().filter_map(|r| r.iterations).sum(),
                common.len(),
            )
        }),
        iterations_max: iterated.then(|| {
            common
                .iter()
                .filter_map(|r| r.iterations)
                .max()
                .unwrap_or(0)
        }),
        all_pairs: error_stats(with_ref.clone()),
        plausible_reference: error_stats(with_ref.filter(|r| r.ref_plausible)),
        success_rate: outcome::success_rate(rows, rigid),
        flag_quality: FlagQuality::of(rows),
        odometry_on_wrong: None,
        degenerate_pairs: flagged(rows, StatusKind::Degenerate),
        no_overlap_pairs: flagged(rows, StatusKind::NoOverlap),
        suspect_pairs: flagged(rows, StatusKind::Suspect),
        ambiguous_pairs: flagged(rows, StatusKind::Ambiguous),
        inconsistent_pairs: flagged(rows, StatusKind::Inconsistent),
        dynamic_pairs: flagged(rows, StatusKind::Dynamic),
        moving_returns: moving_summary(rows),
        trajectory: TrajectoryStats {
            heading_rms_error_deg: {
                let e: Vec<f64> = rows.iter().filter_map(|r| r.hdg_chained_err_deg).collect();
                (!e.is_empty())
                    .then(|| (e.iter().map(|x| x * x).sum::<f64>() / e.len() as f64).sqrt())
            },
            heading_end_error_deg: rows.last().and_then(|r| r.hdg_chained_err_deg),
            ..trajectory_stats(ds, pairs, traj, failures.len())
        },
        over_bound: OverBound::of(common.iter().filter_map(|r| {
            let bound = PairBound::Bounded {
                trans_m: r.bound_trans_m?,
                rot_deg: r.bound_rot_deg?,
            };
            Some((r.trans_err_m?, r.rot_err_deg?, bound))
        })),
        timing: median_p95(&times).map(|(median_us, p95_us)| Timing { median_us, p95_us }),
        failures,
        consistency: None,
        cycles: None,
    }
}

/// What the detector of moving returns left out over `rows` (`None` without a detector).
fn moving_summary(rows: &[PairRecord]) -> Option<MovingReturnsSummary> {
    let detected: Vec<&PairRecord> = rows.iter().filter(|r| r.left_out_src.is_some()).collect();
    if detected.is_empty() {
        return None;
    }
    let truth = detected
        .iter()
        .filter_map(|r| r.left_out_truth)
        .reduce(|a, b| a + b);
    let share = |n: usize, of: usize| (of > 0).then(|| n as f64 / of as f64);
    Some(MovingReturnsSummary {
        pairs_with_left_out: detected
            .iter()
            .filter(|r| r.left_out_src.unwrap_or(0) + r.left_out_ref.unwrap_or(0) > 0)
            .count(),
        left_out_per_scan: detected
            .iter()
            .filter_map(|r| r.left_out_src)
            .sum::<usize>() as f64
            / detected.len() as f64,
        recall: truth.and_then(|t| share(t.moving_left_out, t.moving)),
        static_left_out_rate: truth.and_then(|t| share(t.static_left_out, t.r#static)),
        truth,
    })
}

/// The pairs whose status is `kind`.
fn flagged(rows: &[PairRecord], kind: StatusKind) -> Vec<usize> {
    rows.iter()
        .filter(|r| r.status == kind)
        .map(|r| r.pair)
        .collect()
}

/// Per pair, the error of the heading dead-reckoned through the ΔCOG `estimates` (a pair
/// without one adds 0) from the reference heading at the first pair's source scan, against
/// the reference heading at each pair's reference scan; restarted from the reference where the
/// pairs are not consecutive. `None` without a reference.
fn chained_heading_errors(
    pairs: &[ScanPair],
    estimates: &[Option<MovementParams>],
    refs: &[Option<RefMotion>],
) -> Vec<Option<f64>> {
    let mut heading: Option<f64> = None;
    let mut previous: Option<ScanPair> = None;
    pairs
        .iter()
        .zip(estimates.iter().zip(refs))
        .map(|(pair, (est, reference))| {
            let reference = reference.as_ref()?;
            let consecutive = previous.is_some_and(|p| p.reference == pair.source);
            previous = Some(*pair);
            let start = match heading {
                Some(h) if consecutive => h,
                _ => reference.hdg0_deg,
            };
            let h = start + est.map_or(0.0, |m| m.dcog_deg);
            heading = Some(h);
            Some(wrap_deg(h - reference.hdg1_deg))
        })
        .collect()
}

/// Chains the registrations into scanner poses `t_world_scan`, starting at the reference pose
/// of the first scan when it is a rigid pose (else at the origin). A failed pair is bridged by
/// the identity and counted as a gap.
fn chain(ds: &Dataset, pairs: &[ScanPair], runs: &[PairRun]) -> Vec<(f64, Isometry2<f64>)> {
    let Some(first) = pairs.first() else {
        return Vec::new();
    };
    let start = ds
        .reference
        .as_ref()
        .and_then(|r| r[first.source].scan_pose())
        .unwrap_or_else(Isometry2::identity);
    let time = |k: usize| scan_time_s(ds, k);
    let mut poses = vec![(time(first.source), start)];
    let mut pose = start;
    for (pair, run) in pairs.iter().zip(runs) {
        if let Ok(reg) = &run.result {
            pose *= reg.t_ref_src.inverse();
        }
        poses.push((time(pair.reference), pose));
    }
    poses
}

fn trajectory_stats(
    ds: &Dataset,
    pairs: &[ScanPair],
    traj: &[(f64, Isometry2<f64>)],
    gaps: usize,
) -> TrajectoryStats {
    let length_m = traj
        .windows(2)
        .map(|w| (w[1].1.translation.vector - w[0].1.translation.vector).norm())
        .sum();
    let contiguous = pairs.windows(2).all(|w| w[0].reference == w[1].source);
    let truth: Option<Vec<Isometry2<f64>>> = ds.reference.as_ref().and_then(|r| {
        let first = pairs.first()?;
        std::iter::once(first.source)
            .chain(pairs.iter().map(|p| p.reference))
            .map(|k| r[k].scan_pose())
            .collect()
    });
    let (end_point_error_m, drift_m_per_100m, note) = match (truth, contiguous) {
        (Some(t), true) if t.len() == traj.len() && !t.is_empty() => {
            let ref_len: f64 = t
                .windows(2)
                .map(|w| (w[1].translation.vector - w[0].translation.vector).norm())
                .sum();
            let end = (traj[traj.len() - 1].1.translation.vector
                - t[t.len() - 1].translation.vector)
                .norm();
            (
                Some(end),
                (ref_len > 0.0).then(|| 100.0 * end / ref_len),
                None,
            )
        }
        (Some(_), _) => (None, None, Some("the pairs are not contiguous".to_owned())),
        (None, _) => (
            None,
            None,
            Some(
                "the reference is not a rigid 2D pose of the scanner: no drift, ATE or RPE \
                 against it (its positions and heading are not one frame)"
                    .to_owned(),
            ),
        ),
    };
    TrajectoryStats {
        length_m,
        gaps,
        end_point_error_m,
        drift_m_per_100m,
        note,
        heading_rms_error_deg: None,
        heading_end_error_deg: None,
        ate_rmse_m: None,
        evo: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dead_reckoned_heading_by_hand() {
        let pair = |k: usize| ScanPair {
            source: k,
            reference: k + 1,
        };
        let reference = |h0: f64, h1: f64| {
            Some(RefMotion {
                sog_mps: 1.0,
                dcog_deg: wrap_deg(h1 - h0),
                hdg0_deg: h0,
                hdg1_deg: h1,
                t_ref_src: None,
            })
        };
        let est = |dcog_deg: f64| {
            Some(MovementParams {
                sog_mps: 1.0,
                dcog_deg,
                rot_dps: dcog_deg,
                hdg_deg: 0.0,
            })
        };
        // Truth turns 10° per step from 355°; the estimates say 11°, nothing (failed), 10°;
        // then a gap (pair 5→6) restarts from the reference.
        let pairs = [pair(0), pair(1), pair(2), pair(5)];
        let refs = [
            reference(355.0, 5.0),
            reference(5.0, 15.0),
            reference(15.0, 25.0),
            reference(45.0, 55.0),
        ];
        let estimates = [est(11.0), None, est(10.0), est(12.0)];
        let e = chained_heading_errors(&pairs, &estimates, &refs);
        let expected = [1.0, -9.0, -9.0, 2.0];
        for (got, want) in e.iter().zip(expected) {
            assert!((got.unwrap() - want).abs() < 1e-9, "{e:?}");
        }
        assert_eq!(
            chained_heading_errors(&pairs[..1], &[est(1.0)], &[None]),
            vec![None]
        );
    }
}
