//! Sharded runs: `run`, `compare` and `basin` split their deterministic job list into `n`
//! parts, each shard runs one part and writes it (`part-K-of-N.cbor`), and `icp-eval merge`
//! (`merge`) rebuilds the run's raw results from the parts and renders the same
//! files as a single run through the same code (`measure::build::build`,
//! `render::write_outputs`).
//!
//! **The job list.** A plan holds one or more runs (a `run`; a `compare` and each value of
//! its `--sweep`; the pairs of a `basin`). Each run is cut into *units* that a shard runs
//! whole, so that every result is the one the single run makes:
//! - pairs ([`Cut::Pairs`]): a pair with all its variants, when every registration starts
//!   from something of its own pair (the pair's global search is made once and shared by its
//!   variants, as in [`crate::run::runner`]); a basin's pair with all its perturbations;
//! - variants ([`Cut::Variants`]): a variant with all its pairs, when a start depends on the
//!   same variant's previous result (`--init constant-velocity`): the chain runs in order
//!   and is never cut; and when a variant detects moving returns (`crate::run::moving`),
//!   whose detections use the variant's registrations of the whole sequence. Each shard then makes the pairs' global searches again (the same
//!   results: the search is deterministic); the part holding the run's first variant
//!   keeps them.
//!
//! The units of all runs, in plan order, are numbered `0..U`, and shard `k` of `n` runs the
//! units `u` with `⌊u·n/U⌋ = k`: contiguous, balanced to within one unit, and a function of
//! the plan alone (the same unit always lands in the same part for the same plan and `n`;
//! with more shards than units some parts are empty, and still written).
//!
//! **Loops across lags** (`--lags L`): a registration `k → k+ℓ` belongs to the unit of its
//! first consecutive pair `k → k+1` (with a variant cut, to its variant), so every shard
//! registers its own and the merge, which alone holds every registration, puts them in the
//! single run's order and judges the loops (`measure::cycles`): a loop that crosses a
//! shard's edge is judged as the single run judges it.
//!
//! **The plan's fingerprint** is the SHA-256 of the plan's canonical JSON: the dataset's
//! identity (name, description, file names and SHA-256 sums, scan count, time step, a hash
//! of the loaded scans and reference), the variant specs, the command's options, the runs'
//! units and `n`. A part carries it; the merge refuses parts of different plans and checks
//! the dataset it re-loads against it.
//!
//! **The shard index** comes from `--shard K/N`, else from a Slurm array task
//! (`SLURM_ARRAY_TASK_ID − SLURM_ARRAY_TASK_MIN` of `SLURM_ARRAY_TASK_COUNT`), else from a
//! Kubernetes indexed Job (`JOB_COMPLETION_INDEX` of `--shards N`): see [`resolve`].

pub mod merge;

use std::collections::BTreeMap;
use std::fmt;
use std::ops::Range;
use std::str::FromStr;

use datasets::Dataset;
use icp_core::variants::VariantSpec;
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

use crate::error::EvalError;
use crate::measure::basin::BasinOptions;
use crate::measure::basin::BasinRow;
use crate::measure::compare::CompareOptions;
use crate::measure::sweep::SweepParam;
use crate::run::lags::{self, LagRuns};
use crate::run::options::RunOptions;
use crate::run::runner::Runs;
use crate::run::setup::EvalSetup;
use crate::run::setup::OffsetChoice;

/// Slurm's array task id.
pub const SLURM_ARRAY_TASK_ID: &str = "SLURM_ARRAY_TASK_ID";
/// Slurm's smallest array task id.
pub const SLURM_ARRAY_TASK_MIN: &str = "SLURM_ARRAY_TASK_MIN";
/// Slurm's number of array tasks.
pub const SLURM_ARRAY_TASK_COUNT: &str = "SLURM_ARRAY_TASK_COUNT";
/// A Kubernetes indexed Job's completion index.
pub const JOB_COMPLETION_INDEX: &str = "JOB_COMPLETION_INDEX";

