//! The regression gate: compares a current `summary.json` with a committed baseline, metric by
//! metric, against explicit tolerances; and what makes a run's summary a usable baseline.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::measure::report::ErrorStats;
use crate::measure::report::RunReport;
use crate::measure::report::VariantSummary;
use crate::measure::report::SCHEMA_VERSION;
use crate::measure::stats::Stats;

/// The built-in tolerances: the committed `reports/baseline/tolerance.json` itself, compiled
/// in, so that the two cannot differ.
pub const BUILTIN_TOLERANCE: &str = include_str!("../../../reports/baseline/tolerance.json");

/// How far a metric may move the wrong way: `max(abs, rel · |baseline|)`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Tolerance {
    /// Absolute allowance, in the metric's unit.
    pub abs: f64,
    /// Relative allowance, a fraction of the baseline.
    pub rel: f64,
}

/// The tolerance file: a default and per-metric overrides. A metric key is matched by its
/// longest suffix present in `metrics` (e.g. `sog_err_mps.std` matches
/// `plausible_reference.sog_err_mps.std`), else the default applies.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Tolerances {
    /// Applies to every metric without an override.
    pub default: Tolerance,
    /// Overrides by metric key suffix.
    #[serde(default)]
    pub metrics: BTreeMap<String, Tolerance>,
}

impl Tolerances {
    /// Reads and [validates](Self::validate) a tolerance file's text.
    pub fn parse(text: &str) -> Result<Self, String> {
        let t: Self =
            serde_json::from_str(text).map_err(|e| format!("not a tolerance file: {e}"))?;
        t.validate()?;
        Ok(t)
    }

    /// The built-in tolerances ([`BUILTIN_TOLERANCE`]).
    pub fn builtin() -> Result<Self, String> {
        Self::parse(BUILTIN_TOLERANCE)
    }

    /// The tolerance of `key`.
    pub fn of(&self, key: &str) -> Tolerance {
        self.metrics
            .iter()
            .filter(|(suffix, _)| key == suffix.as_str() || key.ends_with(&format!(".{suffix}")))
            .max_by_key(|(suffix, _)| suffix.len())
            .map_or(self.default, |(_, t)| *t)
    }

    /// Checks every allowance is finite and non-negative.
    pub fn validate(&self) -> Result<(), String> {
        for (k, t) in std::iter::once(("default", &self.default))
            .chain(self.metrics.iter().map(|(k, t)| (k.as_str(), t)))
        {
            if !(t.abs.is_finite() && t.abs >= 0.0 && t.rel.is_finite() && t.rel >= 0.0) {
                return Err(format!(
                    "tolerance {k}: abs and rel must be finite and non-negative"
                ));
            }
        }
        Ok(())
    }
}

/// Which way is better for a metric.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Better {
    /// Smaller is better (errors).
    Lower,
    /// Larger is better (registered pairs, converged fraction).
    Higher,
}

/// One metric that got worse beyond its tolerance (or vanished).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Regression {
    /// Variant.
    pub variant: String,
    /// Metric key.
    pub metric: String,
    /// Baseline value.
    pub baseline: f64,
    /// Current value (`None`: missing in the current run).
    pub current: Option<f64>,
    /// The allowed limit.
    pub allowed: f64,
}

/// The gate's verdict.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GateOutcome {
    /// Metrics compared.
    pub checked: usize,
    /// Those that regressed.
    pub regressions: Vec<Regression>,
    /// What the reader needs to read them right (the runs' populations differ; an external
    /// estimator's file changed).
    #[serde(default)]
    pub notes: Vec<String>,
    /// Variants of the baseline the current run lacks: a failure (a scheme no longer run must
    /// not pass unseen).
    #[serde(default)]
    pub only_baseline: Vec<String>,
    /// Variants of the current run the baseline lacks: not gated, and said so.
    #[serde(default)]
    pub only_current: Vec<String>,
}

impl GateOutcome {
    /// Whether the gate passes: nothing regressed and no baseline variant is missing.
    pub fn passed(&self) -> bool {
        self.regressions.is_empty() && self.only_baseline.is_empty()
    }
}

