//! Truth-free self-consistency across lags (`--lags L`): every loop of consecutive
//! registrations `k → k+1 → … → k+ℓ` against the direct registration `k → k+ℓ`
//! ([`crate::run::lags`]), and the lag-1 registrations that disagree with every trusted loop
//! through their neighbours (status `inconsistent`; see "The flag" below).
//!
//! # What a loop checks, and what it cannot
//! Errors that act like a shift of one scan cancel around a loop: if scan `j` is seen in a
//! frame off by `S_j` (its noise, a range bias, a motion distortion that every registration
//! using it sees the same way), every registration is `T_b⁻¹ S_b⁻¹ … S_a T_a`-shaped and the
//! `S` of the inner scans cancel in the chain, those of the ends in the comparison. A loop
//! therefore closes even when every registration in it carries such an error: it checks
//! association failures and gross errors (a registration in a wrong minimum breaks every loop
//! through it), not the covariance. The loop's predicted σ (the members' covariances summed,
//! frames, levers and the extended modes' motion term aside) overstates what the loop can show
//! for the same reason.
//!
//! # The flag
//! A lag-1 registration `A = k → k+1` has two alternatives across lag 2: `(k−1 → k+1)·(k−1 →
//! k)⁻¹` and `(k+1 → k+2)⁻¹·(k → k+2)`, each from registrations other than `A`. An
//! alternative is *trusted* when both its registrations have status ok: a registration the
//! tool already flags (degenerate, suspect, …) is no evidence against its neighbour, and
//! neither is a lag-2 registration whose scans fit twice ([`fits_once`]). `A` is
//! flagged `inconsistent` when it has at least one trusted alternative and is farther than the
//! field's "wrong" thresholds ([`crate::measure::outcome::WRONG_TRANS_M`],
//! [`crate::measure::outcome::WRONG_ROT_DEG`]: 0.3 m or 3°) from every one: no trusted loop
//! through it closes. A first or last pair, or one whose neighbour is flagged, is judged by
//! the one alternative it has. The reason gives how many alternatives spoke and, for two,
//! whether they agree with each other (within the success thresholds, 0.1 m and 1°: then `A`
//! alone is wrong) or not (failures in a row). The thresholds are the field's, not tuned on
//! a log. Two earlier rules are in eval/README.md with their figures: requiring the two
//! alternatives to agree caught none of aces' wrong registrations (they come in runs), and
//! counting flagged neighbours as evidence flagged good registrations beside failed ones.
//!
//! # A lag-2 registration that fits twice
//! The lag-2 registrations start at their pair's global search (`--init global`), searched
//! within twice the consecutive pairs' window (`run/lags.rs`). Where that search found a
//! runner-up, a translation more than 0.5 m from the best that scores above 0.8 × the best
//! (`GlobalGuess::runner_up_score`), the scans fit in two places, as along a corridor, and
//! the registration may sit in either with status ok: it [`fits_once`] only without one, and
//! it speaks against no neighbour otherwise. On aces (`--init global --lags 2`, PL_ICP,
//! HD_PL_ICP, GICP, HD_GICP) the `inconsistent` flags on right pairs (within 0.1 m and 1° of
//! the reference) went from 8, 14, 9 and 8 to 5, 13, 7 and 5 with the wider lag window, and
//! to 2, 5, 4 and 3 with this rule; the flags' precision from 0.68, 0.65, 0.86 and 0.87 to
//! 0.71, 0.69, 0.90 and 0.91. The price: the rule takes the only flag from 2, 3, 0 and 0
//! badly wrong pairs (> 0.3 m or 3°; the window from 0, 0, 1 and 2), each covered by its
//! covariance: none is silent. On `synthetic:corridor` (the same command) the window changes
//! nothing and the rule removes the 2, 2, 1 and 0 flags on right pairs, and the only flag of
//! 0, 0, 1 and 3 badly wrong ones, all covered (silent stays 0, 0, 1 and 1).

use icp_core::{Covariance, Registration};
use nalgebra::Isometry2;
use serde::{Deserialize, Serialize};