/// One part of a sharded run: part `index` of `count` (numbered from 0).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
pub struct Shard {
    /// Which part, `0..count`.
    pub index: usize,
    /// How many parts.
    pub count: usize,
}

impl Shard {
    /// The shard, when `index < count` (else why not, said as coming from `origin`).
    pub fn new(index: usize, count: usize, origin: &ShardOrigin) -> Result<Self, ShardError> {
        if count == 0 {
            return Err(ShardError::NoShards {
                origin: origin.to_string(),
            });
        }
        if index >= count {
            return Err(ShardError::OutOfRange {
                origin: origin.to_string(),
                index,
                count,
            });
        }
        Ok(Self { index, count })
    }

    /// The part file's name.
    pub fn file_name(&self) -> String {
        format!("part-{}-of-{}.cbor", self.index, self.count)
    }
}

impl fmt::Display for Shard {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

impl FromStr for Shard {
    type Err = ShardError;
    /// `K/N`.
    fn from_str(s: &str) -> Result<Self, ShardError> {
        let (k, n) = s
            .split_once('/')
            .ok_or_else(|| ShardError::Syntax(s.to_owned()))?;
        let number = |text: &str| {
            text.trim()
                .parse::<usize>()
                .map_err(|_| ShardError::Syntax(s.to_owned()))
        };
        Shard::new(number(k)?, number(n)?, &ShardOrigin::Option)
    }
}

/// Where a shard index came from (printed, so that a run that shards without being asked to
/// says why).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum ShardOrigin {
    /// `--shard K/N`.
    Option,
    /// A Slurm array task.
    Slurm {
        /// `SLURM_ARRAY_TASK_ID`.
        id: usize,
        /// `SLURM_ARRAY_TASK_MIN`.
        min: usize,
        /// `SLURM_ARRAY_TASK_COUNT`.
        count: usize,
    },
    /// A Kubernetes indexed Job.
    Kubernetes {
        /// `JOB_COMPLETION_INDEX`.
        index: usize,
        /// `--shards` (or the N of `--shard`).
        shards: usize,
    },
}

impl fmt::Display for ShardOrigin {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Option => f.write_str("--shard"),
            Self::Slurm { id, min, count } => write!(
                f,
                "{SLURM_ARRAY_TASK_ID}={id} − {SLURM_ARRAY_TASK_MIN}={min} of \
                 {SLURM_ARRAY_TASK_COUNT}={count}"
            ),
            Self::Kubernetes { index, shards } => {
                write!(f, "{JOB_COMPLETION_INDEX}={index} of {shards} shards")
            }
        }
    }
}

/// A shard index or count that cannot be used.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ShardError {
    /// `--shard` is not `K/N`.
    #[error("--shard must be K/N with whole numbers, e.g. 2/8 (part 2 of 0..8), got {0:?}")]
    Syntax(String),
    /// An environment variable that is not a whole number.
    #[error("{variable}={value:?} is not a whole number")]
    NotANumber {
        /// The variable.
        variable: &'static str,
        /// Its value.
        value: String,
    },
    /// Zero shards.
    #[error("{origin}: a run cannot have 0 shards")]
    NoShards {
        /// Where the count came from.
        origin: String,
    },
    /// An index beyond the shards.
    #[error("{origin}: shard {index} does not exist, the {count} shards are numbered 0 to {}", count - 1)]
    OutOfRange {
        /// Where the index came from.
        origin: String,
        /// The index.
        index: usize,
        /// The count.
        count: usize,
    },
    /// A Slurm array variable without the others.
    #[error("{present} is set but {missing} is not: not a Slurm array task as icp-eval reads it")]
    Incomplete {
        /// The variable set.
        present: &'static str,
        /// The one missing.
        missing: &'static str,
    },
    /// A Kubernetes completion index without the number of shards.
    #[error("{JOB_COMPLETION_INDEX}={0} is set: give --shards N (the Job's completions), or --no-shard to run everything")]
    NeedsShards(usize),
    /// `--shards` without an index.
    #[error("--shards {0} needs an index: --shard K/N, a Slurm array task or a Kubernetes indexed Job ({JOB_COMPLETION_INDEX})")]
    ShardsWithoutIndex(usize),
    /// Two sources that name different shards.
    #[error("{first} says shard {a}, but {second} says shard {b}: give one (or --no-shard to ignore the environment)")]
    Disagree {
        /// The first source.
        first: String,
        /// Its shard.
        a: Shard,
        /// The second source.
        second: String,
        /// Its shard.
        b: Shard,
    },
}

