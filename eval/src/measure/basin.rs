//! The convergence-basin protocol's definition and measure (Pomerleau et al. 2013, "Comparing ICP variants on
//! real-world data sets", the evaluation behind libpointmatcher): every pair is registered
//! from many starts scattered around its true motion, and a variant is judged by how far
//! from the truth it may start and still land within the success thresholds.
//!
//! This file holds the protocol's options (the seeded starts: per (pair, perturbation), the
//! same for every variant, independent of the thread count and of which pairs are run), its
//! rows and their summary; `studies::basin` runs it.

use datasets::{Dataset, ScanPair};
use nalgebra::Vector2;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::error::EvalError;
use crate::measure::outcome::{SUCCESS_ROT_DEG, SUCCESS_TRANS_M};
use crate::measure::stats::quantile_sorted;
use crate::run::status::StatusKind;

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
    pub fn perturbation(&self, pair: ScanPair, index: usize) -> (Vector2<f64>, f64) {
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
    /// When only the first scans of the dataset were kept (`--scans N`; see
    /// [`datasets::Dataset::first_scans`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub first_scans: Option<datasets::FirstScans>,
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
        first_scans: ds.first_scans,
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
