//! `table.md`: the run's tables in Markdown (GitHub renders it), Table 1's layout first, with
//! the paper's published figures beside ours where the dataset is the paper's.

use std::fmt::Write as _;

use icp_core::global::ambiguity::AmbiguityParams;

use crate::error::EvalError;
use crate::measure::report::{ErrorStats, RunReport};
use crate::measure::stats::Stats;
use crate::render::outdir::OutputDir;
use crate::render::published;
use crate::run::estimates::TILT_NOTE_DEG;
use crate::run::setup::ReferenceChecks;

pub mod basin;
pub mod compare;
pub mod consistency;
pub mod cycles;
pub mod gate;
pub mod moving;
pub mod reference;
pub mod reference_floor;
pub mod scaling;
pub mod sweep;

fn cell(v: Option<f64>, digits: usize) -> String {
    v.map_or_else(|| "–".to_owned(), |v| format!("{v:.digits$}"))
}

fn stat(s: Option<Stats>, f: fn(&Stats) -> f64, digits: usize) -> String {
    cell(s.as_ref().map(f), digits)
}

type Pick = fn(&crate::measure::report::VariantSummary) -> &ErrorStats;
type Column = (
    &'static str,
    fn(&ErrorStats) -> Option<Stats>,
    fn(&Stats) -> f64,
    usize,
);

/// One Markdown table: a row per variant, a column per (header, error, statistic, digits).
fn stats_table(
    out: &mut String,
    report: &RunReport,
    pick: Pick,
    with_pairs: bool,
    columns: &[Column],
) {
    let headers: Vec<&str> = columns.iter().map(|c| c.0).collect();
    let pairs_header = if with_pairs { " pairs |" } else { "" };
    let _ = writeln!(out, "| method |{pairs_header} {} |", headers.join(" | "));
    let align = if with_pairs { " ---: |" } else { "" };
    let _ = writeln!(out, "| --- |{align}{}", " ---: |".repeat(columns.len()));
    for v in &report.variants {
        let e = pick(v);
        let cells = cells(e, columns);
        let pairs = if with_pairs {
            format!(" {} |", e.pairs)
        } else {
            String::new()
        };
        let _ = writeln!(out, "| {} |{pairs} {} |", v.name, cells.join(" | "));
    }
}

/// The formatted cells of one row.
fn cells(e: &ErrorStats, columns: &[Column]) -> Vec<String> {
    columns
        .iter()
        .map(|&(_, error, statistic, digits)| stat(error(e), statistic, digits))
        .collect()
}

fn sog(e: &ErrorStats) -> Option<Stats> {
    e.sog_err_mps
}

fn dcog(e: &ErrorStats) -> Option<Stats> {
    e.dcog_err_deg
}

/// Table 1 of the paper: mean, std and signed max of SOG and ΔCOG errors.
const TABLE1: [Column; 6] = [
    ("SOG mean (m/s)", sog, |s| s.mean, 3),
    ("ΔCOG mean (°)", dcog, |s| s.mean, 2),
    ("SOG std (m/s)", sog, |s| s.std, 3),
    ("ΔCOG std (°)", dcog, |s| s.std, 2),
    ("SOG max (m/s)", sog, |s| s.max_signed, 3),
    ("ΔCOG max (°)", dcog, |s| s.max_signed, 2),
];

/// The robust companion: median |e|, RMSE and p95 |e|.
const ROBUST: [Column; 6] = [
    ("SOG median \\|e\\| (m/s)", sog, |s| s.median_abs, 3),
    ("SOG RMSE (m/s)", sog, |s| s.rmse, 3),
    ("SOG p95 \\|e\\| (m/s)", sog, |s| s.p95_abs, 3),
    ("ΔCOG median \\|e\\| (°)", dcog, |s| s.median_abs, 2),
    ("ΔCOG RMSE (°)", dcog, |s| s.rmse, 2),
    ("ΔCOG p95 \\|e\\| (°)", dcog, |s| s.p95_abs, 2),
];

fn table1_rows(out: &mut String, report: &RunReport, pick: Pick) {
    stats_table(out, report, pick, true, &TABLE1);
}

fn robust_rows(out: &mut String, report: &RunReport, pick: Pick) {
    stats_table(out, report, pick, false, &ROBUST);
}