/// The shard to run, and where it came from: `--shard` (`flag`), else a Slurm array task or
/// a Kubernetes indexed Job read from `env` (with `--shards`, `shards`). `None`: not
/// sharded. Every source given must name the same shard. `env` is a map (the process's
/// environment in the binary), so the rules are tested without touching the environment.
pub fn resolve(
    flag: Option<Shard>,
    shards: Option<usize>,
    env: &BTreeMap<String, String>,
) -> Result<Option<(Shard, ShardOrigin)>, ShardError> {
    let number = |variable: &'static str| -> Result<Option<usize>, ShardError> {
        env.get(variable)
            .map(|value| {
                value
                    .trim()
                    .parse::<usize>()
                    .map_err(|_| ShardError::NotANumber {
                        variable,
                        value: value.clone(),
                    })
            })
            .transpose()
    };
    let mut found: Vec<(Shard, ShardOrigin)> = Vec::new();
    if let Some(s) = flag {
        found.push((
            Shard::new(s.index, s.count, &ShardOrigin::Option)?,
            ShardOrigin::Option,
        ));
    }
    if let Some(id) = number(SLURM_ARRAY_TASK_ID)? {
        let need = |missing: &'static str| ShardError::Incomplete {
            present: SLURM_ARRAY_TASK_ID,
            missing,
        };
        let min = number(SLURM_ARRAY_TASK_MIN)?.ok_or_else(|| need(SLURM_ARRAY_TASK_MIN))?;
        let count = number(SLURM_ARRAY_TASK_COUNT)?.ok_or_else(|| need(SLURM_ARRAY_TASK_COUNT))?;
        let origin = ShardOrigin::Slurm { id, min, count };
        let index = id.checked_sub(min).ok_or_else(|| ShardError::OutOfRange {
            origin: origin.to_string(),
            index: id,
            count,
        })?;
        found.push((Shard::new(index, count, &origin)?, origin));
    }
    if let Some(index) = number(JOB_COMPLETION_INDEX)? {
        let count = shards
            .or(flag.map(|s| s.count))
            .ok_or(ShardError::NeedsShards(index))?;
        let origin = ShardOrigin::Kubernetes {
            index,
            shards: count,
        };
        found.push((Shard::new(index, count, &origin)?, origin));
    }
    let Some((first, first_origin)) = found.first().cloned() else {
        return match shards {
            Some(n) => Err(ShardError::ShardsWithoutIndex(n)),
            None => Ok(None),
        };
    };
    if let Some(n) = shards {
        if n != first.count {
            return Err(ShardError::Disagree {
                first: first_origin.to_string(),
                a: first,
                second: "--shards".to_owned(),
                b: Shard {
                    index: first.index,
                    count: n,
                },
            });
        }
    }
    for (other, origin) in &found[1..] {
        if *other != first {
            return Err(ShardError::Disagree {
                first: first_origin.to_string(),
                a: first,
                second: origin.to_string(),
                b: *other,
            });
        }
    }
    Ok(Some((first, first_origin)))
}

/// How a run is cut into units (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Cut {
    /// A unit is a pair with all its variants (or a basin pair with all its starts).
    Pairs,
    /// A unit is a variant with all its pairs (a sequential init chain).
    Variants,
}

/// One run of a plan: how it is cut and into how many units.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct RunJobs {
    /// The cut.
    pub cut: Cut,
    /// Its units.
    pub units: usize,
}

/// The units of run `run` that a shard runs.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Slice {
    /// Index of the run in the plan.
    pub run: usize,
    /// Its units (pairs or variants, as the run is cut).
    pub units: Range<usize>,
}

