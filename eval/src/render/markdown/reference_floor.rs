//! What the reference can resolve, in `table.md`: one line on its own noise, and the NEES
//! with that noise added and over the unflagged pairs alone.

use std::fmt::Write as _;

use crate::measure::consistency::Consistency;
use crate::measure::report::RunReport;

/// One line on the reference's own noise (nothing for ground truth or without a reference).
pub fn floor_line(out: &mut String, report: &RunReport) {
    let r = &report.reference;
    if let Some(n) = &r.noise {
        let _ = writeln!(out, "What the reference can resolve: {}.\n", n.floor_line());
    } else if let Some(note) = &r.noise_note {
        let _ = writeln!(out, "The reference's own noise is not estimated: {note}.\n");
    }
}

/// The NEES twins: with the reference's noise added, and over the pairs whose status is `ok`
/// (nothing when no variant has either).
pub fn nees_twins_md(out: &mut String, report: &RunReport) {
    let rows: Vec<(&str, Option<&Consistency>, Option<&Consistency>)> = report
        .variants
        .iter()
        .filter_map(|v| {
            let c = v.consistency.as_ref()?;
            let (a, b) = (
                c.nees_with_reference_noise.as_ref(),
                c.nees_unflagged.as_ref(),
            );
            (a.is_some() || b.is_some()).then_some((v.name.as_str(), a, b))
        })
        .collect();
    if rows.is_empty() {
        return;
    }
    let _ = writeln!(
        out,
        "\nNEES with the reference's own step covariance added (a measured rigid reference), and over the pairs whose status is `ok` alone (a few gross failures do not hide how the others fare):\n"
    );
    let _ = writeln!(
        out,
        "| method | with ref. noise: pairs | ANEES/3 | NEES in 95 % | unflagged: pairs | ANEES/3 | NEES in 95 % |"
    );
    let _ = writeln!(out, "| --- | ---: | ---: | ---: | ---: | ---: | ---: |");
    let cells = |c: Option<&Consistency>| {
        c.map_or_else(
            || "|  |  |  ".to_owned(),
            |c| {
                format!(
                    "| {} | {:.3} | {:.3} ",
                    c.pairs, c.anees_per_dof, c.inside_95_fraction
                )
            },
        )
    };
    for (name, with_ref, unflagged) in rows {
        let _ = writeln!(out, "| {name} {}{}|", cells(with_ref), cells(unflagged));
    }
}