use crate::measure::outcome::{SUCCESS_ROT_DEG, SUCCESS_TRANS_M, WRONG_ROT_DEG, WRONG_TRANS_M};
use crate::measure::stats::quantile_sorted;
use crate::run::covariance::closed_form_inflation;
use crate::run::covariance::CovarianceMode;
use crate::run::extended;
use crate::run::lags::{LagPair, LagRuns};
use crate::run::runner::{PairRun, PairSearch, Runs};
use crate::run::setup::EvalSetup;
use crate::run::status::{apart, PairStatus};

/// One loop of one variant (a row of `cycles.csv`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CycleRecord {
    /// Variant name.
    pub variant: String,
    /// Scan k.
    pub source: usize,
    /// Scan k+ℓ.
    pub reference: usize,
    /// ℓ.
    pub lag: usize,
    /// Translation between the chained consecutive registrations and the direct one, m.
    pub discrepancy_trans_m: Option<f64>,
    /// Rotation between them, degrees.
    pub discrepancy_rot_deg: Option<f64>,
    /// The members' translation covariances summed, as a standard deviation of the
    /// discrepancy's length (frames and levers aside; an overstatement, see the module), m.
    pub predicted_sigma_trans_m: Option<f64>,
    /// The same for the rotation, degrees.
    pub predicted_sigma_rot_deg: Option<f64>,
    /// `closed` (within 0.1 m and 1°), `open` (beyond), or `incomplete` (a member not
    /// registered).
    pub status: String,
}

/// A variant's loops in `summary.json` (`variants[].cycles`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CycleSummary {
    /// Loops across lag 2 with every member registered.
    pub triangles: usize,
    /// Lag-1 registrations flagged `inconsistent`.
    pub inconsistent: usize,
    /// Median translation discrepancy over those triangles, m.
    pub median_trans_m: Option<f64>,
    /// Median rotation discrepancy, degrees.
    pub median_rot_deg: Option<f64>,
    /// Wall time of the registrations across lags per consecutive pair, µs (beside the
    /// global search's per pair, `global_search.timing`).
    pub lag_time_per_pair_us: Option<f64>,
    /// Wall time of the global searches of the pairs across lags per consecutive pair, µs
    /// (made once, shared by every variant; none without `--init global` or checks).
    pub lag_search_time_per_pair_us: Option<f64>,
}

/// The chained `t_ref_src` of consecutive registrations `steps` (`k → k+1` first): scan k
/// into the frame of scan k+ℓ.
pub fn chain(steps: &[Isometry2<f64>]) -> Isometry2<f64> {
    steps
        .iter()
        .fold(Isometry2::identity(), |acc, step| step * acc)
}

fn within_success((m, deg): (f64, f64)) -> bool {
    m <= SUCCESS_TRANS_M && deg <= SUCCESS_ROT_DEG
}

fn wrong((m, deg): (f64, f64)) -> bool {
    m > WRONG_TRANS_M || deg > WRONG_ROT_DEG
}

/// The registration of a run, when there is one.
fn registered(run: &PairRun) -> Option<&Registration> {
    run.result.as_ref().ok()
}

/// A registration of a run that may speak against another: registered, and its own status
/// ok. A registration the tool already flags is no evidence against its neighbours.
fn trusted(run: &PairRun) -> Option<Isometry2<f64>> {
    (run.status == PairStatus::Ok)
        .then(|| registered(run).map(|r| r.t_ref_src))
        .flatten()
}

/// Whether the scans of a pair fit in one place only, by its global search `search`: true
/// unless the search found a runner-up (a distinct translation scoring almost as well as the
/// best). A pair not searched, or whose best pose was not asked for (results only checked),
/// has nothing to say against it: true.
pub fn fits_once(search: Option<&PairSearch>) -> bool {
    !search.is_some_and(|s| {
        s.result
            .as_ref()
            .is_ok_and(|g| g.is_some_and(|g| g.runner_up_score.is_some()))
    })
}