/// The units of `runs` (numbered over all runs in order) that `shard` runs: `u` with
/// `⌊u·n/U⌋ = k`, i.e. `⌈k·U/n⌉ ≤ u < ⌈(k+1)·U/n⌉`, as one slice per run it touches.
pub fn slices(runs: &[RunJobs], shard: Shard) -> Vec<Slice> {
    let total: usize = runs.iter().map(|r| r.units).sum();
    let edge = |k: usize| -> usize {
        let (k, total, n) = (k as u128, total as u128, shard.count as u128);
        usize::try_from((k * total).div_ceil(n)).expect("an edge is at most the unit count")
    };
    let mine = edge(shard.index)..edge(shard.index + 1);
    let mut out = Vec::new();
    let mut first = 0;
    for (run, jobs) in runs.iter().enumerate() {
        let start = mine.start.max(first);
        let end = mine.end.min(first + jobs.units);
        if start < end {
            out.push(Slice {
                run,
                units: start - first..end - first,
            });
        }
        first += jobs.units;
    }
    out
}

/// The dataset a plan runs on, as the merge can check it after re-loading it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DatasetIdentity {
    /// Short name.
    pub name: String,
    /// Description.
    pub description: String,
    /// The files read: name (without the directory, which may differ between machines) and
    /// SHA-256.
    pub files: Vec<(String, String)>,
    /// Scans.
    pub scans: usize,
    /// Nominal time between scans, s.
    pub dt_s: f64,
    /// SHA-256 of the loaded scans, reference, odometry and sensor model (their exact
    /// values), hex: catches options that change the data without changing a file (a
    /// synthetic scenario's seed, `--dt`, `--sensor`).
    pub content_sha256: String,
}

impl DatasetIdentity {
    /// The identity of `ds`.
    pub fn of(ds: &Dataset) -> Self {
        let mut hash = Sha256::new();
        // The scans' values by their bits: equal bits, equal values. (Their `{:?}` text, the
        // shortest exact form, was a quarter of a merge's CPU.)
        for scan in &ds.scans {
            match scan.timestamp_s() {
                Some(t) => {
                    hash.update([1]);
                    hash.update(t.to_bits().to_le_bytes());
                }
                None => hash.update([0]),
            }
            hash.update((scan.returns().len() as u64).to_le_bytes());
            for r in scan.returns() {
                for v in [r.point.x, r.point.y, r.range_m, r.bearing_rad] {
                    hash.update(v.to_bits().to_le_bytes());
                }
            }
        }
        // The rest is small: its `{:?}` text, the shortest exact form of each value.
        hash.update(
            format!(
                "{:?}{:?}{:?}{:?}{:?}{:?}{:?}",
                ds.reference,
                ds.reference_kind,
                ds.odometry,
                ds.scanner_offset,
                ds.sensor,
                ds.bearing_sense,
                ds.reference_heading_sense
            )
            .as_bytes(),
        );
        Self {
            name: ds.provenance.name.clone(),
            description: ds.provenance.description.clone(),
            files: ds
                .provenance
                .files
                .iter()
                .map(|f| {
                    let name = f.path.file_name().map_or_else(
                        || f.path.display().to_string(),
                        |n| n.to_string_lossy().into_owned(),
                    );
                    (name, f.sha256.clone())
                })
                .collect(),
            scans: ds.scans.len(),
            dt_s: ds.dt_s,
            content_sha256: hex(&hash.finalize()),
        }
    }
}

/// A `compare --sweep`: the parameter and its values.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SweepPlan {
    /// The parameter.
    pub param: SweepParam,
    /// Its values, in order (one run each).
    pub values: Vec<f64>,
}

/// What a plan does.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Work {
    /// `run`: one run.
    Run(RunOptions),
    /// `compare`: one run, then one per sweep value.
    Compare {
        /// The runs' options.
        run: RunOptions,
        /// The comparison's options.
        options: CompareOptions,
        /// The sweep, if any.
        sweep: Option<SweepPlan>,
    },
    /// `basin`: the convergence-basin protocol.
    Basin(BasinOptions),
}