/// `v` to `decimals` decimals, without trailing zeros (`0.2`, `2.159`, `1`).
fn trimmed(v: f64, decimals: usize) -> String {
    let text = format!("{v:.decimals$}");
    let trimmed = text.trim_end_matches('0').trim_end_matches('.');
    if trimmed.is_empty() {
        "0".to_owned()
    } else {
        trimmed.to_owned()
    }
}

/// HDG: per pair its error is the ΔCOG error (HDG = reference HDG₀ + ΔCOG); dead-reckoned
/// through the ΔCOG estimates from the first reference heading, its error accumulates.
fn heading_md(out: &mut String, report: &RunReport) {
    if !report
        .variants
        .iter()
        .any(|v| v.trajectory.heading_rms_error_deg.is_some())
    {
        return;
    }
    let _ = writeln!(
        out,
        "\n## Heading (HDG)\n\nPer pair, HDG = the reference heading at scan k + the estimated ΔCOG (eq. 24), so its error is the ΔCOG error above. Dead-reckoned from the first reference heading through every ΔCOG estimate (no compass), the error accumulates:\n"
    );
    let _ = writeln!(
        out,
        "| method | dead-reckoned HDG RMS error (°) | at the last pair (°) |"
    );
    let _ = writeln!(out, "| --- | ---: | ---: |");
    for v in &report.variants {
        let _ = writeln!(
            out,
            "| {} | {} | {} |",
            v.name,
            cell(v.trajectory.heading_rms_error_deg, 2),
            cell(v.trajectory.heading_end_error_deg, 2)
        );
    }
}

/// ATE and RPE of the chained trajectories against `reference.tum`, as evo computes them.
fn trajectory_errors_md(out: &mut String, report: &RunReport) {
    let Some(kind) = report.reference.reference_tum else {
        return;
    };
    if kind == crate::measure::trajectory::ReferenceTum::PositionsOnly {
        let _ = writeln!(
            out,
            "\n## Trajectory errors against `reference.tum`\n\nNot given: the reference's positions and heading are not one rigid frame (GNSS positions beside a separate heading), so no chained trajectory aligns to it, and an ATE against it measures that mismatch (about 21 m on marina), not the estimate. SOG and ΔCOG are judged against it instead.\n"
        );
        return;
    }
    let _ = writeln!(
        out,
        "\n## Trajectory errors against `reference.tum` (evo)\n\nThe chained trajectory (`trajectory_<variant>.tum`; a failed pair is bridged by the identity) against the reference at the same timestamps: ATE after a rigid SE(2) alignment (Umeyama, no scale; `evo_ape tum reference.tum trajectory_<variant>.tum -a`), RPE between consecutive poses (`evo_rpe`) and over segments of {} m of the estimate's path (`--delta {} --delta_unit m`).\n",
        trimmed(crate::measure::trajectory::RPE_SEGMENT_M, 3),
        trimmed(crate::measure::trajectory::RPE_SEGMENT_M, 3),
    );
    let _ = writeln!(
        out,
        "| method | poses | ATE RMSE (m) | ATE max (m) | ATE rot RMSE (°) | RPE RMSE (m) | RPE rot RMSE (°) | segments | segment RPE RMSE (m) | segment RPE rot RMSE (°) |"
    );
    let _ = writeln!(out, "| --- |{}", " ---: |".repeat(9));
    for v in &report.variants {
        let Some(e) = &v.trajectory.evo else {
            let _ = writeln!(out, "| {} |{}", v.name, " – |".repeat(9));
            continue;
        };
        let rmse = |s: Option<crate::measure::trajectory_metrics::EvoStats>, digits| {
            cell(s.map(|s| s.rmse), digits)
        };
        let _ = writeln!(
            out,
            "| {} | {} | {:.4} | {:.4} | {} | {} | {} | {} | {} | {} |",
            v.name,
            e.poses,
            e.ate_trans_m.rmse,
            e.ate_trans_m.max,
            rmse(e.ate_rot_deg, 3),
            rmse(e.rpe_trans_m, 4),
            rmse(e.rpe_rot_deg, 3),
            e.rpe_segments,
            rmse(e.rpe_segment_trans_m, 4),
            rmse(e.rpe_segment_rot_deg, 3),
        );
    }
    let mirrored: Vec<&str> = report
        .variants
        .iter()
        .filter(|v| {
            v.trajectory
                .evo
                .as_ref()
                .is_some_and(|e| e.mirror_fits_better)
        })
        .map(|v| v.name.as_str())
        .collect();
    if !mirrored.is_empty() {
        let _ = writeln!(
            out,
            "\nFor {}, a mirror image of the track fits the reference better than any rotation: `evo_ape -a` aligns in SE(3), where that mirror is a half turn about an in-plane axis, so its ATE differs from the SE(2) one here (RPE agrees).",
            mirrored.join(", ")
        );
    }
}

