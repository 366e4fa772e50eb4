//! `icp-eval merge`: reads the part files of a sharded run ([`crate::shard`]), checks that
//! they come from one plan and cover it exactly once, and rebuilds each run's raw results
//! as a single run makes them, for [`crate::measure::build::build`] and the basin's report.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use crate::measure::basin::BasinRow;
use crate::run::lags::{LagPair, LagRuns};
use crate::run::runner::Runs;
use crate::shard::slices;
use crate::shard::Cut;
use crate::shard::Part;
use crate::shard::Plan;
use crate::shard::SliceResults;
use crate::shard::Work;
use crate::shard::PART_FORMAT;

/// Part files that cannot be merged.
#[derive(Debug, thiserror::Error)]
pub enum MergeError {
    /// A file or directory that cannot be read.
    #[error("{path}: {source}")]
    Io {
        /// The path.
        path: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// A directory without a part file.
    #[error("{0}: no part file (part-K-of-N.cbor) in it")]
    NoPart(PathBuf),
    /// A file that is not a part file.
    #[error("{path}: not a part file of this icp-eval: {why}")]
    NotAPart {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        why: String,
    },
    /// Parts of two plans.
    #[error("{path} is of another plan than {first} (fingerprint {theirs} ≠ {ours}): parts of different runs, or of the same run with other options, data or shard count")]
    ForeignPart {
        /// The part of the other plan.
        path: PathBuf,
        /// The first part read.
        first: PathBuf,
        /// Its fingerprint.
        theirs: String,
        /// The first part's.
        ours: String,
    },
    /// The same shard twice.
    #[error("shard {index} of {count} is given twice: {a} and {b}")]
    DuplicatePart {
        /// The shard.
        index: usize,
        /// Shard count.
        count: usize,
        /// One file.
        a: PathBuf,
        /// The other.
        b: PathBuf,
    },
    /// Shards not given.
    #[error("the run has {count} shards, but shard(s) {missing:?} are not among the parts given")]
    MissingParts {
        /// Shard count.
        count: usize,
        /// The shards missing.
        missing: Vec<usize>,
    },
    /// A part whose results do not fit the plan it names.
    #[error("{path}: {why}")]
    Inconsistent {
        /// The part.
        path: PathBuf,
        /// What does not fit.
        why: String,
    },
}

/// The merged results of a plan.
#[derive(Debug)]
pub struct Merged {
    /// The plan.
    pub plan: Plan,
    /// The command line of shard 0 (to re-load the dataset).
    pub command_line: Vec<String>,
    /// Per run of the plan, its results.
    pub runs: Vec<MergedRun>,
}

/// One run's merged results.
#[derive(Debug)]
pub enum MergedRun {
    /// A run's registrations.
    Runs {
        /// The consecutive pairs'.
        runs: Runs,
        /// Those across lags (`--lags` above 1), in the single run's order.
        lagged: Option<LagRuns>,
    },
    /// A basin's rows.
    Basin(Vec<BasinRow>),
}

/// The part file in `path`: the file itself, or the one `part-*.cbor` in a directory.
fn part_file(path: &Path) -> Result<PathBuf, MergeError> {
    if !path.is_dir() {
        return Ok(path.to_owned());
    }
    let io = |source| MergeError::Io {
        path: path.to_owned(),
        source,
    };
    let mut found = Vec::new();
    for entry in std::fs::read_dir(path).map_err(io)? {
        let p = entry.map_err(io)?.path();
        let name = p.file_name().map(|n| n.to_string_lossy().into_owned());
        if name.is_some_and(|n| n.starts_with("part-") && n.ends_with(".cbor")) {
            found.push(p);
        }
    }
    found.sort();
    match found.len() {
        0 => Err(MergeError::NoPart(path.to_owned())),
        1 => Ok(found.remove(0)),
        _ => Err(MergeError::NotAPart {
            path: path.to_owned(),
            why: format!(
                "holds {} part files; give each shard its own --out directory, or the files",
                found.len()
            ),
        }),
    }
}

/// Reads the part in `path` (a part file, or a shard's output directory).
pub fn read_part(path: &Path) -> Result<(PathBuf, Part), MergeError> {
    let file = part_file(path)?;
    let bytes = std::fs::read(&file).map_err(|source| MergeError::Io {
        path: file.clone(),
        source,
    })?;
    let part: Part = ciborium::from_reader(bytes.as_slice()).map_err(|e| MergeError::NotAPart {
        path: file.clone(),
        why: e.to_string(),
    })?;
    if part.format != PART_FORMAT {
        return Err(MergeError::NotAPart {
            path: file,
            why: format!("format {:?}, expected {PART_FORMAT:?}", part.format),
        });
    }
    Ok((file, part))
}

/// Merges the parts in `paths`: one plan, every shard exactly once.
pub fn merge(paths: &[PathBuf]) -> Result<Merged, MergeError> {
    let mut parts: BTreeMap<usize, (PathBuf, Part)> = BTreeMap::new();
    let mut first: Option<(PathBuf, String, usize)> = None;
    for path in paths {
        let (file, part) = read_part(path)?;
        let fingerprint = part.plan.fingerprint().map_err(|e| MergeError::NotAPart {
            path: file.clone(),
            why: e.to_string(),
        })?;
        if fingerprint != part.fingerprint {
            return Err(MergeError::Inconsistent {
                path: file,
                why: "its plan does not match the fingerprint it carries".to_owned(),
            });
        }
        match &first {
            None => first = Some((file.clone(), fingerprint, part.plan.shards)),
            Some((first_file, ours, _)) if *ours != fingerprint => {
                return Err(MergeError::ForeignPart {
                    path: file,
                    first: first_file.clone(),
                    theirs: fingerprint,
                    ours: ours.clone(),
                })
            }
            Some(_) => {}
        }
        if part.shard.count != part.plan.shards {
            return Err(MergeError::Inconsistent {
                path: file,
                why: format!(
                    "shard {} in a plan of {} shards",
                    part.shard, part.plan.shards
                ),
            });
        }
        if let Some((a, _)) = parts.get(&part.shard.index) {
            return Err(MergeError::DuplicatePart {
                index: part.shard.index,
                count: part.shard.count,
                a: a.clone(),
                b: file,
            });
        }
        parts.insert(part.shard.index, (file, part));
    }
    let Some((_, _, count)) = first else {
        return Err(MergeError::MissingParts {
            count: 0,
            missing: Vec::new(),
        });
    };
    let missing: Vec<usize> = (0..count).filter(|k| !parts.contains_key(k)).collect();
    if !missing.is_empty() {
        return Err(MergeError::MissingParts { count, missing });
    }
    let (_, shard0) = &parts[&0];
    let plan = shard0.plan.clone();
    let command_line = shard0.command_line.clone();
    let mut runs: Vec<Option<MergedRun>> = plan.runs.iter().map(|_| None).collect();
    // Parts in shard order hold their units in plan order: appending rebuilds each run.
    for (file, part) in parts.into_values() {
        let expected = slices(&plan.runs, part.shard);
        let held: Vec<_> = part.slices.iter().map(|(s, _)| s.clone()).collect();
        if held != expected {
            return Err(MergeError::Inconsistent {
                path: file,
                why: format!("holds the units {held:?}, the plan gives it {expected:?}"),
            });
        }
        for (slice, results) in part.slices {
            let cut = plan.runs[slice.run].cut;
            let bad = |why: String| MergeError::Inconsistent {
                path: file.clone(),
                why,
            };
            let target = &mut runs[slice.run];
            match results {
                SliceResults::Basin(rows) => match target {
                    None => *target = Some(MergedRun::Basin(rows)),
                    Some(MergedRun::Basin(all)) => all.extend(rows),
                    Some(MergedRun::Runs { .. }) => return Err(bad("basin rows in a run".into())),
                },
                SliceResults::Runs { runs: r, lagged } => {
                    let width = match cut {
                        Cut::Pairs => r.per_variant.first().map_or(0, Vec::len),
                        Cut::Variants => r.per_variant.len(),
                    };
                    if width != slice.units.len() {
                        return Err(bad(format!(
                            "run {} holds {width} units for the {} it should",
                            slice.run,
                            slice.units.len()
                        )));
                    }
                    match target {
                        None => *target = Some(MergedRun::Runs { runs: r, lagged }),
                        Some(MergedRun::Runs {
                            runs: all,
                            lagged: all_lagged,
                        }) => {
                            append(all, r, cut);
                            match (all_lagged, lagged) {
                                (Some(all), Some(more)) => append_lagged(all, more, cut),
                                (None, None) => {}
                                _ => {
                                    return Err(bad(
                                        "registrations across lags in some slices of a run only"
                                            .into(),
                                    ))
                                }
                            }
                        }
                        Some(MergedRun::Basin(_)) => {
                            return Err(bad("registrations in a basin".into()))
                        }
                    }
                }
            }
        }
    }
    // A run no part holds has no unit: no pair (or no basin pair).
    let basin = matches!(plan.work, Work::Basin(_));
    let runs = runs
        .into_iter()
        .enumerate()
        .map(|(i, r)| {
            r.unwrap_or_else(|| {
                if basin {
                    MergedRun::Basin(Vec::new())
                } else {
                    MergedRun::Runs {
                        runs: Runs::empty(plan.methods(i)),
                        lagged: None,
                    }
                }
            })
        })
        .map(|r| match r {
            MergedRun::Runs {
                runs,
                lagged: Some(lagged),
            } => MergedRun::Runs {
                runs,
                lagged: Some(in_run_order(lagged)),
            },
            other => other,
        })
        .collect();
    Ok(Merged {
        plan,
        command_line,
        runs,
    })
}

/// Appends the next slice `more` of a run to `all`, as the run is cut: the next pairs of
/// every variant, or the next variants.
fn append(all: &mut Runs, more: Runs, cut: Cut) {
    match cut {
        Cut::Pairs => all.append_pairs(more),
        Cut::Variants => {
            all.per_variant.extend(more.per_variant);
            if all.searches.is_empty() {
                all.searches = more.searches;
            }
            // Each slice prepares the scans: their surface-estimate times are counted once
            // per slice, a timing, like every field that differs from a single run.
            all.prepare_us.extend(more.prepare_us);
        }
    }
}

/// Appends the next slice `more` of a run's registrations across lags to `all`, as the run
/// is cut: more pairs (put in order by [`in_run_order`]) or the next variants.
fn append_lagged(all: &mut LagRuns, more: LagRuns, cut: Cut) {
    match cut {
        Cut::Pairs => {
            all.pairs.extend(more.pairs);
            append(&mut all.runs, more.runs, cut);
        }
        Cut::Variants => append(&mut all.runs, more.runs, cut),
    }
}

/// `lagged`'s pairs and their registrations in the single run's order, by lag then first
/// consecutive pair (the slices of a pair cut hold each lag's pairs in turn).
fn in_run_order(lagged: LagRuns) -> LagRuns {
    let mut order: Vec<usize> = (0..lagged.pairs.len()).collect();
    order.sort_by_key(|&i| (lagged.pairs[i].lag, lagged.pairs[i].first));
    let pick = |v: &[LagPair]| order.iter().map(|&i| v[i]).collect::<Vec<_>>();
    let mut runs = lagged.runs;
    for variant in &mut runs.per_variant {
        if variant.len() == order.len() {
            *variant = order.iter().map(|&i| variant[i].clone()).collect();
        }
    }
    if runs.searches.len() == order.len() {
        runs.searches = order.iter().map(|&i| runs.searches[i].clone()).collect();
    }
    LagRuns {
        pairs: pick(&lagged.pairs),
        runs,
    }
}

/// `Err` saying what is wrong unless `lagged` holds the registrations of `variants` variants
/// across exactly the lag pairs `expected` (what a single run registers), with one global
/// search per lag pair or none.
pub fn check_lag_shape(
    lagged: &LagRuns,
    expected: &[LagPair],
    variants: usize,
) -> Result<(), String> {
    if lagged.pairs != expected {
        return Err(format!(
            "{} pairs across lags where the run has {}, or not the same",
            lagged.pairs.len(),
            expected.len()
        ));
    }
    check_shape(&lagged.runs, variants, expected.len()).map_err(|e| format!("across lags: {e}"))
}

/// `Err` saying what is wrong unless `runs` holds `variants` variants of `pairs` pairs each
/// and one global search per pair or none: what [`crate::measure::build::build`] takes.
pub fn check_shape(runs: &Runs, variants: usize, pairs: usize) -> Result<(), String> {
    if runs.per_variant.len() != variants {
        return Err(format!(
            "{} variants' results for {variants} variants",
            runs.per_variant.len()
        ));
    }
    if let Some(v) = runs.per_variant.iter().position(|r| r.len() != pairs) {
        return Err(format!(
            "variant {v} has {} results for {pairs} pairs",
            runs.per_variant[v].len()
        ));
    }
    if !(runs.searches.is_empty() || runs.searches.len() == pairs) {
        return Err(format!(
            "{} global searches for {pairs} pairs",
            runs.searches.len()
        ));
    }
    Ok(())
}