/// A sharded run's plan: everything its results depend on, and its job list.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Plan {
    /// The tool and its version (parts of different versions are not merged).
    pub tool: String,
    /// The dataset.
    pub dataset: DatasetIdentity,
    /// The variants, as specs.
    pub variants: Vec<VariantSpec>,
    /// The command and its options.
    pub work: Work,
    /// The runs and their units.
    pub runs: Vec<RunJobs>,
    /// Number of shards.
    pub shards: usize,
}

impl Plan {
    /// The plan of `work` with `variants` on `ds` in `shards` parts (its job list made from
    /// the setups it implies).
    pub fn new(
        ds: &Dataset,
        variants: Vec<VariantSpec>,
        work: Work,
        shards: usize,
    ) -> Result<Self, EvalError> {
        let mut plan = Self {
            tool: format!("icp-eval {}", env!("CARGO_PKG_VERSION")),
            dataset: DatasetIdentity::of(ds),
            variants,
            work,
            runs: Vec::new(),
            shards,
        };
        plan.runs = match &plan.work {
            Work::Basin(options) => vec![RunJobs {
                cut: Cut::Pairs,
                units: crate::studies::basin::chosen_pairs(ds, options).len(),
            }],
            Work::Run(run) | Work::Compare { run, .. } => {
                let setups = plan.setups(ds)?;
                let (pairs, _) = crate::run::setup::checked_pairs(ds, &setups[0])?;
                // `--lags` beyond the run is refused before any shard runs.
                lags::lag_pairs(&pairs, run.lags)?;
                // Starts that chain pairs, and detections of moving returns, need a
                // variant's whole sequence.
                let sequential = run.init.sequential()
                    || setups
                        .iter()
                        .any(|s| s.variants.iter().any(|v| v.moving().is_some()));
                setups
                    .iter()
                    .map(|s| RunJobs {
                        cut: if sequential {
                            Cut::Variants
                        } else {
                            Cut::Pairs
                        },
                        units: if sequential {
                            s.method_names().len()
                        } else {
                            pairs.len()
                        },
                    })
                    .collect()
            }
        };
        Ok(plan)
    }

    /// How many methods run `run` of the plan has: its variants, and in the first run (not a
    /// sweep's) the external estimates.
    pub fn methods(&self, run: usize) -> usize {
        let external = match &self.work {
            Work::Run(options) | Work::Compare { run: options, .. } if run == 0 => {
                options.estimates.len()
            }
            _ => 0,
        };
        self.variants.len() + external
    }

    /// SHA-256 of the plan's canonical JSON, hex.
    pub fn fingerprint(&self) -> Result<String, EvalError> {
        let json = serde_json::to_vec(self).map_err(|e| EvalError::Serialize(e.to_string()))?;
        Ok(hex(&Sha256::digest(&json)))
    }

    /// The setup of each run of the plan on `ds`, in order (a basin's one, with the
    /// alignment it uses). A sweep's runs have no external estimates: they do not move with
    /// the parameter.
    pub fn setups(&self, ds: &Dataset) -> Result<Vec<EvalSetup>, EvalError> {
        let base = |run: &RunOptions| run.setup(&self.variants, ds);
        match &self.work {
            Work::Run(run) => Ok(vec![base(run)?]),
            Work::Compare { run, sweep, .. } => {
                let first = base(run)?;
                let mut setups = match sweep {
                    Some(s) => {
                        crate::studies::sweep::setups(&first, &self.variants, &s.param, &s.values)?
                    }
                    None => Vec::new(),
                };
                setups.insert(0, first);
                Ok(setups)
            }
            Work::Basin(_) => Ok(vec![EvalSetup::from_specs(
                &self.variants,
                OffsetChoice::Fixed(0),
            )?]),
        }
    }
}