/// Per lag-1 registration of one variant (`lag1`, the run's pairs in order; `lagged`, its
/// registrations across lags in `lags.pairs`' order), the `inconsistent` status it earns;
/// `None` where the loops do not say so (no trusted alternative, or one within reach).
pub fn inconsistent(
    lag1: &[PairRun],
    lags: &LagRuns,
    lagged: &[PairRun],
) -> Vec<Option<PairStatus>> {
    let direct = |first: usize| {
        let i = lags
            .pairs
            .iter()
            .position(|p| p.lag == 2 && p.first == first)?;
        trusted(&lagged[i]).filter(|_| fits_once(lags.runs.searches.get(i)))
    };
    let before = |i: usize| Some(direct(i.checked_sub(1)?)? * trusted(&lag1[i - 1])?.inverse());
    let after = |i: usize| Some(trusted(lag1.get(i + 1)?)?.inverse() * direct(i)?);
    (0..lag1.len())
        .map(|i| {
            let a = registered(&lag1[i])?.t_ref_src;
            let alternatives: Vec<Isometry2<f64>> = before(i).into_iter().chain(after(i)).collect();
            let apart_each: Vec<(f64, f64)> = alternatives.iter().map(|b| apart(&a, b)).collect();
            if apart_each.is_empty() || !apart_each.iter().all(|&d| wrong(d)) {
                return None;
            }
            let nearer = apart_each
                .iter()
                .copied()
                .min_by(|x, y| (x.0 + x.1 / 10.0).total_cmp(&(y.0 + y.1 / 10.0)))?;
            let between = match alternatives[..] {
                [b, c] => Some(apart(&b, &c)),
                _ => None,
            };
            Some(PairStatus::Inconsistent {
                apart_m: nearer.0,
                apart_deg: nearer.1,
                alternatives: alternatives.len(),
                alternatives_apart_m: between.map(|d| d.0),
                alternatives_apart_deg: between.map(|d| d.1),
                alternatives_agree: between.is_some_and(within_success),
            })
        })
        .collect()
}

/// Whether the loop of consecutive registrations that registration `run` across lag `p`
/// spans contradicts it: every member registered with status ok ([`trusted`]), and their
/// chain farther than the "wrong" thresholds (0.3 m or 3°) from it. The sequence smoother
/// leaves such a registration out: one of the two is wrong, and the consecutive ones are
/// judged on their own (their flags, the loops of [`inconsistent`], and the smoother's
/// `contradicted` status). A loop with a member flagged or missing says nothing.
pub fn loop_open(lag1: &[PairRun], p: &LagPair, run: &PairRun) -> bool {
    let Some(direct) = registered(run).map(|r| r.t_ref_src) else {
        return false;
    };
    let steps: Option<Vec<Isometry2<f64>>> = lag1
        .get(p.first..p.first + p.lag)
        .and_then(|members| members.iter().map(trusted).collect());
    steps.is_some_and(|s| wrong(apart(&chain(&s), &direct)))
}

/// Every loop of one variant `name`: its lag-1 registrations `lag1` chained against each of
/// its registrations across lags `lagged`, with `cov` giving a registration's covariance as
/// the report uses it.
pub fn records(
    name: &str,
    lag1: &[PairRun],
    lags: &LagRuns,
    lagged: &[PairRun],
    cov: &dyn Fn(&Registration) -> Option<Covariance>,
) -> Vec<CycleRecord> {
    lags.pairs
        .iter()
        .zip(lagged)
        .map(|(p, run)| {
            let members: Option<Vec<&Registration>> = lag1[p.first..p.first + p.lag]
                .iter()
                .chain(std::iter::once(run))
                .map(|r| r.result.as_ref().ok())
                .collect();
            let d = members.as_ref().map(|m| {
                let steps: Vec<Isometry2<f64>> = m[..p.lag].iter().map(|r| r.t_ref_src).collect();
                apart(&chain(&steps), &m[p.lag].t_ref_src)
            });
            let sigma = members.as_ref().and_then(|m| {
                let (mut t2, mut r2) = (0.0, 0.0);
                for r in m {
                    let Covariance::Bounded(c) = cov(r)? else {
                        return None;
                    };
                    t2 += c[(0, 0)] + c[(1, 1)];
                    r2 += c[(2, 2)];
                }
                Some((t2.sqrt(), r2.sqrt().to_degrees()))
            });
            CycleRecord {
                variant: name.to_owned(),
                source: p.pair.source,
                reference: p.pair.reference,
                lag: p.lag,
                discrepancy_trans_m: d.map(|d| d.0),
                discrepancy_rot_deg: d.map(|d| d.1),
                predicted_sigma_trans_m: sigma.map(|s| s.0),
                predicted_sigma_rot_deg: sigma.map(|s| s.1),
                status: match d {
                    None => "incomplete",
                    Some(d) if within_success(d) => "closed",
                    Some(_) => "open",
                }
                .to_owned(),
            }
        })
        .collect()
}

