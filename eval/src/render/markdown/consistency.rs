//! The covariance-consistency section of `table.md`.

use crate::measure::consistency::{ConsistencySummary, Standardised};
use crate::measure::report::RunReport;

/// The consistency section of `table.md` (nothing when no variant has one).
pub fn consistency_md(out: &mut String, report: &RunReport) {
    use std::fmt::Write;
    let rows: Vec<(&str, &ConsistencySummary)> = report
        .variants
        .iter()
        .filter_map(|v| Some((v.name.as_str(), v.consistency.as_ref()?)))
        .collect();
    let Some((_, first)) = rows.first() else {
        return;
    };
    let f = |v: Option<f64>, digits: usize| v.map_or_else(String::new, |v| format!("{v:.digits$}"));
    let _ = writeln!(
        out,
        "\n## Covariance consistency ({}; see eval/README.md)\n",
        first.mode
    );
    let _ = writeln!(
        out,
        "NEES where the reference is a rigid pose (χ²(3) if the covariance is honest: ANEES/3 = 1, \
         95 % of pairs in [0.216, 9.348]); z = e/σ of SOG and ΔCOG over the pairs with a \
         plausible reference (sd 1, 95.4 % within ±2), and with the reference's own noise added \
         to σ where the reference is measured.\n"
    );
    let _ = writeln!(
        out,
        "| method | inflation | NEES pairs | unbounded | ANEES/3 | 95 % bounds of ANEES/3 | NEES in 95 % | SOG z sd (robust) | SOG within ±2σ | with ref. noise | ΔCOG z sd (robust) | ΔCOG within ±2σ | with ref. noise |"
    );
    let _ = writeln!(
        out,
        "| --- | ---: | ---: | ---: | ---: | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"
    );
    for (name, c) in rows {
        let n = c.nees.as_ref();
        let z = |s: Option<&Standardised>| {
            (
                s.map_or_else(String::new, |s| format!("{:.2} ({:.2})", s.sd, s.mad_sd)),
                f(s.map(|s| s.within_2sigma_fraction), 3),
            )
        };
        let (sog_sd, sog_in) = z(c.sog_z.as_ref());
        let (dcog_sd, dcog_in) = z(c.dcog_z.as_ref());
        let _ = writeln!(
            out,
            "| {name} | {} | {} | {} | {} | {} | {} | {sog_sd} | {sog_in} | {} | {dcog_sd} | {dcog_in} | {} |",
            f(Some(c.inflation), 2),
            n.map_or_else(String::new, |n| n.pairs.to_string()),
            n.map_or_else(String::new, |n| n.unbounded_pairs.to_string()),
            f(n.map(|n| n.anees_per_dof), 3),
            n.map_or_else(String::new, |n| format!(
                "[{:.3}, {:.3}]",
                n.anees_bounds_95[0] / 3.0,
                n.anees_bounds_95[1] / 3.0
            )),
            f(n.map(|n| n.inside_95_fraction), 3),
            f(c.sog_z_with_reference_noise.as_ref().map(|s| s.within_2sigma_fraction), 3),
            f(c.dcog_z_with_reference_noise.as_ref().map(|s| s.within_2sigma_fraction), 3),
        );
    }
}