/// A shard's results for one slice of a run.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub enum SliceResults {
    /// The registrations of the slice's pairs (all variants) or variants (all pairs): the
    /// runner's raw results; for a variant slice, the pairs' searches only in the slice that
    /// starts at the run's first variant.
    Runs {
        /// The consecutive pairs' registrations.
        runs: Runs,
        /// With `--lags` above 1, the registrations across lags the slice owns: for a pair
        /// slice, those whose first consecutive pair is in the slice (all variants); for a
        /// variant slice, every lag pair of its variants. Their loops are judged by the
        /// merge, once every registration is in.
        lagged: Option<LagRuns>,
    },
    /// The basin rows of the slice's pairs, in order.
    Basin(Vec<BasinRow>),
}

/// What one shard writes.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Part {
    /// Always [`PART_FORMAT`].
    pub format: String,
    /// The plan's fingerprint ([`Plan::fingerprint`]).
    pub fingerprint: String,
    /// Which part.
    pub shard: Shard,
    /// The plan.
    pub plan: Plan,
    /// The command line that ran the shard (the merge re-loads the dataset from it).
    pub command_line: Vec<String>,
    /// Per slice the shard ran, its results.
    pub slices: Vec<(Slice, SliceResults)>,
}

/// The `format` of a part file.
pub const PART_FORMAT: &str = "icp-eval part 2";

impl Part {
    /// The part's bytes (CBOR: every number, NaN and infinities included, read back exactly).
    pub fn to_bytes(&self) -> Result<Vec<u8>, EvalError> {
        let mut bytes = Vec::new();
        ciborium::into_writer(self, &mut bytes).map_err(|e| EvalError::Serialize(e.to_string()))?;
        Ok(bytes)
    }
}

/// Runs the slices of `plan` that `shard` owns on `ds` (the dataset the plan was made from)
/// and returns its part. `progress` counts the registrations.
pub fn run_shard(
    ds: &Dataset,
    plan: &Plan,
    shard: Shard,
    command_line: Vec<String>,
    progress: &indicatif::ProgressBar,
) -> Result<Part, EvalError> {
    let setups = plan.setups(ds)?;
    let mut out = Vec::new();
    for slice in slices(&plan.runs, shard) {
        let setup = &setups[slice.run];
        let results = match &plan.work {
            Work::Basin(options) => {
                options.validate()?;
                if !ds.rigid_reference() {
                    return Err(EvalError::NeedsRigidReference {
                        what: "the convergence basin",
                        dataset: ds.provenance.name.clone(),
                    });
                }
                let chosen = crate::studies::basin::chosen_pairs(ds, options);
                SliceResults::Basin(crate::studies::basin::run_pairs(
                    ds,
                    &setup.variants,
                    options,
                    &chosen[slice.units.clone()],
                    progress,
                ))
            }
            Work::Run(_) | Work::Compare { .. } => {
                let (pairs, _) = crate::run::setup::checked_pairs(ds, setup)?;
                let close = setup.close_start_variants()?;
                let methods = setup.methods(&close);
                let run_plan = setup.run_plan();
                let lag_pairs = lags::lag_pairs(&pairs, setup.lags)?;
                let (runs, lagged) = match plan.runs[slice.run].cut {
                    Cut::Pairs => {
                        // A pair across lags belongs to the slice of its first consecutive pair.
                        let mine: Vec<_> = lag_pairs
                            .into_iter()
                            .filter(|p| slice.units.contains(&p.first))
                            .collect();
                        progress.inc_length(
                            (methods.len() * slice.units.len() + setup.variants.len() * mine.len())
                                as u64,
                        );
                        let runs = crate::run::runner::run_from(
                            ds,
                            &pairs[slice.units.clone()],
                            slice.units.start,
                            methods,
                            &run_plan,
                            progress,
                        );
                        let lagged = lags::run(ds, mine, setup.lags, methods, &run_plan, progress);
                        (runs, lagged)
                    }
                    Cut::Variants => {
                        // Each method with its own close-start twin.
                        let mine = methods.slice(slice.units.clone());
                        progress.inc_length(
                            (pairs.len() * mine.len() + lag_pairs.len() * mine.registrars.len())
                                as u64,
                        );
                        let mut runs =
                            crate::run::runner::run_all(ds, &pairs, mine, &run_plan, progress);
                        let mut lagged =
                            lags::run(ds, lag_pairs, setup.lags, mine, &run_plan, progress);
                        crate::run::moving::apply(
                            ds,
                            &pairs,
                            mine,
                            &mut runs,
                            lagged.as_mut(),
                            &run_plan,
                        );
                        if slice.units.start != 0 {
                            runs.searches.clear();
                            if let Some(l) = &mut lagged {
                                l.runs.searches.clear();
                            }
                        }
                        (runs, lagged)
                    }
                };
                SliceResults::Runs { runs, lagged }
            }
        };
        out.push((slice, results));
    }
    progress.finish_and_clear();
    Ok(Part {
        format: PART_FORMAT.to_owned(),
        fingerprint: plan.fingerprint()?,
        shard,
        plan: plan.clone(),
        command_line,
        slices: out,
    })
}

