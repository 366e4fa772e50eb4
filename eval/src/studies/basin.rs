//! The convergence-basin protocol (Pomerleau et al. 2013, "Comparing ICP variants on
//! real-world data sets", the evaluation behind libpointmatcher): every pair is registered
//! from many starts scattered around its true motion, and a variant is judged by how far
//! from the truth it may start and still land within the success thresholds.
//!
//! The starts are seeded per (pair, perturbation), the same for every variant, and do not
//! depend on the thread count or on which pairs are run.

use datasets::{Dataset, ScanPair};
use icp_core::motion::wrap_deg;
use icp_core::{Prepared, Registrar, SurfaceParams, Surfaces, Workspace};
use indicatif::ProgressBar;
use nalgebra::Isometry2;
use rayon::prelude::*;

use crate::data;
use crate::error::EvalError;
use crate::measure::basin::{report, BasinOptions, BasinReport, BasinRow};
use crate::measure::outcome::{SUCCESS_ROT_DEG, SUCCESS_TRANS_M};
use crate::run::runner::distinct_surface_params;
use crate::run::status::PairStatus;

/// Runs the protocol: each of `registrars` on every `options.pair_stride`-th consecutive pair
/// of `ds`, from `options.perturbations` starts around the pair's true motion.
pub fn run(
    ds: &Dataset,
    registrars: &[Box<dyn Registrar>],
    options: &BasinOptions,
    progress: &ProgressBar,
) -> Result<BasinReport, EvalError> {
    options.validate()?;
    if !ds.rigid_reference() {
        return Err(EvalError::NeedsRigidReference {
            what: "the convergence basin",
            dataset: ds.provenance.name.clone(),
        });
    }
    let chosen = chosen_pairs(ds, options);
    let rows = run_pairs(ds, registrars, options, &chosen, progress);
    let names: Vec<&str> = registrars.iter().map(|r| r.name()).collect();
    Ok(report(ds, &names, options, chosen.len(), rows))
}

/// `Err` unless `lags` is 1: the protocol makes no loop across lags (`--lags`). It judges
/// every start against the true motion (it needs a rigid reference), so a truth-free check
/// adds nothing to what it measures; and a loop chains the registrations of neighbouring
/// pairs, each from its own start drawn independently per (pair, perturbation) and perhaps
/// skipped by `pair_stride`, so whether a loop closes would be a property of several starts,
/// not of one. How well loops catch wrong registrations is measured by `run --lags` against a
/// rigid reference (the flags' recall and precision).
pub fn check_lags(lags: usize) -> Result<(), EvalError> {
    if lags == 1 {
        return Ok(());
    }
    Err(EvalError::Lags {
        lags,
        why: "the convergence basin makes no loops: each start is judged against the true \
              motion, and a loop would chain the independent starts of neighbouring pairs; \
              measure the loops with `run --lags` on a rigid reference"
            .to_owned(),
    })
}

/// The pairs the protocol runs: every `options.pair_stride`-th consecutive pair of `ds`, with
/// its index among them all.
pub fn chosen_pairs(ds: &Dataset, options: &BasinOptions) -> Vec<(usize, ScanPair)> {
    let (all, _) = ds.consecutive_pairs();
    all.into_iter()
        .enumerate()
        .step_by(options.pair_stride)
        .collect()
}

/// The protocol's registrations on `chosen` (some of [`chosen_pairs`]; a shard of the run
/// runs its own, see the `shard` module), in their order: `ds` has a rigid reference and
/// `options` are valid (checked by [`run`] or the caller).
pub fn run_pairs(
    ds: &Dataset,
    registrars: &[Box<dyn Registrar>],
    options: &BasinOptions,
    chosen: &[(usize, ScanPair)],
    progress: &ProgressBar,
) -> Vec<BasinRow> {
    let params: Vec<SurfaceParams> =
        distinct_surface_params(registrars.iter().map(|r| r.surface_params()));
    progress.set_length((chosen.len() * registrars.len() * options.perturbations) as u64);
    let per_pair: Vec<Vec<BasinRow>> = chosen
        .par_iter()
        .map_init(Workspace::default, |workspace, &(index, pair)| {
            let truth = data::motion(ds, pair.source, pair.reference, ds.pair_dt_s(pair))
                .and_then(|m| m.t_ref_src)
                .expect("a rigid reference has a motion for every pair");
            let surfaces: Vec<(Surfaces, Surfaces)> = params
                .iter()
                .map(|p| {
                    (
                        Surfaces::estimate(&ds.scans[pair.source], p),
                        Surfaces::estimate(&ds.scans[pair.reference], p),
                    )
                })
                .collect();
            let mut rows = Vec::new();
            for j in 0..options.perturbations {
                let (offset, rotation) = options.perturbation(pair, j);
                let start = Isometry2::new(truth.translation.vector + offset, 0.0)
                    * nalgebra::UnitComplex::new(truth.rotation.angle() + rotation);
                for reg in registrars {
                    let set = params
                        .iter()
                        .position(|p| *p == reg.surface_params())
                        .expect("every variant's parameters were prepared");
                    let (s, r) = &surfaces[set];
                    let result = reg.register_prepared(
                        workspace,
                        Prepared::new(&ds.scans[pair.source], s),
                        Prepared::new(&ds.scans[pair.reference], r),
                        start,
                    );
                    let status = PairStatus::of(&result, None, None);
                    let errors = result.ok().map(|r| {
                        let t = &r.t_ref_src;
                        (
                            (t.translation.vector - truth.translation.vector).norm(),
                            wrap_deg((t.rotation.angle() - truth.rotation.angle()).to_degrees()),
                        )
                    });
                    rows.push(BasinRow {
                        variant: reg.name().to_owned(),
                        pair: index,
                        perturbation: j,
                        start_trans_m: offset.norm(),
                        start_rot_deg: rotation.to_degrees(),
                        status: status.kind(),
                        trans_err_m: errors.map(|e| e.0),
                        rot_err_deg: errors.map(|e| e.1),
                        success: errors.is_some_and(|(t, a)| {
                            t <= SUCCESS_TRANS_M && a.abs() <= SUCCESS_ROT_DEG
                        }),
                    });
                    progress.inc(1);
                }
            }
            rows
        })
        .collect();
    per_pair.into_iter().flatten().collect()
}
