//! The gate's outcome in Markdown (printed by `icp-eval gate`).

use crate::measure::gate::GateOutcome;

/// A readable table of the outcome.
pub fn outcome_md(outcome: &GateOutcome) -> String {
    use std::fmt::Write as _;
    let mut s = format!(
        "{} metrics checked, {} regressed\n",
        outcome.checked,
        outcome.regressions.len()
    );
    for n in &outcome.notes {
        let _ = writeln!(s, "note: {n}");
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
