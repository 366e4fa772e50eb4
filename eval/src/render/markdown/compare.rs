//! `compare.md`: the paired comparisons of a run's variants, with their verdicts.

use crate::measure::compare::{CompareOptions, PairedComparison};
use crate::measure::report::RunReport;

/// The comparison as a Markdown table.
pub fn compare_md(
    report: &RunReport,
    rows: &[PairedComparison],
    options: &CompareOptions,
) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "# Paired comparison — {} ({} pairs)\n",
        report.dataset.name, report.dataset.pairs
    );
    if let Some(sentence) = crate::render::markdown::reference::no_reference_sentence(report) {
        let _ = writeln!(s, "{sentence}");
    }
    let _ = writeln!(
        s,
        "Per pair, Δ = |error of A| − |error of B| over the pairs every variant registered whose reference is plausible; \
         negative Δ means A is more accurate. 95 % interval: bootstrap percentile of the mean ({} resamples, seed {}). \
         p: Wilcoxon signed-rank, two-sided; p (Holm): adjusted for the {} comparisons of this table. \
         A verdict needs both the interval to exclude 0 and the adjusted p < 0.05.\n",
        options.resamples,
        options.seed,
        rows.len()
    );
    let _ = writeln!(
        s,
        "| A | B | error | n | mean Δ | 95 % interval | Wilcoxon p | p (Holm) | verdict |"
    );
    let _ = writeln!(
        s,
        "| --- | --- | --- | ---: | ---: | --- | ---: | ---: | --- |"
    );
    for r in rows {
        let (unit, digits, metric) = if r.metric.ends_with("mps") {
            ("m/s", 4, "SOG")
        } else {
            ("°", 3, "ΔCOG")
        };
        let ci = r.ci95.map_or("–".to_owned(), |(lo, hi)| {
            format!("[{lo:.digits$}, {hi:.digits$}] {unit}")
        });
        let p = r.wilcoxon.map_or("–".to_owned(), |w| {
            format!(
                "{}{}",
                fmt_p(w.p_value),
                if w.exact { "" } else { " (approx.)" }
            )
        });
        let holm = r.p_holm.map_or("–".to_owned(), fmt_p);
        let _ = writeln!(
            s,
            "| {} | {} | {metric} | {} | {:.digits$} {unit} | {ci} | {p} | {holm} | {} |",
            r.a, r.b, r.n, r.mean_diff, r.verdict
        );
    }
    s
}

fn fmt_p(p: f64) -> String {
    if p < 0.001 {
        format!("{p:.1e}")
    } else {
        format!("{p:.3}")
    }
}
