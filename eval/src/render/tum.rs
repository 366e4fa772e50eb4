//! `trajectory_<variant>.tum` and `reference.tum`: the chained poses in the TUM format evo
//! reads.

use std::fmt::Write as _;

use crate::error::EvalError;
use crate::measure::report::RunReport;
use crate::render::outdir::OutputDir;

/// Writes one trajectory per variant and, where there is one, the reference's.
pub fn write(out: &mut OutputDir, report: &RunReport) -> Result<(), EvalError> {
    for (i, v) in report.variants.iter().enumerate() {
        out.write(
            &format!("trajectory_{}.tum", v.name),
            tum(report, i).as_bytes(),
        )?;
    }
    if let Some(text) = reference_tum(report) {
        out.write("reference.tum", text.as_bytes())?;
    }
    Ok(())
}

/// `trajectory_<variant>.tum`: `timestamp x y z qx qy qz qw` per chained pose.
pub fn tum(report: &RunReport, variant: usize) -> String {
    let mut s = String::new();
    for (t, pose) in &report.trajectories[variant] {
        tum_line(&mut s, *t, pose);
    }
    s
}

/// `reference.tum`: the reference pose at each pose of the trajectories, with their
/// timestamps (so evo associates them exactly); poses without a reference are left out.
/// Identity orientations when the reference gives positions only
/// (`reference.reference_tum` says which).
pub fn reference_tum(report: &RunReport) -> Option<String> {
    report.reference.reference_tum?;
    let times = report.trajectories.first()?;
    let mut s = String::new();
    for ((t, _), pose) in times.iter().zip(&report.reference_trajectory) {
        if let Some(pose) = pose {
            tum_line(&mut s, *t, pose);
        }
    }
    Some(s)
}

/// One TUM line. Positions and the quaternion are written with the shortest decimal that
/// reads back as the same `f64`, so evo computes on exactly our numbers; the timestamp to the
/// microsecond, identical in every file of a run.
fn tum_line(s: &mut String, t: f64, pose: &nalgebra::Isometry2<f64>) {
    let half = 0.5 * pose.rotation.angle();
    let _ = writeln!(
        s,
        "{t:.6} {} {} 0 0 0 {} {}",
        pose.translation.x,
        pose.translation.y,
        half.sin(),
        half.cos()
    );
}
