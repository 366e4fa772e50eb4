//! `sweep.md`: each variant's error spread at each value of the swept parameter.

use crate::measure::sweep::SweepResult;

/// The sweep as a Markdown table.
pub fn sweep_md(result: &SweepResult) -> String {
    use std::fmt::Write as _;
    let cell = |v: Option<f64>, d: usize| v.map_or("–".to_owned(), |v| format!("{v:.d$}"));
    let mut s = format!(
        "# Sweep of {} (pairs with a plausible reference)\n\n",
        result.param.name
    );
    let _ = writeln!(s, "| {} | variant | SOG std (m/s) | SOG median \\|e\\| (m/s) | ΔCOG std (°) | ΔCOG median \\|e\\| (°) |", result.param.name);
    let _ = writeln!(s, "| ---: | --- | ---: | ---: | ---: | ---: |");
    for p in &result.points {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | {} |",
            p.value,
            p.variant,
            cell(p.sog_std_mps, 4),
            cell(p.sog_median_abs_mps, 4),
            cell(p.dcog_std_deg, 3),
            cell(p.dcog_median_abs_deg, 3)
        );
    }
    s
}