/// What became of each variant's badly wrong registrations: flagged, covered by their
/// covariance, or silent (the issue-36 table).
fn wrong_md(out: &mut String, report: &RunReport) {
    use crate::measure::outcome::{COVERED_NEES, WRONG_ROT_DEG, WRONG_TRANS_M};
    let _ = writeln!(
        out,
        "\nThe badly wrong registrations (> {WRONG_TRANS_M} m or {WRONG_ROT_DEG}° from the reference): flagged, covered by the reported covariance (the NEES of the error ≤ {COVERED_NEES:.2}, χ²₃ at 99.9 %; flagged or not), and silent (status `ok` and not covered: a confident wrong number nothing warns of). A flag is right when its pair is not a success.\n"
    );
    let _ = writeln!(
        out,
        "| method | judged | badly wrong | flagged | covered | silent | flags' precision |"
    );
    let _ = writeln!(out, "| --- | ---: | ---: | ---: | ---: | ---: | ---: |");
    for v in &report.variants {
        let Some(q) = v.flag_quality else {
            continue;
        };
        let _ = writeln!(
            out,
            "| {} | {} | {} | {} | {} | {} | {} |",
            v.name,
            q.pairs,
            q.wrong,
            q.wrong_flagged,
            q.wrong_covered,
            q.silent,
            cell(q.precision, 2)
        );
    }
}

/// The failures and flags of each variant, and how the flags fare against a rigid reference.
fn failures_md(out: &mut String, report: &RunReport) {
    let d = &report.dataset;
    let _ = writeln!(out, "\n## Failures and flags\n");
    let _ = writeln!(
        out,
        "A pair is a failure of a variant when it is not registered or its registration is flagged: degenerate (conditioning ratio below {}, unless the reference's likelihood grid pins the result: every pose scoring {} × the best around it within {} m of it, away from no motion, under the extended covariance modes), no overlap (fewer than {:.0} % of the final pairs within {} m), suspect ({}; {}), ambiguous (two distinct poses around the result score nearly alike on that grid, or it cannot say where the scans fit; under the extended covariance modes). Skipped pairs: {}.\n",
        icp_core::quality::DEGENERATE_RATIO,
        AmbiguityParams::default().pinned_ratio.unwrap_or(1.0),
        AmbiguityParams::default().peak_radius_m,
        100.0 * icp_core::quality::MIN_OVERLAP,
        icp_core::quality::OVERLAP_GATE_M,
        crate::run::status::suspect_rule(),
        match (&report.global_search, report.config.global_check) {
            (Some(g), crate::run::setup::GlobalChecks::On) => format!(
                "checked on {} pairs, {} searches failed",
                g.pairs,
                g.failures.len(),
            ),
            _ => "not checked in this run: `--global-check on`".to_owned(),
        },
        d.skipped_pairs.len()
    );
    let rigid = report.variants.iter().any(|v| v.success_rate.is_some());
    let judged = if rigid {
        format!(
            " success rate (≤ {} m and {}°) | flags' recall of the wrong (> {} m or {}°) | flags' precision |",
            crate::measure::outcome::SUCCESS_TRANS_M,
            crate::measure::outcome::SUCCESS_ROT_DEG,
            crate::measure::outcome::WRONG_TRANS_M,
            crate::measure::outcome::WRONG_ROT_DEG
        )
    } else {
        String::new()
    };
    let _ = writeln!(
        out,
        "| method | ok | failed | no overlap | degenerate | suspect | ambiguous | failure rate |{judged}"
    );
    let _ = writeln!(
        out,
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |{}",
        if rigid { " ---: | ---: | ---: |" } else { "" }
    );
    let percent =
        |x: Option<f64>| cell(x.map(|x| 100.0 * x), 1) + if x.is_some() { " %" } else { "" };
    for v in &report.variants {
        let judged = if rigid {
            let q = v.flag_quality;
            format!(
                " {} | {} | {} |",
                percent(v.success_rate),
                percent(q.and_then(|q| q.recall)),
                percent(q.and_then(|q| q.precision))
            )
        } else {
            String::new()
        };
        let _ = writeln!(
            out,
            "| {} | {} | {} | {} | {} | {} | {} | {} |{judged}",
            v.name,
            v.pairs_ok,
            v.failures.len(),
            v.no_overlap_pairs.len(),
            v.degenerate_pairs.len(),
            v.suspect_pairs.len(),
            v.ambiguous_pairs.len(),
            percent(Some(v.failure_rate)),
        );
    }
    if rigid {
        wrong_md(out, report);
    }
    let _ = writeln!(out);
    for v in &report.variants {
        for (flag, pairs) in [
            ("degenerate", &v.degenerate_pairs),
            ("without overlap", &v.no_overlap_pairs),
            ("suspect", &v.suspect_pairs),
            ("ambiguous", &v.ambiguous_pairs),
        ] {
            if !pairs.is_empty() {
                let _ = writeln!(out, "- {} {flag} on pairs {pairs:?}", v.name);
            }
        }
        for f in &v.failures {
            let _ = writeln!(out, "- {} failed on pair {}: {}", v.name, f.pair, f.reason);
        }
    }
    odometry_word(out, report);
}