/// What the loops of a run say: every loop, per variant its summary, and per variant and
/// lag-1 pair the `inconsistent` status it earns.
pub struct Checked {
    /// Every loop, variant by variant.
    pub records: Vec<CycleRecord>,
    /// Per registrar, its summary.
    pub summaries: Vec<CycleSummary>,
    /// Per registrar and pair of the run, the flag.
    pub flags: Vec<Vec<Option<PairStatus>>>,
}

/// The loops of `setup`'s registrars over the run's consecutive registrations `runs` and
/// those across lags `lags`.
pub fn check(setup: &EvalSetup, runs: &Runs, lags: &LagRuns) -> Checked {
    let mut out = Checked {
        records: Vec::new(),
        summaries: Vec::new(),
        flags: Vec::new(),
    };
    for (v, variant) in setup.variants.iter().enumerate() {
        let (lag1, lagged) = (&runs.per_variant[v], &lags.runs.per_variant[v]);
        let inflation = closed_form_inflation(&variant.spec().metric);
        // Sampled and restarted covariances are made for the consecutive pairs only; the
        // closed form and the extended one come with every registration, lag pairs included.
        let cov = |r: &Registration| {
            matches!(
                setup.covariance,
                CovarianceMode::ClosedForm | CovarianceMode::Extended
            )
            .then(|| extended::of_registration(r, setup.covariance, inflation))
            .flatten()
        };
        let rows = records(variant.name(), lag1, lags, lagged, &cov);
        // Only a registration nothing else flagged takes the status.
        let flags: Vec<Option<PairStatus>> = inconsistent(lag1, lags, lagged)
            .into_iter()
            .zip(lag1)
            .map(|(f, run)| f.filter(|_| run.status == PairStatus::Ok))
            .collect();
        let mut summary = summarize(&rows, flags.iter().flatten().count());
        let per_pair = |us: f64| (!lag1.is_empty()).then(|| us / lag1.len() as f64);
        summary.lag_time_per_pair_us = per_pair(lagged.iter().filter_map(|r| r.time_us).sum());
        summary.lag_search_time_per_pair_us =
            per_pair(lags.runs.searches.iter().map(|s| s.time_us).sum());
        out.records.extend(rows);
        out.summaries.push(summary);
        out.flags.push(flags);
    }
    out
}

/// The summary of one variant's loops `rows` with `inconsistent` lag-1 flags.
pub fn summarize(rows: &[CycleRecord], inconsistent: usize) -> CycleSummary {
    let triangles: Vec<&CycleRecord> = rows
        .iter()
        .filter(|r| r.lag == 2 && r.discrepancy_trans_m.is_some())
        .collect();
    let median = |f: fn(&CycleRecord) -> Option<f64>| {
        let mut v: Vec<f64> = triangles.iter().filter_map(|r| f(r)).collect();
        v.sort_by(f64::total_cmp);
        (!v.is_empty()).then(|| quantile_sorted(&v, 0.5))
    };
    CycleSummary {
        triangles: triangles.len(),
        inconsistent,
        median_trans_m: median(|r| r.discrepancy_trans_m),
        median_rot_deg: median(|r| r.discrepancy_rot_deg),
        lag_time_per_pair_us: None,
        lag_search_time_per_pair_us: None,
    }
}

#[cfg(test)]
mod tests {
    use icp_core::global::GlobalGuess;
    use icp_core::IcpError;
    use nalgebra::Vector2;

    use super::*;

    fn pose(x: f64, y: f64, deg: f64) -> Isometry2<f64> {
        Isometry2::new(Vector2::new(x, y), deg.to_radians())
    }

    /// `t_ref_src` of scans `a → b` from their world poses `t_world_scan`.
    fn between(poses: &[Isometry2<f64>], a: usize, b: usize) -> Isometry2<f64> {
        poses[b].inverse() * poses[a]
    }