/// The gated metrics of one variant: `(key, value, which way is better)`.
pub fn metrics(v: &VariantSummary) -> Vec<(String, f64, Better)> {
    let mut out = vec![
        ("pairs_ok".to_owned(), v.pairs_ok as f64, Better::Higher),
        ("failure_rate".to_owned(), v.failure_rate, Better::Lower),
    ];
    // An external estimator has none (nothing iterated here).
    if let Some(c) = v.converged_fraction {
        out.push(("converged_fraction".to_owned(), c, Better::Higher));
    }
    if let Some(rate) = v.success_rate {
        out.push(("success_rate".to_owned(), rate, Better::Higher));
    }
    let stats = |set: &str, name: &str, s: &Option<Stats>, out: &mut Vec<(String, f64, Better)>| {
        if let Some(s) = s {
            out.push((
                format!("{set}.{name}.abs_mean"),
                s.mean.abs(),
                Better::Lower,
            ));
            for (k, val) in [
                ("std", s.std),
                ("median_abs", s.median_abs),
                ("rmse", s.rmse),
                ("p95_abs", s.p95_abs),
            ] {
                out.push((format!("{set}.{name}.{k}"), val, Better::Lower));
            }
        }
    };
    for (set, e) in [
        ("all_pairs", &v.all_pairs),
        ("plausible_reference", &v.plausible_reference),
    ] {
        let ErrorStats {
            sog_err_mps,
            dcog_err_deg,
            trans_err_m,
            rot_err_deg,
            ..
        } = e;
        stats(set, "sog_err_mps", sog_err_mps, &mut out);
        stats(set, "dcog_err_deg", dcog_err_deg, &mut out);
        stats(set, "trans_err_m", trans_err_m, &mut out);
        stats(set, "rot_err_deg", rot_err_deg, &mut out);
    }
    if let Some(d) = v.trajectory.drift_m_per_100m {
        out.push(("trajectory.drift_m_per_100m".to_owned(), d, Better::Lower));
    }
    out
}

/// Why two reports cannot be compared.
pub fn incompatibility(baseline: &RunReport, current: &RunReport) -> Option<String> {
    let (b, c) = (&baseline.dataset, &current.dataset);
    if baseline.schema_version != current.schema_version {
        return Some(format!(
            "schema_version {} vs {}",
            baseline.schema_version, current.schema_version
        ));
    }
    if b.name != c.name || b.scans != c.scans || b.pairs != c.pairs {
        return Some(format!(
            "different data: {} ({} scans, {} pairs) vs {} ({} scans, {} pairs)",
            b.name, b.scans, b.pairs, c.name, c.scans, c.pairs
        ));
    }
    let sums = |d: &crate::measure::report::DatasetInfo| {
        d.files.iter().map(|f| f.sha256.clone()).collect::<Vec<_>>()
    };
    if sums(b) != sums(c) {
        return Some("the input files' sha256 differ".to_owned());
    }
    None
}

/// Compares every gated metric of every variant both runs have, and names the variants only
/// one of them has.
pub fn gate(baseline: &RunReport, current: &RunReport, tolerances: &Tolerances) -> GateOutcome {
    let mut checked = 0;
    let mut regressions = Vec::new();
    let mut only_baseline = Vec::new();
    for bv in &baseline.variants {
        let Some(cv) = current.variants.iter().find(|v| v.name == bv.name) else {
            only_baseline.push(bv.name.clone());
            continue;
        };
        let cur = metrics(cv);
        for (key, base, better) in metrics(bv) {
            checked += 1;
            let t = tolerances.of(&key);
            let slack = t.abs.max(t.rel * base.abs());
            let allowed = match better {
                Better::Lower => base + slack,
                Better::Higher => base - slack,
            };
            let now = cur.iter().find(|(k, _, _)| *k == key).map(|(_, v, _)| *v);
            let worse = match (now, better) {
                (None, _) => true,
                // A NaN compares as neither, and so counts as worse.
                (Some(x), Better::Lower) => x.partial_cmp(&allowed).is_none_or(|o| o.is_gt()),
                (Some(x), Better::Higher) => x.partial_cmp(&allowed).is_none_or(|o| o.is_lt()),
            };
            if worse {
                regressions.push(Regression {
                    variant: bv.name.clone(),
                    metric: key,
                    baseline: base,
                    current: now,
                    allowed,
                });
            }
        }
    }
    let only_current = current
        .variants
        .iter()
        .filter(|c| !baseline.variants.iter().any(|b| b.name == c.name))
        .map(|c| c.name.clone())
        .collect();
    GateOutcome {
        checked,
        regressions,
        notes: notes(baseline, current),
        only_baseline,
        only_current,
    }
}