/// Odometry's word on the wrong registrations, where the log has odometry of its own.
fn odometry_word(out: &mut String, report: &RunReport) {
    if report
        .variants
        .iter()
        .all(|v| v.odometry_on_wrong.is_none())
    {
        return;
    }
    let _ = writeln!(
        out,
        "\nOdometry's word on the wrong registrations (the log's own odometry, independent of \
         the reference; translations only): it confirms a failure when its step lies within {} m \
         of the reference's and beyond {} m of the estimate, and sides with the estimate in the \
         mirror case. Wrong and unflagged are the flags' misses.\n",
        crate::measure::outcome::SUCCESS_TRANS_M,
        crate::measure::outcome::WRONG_TRANS_M,
    );
    let _ = writeln!(
        out,
        "| method | wrong, flagged | confirmed | sides with the estimate | undecided | \
         wrong, unflagged | confirmed | sides with the estimate | undecided |"
    );
    let _ = writeln!(
        out,
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"
    );
    for v in &report.variants {
        if let Some(w) = v.odometry_on_wrong {
            let cells = |x: crate::measure::odometry_word::Verdicts| {
                format!(
                    "{} | {} | {} | {}",
                    x.wrong, x.confirmed, x.sides_with_estimate, x.undecided
                )
            };
            let _ = writeln!(
                out,
                "| {} | {} | {} |",
                v.name,
                cells(w.flagged),
                cells(w.unflagged)
            );
        }
    }
}

/// A time in seconds to the millisecond, without trailing zeros (`0.2`, `2.159`, `1`).
fn seconds(t: f64) -> String {
    trimmed(t, 3)
}

/// Writes `table.md`.
pub fn write(out: &mut OutputDir, report: &RunReport) -> Result<(), EvalError> {
    out.write("table.md", table_md(report).as_bytes())
}

