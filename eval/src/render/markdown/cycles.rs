//! The loops across lags in `table.md` (`--lags`): per variant its triangles, their median
//! discrepancy, and the registrations flagged `inconsistent`.

use std::fmt::Write as _;

use crate::measure::report::RunReport;

/// The loops section (nothing without `--lags`).
pub fn cycles_md(out: &mut String, report: &RunReport) {
    let rows: Vec<_> = report
        .variants
        .iter()
        .filter_map(|v| Some((v, v.cycles.as_ref()?)))
        .collect();
    if rows.is_empty() {
        return;
    }
    let _ = writeln!(
        out,
        "\n## Loops across lags (`cycles.csv`)\n\nEach consecutive registration chained against the direct one across the lag; a registration more than 0.3 m or 3° from every trusted loop through its neighbours across lag 2 (one whose registrations all have status ok), with at least one, is flagged `inconsistent` (a failure, counted in the failure rate above). Errors that act like a shift of one scan cancel around a loop: loops check gross errors, not covariances.\n"
    );
    let _ = writeln!(
        out,
        "| method | triangles | median discrepancy (m) | median discrepancy (°) | inconsistent |"
    );
    let _ = writeln!(out, "| --- | ---: | ---: | ---: | ---: |");
    let cell =
        |v: Option<f64>, digits: usize| v.map_or_else(String::new, |v| format!("{v:.digits$}"));
    for (v, c) in &rows {
        let _ = writeln!(
            out,
            "| {} | {} | {} | {} | {} |",
            v.name,
            c.triangles,
            cell(c.median_trans_m, 4),
            cell(c.median_rot_deg, 3),
            c.inconsistent
        );
    }
    out.push('\n');
    for (v, _) in rows
        .iter()
        .filter(|(v, _)| !v.inconsistent_pairs.is_empty())
    {
        let _ = writeln!(
            out,
            "- {} inconsistent on pairs {:?}",
            v.name, v.inconsistent_pairs
        );
    }
}