/// Why a run's summary cannot serve as a baseline.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum Unusable {
    /// Written by another layout of `summary.json`: the gate refuses to compare it with the
    /// runs this tool makes.
    #[error("it is of summary.json schema {found}, this icp-eval writes schema {expected}: make the run again with this icp-eval")]
    Schema {
        /// The summary's.
        found: u32,
        /// This tool's.
        expected: u32,
    },
    /// A run on data without a reference: its variants have no error statistics.
    #[error("{dataset} has no reference, so the run has no error statistics to gate (only counts of registered pairs): make the baseline from a run on data with a reference")]
    NoReference {
        /// The dataset.
        dataset: String,
    },
    /// Nothing to gate.
    #[error("it holds no variant")]
    NoVariants,
    /// `--variants` names a variant the run does not have.
    #[error("it has no variant {unknown}; its variants are {known}")]
    UnknownVariants {
        /// The names not found, comma-separated.
        unknown: String,
        /// The run's, comma-separated.
        known: String,
    },
}

/// `report` as a baseline: checked to be of this schema, with a reference and variants, and
/// cut to the variants in `keep` (all when empty). Its configuration and population stay the
/// whole run's: the statistics kept are over the pairs every variant of the run registered.
pub fn baseline_of(mut report: RunReport, keep: &[String]) -> Result<RunReport, Unusable> {
    if report.schema_version != SCHEMA_VERSION {
        return Err(Unusable::Schema {
            found: report.schema_version,
            expected: SCHEMA_VERSION,
        });
    }
    if !report.reference.available {
        return Err(Unusable::NoReference {
            dataset: report.dataset.name,
        });
    }
    let names = |vs: &[VariantSummary]| {
        vs.iter()
            .map(|v| v.name.as_str())
            .collect::<Vec<_>>()
            .join(", ")
    };
    let unknown: Vec<&str> = keep
        .iter()
        .filter(|k| !report.variants.iter().any(|v| &v.name == *k))
        .map(String::as_str)
        .collect();
    if !unknown.is_empty() {
        return Err(Unusable::UnknownVariants {
            unknown: unknown.join(", "),
            known: names(&report.variants),
        });
    }
    if !keep.is_empty() {
        report.variants.retain(|v| keep.contains(&v.name));
    }
    if report.variants.is_empty() {
        return Err(Unusable::NoVariants);
    }
    Ok(report)
}

/// Why a variant's figures may have moved without the variant changing: its statistics are
/// over the run's population (the pairs every variant registered), and an external
/// estimator's are those of its file.
fn notes(baseline: &RunReport, current: &RunReport) -> Vec<String> {
    let mut out = Vec::new();
    let (b, c) = (&baseline.population, &current.population);
    if b.pairs != c.pairs || b.left_out != c.left_out {
        out.push(format!(
            "the populations differ ({} pairs in the baseline, {} now): every variant's statistics are over the pairs every variant registered, so a change in any variant's failures (or in the variants run) moves every variant's figures",
            b.pairs, c.pairs
        ));
    }
    for e in &baseline.config.estimates {
        match current.config.estimates.iter().find(|n| n.name == e.name) {
            Some(n) if n.sha256 != e.sha256 => out.push(format!(
                "external estimator {}: its file changed (SHA-256 {} → {})",
                e.name, e.sha256, n.sha256
            )),
            _ => {}
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn longest_suffix_wins() {
        let t = Tolerances {
            default: Tolerance {
                abs: 0.0,
                rel: 0.01,
            },
            metrics: [
                ("std".to_owned(), Tolerance { abs: 1.0, rel: 0.0 }),
                (
                    "sog_err_mps.std".to_owned(),
                    Tolerance { abs: 2.0, rel: 0.0 },
                ),
            ]
            .into_iter()
            .collect(),
        };
        assert_eq!(t.of("all_pairs.sog_err_mps.std").abs, 2.0);
        assert_eq!(t.of("all_pairs.dcog_err_deg.std").abs, 1.0);
        assert_eq!(t.of("pairs_ok").rel, 0.01);
        assert_eq!(
            t.of("all_pairs.sog_err_mps.xstd").rel,
            0.01,
            "a suffix must start at a dot"
        );
        assert!(t.validate().is_ok());
        let bad = Tolerances {
            default: Tolerance {
                abs: -1.0,
                rel: 0.0,
            },
            metrics: BTreeMap::new(),
        };
        assert!(bad.validate().is_err());
    }

    #[test]
    fn the_builtin_tolerance_file_is_valid_and_bad_files_are_refused() {
        // BUILTIN_TOLERANCE is the committed file itself (include_str!): what can go wrong is
        // that file failing to parse or validate, which would break every default gate.
        assert!(Tolerances::builtin().is_ok());
        assert!(Tolerances::parse(r#"{"default": {"abs": -1, "rel": 0}}"#).is_err());
        assert!(Tolerances::parse("{").is_err());
    }
}