/// Lower-case hex of `bytes`.
fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

#[cfg(test)]
mod tests {
    use datasets::synthetic::{generate, Scenario};
    use icp_core::Scan;

    use super::*;

    /// The content hash tells datasets apart by any value of a scan: a range one unit in
    /// the last place longer, a timestamp, a return fewer.
    #[test]
    fn the_dataset_identity_sees_every_value_of_every_scan() {
        let ds = generate(&Scenario {
            n_scans: 4,
            ..Scenario::paper()
        })
        .unwrap();
        let identity = DatasetIdentity::of(&ds);
        assert_eq!(identity, DatasetIdentity::of(&ds.clone()));
        let with_scan = |k: usize, scan: Scan| {
            let mut other = ds.clone();
            other.scans[k] = scan;
            DatasetIdentity::of(&other).content_sha256
        };
        let polar = |scan: &Scan| -> (Vec<f64>, Vec<f64>) {
            scan.returns()
                .iter()
                .map(|r| (r.range_m, r.bearing_rad))
                .unzip()
        };
        // Scan 2 read again from its ranges and bearings, and changed once each way.
        let (mut ranges, bearings) = polar(&ds.scans[2]);
        let same = Scan::from_polar(&ranges, &bearings).unwrap();
        let base = with_scan(2, same.clone());
        ranges[7] = f64::from_bits(ranges[7].to_bits() + 1);
        let one_ulp = Scan::from_polar(&ranges, &bearings).unwrap();
        assert_ne!(with_scan(2, one_ulp), base);
        let timed = same.with_timestamp(0.0).unwrap();
        assert_ne!(with_scan(2, timed), base);
        let (ranges, bearings) = polar(&ds.scans[2]);
        let fewer = Scan::from_polar(&ranges[1..], &bearings[1..]).unwrap();
        assert_ne!(with_scan(2, fewer), base);
    }

    #[test]
    fn every_unit_lands_in_exactly_one_part_and_parts_are_contiguous() {
        for units in [
            vec![0],
            vec![1],
            vec![5],
            vec![3, 4],
            vec![4, 0, 7],
            vec![30, 30, 30],
        ] {
            let runs: Vec<RunJobs> = units
                .iter()
                .map(|&u| RunJobs {
                    cut: Cut::Pairs,
                    units: u,
                })
                .collect();
            let total: usize = units.iter().sum();
            for n in 1..=9 {
                let mut seen: Vec<Vec<usize>> = units.iter().map(|&u| vec![0; u]).collect();
                let mut sizes = Vec::new();
                for k in 0..n {
                    let mut size = 0;
                    for s in slices(&runs, Shard { index: k, count: n }) {
                        for u in s.units.clone() {
                            seen[s.run][u] += 1;
                            // The brute-force rule: unit u (numbered over all runs) is in
                            // part ⌊u·n/U⌋.
                            let global: usize = units[..s.run].iter().sum::<usize>() + u;
                            assert_eq!(global * n / total, k);
                        }
                        size += s.units.len();
                    }
                    sizes.push(size);
                }
                assert!(seen.iter().flatten().all(|&c| c == 1), "{units:?} in {n}");
                let (lo, hi) = (sizes.iter().min().unwrap(), sizes.iter().max().unwrap());
                assert!(hi - lo <= 1, "balanced: {sizes:?}");
            }
        }
    }
}