/// `table.md`: Table 1 laid out like the paper, the robust table, and for the marina data the
/// published values beside ours.
pub fn table_md(report: &RunReport) -> String {
    let mut out = String::new();
    let d = &report.dataset;
    let (lo, hi) = report
        .pairs
        .iter()
        .map(|r| r.dt_s)
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), t| {
            (lo.min(t), hi.max(t))
        });
    let spread = if lo < hi && hi - lo > 1e-3 * d.dt_s {
        format!(" (per pair {}–{} s)", seconds(lo), seconds(hi))
    } else {
        String::new()
    };
    let _ = writeln!(
        out,
        "# {} — {} pairs of {} scans{}, Δt = {} s{spread}\n",
        d.name,
        d.pairs,
        d.scans,
        d.first_scans
            .map_or_else(String::new, |f| format!(" ({f})")),
        seconds(d.dt_s)
    );
    let reference = d
        .reference_kind
        .map_or_else(|| "none".to_owned(), |k| k.to_string());
    let sensor = d.sensor.map_or_else(String::new, |m| {
        format!(
            " Sensor model: σ_r = {} m + {}·r, σ_α = {}°.",
            trimmed(m.sigma_r_const_m, 6),
            trimmed(m.sigma_r_per_m, 6),
            trimmed(m.sigma_alpha_rad.to_degrees(), 6)
        )
    });
    let _ = writeln!(out, "Reference: {reference}.{sensor}\n");
    if let Some(sentence) = reference::no_reference_sentence(report) {
        let _ = writeln!(out, "{sentence}");
    }
    reference_floor::floor_line(&mut out, report);
    if !d.warnings.is_empty() {
        let _ = writeln!(out, "Load warnings:\n");
        for w in &d.warnings {
            let _ = writeln!(out, "- {w}");
        }
        out.push('\n');
    }
    let _ = writeln!(
        out,
        "Errors are estimate minus reference. \"max\" is the signed value of largest magnitude.\n"
    );
    let _ = writeln!(
        out,
        "Initial guess: {} (`--init`; a chain tries the next mode while a registration is flagged).\n",
        report.config.init
    );
    if !report.config.start_gated.is_empty() {
        let gated: Vec<String> = report
            .config
            .start_gated
            .iter()
            .map(|(name, gate_m)| format!("{name} at {gate_m} m"))
            .collect();
        let _ = writeln!(
            out,
            "Registrations started close to the motion (at the global search's pose or the reference) gate their correspondences (`--start-gate {}`; surface metrics without a gate of their own): {}.\n",
            report.config.start_gate,
            gated.join(", ")
        );
    }
    if !report.config.estimates.is_empty() {
        let _ = writeln!(
            out,
            "External estimators (`--estimates`), evaluated on the same pairs and assessed at their poses by the same flags (no iterations, timing or covariance of theirs are known here):\n"
        );
        for e in &report.config.estimates {
            let mut unused = String::new();
            if e.unused > 0 {
                unused += &format!(
                    "; {} estimates of the file for no pair of this run, unused",
                    e.unused
                );
            }
            if e.tilted_poses > 0 {
                unused += &format!(
                    "; {} poses tilted more than {TILT_NOTE_DEG}° out of the plane (up to {:.1}°), their roll and pitch dropped",
                    e.tilted_poses, e.max_tilt_deg
                );
            }
            let _ = writeln!(
                out,
                "- {}: {} ({}, SHA-256 {}), an estimate for {} of the {} pairs{unused}",
                e.name,
                e.path.display(),
                e.format,
                e.sha256,
                e.pairs_estimated,
                report.dataset.pairs
            );
        }
        out.push('\n');
    }
    let r = &report.reference;
    reference::offset_md(&mut out, report);
    if r.available && r.checks == ReferenceChecks::Off {
        let _ = writeln!(
            out,
            "Reference checks: off (`--reference-checks off`): every step with a reference counts as plausible.\n"
        );
    }
    let population = &report.population;
    let _ = writeln!(
        out,
        "Every variant's statistics are taken over the same {} pairs: those every variant registered{}. A flagged registration counts as a failure of its variant (see \"Failures and flags\") and its number stays in the statistics.\n",
        population.pairs,
        if population.left_out.is_empty() {
            String::new()
        } else {
            format!(" (pairs {:?} are left out: some variant failed on them)", population.left_out)
        }
    );
    let _ = writeln!(out, "## Table 1 layout, all pairs\n");
    table1_rows(&mut out, report, |v| &v.all_pairs);
    let _ = writeln!(
        out,
        "\n## Table 1 layout, pairs with a plausible reference ({} of {}; {} flagged)\n",
        r.plausible_pairs,
        d.pairs,
        r.flagged_pairs.len()
    );
    table1_rows(&mut out, report, |v| &v.plausible_reference);
    let _ = writeln!(out, "\n## Robust statistics, all pairs\n");
    robust_rows(&mut out, report, |v| &v.all_pairs);
    let _ = writeln!(
        out,
        "\n## Robust statistics, pairs with a plausible reference\n"
    );
    robust_rows(&mut out, report, |v| &v.plausible_reference);
    if report
        .variants
        .iter()
        .any(|v| v.all_pairs.trans_err_m.is_some())
    {
        let _ = writeln!(
            out,
            "\n## Pose error against the rigid reference, all pairs\n"
        );
        if let Some(b) = &report.bound {
            let _ = writeln!(
                out,
                "The noise-limited bound (Cramér–Rao, Censi 2007, from the true surface normals and \
                 the dataset's nominal sensor model: errors the model leaves out are not in it): \
                 RMS over {} pairs {:.4} m and {:.3}°{}. \"× bound\" is a variant's RMSE over the \
                 RMS bound of the same pairs.\n",
                b.pairs,
                b.trans_rms_m,
                b.rot_rms_deg,
                if b.unbounded_pairs > 0 {
                    format!("; {} pairs unbounded (a direction no scan observes)", b.unbounded_pairs)
                } else {
                    String::new()
                }
            );
        }
        let _ = writeln!(out, "| method | translation RMSE (m) | × bound | translation p95 (m) | rotation RMSE (°) | × bound | rotation p95 (°) | chained drift (m per 100 m) |");
        let _ = writeln!(
            out,
            "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"
        );
        for v in &report.variants {
            let e = &v.all_pairs;
            let ratio = |f: fn(&crate::measure::bound::OverBound) -> f64| {
                cell(v.over_bound.as_ref().map(f), 2)
            };
            let _ = writeln!(
                out,
                "| {} | {} | {} | {} | {} | {} | {} | {} |",
                v.name,
                stat(e.trans_err_m, |s| s.rmse, 4),
                ratio(|o| o.trans_ratio),
                stat(e.trans_err_m, |s| s.p95_abs, 4),
                stat(e.rot_err_deg, |s| s.rmse, 3),
                ratio(|o| o.rot_ratio),
                stat(e.rot_err_deg, |s| s.p95_abs, 3),
                cell(v.trajectory.drift_m_per_100m, 2),
            );
        }
    }
    crate::render::markdown::consistency::consistency_md(&mut out, report);
    reference_floor::nees_twins_md(&mut out, report);
    if d.name == "marina" {
        let _ = writeln!(out, "\n## Published (Naus & Marchel 2019, Table 1: 865 scans every 0.2 s) beside ours (175 pairs every ~1 s, all pairs)\n");
        let _ = writeln!(
            out,
            "| method | source | SOG mean | ΔCOG mean | SOG std | ΔCOG std | SOG max | ΔCOG max |"
        );
        let _ = writeln!(
            out,
            "| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: |"
        );
        for v in &report.variants {
            if let Some(p) = published::row(&v.name) {
                let _ = writeln!(
                    out,
                    "| {} | paper | {:.3} | {:.2} | {:.3} | {:.2} | {:.3} | {:.2} |",
                    v.name, p.sog_mean, p.dcog_mean, p.sog_std, p.dcog_std, p.sog_max, p.dcog_max
                );
            }
            let ours = cells(&v.all_pairs, &TABLE1).join(" | ");
            let _ = writeln!(out, "| {} | ours | {ours} |", v.name);
        }
    }
    heading_md(&mut out, report);
    trajectory_errors_md(&mut out, report);
    failures_md(&mut out, report);
    cycles::cycles_md(&mut out, report);
    moving::moving_md(&mut out, report);
    for s in &d.skipped_pairs {
        let _ = writeln!(
            out,
            "- skipped {} → {}: {}",
            s.pair.source, s.pair.reference, s.reason
        );
    }
    if !r.flagged_pairs.is_empty() {
        let _ = writeln!(
            out,
            "\nFlagged reference steps (left out of the \"plausible\" tables):\n"
        );
        for f in &r.flagged_pairs {
            let _ = writeln!(
                out,
                "- pair {} ({} → {}): {}",
                f.pair, f.source, f.reference, f.reason
            );
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::seconds;

    #[test]
    fn seconds_print_to_the_millisecond_without_trailing_zeros() {
        for (t, text) in [
            (0.10000000000000009, "0.1"),
            (0.2, "0.2"),
            (1.0, "1"),
            (10.0, "10"),
            (2.1590000000000487, "2.159"),
            (37.0004, "37"),
            (0.0, "0"),
        ] {
            assert_eq!(seconds(t), text, "{t}");
        }
    }
}
