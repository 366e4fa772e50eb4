//! The convergence-basin protocol (Pomerleau et al. 2013, "Comparing ICP variants on
//! real-world data sets", the evaluation behind libpointmatcher): every pair is registered
//! from many starts scattered around its true motion, and a variant is judged by how far
//! from the truth it may start and still land within the success thresholds.
//!
//! The starts are seeded per (pair, perturbation), the same for every variant, and do not
//! depend on the thread count or on which pairs are run.

use std::fmt::Write as _;

use datasets::{Dataset, ScanPair};
use icp_core::motion::wrap_deg;
use icp_core::{Prepared, Registrar, SurfaceParams, Surfaces, Workspace};
use indicatif::ProgressBar;
use nalgebra::{Isometry2, Vector2};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::outcome::{SUCCESS_ROT_DEG, SUCCESS_TRANS_M};
use crate::reference;
use crate::runner::distinct_surface_params;
use crate::stats::quantile_sorted;
use crate::status::{PairStatus, StatusKind};
use crate::EvalError;

/// What to perturb and how much.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct BasinOptions {
    /// Starts per pair.
    pub perturbations: usize,
    /// Largest distance of a start's translation from the true one, m (uniform in distance,
    /// uniform in direction).
    pub max_translation_m: f64,
    /// Largest rotation of a start from the true one, degrees (uniform in ±this).
    pub max_rotation_deg: f64,
    /// Seed of the starts.
    pub seed: u64,
    /// Every how many pairs one is run (1: all).
    pub pair_stride: usize,
    /// Bins of perturbation size in the success curves.
    pub bins: usize,
}

impl Default for BasinOptions {
    /// 20 starts within 0.3 m and 10° (the synthetic target), every pair, 6 bins.
    fn default() -> Self {
        Self {
            perturbations: 20,
            max_translation_m: 0.3,
            max_rotation_deg: 10.0,
            seed: 0,
            pair_stride: 1,
            bins: 6,
        }
    }
}

impl BasinOptions {
    /// `Err` naming the first option out of its domain.
    pub fn validate(&self) -> Result<(), EvalError> {
        let bad = |name: &'static str, value: f64, why: &'static str| {
            Err(EvalError::BadOption { name, value, why })
        };
        if self.perturbations == 0 {
            return bad("perturbations", 0.0, "must be at least 1");
        }
        if !(self.max_translation_m.is_finite() && self.max_translation_m >= 0.0) {
            return bad(
                "max_translation_m",
                self.max_translation_m,
                "must be finite and non-negative",
            );
        }
        if !(self.max_rotation_deg.is_finite() && (0.0..=180.0).contains(&self.max_rotation_deg)) {
            return bad(
                "max_rotation_deg",
                self.max_rotation_deg,
                "must be within [0, 180]",
            );
        }
        if self.pair_stride == 0 {
            return bad("pair_stride", 0.0, "must be at least 1");
        }
        if self.bins == 0 {
            return bad("bins", 0.0, "must be at least 1");
        }
        Ok(())
    }

    /// The start error of perturbation `index` of `pair`: `(translation offset, rotation)`.
    fn perturbation(&self, pair: ScanPair, index: usize) -> (Vector2<f64>, f64) {
        let mut rng = ChaCha8Rng::seed_from_u64(self.seed);
        rng.set_stream(((pair.source as u64) << 32) ^ index as u64);
        let distance = self.max_translation_m * rng.random::<f64>();
        let direction = std::f64::consts::TAU * rng.random::<f64>();
        let rotation = self.max_rotation_deg * (2.0 * rng.random::<f64>() - 1.0);
        (
            distance * Vector2::new(direction.cos(), direction.sin()),
            rotation.to_radians(),
        )
    }
}

/// One registration of the protocol: a row of `basin.csv`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BasinRow {
    /// Variant name.
    pub variant: String,
    /// Pair index in the dataset's consecutive pairs.
    pub pair: usize,
    /// Perturbation index.
    pub perturbation: usize,
    /// Distance of the start's translation from the true one, m.
    pub start_trans_m: f64,
    /// Rotation of the start from the true one, degrees.
    pub start_rot_deg: f64,
    /// The registration's status.
    pub status: StatusKind,
    /// Translation error of the result, m (empty when not registered).
    pub trans_err_m: Option<f64>,
    /// Rotation error of the result, degrees.
    pub rot_err_deg: Option<f64>,
    /// Registered within the success thresholds (flagged or not).
    pub success: bool,
}

/// Success over the starts whose perturbation falls in `[lo, hi)`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BasinBin {
    /// Lower edge.
    pub lo: f64,
    /// Upper edge.
    pub hi: f64,
    /// Starts in the bin.
    pub trials: usize,
    /// Fraction of them that succeeded.
    pub success_rate: Option<f64>,
}

/// Percentiles of an error.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Percentiles {
    /// Median.
    pub p50: f64,
    /// 90th percentile.
    pub p90: f64,
    /// 95th percentile.
    pub p95: f64,
}