    #[test]
    fn a_pair_fits_twice_only_where_its_search_found_a_runner_up() {
        let search = |result| PairSearch {
            result,
            time_us: 0.0,
        };
        let guess = |runner_up_score| {
            Ok(Some(GlobalGuess {
                t_ref_src: Isometry2::identity(),
                score: 0.6,
                runner_up_score,
                rotations: 1,
                grid_lookups: 1,
            }))
        };
        assert!(!fits_once(Some(&search(guess(Some(0.55))))));
        assert!(fits_once(Some(&search(guess(None)))));
        // Nothing known against it: results only checked, a failed search, no search.
        assert!(fits_once(Some(&search(Ok(None)))));
        let failed = Err(IcpError::NoEstimate {
            why: "no grid".to_owned(),
        });
        assert!(fits_once(Some(&search(failed))));
        assert!(fits_once(None));
    }

    #[test]
    fn per_scan_shifts_cancel_around_a_loop() {
        // A track of five scans, each seen in a frame off by its own shift S_j (a few cm and
        // tenths of a degree: what one scan's noise or distortion does to every registration
        // that uses it).
        let truth: Vec<Isometry2<f64>> = (0..5)
            .map(|k| pose(0.3 * k as f64, 0.02 * (k * k) as f64, 4.0 * k as f64))
            .collect();
        let shifts = [
            pose(0.03, -0.01, 0.2),
            pose(-0.02, 0.04, -0.3),
            pose(0.05, 0.02, 0.4),
            pose(-0.01, -0.03, 0.1),
            pose(0.02, 0.0, -0.2),
        ];
        let seen: Vec<Isometry2<f64>> = truth.iter().zip(&shifts).map(|(t, s)| t * s).collect();
        for k in 0..3 {
            // Every registration is off against the truth…
            let step_error = apart(&between(&seen, k, k + 1), &between(&truth, k, k + 1));
            assert!(step_error.0 > 0.01, "{step_error:?}");
            // …but the loop closes exactly.
            let steps = [between(&seen, k, k + 1), between(&seen, k + 1, k + 2)];
            let d = apart(&chain(&steps), &between(&seen, k, k + 2));
            assert!(d.0 < 1e-12 && d.1 < 1e-9, "{d:?}");
        }
        // A wrong minimum in one registration does not cancel.
        let mut wrong = between(&seen, 1, 2);
        wrong.translation.vector.x += 0.5;
        let d = apart(
            &chain(&[between(&seen, 0, 1), wrong]),
            &between(&seen, 0, 2),
        );
        assert!((d.0 - 0.5).abs() < 0.05, "{d:?}");
    }

    #[test]
    fn a_registration_across_a_lag_is_contradicted_only_by_a_loop_of_ok_registrations() {
        let truth: Vec<Isometry2<f64>> = (0..3)
            .map(|k| pose(0.4 * k as f64, 0.05 * k as f64, 5.0 * k as f64))
            .collect();
        let ok = |a: usize, b: usize| PairRun::ok_for_test(between(&truth, a, b), None);
        let mut lag1 = vec![ok(0, 1), ok(1, 2)];
        let p = LagPair {
            pair: datasets::ScanPair {
                source: 0,
                reference: 2,
            },
            lag: 2,
            first: 0,
        };
        let mut slid = between(&truth, 0, 2);
        slid.translation.vector.x += 0.5;
        let slid = PairRun::ok_for_test(slid, None);
        assert!(!loop_open(&lag1, &p, &ok(0, 2)));
        assert!(loop_open(&lag1, &p, &slid));
        // A direct registration that failed is not a number to leave out.
        let failed = PairRun {
            result: Err(icp_core::IcpError::NoEstimate {
                why: "test".to_owned(),
            }),
            ..ok(0, 2)
        };
        assert!(!loop_open(&lag1, &p, &failed));
        // A member flagged: the loop says nothing; a loop past the run's end neither.
        lag1[1].status = PairStatus::Degenerate { cond_ratio: 1e-4 };
        assert!(!loop_open(&lag1, &p, &slid));
        assert!(!loop_open(&lag1[..1], &p, &slid));
    }
}
