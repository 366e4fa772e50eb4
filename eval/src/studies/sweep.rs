//! Sensitivity sweeps: re-run the variants with one parameter changed and record how the
//! error spread moves.

use datasets::Dataset;
use icp_core::variants::VariantSpec;
use indicatif::ProgressBar;

use crate::error::EvalError;
use crate::measure::sweep::{points_of, SweepParam, SweepResult};
use crate::pipeline::evaluate;
use crate::run::setup::EvalSetup;

/// Runs `variants` at each value of `param` over `ds`, with the reference alignment and
/// checks of `base` (its variants are not used).
pub fn sweep(
    ds: &Dataset,
    base: &EvalSetup,
    variants: &[VariantSpec],
    param: SweepParam,
    values: &[f64],
    progress: &ProgressBar,
) -> Result<SweepResult, EvalError> {
    let mut points = Vec::new();
    for (&value, setup) in values.iter().zip(setups(base, variants, &param, values)?) {
        let report = evaluate(ds, &setup, progress)?;
        points.extend(points_of(value, &report));
    }
    Ok(SweepResult { param, points })
}

/// The setup of each value of `param`: `variants` with the value, the reference alignment,
/// checks and starts of `base`.
pub fn setups(
    base: &EvalSetup,
    variants: &[VariantSpec],
    param: &SweepParam,
    values: &[f64],
) -> Result<Vec<EvalSetup>, EvalError> {
    values
        .iter()
        .map(|&value| {
            let specs = variants
                .iter()
                .map(|v| param.apply(v, value))
                .collect::<Result<Vec<_>, _>>()?;
            Ok(EvalSetup::from_specs(&specs, base.offset)?
                .with_reference_checks(base.reference_checks)
                .with_init(base.init.clone())
                .with_global(base.global, base.global_check)
                .with_start_gate(base.start_gate))
        })
        .collect()
}