/// One variant's basin.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct VariantBasin {
    /// Variant name.
    pub name: String,
    /// Registrations made.
    pub trials: usize,
    /// Fraction within the success thresholds.
    pub success_rate: f64,
    /// Success against the start's translation offset, m.
    pub by_translation_m: Vec<BasinBin>,
    /// Success against the start's |rotation offset|, degrees.
    pub by_rotation_deg: Vec<BasinBin>,
    /// Translation error of the registered results, m.
    pub trans_err_m: Option<Percentiles>,
    /// |Rotation error| of the registered results, degrees.
    pub rot_err_deg: Option<Percentiles>,
}

/// The protocol's result.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BasinReport {
    /// Dataset name.
    pub dataset: String,
    /// The options.
    pub options: BasinOptions,
    /// Pairs run.
    pub pairs: usize,
    /// A result within this translation error of the truth is a success, m.
    pub success_trans_m: f64,
    /// …and within this rotation error, degrees.
    pub success_rot_deg: f64,
    /// Per variant, in run order.
    pub variants: Vec<VariantBasin>,
    /// Every registration (written to `basin.csv`).
    #[serde(skip)]
    pub rows: Vec<BasinRow>,
}

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
/// runs its own, see [`crate::shard`]), in their order: `ds` has a rigid reference and
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
            let truth = reference::motion(ds, pair.source, pair.reference, ds.pair_dt_s(pair))
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
                    let status = PairStatus::of(&result, None);
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

/// The protocol's report from the `rows` of `pairs` pairs, one summary per variant of
/// `names` (in run order).
pub fn report(
    ds: &Dataset,
    names: &[&str],
    options: &BasinOptions,
    pairs: usize,
    rows: Vec<BasinRow>,
) -> BasinReport {
    let variants = names
        .iter()
        .map(|name| summarize(name, &rows, options))
        .collect();
    BasinReport {
        dataset: ds.provenance.name.clone(),
        options: *options,
        pairs,
        success_trans_m: SUCCESS_TRANS_M,
        success_rot_deg: SUCCESS_ROT_DEG,
        variants,
        rows,
    }
}

fn summarize(name: &str, rows: &[BasinRow], options: &BasinOptions) -> VariantBasin {
    let mine: Vec<&BasinRow> = rows.iter().filter(|r| r.variant == name).collect();
    let rate = |rs: &[&BasinRow]| {
        (!rs.is_empty()).then(|| rs.iter().filter(|r| r.success).count() as f64 / rs.len() as f64)
    };
    let bins = |max: f64, size: fn(&BasinRow) -> f64| -> Vec<BasinBin> {
        let width = max / options.bins as f64;
        (0..options.bins)
            .map(|b| {
                let (lo, hi) = (b as f64 * width, (b + 1) as f64 * width);
                let last = b + 1 == options.bins;
                let inside: Vec<&BasinRow> = mine
                    .iter()
                    .copied()
                    .filter(|r| {
                        let s = size(r);
                        s >= lo && (s < hi || (last && s <= hi))
                    })
                    .collect();
                BasinBin {
                    lo,
                    hi,
                    trials: inside.len(),
                    success_rate: rate(&inside),
                }
            })
            .collect()
    };
    let percentiles = |get: fn(&BasinRow) -> Option<f64>| {
        let mut v: Vec<f64> = mine.iter().filter_map(|r| get(r)).map(f64::abs).collect();
        v.sort_by(f64::total_cmp);
        (!v.is_empty()).then(|| Percentiles {
            p50: quantile_sorted(&v, 0.5),
            p90: quantile_sorted(&v, 0.9),
            p95: quantile_sorted(&v, 0.95),
        })
    };
    VariantBasin {
        name: name.to_owned(),
        trials: mine.len(),
        success_rate: rate(&mine).unwrap_or(0.0),
        by_translation_m: bins(options.max_translation_m, |r| r.start_trans_m),
        by_rotation_deg: bins(options.max_rotation_deg, |r| r.start_rot_deg.abs()),
        trans_err_m: percentiles(|r| r.trans_err_m),
        rot_err_deg: percentiles(|r| r.rot_err_deg),
    }
}

/// `basin.csv`: one row per registration.
pub fn basin_csv(report: &BasinReport) -> Result<Vec<u8>, EvalError> {
    let mut w = csv::Writer::from_writer(Vec::new());
    for r in &report.rows {
        w.serialize(r)
            .map_err(|e| EvalError::Serialize(e.to_string()))?;
    }
    w.into_inner()
        .map_err(|e| EvalError::Serialize(e.to_string()))
}

/// `basin.md`: success per variant, overall and per perturbation bin.
pub fn basin_md(report: &BasinReport) -> String {
    let o = &report.options;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "# Convergence basin — {}\n\n{} pairs × {} starts within {} m and ±{}° of the true motion (seed {}); success: within {} m and {}° of it.\n",
        report.dataset,
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
