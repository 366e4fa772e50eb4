//! The gate's outcome in Markdown (printed by `icp-eval gate`).

use crate::measure::gate::GateOutcome;

/// A readable account of the outcome: the count, the notes, one line per variant only one run
/// has (`add` is the command that makes a baseline of the current run, for those only in it),
/// and a table of what regressed.
pub fn outcome_md(outcome: &GateOutcome, add: &str) -> String {
    use std::fmt::Write as _;
    let mut s = format!(
        "{} metrics checked, {} regressed\n",
        outcome.checked,
        outcome.regressions.len()
    );
    for n in &outcome.notes {
        let _ = writeln!(s, "note: {n}");
    }
    for v in &outcome.only_baseline {
        let _ = writeln!(s, "{v}: in the baseline only, missing from the current run");
    }
    for v in &outcome.only_current {
        let _ = writeln!(
            s,
            "{v}: in the current run only, not gated (add it to the baseline: {add})"
        );
    }
    if !outcome.regressions.is_empty() {
        let _ = writeln!(s, "\n| variant | metric | baseline | current | allowed |\n| --- | --- | ---: | ---: | ---: |");
        for r in &outcome.regressions {
            let cur = r
                .current
                .map_or("missing".to_owned(), |c| format!("{c:.6}"));
            let _ = writeln!(
                s,
                "| {} | {} | {:.6} | {cur} | {:.6} |",
                r.variant, r.metric, r.baseline, r.allowed
            );
        }
    }
    s
}
