//! What `table.md` (and `compare.md`) say about the reference beyond its kind: that there is
//! none and so nothing could be scored, and its time offset, estimated and applied.

use std::fmt::Write as _;

use crate::measure::report::RunReport;
use crate::run::setup::OffsetChoice;

/// Without a reference, the sentence that says nothing could be scored and where the
/// estimates are (`table.md`, `compare.md` and the console).
pub fn no_reference_sentence(report: &RunReport) -> Option<String> {
    (!report.reference.available).then(|| {
        format!(
            "Nothing could be scored: {} has no reference to measure the estimates against, so \
             every error, statistic and comparison here is empty (–); the estimated motions are \
             in `pairs.csv` (`tx_m`, `ty_m`, `theta_deg`, `sog_est_mps`, `dcog_est_deg` per \
             variant and pair) and the chained trajectories in `trajectory_<variant>.tum`.\n",
            report.dataset.name
        )
    })
}

/// The reference time offset: the estimate and the lag applied, and where they differ, what
/// `--reference-offset` did and how to apply the estimate.
pub fn offset_md(out: &mut String, report: &RunReport) {
    let r = &report.reference;
    if let Some(o) = r.offset_estimate {
        let _ = writeln!(
            out,
            "Reference time offset: estimated {} scans ({:.2} s; correlation score {:.3} vs {:.3} at 0; best lag {} scoring {:.3}, accepted only with a gain of {} or more; from {}); applied {} scans.{}\n",
            o.scans,
            o.seconds,
            o.score,
            o.score_at_zero,
            o.best_lag_scans,
            o.best_score,
            o.min_score_gain,
            r.offset_from_variant.as_deref().unwrap_or("–"),
            r.offset_applied_scans,
            offset_not_applied(r.offset_choice, o.scans, r.offset_applied_scans)
        );
    } else if r.offset_applied_scans != 0 {
        let _ = writeln!(
            out,
            "Reference time offset: none estimated (too few pairs, or constant motion); applied {} scans (`--reference-offset {}`).\n",
            r.offset_applied_scans, r.offset_applied_scans
        );
    }
}

/// Where the offset applied is not the one estimated, what `--reference-offset` did and how
/// to apply the estimate (empty where they agree).
fn offset_not_applied(choice: OffsetChoice, estimated: i64, applied: i64) -> String {
    match choice {
        _ if estimated == applied => String::new(),
        OffsetChoice::Fixed(0) => format!(
            " The estimate is not applied: `--reference-offset 0`, the default, never applies \
             an offset; `--reference-offset auto` applies the estimate ({estimated} scans), \
             `--reference-offset N` a lag of N scans."
        ),
        OffsetChoice::Fixed(n) => format!(
            " `--reference-offset {n}` applies that lag whatever is estimated; \
             `--reference-offset auto` would apply the estimate ({estimated} scans)."
        ),
        // `auto` applies the estimate.
        OffsetChoice::Auto => String::new(),
    }
}
