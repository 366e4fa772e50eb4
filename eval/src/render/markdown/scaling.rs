//! `scaling.md`: the cost of a registration against the scan's size.

use std::fmt::Write as _;

use crate::measure::scaling::ScalingResult;

/// The result as a Markdown table.
pub fn scaling_md(result: &ScalingResult) -> String {
    let mut out = format!(
        "# Scaling of {} with scan size\n\nOne registration of scan 0 onto scan 1 of the synthetic `paper` scenario, scanners of \
         more and more beams; wall times are medians on this machine.\n\n\
         | beams | returns | iterations | stop | time per registration | ns per point and iteration |\n\
         | ---: | ---: | ---: | --- | ---: | ---: |\n",
        result.variant
    );
    for p in &result.points {
        let _ = writeln!(
            out,
            "| {} | {} | {} | {} | {:.1} µs | {:.0} |",
            p.beams, p.returns, p.iterations, p.stop, p.median_us, p.ns_per_point_iteration
        );
    }
    out
}
