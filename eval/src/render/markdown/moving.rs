//! Moving returns in `table.md`: per variant with a detector (`icp_core::moving`), what it
//! left out and, where the scans carry truth labels, how well that matches them; the pairs
//! flagged `dynamic`.

use std::fmt::Write as _;

use crate::measure::report::RunReport;
use crate::run::moving::{PULL_APART_DEG, PULL_APART_M};

/// The moving-returns section (nothing when no variant has a detector).
pub fn moving_md(out: &mut String, report: &RunReport) {
    let rows: Vec<_> = report
        .variants
        .iter()
        .filter_map(|v| Some((v, v.moving_returns.as_ref()?)))
        .collect();
    if rows.is_empty() {
        return;
    }
    let _ = writeln!(
        out,
        "\n## Moving returns (`left_out_src`, `left_out_ref` of `pairs.csv`)\n\nA variant with a detector of moving returns registers each pair again without the returns its neighbours in the sequence looked through. Recall is the share of the returns labelled moving that were left out, and static left out the share of the others (over the pairs' source scans, where the dataset has the labels). A pair is flagged `dynamic` (a failure, counted above) when much of a scan moves, or when the motion without the moving returns is far from the motion with them and the returns kept, paired once at that motion, pull it away too (more than {PULL_APART_M} m or {PULL_APART_DEG}°).\n"
    );
    let _ = writeln!(
        out,
        "| method | pairs with returns left out | left out per scan | recall | static left out | dynamic |"
    );
    let _ = writeln!(out, "| --- | ---: | ---: | ---: | ---: | ---: |");
    let share = |v: Option<f64>| v.map_or_else(String::new, |v| format!("{:.1} %", 100.0 * v));
    for (v, m) in &rows {
        let _ = writeln!(
            out,
            "| {} | {} | {:.1} | {} | {} | {} |",
            v.name,
            m.pairs_with_left_out,
            m.left_out_per_scan,
            share(m.recall),
            share(m.static_left_out_rate),
            v.dynamic_pairs.len()
        );
    }
    out.push('\n');
    for (v, _) in rows.iter().filter(|(v, _)| !v.dynamic_pairs.is_empty()) {
        let _ = writeln!(out, "- {} dynamic on pairs {:?}", v.name, v.dynamic_pairs);
    }
}
