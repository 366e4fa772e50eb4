//! `basin.md`: the convergence basin per variant, overall and per perturbation bin.

use std::fmt::Write as _;

use crate::measure::basin::{BasinBin, BasinReport, Percentiles, VariantBasin};

/// `basin.md`: success per variant, overall and per perturbation bin.
pub fn basin_md(report: &BasinReport) -> String {
    let o = &report.options;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "# Convergence basin — {}{}\n\n{} pairs × {} starts within {} m and ±{}° of the true motion (seed {}); success: within {} m and {}° of it.\n",
        report.dataset,
        report
            .first_scans
            .map_or_else(String::new, |f| format!(" ({f})")),
        report.pairs,
        o.perturbations,
        o.max_translation_m,
        o.max_rotation_deg,
        o.seed,
        report.success_trans_m,
        report.success_rot_deg
    );
    let pct = |x: Option<f64>| x.map_or("–".to_owned(), |x| format!("{:.1} %", 100.0 * x));
    let head = |bins: &[BasinBin], unit: &str| -> String {
        bins.iter()
            .map(|b| format!("{:.3}–{:.3} {unit}", b.lo, b.hi))
            .collect::<Vec<_>>()
            .join(" | ")
    };
    if let Some(v) = report.variants.first() {
        for (title, pick, unit) in [
            (
                "by the start's translation offset",
                (|v: &VariantBasin| &v.by_translation_m) as fn(&VariantBasin) -> &Vec<BasinBin>,
                "m",
            ),
            (
                "by the start's rotation offset",
                |v| &v.by_rotation_deg,
                "°",
            ),
        ] {
            let bins = pick(v);
            let _ = writeln!(s, "## Success {title}\n");
            let _ = writeln!(s, "| method | all | {} |", head(bins, unit));
            let _ = writeln!(s, "| --- | ---: |{}", " ---: |".repeat(bins.len()));
            for v in &report.variants {
                let cells: Vec<String> = pick(v).iter().map(|b| pct(b.success_rate)).collect();
                let _ = writeln!(
                    s,
                    "| {} | {} | {} |",
                    v.name,
                    pct(Some(v.success_rate)),
                    cells.join(" | ")
                );
            }
            let _ = writeln!(s);
        }
    }
    let _ = writeln!(s, "## Error of the registered results\n");
    let _ = writeln!(
        s,
        "| method | translation p50 (m) | p90 | p95 | rotation p50 (°) | p90 | p95 |"
    );
    let _ = writeln!(s, "| --- | ---: | ---: | ---: | ---: | ---: | ---: |");
    let cells = |p: Option<Percentiles>, digits: usize| -> String {
        p.map_or("– | – | –".to_owned(), |p| {
            format!(
                "{:.digits$} | {:.digits$} | {:.digits$}",
                p.p50, p.p90, p.p95
            )
        })
    };
    for v in &report.variants {
        let _ = writeln!(
            s,
            "| {} | {} | {} |",
            v.name,
            cells(v.trans_err_m, 4),
            cells(v.rot_err_deg, 3)
        );
    }
    s
}
