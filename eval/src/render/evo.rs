//! The per-pair errors as evo result zips (`evo/<variant>_<error>.zip`, read by `evo_res`; the
//! zip layout is [`crate::render::evo_zip`]'s).

use datasets::Dataset;

use crate::data::scan_time_s;
use crate::error::EvalError;
use crate::measure::record::PairRecord;
use crate::measure::report::RunReport;
use crate::render::evo_zip::{self, EvoInfo, EvoResult};
use crate::render::outdir::OutputDir;

/// The per-pair errors exported as evo results: (file stem, title, label, column).
type Column = (
    &'static str,
    &'static str,
    &'static str,
    fn(&PairRecord) -> Option<f64>,
);

const COLUMNS: [Column; 4] = [
    (
        "sog",
        "SOG error per pair (estimate − reference)",
        "SOG error (m/s)",
        |r| r.sog_err_mps,
    ),
    (
        "dcog",
        "ΔCOG error per pair (estimate − reference)",
        "ΔCOG error (deg)",
        |r| r.dcog_err_deg,
    ),
    (
        "translation",
        "translation error of t_ref_src per pair",
        "translation error (m)",
        |r| r.trans_err_m,
    ),
    (
        "rotation",
        "rotation error of t_ref_src per pair (signed)",
        "rotation error (deg)",
        |r| r.rot_err_deg,
    ),
];

/// One evo result per variant and per-pair error (`evo/<variant>_<error>.zip`), over the pairs
/// the variant's statistics are taken over (every variant registered them) that have a value,
/// timestamped at each pair's reference scan. Errors no pair has are left out.
pub fn results(report: &RunReport, time_s: impl Fn(usize) -> f64) -> Vec<(String, EvoResult)> {
    let mut out = Vec::new();
    for v in &report.variants {
        for (stem, title, label, column) in COLUMNS {
            let (errors, timestamps_s): (Vec<f64>, Vec<f64>) = report
                .pairs
                .iter()
                .filter(|r| r.variant == v.name && r.all_registered)
                .filter_map(|r| Some((column(r)?, time_s(r.reference))))
                .unzip();
            if errors.is_empty() {
                continue;
            }
            out.push((
                format!("{}_{stem}.zip", v.name),
                EvoResult {
                    info: EvoInfo {
                        title: title.to_owned(),
                        ref_name: format!("{} reference", report.dataset.name),
                        est_name: v.name.clone(),
                        label: label.to_owned(),
                    },
                    errors,
                    timestamps_s,
                },
            ));
        }
    }
    out
}

/// The per-pair errors as evo result zips, `evo/<variant>_<error>.zip` (see [`results`]).
pub fn write_evo_results(
    out: &mut OutputDir,
    ds: &Dataset,
    report: &RunReport,
) -> Result<(), EvalError> {
    let results = results(report, |k| scan_time_s(ds, k));
    if results.is_empty() {
        return Ok(());
    }
    let dir = out.dir().join("evo");
    std::fs::create_dir_all(&dir).map_err(|source| EvalError::Io { path: dir, source })?;
    for (name, result) in &results {
        if let Some(bytes) = evo_zip::result_zip(result)? {
            out.write(&format!("evo/{name}"), &bytes)?;
        }
    }
    Ok(())
}
