//! `icp-eval`: the command line of the evaluation harness.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{bail, Context, Result};
use clap::{Args, Parser, Subcommand};
use datasets::synthetic::{self, Scenario};
use datasets::{marina, Dataset, DatasetSource};
use eval::basin::BasinOptions;
use eval::compare::CompareOptions;
use eval::consistency::CovarianceMode;
use eval::estimates::EstimatesSpec;
use eval::gate::{gate, incompatibility, outcome_md, Tolerances};
use eval::init::{InitChain, MODES};
use eval::merge::MergedRun;
use eval::report::RunReport;
use eval::run_options::{override_sensor, BuiltinOptions};
use eval::shard::{Plan, RunOptions, Shard, ShardOrigin, SweepPlan, Work};
use eval::start_gate::StartGate;
use eval::{
    evaluate, write_outputs, EvalSetup, GlobalChecks, OffsetChoice, OutputDir, ReferenceChecks,
};
use icp_core::global::{GlobalParams, RotationMode};
use icp_core::matching::MATCHERS;
use icp_core::sensor::SensorOverrides;
use icp_core::variants::{
    builtin, builtin_names, builtins, section_docs, stage_families, table1, VariantSpec, TABLE1,
};
use icp_core::SensorModel;
use indicatif::{ProgressBar, ProgressStyle};
use serde::Deserialize;
use std::collections::BTreeMap;

/// Weighted-ICP evaluation for 2D LIDAR (Naus & Marchel 2019): runs the variants over every
/// consecutive scan pair and reports SOG/ΔCOG errors like the paper's Table 1, and more.
#[derive(Parser)]
#[command(name = "icp-eval", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Reproduce the paper: the four variants on the marina data (when found) and on the
    /// synthetic `paper` scenario; writes reports and prints the tables.
    Reproduce(ReproduceArgs),
    /// Run chosen variants on one dataset.
    Run(RunArgs),
    /// Compare variants pair by pair (bootstrap interval, Wilcoxon test), optionally over a
    /// parameter sweep.
    Compare(CompareArgs),
    /// Compare a run's summary.json with a baseline: exit 0 if nothing got worse beyond the
    /// tolerances, 1 with a table of what regressed, 2 on unusable input.
    Gate(GateArgs),
    /// The convergence-basin protocol (Pomerleau et al. 2013): each pair registered from
    /// seeded starts around its true motion; success against the start's offset (basin.csv,
    /// .json, .md, .png, .svg). Needs a rigid reference.
    Basin(BasinArgs),
    /// Generate a synthetic harbour dataset and write it in our CSV format.
    Synth(SynthArgs),
    /// Time one variant on synthetic scan pairs of growing size: time per registration,
    /// iterations and time per point and iteration (scaling.md, .json, .png, .svg).
    Scaling(ScalingArgs),
    /// List the built-in variants and the stages a configuration file can name.
    List,
    /// Merge the part files of a sharded `run`, `compare` or `basin` (`--shard K/N`) into
    /// the files a single run writes (timings aside); checks that the parts are of one plan
    /// and cover it exactly once.
    Merge(MergeArgs),
}

#[derive(Args)]
struct ShardArgs {
    /// Run only part K of N (0 ≤ K < N) of the job list and write it as part-K-of-N.cbor
    /// into --out, for `icp-eval merge`. Without it, a Slurm array task
    /// (SLURM_ARRAY_TASK_ID − SLURM_ARRAY_TASK_MIN of SLURM_ARRAY_TASK_COUNT) or a Kubernetes
    /// indexed Job (JOB_COMPLETION_INDEX, with --shards) is sharded likewise.
    #[arg(long)]
    shard: Option<eval::shard::Shard>,
    /// Number of shards of a Kubernetes indexed Job (its completions); checked against the
    /// other sources when given with them.
    #[arg(long)]
    shards: Option<usize>,
    /// Run everything, ignoring the Slurm and Kubernetes variables.
    #[arg(long, conflicts_with_all = ["shard", "shards"])]
    no_shard: bool,
}

#[derive(Args)]
struct MergeArgs {
    /// The shards' part files, or their --out directories (one part each).
    #[arg(required = true)]
    parts: Vec<PathBuf>,
    /// Output directory of the merged run.
    #[arg(long)]
    out: PathBuf,
    #[command(flatten)]
    common: Common,
}

#[derive(Args)]
struct ScalingArgs {
    /// Built-in variant to time.
    #[arg(long, default_value = "HD_ICP")]
    variant: String,
    /// Beams per scanner revolution, comma-separated.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "100,300,1000,3000,10000,30000,100000"
    )]
    beams: Vec<usize>,
    /// Seconds spent timing each size (at least 3 registrations each).
    #[arg(long, default_value_t = 1.0)]
    budget_s: f64,
    /// Output directory (outside the committed reports).
    #[arg(long, default_value = "results/performance")]
    out: PathBuf,
    /// Write into a directory that holds files icp-eval did not list.
    #[arg(long)]
    force: bool,
}

#[derive(Args)]
struct Common {
    /// Number of worker threads (results do not depend on it).
    #[arg(long)]
    threads: Option<usize>,
    /// No progress bar.
    #[arg(long)]
    quiet: bool,
    /// Skip the figures.
    #[arg(long)]
    no_plots: bool,
    /// Write into an output directory that holds files icp-eval did not list in its
    /// manifest.json (they are left alone); without it such a directory is refused.
    #[arg(long)]
    force: bool,
}

#[derive(Args)]
struct ReproduceArgs {
    /// Directory holding the marina files (or a `marina/` folder); else $ICP_DATA_DIR, then ./datasets.
    #[arg(long)]
    data_dir: Option<PathBuf>,
    /// Output directory (outside the committed reports; `scripts/update-reproduction.sh`
    /// regenerates those).
    #[arg(long, default_value = "results/reproduction")]
    out: PathBuf,
    #[command(flatten)]
    common: Common,
}

/// `--dataset`'s one-line help: the registered kinds.
fn dataset_help_short() -> String {
    format!(
        "{} (options: KIND:TARGET?KEY=VALUE&...; see --help)",
        datasets::source::syntaxes()
    )
}

#[derive(Args)]
struct DataArgs {
    /// The dataset (kinds and options listed by --help, generated from the loader registry).
    #[arg(long, help = dataset_help_short(), long_help = datasets::source::help())]
    dataset: String,
    /// Directory of the marina files.
    #[arg(long)]
    data_dir: Option<PathBuf>,
    /// Nominal time between scans, s, where scans carry no timestamps (marina: 1.0;
    /// synthetic: the scenario's spacing).
    #[arg(long)]
    dt: Option<f64>,
    /// Synthetic only: number of scans (default: the scenario's).
    #[arg(long)]
    scans: Option<usize>,
    /// Synthetic only: seed of the scenario (default: the scenario's own).
    #[arg(long)]
    scenario_seed: Option<u64>,
    /// CARMEN only: field of view of the laser, degrees (default 180; or ?fov_deg=).
    #[arg(long)]
    carmen_fov_deg: Option<f64>,
    /// CARMEN only: readings at or beyond this range are no-returns, metres (default 50; or
    /// ?max_range_m=).
    #[arg(long)]
    carmen_max_range_m: Option<f64>,
    /// The sensor model of this run, as overrides of the dataset's:
    /// sigma_r_const_m=M,sigma_r_per_m=M_PER_M,sigma_alpha_deg=DEG (any of them). The
    /// built-in variants' weights, the metrics and the noise bound use it; the data are not
    /// changed.
    #[arg(long)]
    sensor: Option<SensorOverrides>,
}

#[derive(Args)]
struct VariantArgs {
    /// Built-in variants, comma-separated (listed below and by `icp-eval list`). Default: the
    /// four of Table 1, or none when --config is given.
    #[arg(long, value_delimiter = ',')]
    variants: Option<Vec<String>>,
    /// Variants from a JSON or TOML file: one variant spec, or `variants = [...]`. Taken as
    /// written (the options below apply to the built-in variants only). Repeatable.
    #[arg(long)]
    config: Vec<PathBuf>,
    /// Nearest-neighbour matcher of the built-in variants (a kind listed below; all exact).
    #[arg(long)]
    matcher: Option<String>,
    /// Factor c of the robust threshold c · median of the built-in variants that reject.
    #[arg(long)]
    huber_c: Option<f64>,
    /// Seed of the random selection of the built-in variants that select at random.
    #[arg(long)]
    seed: Option<u64>,
}

#[derive(Args)]
struct RunArgs {
    #[command(flatten)]
    data: DataArgs,
    #[command(flatten)]
    variants: VariantArgs,
    /// Reference time offset in scans, or `auto` to apply the estimated one.
    #[arg(long, default_value = "0")]
    reference_offset: OffsetChoice,
    /// Test the reference steps for plausibility (`on`, for measured references such as GNSS)
    /// or take every step as plausible (`off`, for ground truth).
    #[arg(long, value_enum, default_value_t = ReferenceChecks::On)]
    reference_checks: ReferenceChecks,
    /// Where each registration starts (help generated from the registered modes).
    #[arg(long, default_value = "identity")]
    init: InitChain,
    /// Check every result against a global search of its pair (correlative scan matching):
    /// a result far from a clearly better pose is flagged suspect.
    #[arg(long, value_enum, default_value_t = GlobalChecks::On)]
    global_check: GlobalChecks,
    /// Correspondence gate of registrations started close to the motion (at the global
    /// search's pose or the reference), for variants whose metric measures along a surface
    /// normal and has no gate of its own: auto (2 cells of the search, 0.2 m by default), off,
    /// or a distance in metres.
    #[arg(long, default_value = "auto")]
    start_gate: StartGate,
    /// Half-width of the global search's translation window around the identity, m.
    #[arg(long, default_value_t = GlobalParams::default().window_m)]
    global_window_m: f64,
    /// Rotation candidates of the global search: histogram (around the peaks of the
    /// surface-normal orientation histograms, and the identity) or full (every step over
    /// ±180°).
    #[arg(long, value_enum, default_value_t = GlobalRotation::Histogram)]
    global_rotation: GlobalRotation,
    /// Where each registration's covariance comes from (help generated from the registered
    /// modes).
    #[arg(long, default_value = "closed-form")]
    covariance: CovarianceMode,
    /// Another estimator's results, evaluated after the variants like one more variant:
    /// NAME=FILE, the file TUM poses per scan (`timestamp x y z qx qy qz qw`, matched to the
    /// scans' times within 1 ms) or a CSV of per-pair motions
    /// (`source,reference,tx_m,ty_m,theta_deg`, t_ref_src as in pairs.csv). Repeatable.
    #[arg(long)]
    estimates: Vec<EstimatesSpec>,
    /// Output directory.
    #[arg(long)]
    out: PathBuf,
    #[command(flatten)]
    common: Common,
    #[command(flatten)]
    shard: ShardArgs,
}

/// The global search's rotation modes on the command line.
#[derive(Clone, Copy, clap::ValueEnum)]
enum GlobalRotation {
    Full,
    Histogram,
}

impl RunArgs {
    /// The options a sharded run's plan records.
    fn run_options(&self) -> Result<RunOptions> {
        Ok(RunOptions {
            offset: self.reference_offset,
            reference_checks: self.reference_checks,
            init: self.init.clone(),
            global: self.global()?,
            global_check: self.global_check,
            start_gate: self.start_gate,
            covariance: self.covariance,
            estimates: self.estimates.clone(),
        })
    }

    /// The global search's parameters from the options.
    fn global(&self) -> Result<GlobalParams> {
        let params = GlobalParams {
            window_m: self.global_window_m,
            rotation: match self.global_rotation {
                GlobalRotation::Full => RotationMode::Full,
                GlobalRotation::Histogram => RotationMode::Histogram,
            },
            ..GlobalParams::default()
        };
        params
            .validate()
            .map_err(|e| anyhow::anyhow!("--global-window-m: {e}"))?;
        Ok(params)
    }
}

#[derive(Args)]
struct CompareArgs {
    #[command(flatten)]
    run: RunArgs,
    /// Bootstrap resamples.
    #[arg(long, default_value_t = 10_000)]
    bootstrap: usize,
    /// Bootstrap seed.
    #[arg(long, default_value_t = 0)]
    bootstrap_seed: u64,
    /// Also re-run the variants over values of one parameter: sigma_alpha_deg=0.1,0.5,... or
    /// huber_c=1,2.0138,3.
    #[arg(long)]
    sweep: Option<String>,
}

#[derive(Args)]
struct BasinArgs {
    #[command(flatten)]
    data: DataArgs,
    #[command(flatten)]
    variants: VariantArgs,
    /// Starts per pair.
    #[arg(long, default_value_t = BasinOptions::default().perturbations)]
    perturbations: usize,
    /// Largest distance of a start's translation from the true one, m.
    #[arg(long, default_value_t = BasinOptions::default().max_translation_m)]
    max_translation_m: f64,
    /// Largest rotation of a start from the true one, degrees.
    #[arg(long, default_value_t = BasinOptions::default().max_rotation_deg)]
    max_rotation_deg: f64,
    /// Seed of the starts (the same for every variant).
    #[arg(long, default_value_t = 0)]
    perturbation_seed: u64,
    /// Run every n-th pair only.
    #[arg(long, default_value_t = 1)]
    pair_stride: usize,
    /// Output directory.
    #[arg(long)]
    out: PathBuf,
    #[command(flatten)]
    common: Common,
    #[command(flatten)]
    shard: ShardArgs,
}

#[derive(Args)]
struct GateArgs {
    /// The committed baseline summary.json.
    #[arg(long)]
    baseline: PathBuf,
    /// The current run's summary.json.
    #[arg(long)]
    current: PathBuf,
    /// Tolerances (JSON); default: reports/baseline/tolerance.json.
    #[arg(long, default_value = "reports/baseline/tolerance.json")]
    tolerance: PathBuf,
}

#[derive(Args)]
struct SynthArgs {
    /// Scenario: paper (865 scans every 0.2 s) or marina-like (177 scans every 1 s).
    #[arg(long, default_value = "paper")]
    scenario: String,
    /// Number of scans (default: the scenario's).
    #[arg(long)]
    scans: Option<usize>,
    /// Time between scans, s.
    #[arg(long)]
    dt: Option<f64>,
    /// Mean speed over ground, m/s.
    #[arg(long)]
    speed: Option<f64>,
    /// Seed of the world and the noise.
    #[arg(long)]
    seed: Option<u64>,
    /// Bearing standard deviation, degrees.
    #[arg(long, default_value_t = SensorModel::SWEEP_SIGMA_ALPHA_DEG)]
    sigma_alpha_deg: f64,
    /// Exact returns (no range or bearing noise).
    #[arg(long)]
    no_noise: bool,
    /// Fraction of spurious returns (spray, water).
    #[arg(long)]
    gross_error_fraction: Option<f64>,
    /// Take each beam at its own time within the revolution.
    #[arg(long)]
    motion_distortion: bool,
    /// Output directory (scans.csv with each return's true surface normal, poses.csv,
    /// dataset.json).
    #[arg(long)]
    out: PathBuf,
}

fn main() -> ExitCode {
    let parsed = cli_command()
        .try_get_matches()
        .and_then(|m| <Cli as clap::FromArgMatches>::from_arg_matches(&m));
    let cli = match parsed {
        Ok(cli) => cli,
        Err(e) => e.exit(),
    };
    match run(cli) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {}", message(&e));
            ExitCode::from(2)
        }
    }
}

/// The command line, with the help of the variant options generated from the registered
/// variants and matchers (so it cannot go stale).
fn cli_command() -> clap::Command {
    let variants = format!(
        "Built-in variants, comma-separated: {}. Default: the four of Table 1, or none when \
         --config is given",
        builtin_names().join(", ")
    );
    let matchers = format!(
        "Nearest-neighbour matcher of the built-in variants: {} (all exact)",
        MATCHERS.names().join(", ")
    );
    let init = format!(
        "Where each registration starts: {}. A comma-separated chain tries the next mode while \
         a registration is flagged (e.g. constant-velocity,identity)",
        MODES
            .iter()
            .map(|(_, name, help)| format!("{name}: {help}"))
            .collect::<Vec<_>>()
            .join("; ")
    );
    let patch = |c: clap::Command| {
        c.mut_arg("variants", |a| a.help(variants.clone()))
            .mut_arg("matcher", |a| a.help(matchers.clone()))
            .mut_arg("init", |a| a.help(init.clone()))
            .mut_arg("covariance", |a| a.help(CovarianceMode::help()))
    };
    <Cli as clap::CommandFactory>::command()
        .mut_subcommand("run", patch)
        .mut_subcommand("compare", patch)
        .mut_subcommand("basin", |c| {
            c.mut_arg("variants", |a| a.help(variants.clone()))
                .mut_arg("matcher", |a| a.help(matchers.clone()))
        })
}

/// The error and its causes, each said once: our errors already print their cause.
fn message(e: &anyhow::Error) -> String {
    let mut msg = e.to_string();
    for cause in e.chain().skip(1).map(|c| c.to_string()) {
        if !msg.contains(&cause) {
            msg = format!("{msg}: {cause}");
        }
    }
    msg
}

fn run(cli: Cli) -> Result<ExitCode> {
    match cli.command {
        Command::Reproduce(args) => reproduce(args),
        Command::Run(args) => run_one(args),
        Command::Compare(args) => compare_cmd(args),
        Command::Gate(args) => gate_cmd(args),
        Command::Basin(args) => basin_cmd(args),
        Command::Synth(args) => synth(args),
        Command::Scaling(args) => scaling(args),
        Command::List => list(),
        Command::Merge(args) => merge_cmd(args),
    }
}

fn progress(quiet: bool, label: &str) -> ProgressBar {
    if quiet {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::new(0);
    if let Ok(style) =
        ProgressStyle::with_template("{msg:>22} [{bar:40}] {pos}/{len} registrations ({eta})")
    {
        bar.set_style(style.progress_chars("=> "));
    }
    bar.set_message(label.to_owned());
    bar
}

fn in_pool<T: Send>(threads: Option<usize>, f: impl FnOnce() -> T + Send) -> Result<T> {
    match threads {
        None => Ok(f()),
        Some(0) => bail!("--threads must be at least 1"),
        Some(n) => Ok(rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .context("building the thread pool")?
            .install(f)),
    }
}

fn evaluate_in_pool(ds: &Dataset, setup: &EvalSetup, common: &Common) -> Result<RunReport> {
    let bar = progress(common.quiet, &ds.provenance.name);
    Ok(in_pool(common.threads, || evaluate(ds, setup, &bar))??)
}

/// Runs and writes the reports into `out`; returns the report and the directory, for files
/// a command adds.
fn evaluate_and_write(
    ds: &Dataset,
    setup: &EvalSetup,
    out: &Path,
    common: &Common,
) -> Result<(RunReport, OutputDir)> {
    let mut dir = OutputDir::open(out, common.force).context("opening the output directory")?;
    let report = evaluate_in_pool(ds, setup, common)?;
    write_outputs(&mut dir, ds, &report, !common.no_plots).context("writing the reports")?;
    Ok((report, dir))
}

fn reproduce(args: ReproduceArgs) -> Result<ExitCode> {
    let setup = EvalSetup::from_specs(&table1(), OffsetChoice::Fixed(0))?;
    match marina::find_data_dir(args.data_dir.as_deref()) {
        Ok(dir) => {
            let ds = marina::load(&dir, &marina::MarinaOptions::default())
                .with_context(|| format!("loading the marina data from {}", dir.display()))?;
            let out = args.out.join("marina");
            let (report, _) = evaluate_and_write(&ds, &setup, &out, &args.common)?;
            println!("{}", eval::output::table_md(&report));
            println!("(marina reports in {})\n", out.display());
        }
        Err(e) => {
            if args.data_dir.is_some() {
                return Err(e).context("--data-dir was given but holds no marina data");
            }
            eprintln!("note: skipping the marina data: {e}\n");
        }
    }
    let ds = synthetic::generate(&Scenario::paper())
        .context("generating the synthetic `paper` scenario")?;
    let out = args.out.join("synthetic-paper");
    let (report, _) = evaluate_and_write(&ds, &setup, &out, &args.common)?;
    println!("{}", eval::output::table_md(&report));
    println!("(synthetic reports in {})", out.display());
    Ok(ExitCode::SUCCESS)
}

/// A variants file: one spec, or a list under `variants`.
#[derive(Deserialize)]
#[serde(untagged)]
enum VariantsFile {
    Many { variants: Vec<VariantSpec> },
    One(Box<VariantSpec>),
}

fn read_variants_file(path: &Path) -> Result<Vec<VariantSpec>> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    let parsed: VariantsFile = if path.extension().is_some_and(|e| e == "toml") {
        toml::from_str(&text)
            .with_context(|| format!("{} is not a valid variants file", path.display()))?
    } else {
        serde_json::from_str(&text)
            .with_context(|| format!("{} is not a valid variants file", path.display()))?
    };
    let specs = match parsed {
        VariantsFile::Many { variants } => variants,
        VariantsFile::One(spec) => vec![*spec],
    };
    for s in &specs {
        s.validate()
            .with_context(|| format!("variant {} in {}", s.name, path.display()))?;
    }
    Ok(specs)
}

/// `spec` with the parameter at `path` set to `value` when it has one.
/// The variants to run: the built-in ones named, with the dataset's sensor model (after
/// `--sensor`) and the shared options, then those of the configuration files as written.
fn resolve_variants(args: &VariantArgs, ds: &Dataset) -> Result<Vec<VariantSpec>> {
    if let Some(m) = &args.matcher {
        MATCHERS.find(m).context("--matcher")?;
    }
    let names: Vec<String> = match &args.variants {
        Some(v) => v.clone(),
        None if args.config.is_empty() => TABLE1.iter().map(|s| s.to_string()).collect(),
        None => Vec::new(),
    };
    let options = BuiltinOptions {
        matcher: args.matcher.clone(),
        huber_c: args.huber_c,
        seed: args.seed,
    };
    let mut specs = Vec::new();
    for n in &names {
        let spec = builtin(n).with_context(|| {
            format!(
                "unknown variant {n:?}: expected one of {}, or --config FILE",
                builtin_names().join(", ")
            )
        })?;
        // The shared options apply to the built-in variants, where they have the parameter.
        let name = spec.name.clone();
        specs.push(
            options
                .apply(spec, ds.sensor)
                .with_context(|| format!("variant {name}"))?,
        );
    }
    for path in &args.config {
        specs.extend(read_variants_file(path)?);
    }
    if specs.is_empty() {
        bail!("no variant to run");
    }
    for s in &specs {
        s.validate()
            .with_context(|| format!("variant {}", s.name))?;
    }
    Ok(specs)
}

fn run_one(args: RunArgs) -> Result<ExitCode> {
    let ds = load_dataset(&args.data)?;
    let specs = resolve_variants(&args.variants, &ds)?;
    if let Some(shard) = shard_of(&args.shard)? {
        let work = Work::Run(args.run_options()?);
        return run_shard_cmd(&ds, specs, work, shard, &args.out, &args.common);
    }
    let setup = args.run_options()?.setup(&specs, &ds)?;
    note_estimates(&setup);
    let (report, _) = evaluate_and_write(&ds, &setup, &args.out, &args.common)?;
    println!("{}", eval::output::table_md(&report));
    Ok(ExitCode::SUCCESS)
}

fn compare_cmd(args: CompareArgs) -> Result<ExitCode> {
    let run = &args.run;
    let ds = load_dataset(&run.data)?;
    let variants = resolve_variants(&run.variants, &ds)?;
    let options = CompareOptions {
        resamples: args.bootstrap,
        seed: args.bootstrap_seed,
    };
    let sweep = args
        .sweep
        .as_deref()
        .map(|text| {
            eval::sweep::parse_sweep(text)
                .map(|(param, values)| SweepPlan { param, values })
                .map_err(anyhow::Error::msg)
                .context("--sweep")
        })
        .transpose()?;
    if let Some(shard) = shard_of(&run.shard)? {
        let work = Work::Compare {
            run: run.run_options()?,
            options,
            sweep,
        };
        return run_shard_cmd(&ds, variants, work, shard, &run.out, &run.common);
    }
    let setup = run.run_options()?.setup(&variants, &ds)?;
    note_estimates(&setup);
    let (report, mut dir) = evaluate_and_write(&ds, &setup, &run.out, &run.common)?;
    write_compare(&mut dir, &report, &options)?;
    if let Some(SweepPlan { param, values }) = sweep {
        let bar = progress(run.common.quiet, "sweep");
        let result = in_pool(run.common.threads, || {
            eval::sweep::sweep(&ds, &setup, &variants, param, &values, &bar)
        })??;
        write_sweep(&mut dir, &result, !run.common.no_plots)?;
    }
    Ok(ExitCode::SUCCESS)
}

/// Says on the terminal what an external estimates file held that the run does not use (also
/// in table.md): a count that is not 0 may be a file of another run, or of a 3D estimator.
fn note_estimates(setup: &EvalSetup) {
    for e in &setup.estimates {
        let s = &e.source;
        if s.unused > 0 {
            eprintln!(
                "note: --estimates {}: {} of the estimates in {} are for no pair of this run (left unused)",
                s.name,
                s.unused,
                s.path.display()
            );
        }
        if s.tilted_poses > 0 {
            eprintln!(
                "note: --estimates {}: {} poses of {} are tilted more than {}° out of the plane (up to {:.1}°): their roll and pitch are dropped",
                s.name,
                s.tilted_poses,
                s.path.display(),
                eval::estimates::TILT_NOTE_DEG,
                s.max_tilt_deg
            );
        }
    }
}

/// Writes and prints `compare.md` and `compare.json` of `report`.
fn write_compare(dir: &mut OutputDir, report: &RunReport, options: &CompareOptions) -> Result<()> {
    let (md, _) = eval::compare_files::write_compare(dir, report, options)?;
    println!("{md}");
    Ok(())
}

/// Writes and prints `sweep.md` and `sweep.json` (and the sweep's figures when `plots`).
fn write_sweep(dir: &mut OutputDir, result: &eval::sweep::SweepResult, plots: bool) -> Result<()> {
    let md = eval::sweep::sweep_md(result);
    write_md_json(dir, "sweep", &md, result)?;
    if plots {
        eval::plots::write_sweep(dir, result)?;
    }
    println!("{md}");
    Ok(())
}

fn basin_cmd(args: BasinArgs) -> Result<ExitCode> {
    let ds = load_dataset(&args.data)?;
    let setup = EvalSetup::from_specs(
        &resolve_variants(&args.variants, &ds)?,
        OffsetChoice::Fixed(0),
    )?;
    let options = BasinOptions {
        perturbations: args.perturbations,
        max_translation_m: args.max_translation_m,
        max_rotation_deg: args.max_rotation_deg,
        seed: args.perturbation_seed,
        pair_stride: args.pair_stride,
        ..BasinOptions::default()
    };
    options.validate()?;
    if let Some(shard) = shard_of(&args.shard)? {
        let specs = setup.variants.iter().map(|v| v.spec()).collect();
        let work = Work::Basin(options);
        return run_shard_cmd(&ds, specs, work, shard, &args.out, &args.common);
    }
    let mut dir =
        OutputDir::open(&args.out, args.common.force).context("opening the output directory")?;
    let bar = progress(args.common.quiet, "basin");
    let report = in_pool(args.common.threads, || {
        eval::basin::run(&ds, &setup.variants, &options, &bar)
    })??;
    bar.finish_and_clear();
    write_basin(&mut dir, &report, !args.common.no_plots)?;
    Ok(ExitCode::SUCCESS)
}

/// Writes and prints `basin.csv`, `.md` and `.json` (and its figures when `plots`).
fn write_basin(dir: &mut OutputDir, report: &eval::basin::BasinReport, plots: bool) -> Result<()> {
    dir.write("basin.csv", &eval::basin::basin_csv(report)?)?;
    let md = eval::basin::basin_md(report);
    write_md_json(dir, "basin", &md, report)?;
    if plots {
        eval::plots::write_basin(dir, report)?;
    }
    println!("{md}");
    Ok(())
}

/// The shard this process runs, from `--shard`, else from the Slurm or Kubernetes variables
/// (unless `--no-shard`).
fn shard_of(args: &ShardArgs) -> Result<Option<(Shard, ShardOrigin)>> {
    let env: BTreeMap<String, String> = if args.no_shard {
        BTreeMap::new()
    } else {
        [
            eval::shard::SLURM_ARRAY_TASK_ID,
            eval::shard::SLURM_ARRAY_TASK_MIN,
            eval::shard::SLURM_ARRAY_TASK_COUNT,
            eval::shard::JOB_COMPLETION_INDEX,
        ]
        .into_iter()
        .filter_map(|name| {
            std::env::var_os(name).map(|v| (name.to_owned(), v.to_string_lossy().into_owned()))
        })
        .collect()
    };
    Ok(eval::shard::resolve(args.shard, args.shards, &env)?)
}

/// Runs one shard of the plan of `work` and writes its part file into `out`.
fn run_shard_cmd(
    ds: &Dataset,
    specs: Vec<VariantSpec>,
    work: Work,
    (shard, origin): (Shard, ShardOrigin),
    out: &Path,
    common: &Common,
) -> Result<ExitCode> {
    if let Work::Run(run) | Work::Compare { run, .. } = &work {
        if run.covariance == CovarianceMode::Sampled {
            // Its samples are seeded by the pair's position in the run, which a shard does not
            // see yet: refused rather than giving other numbers than a single run.
            bail!("--covariance sampled cannot be sharded yet: run it unsharded (--no-shard)");
        }
    }
    let plan = Plan::new(ds, specs, work, shard.count)?;
    let slices = eval::shard::slices(&plan.runs, shard);
    let mine: usize = slices.iter().map(|s| s.units.len()).sum();
    let total: usize = plan.runs.iter().map(|r| r.units).sum();
    // Said on every sharded run: a run inside a Slurm array or an indexed Job shards itself.
    eprintln!(
        "icp-eval: shard {shard} (from {origin}): {mine} of the plan's {total} units; writes {} only: merge the parts with `icp-eval merge` (--no-shard runs everything)",
        out.join(shard.file_name()).display()
    );
    let mut dir = OutputDir::open(out, common.force).context("opening the output directory")?;
    let bar = progress(common.quiet, &format!("shard {shard}"));
    let command_line: Vec<String> = std::env::args().collect();
    let part = in_pool(common.threads, || {
        eval::shard::run_shard(ds, &plan, shard, command_line, &bar)
    })??;
    dir.write(&shard.file_name(), &part.to_bytes()?)?;
    Ok(ExitCode::SUCCESS)
}

/// `icp-eval merge`: the parts' results, rendered as a single run renders its own.
fn merge_cmd(args: MergeArgs) -> Result<ExitCode> {
    let merged = eval::merge::merge(&args.parts)?;
    let plan = &merged.plan;
    // The dataset is re-loaded from the shard's own options, and checked against the plan.
    let data = match Cli::try_parse_from(&merged.command_line)
        .map(|cli| cli.command)
        .context("re-reading the command line of shard 0")?
    {
        Command::Run(a) => a.data,
        Command::Compare(a) => a.run.data,
        Command::Basin(a) => a.data,
        _ => bail!("shard 0 was not a run, compare or basin"),
    };
    let ds = load_dataset(&data).context("re-loading the dataset of the sharded run")?;
    let identity = eval::shard::DatasetIdentity::of(&ds);
    if identity != plan.dataset {
        bail!(
            "the dataset re-loaded for the merge ({}, {} scans, content {}) is not the one the              shards ran ({}, {} scans, content {}): run the merge where the shards' dataset              paths lead to the same files",
            identity.name,
            identity.scans,
            identity.content_sha256,
            plan.dataset.name,
            plan.dataset.scans,
            plan.dataset.content_sha256
        );
    }
    let setups = plan.setups(&ds)?;
    let mut dir =
        OutputDir::open(&args.out, args.common.force).context("opening the output directory")?;
    let plots = !args.common.no_plots;
    if merged.runs.len() != setups.len() {
        bail!(
            "the parts hold {} runs, their plan {}",
            merged.runs.len(),
            setups.len()
        );
    }
    let report_of = |i: usize| -> Result<RunReport> {
        let MergedRun::Runs(runs) = &merged.runs[i] else {
            bail!("run {i} of the plan holds basin rows");
        };
        let (pairs, skipped) = eval::checked_pairs(&ds, &setups[i])?;
        eval::merge::check_shape(runs, setups[i].method_names().len(), pairs.len())
            .map_err(anyhow::Error::msg)
            .with_context(|| format!("run {i} of the merged plan"))?;
        Ok(eval::report::build(&ds, &pairs, skipped, &setups[i], runs))
    };
    match &plan.work {
        Work::Run(_) => {
            let report = report_of(0)?;
            write_outputs(&mut dir, &ds, &report, plots).context("writing the reports")?;
            println!("{}", eval::output::table_md(&report));
        }
        Work::Compare { options, sweep, .. } => {
            let report = report_of(0)?;
            write_outputs(&mut dir, &ds, &report, plots).context("writing the reports")?;
            write_compare(&mut dir, &report, options)?;
            if let Some(s) = sweep {
                let mut points = Vec::new();
                for (i, &value) in s.values.iter().enumerate() {
                    points.extend(eval::sweep::points_of(value, &report_of(i + 1)?));
                }
                let result = eval::sweep::SweepResult {
                    param: s.param.clone(),
                    points,
                };
                write_sweep(&mut dir, &result, plots)?;
            }
        }
        Work::Basin(options) => {
            let MergedRun::Basin(rows) = &merged.runs[0] else {
                bail!("the basin's run holds registrations");
            };
            let names: Vec<&str> = setups[0].variants.iter().map(|v| v.name()).collect();
            let chosen = eval::basin::chosen_pairs(&ds, options).len();
            let report = eval::basin::report(&ds, &names, options, chosen, rows.clone());
            write_basin(&mut dir, &report, plots)?;
        }
    }
    Ok(ExitCode::SUCCESS)
}

fn read_report(path: &Path) -> Result<RunReport> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    serde_json::from_str(&text)
        .with_context(|| format!("{} is not a summary.json of this schema", path.display()))
}

fn gate_cmd(args: GateArgs) -> Result<ExitCode> {
    let baseline = read_report(&args.baseline)?;
    let current = read_report(&args.current)?;
    let text = std::fs::read_to_string(&args.tolerance)
        .with_context(|| format!("reading {}", args.tolerance.display()))?;
    let tolerances: Tolerances = serde_json::from_str(&text)
        .with_context(|| format!("{} is not a tolerance file", args.tolerance.display()))?;
    tolerances.validate().map_err(anyhow::Error::msg)?;
    if let Some(why) = incompatibility(&baseline, &current) {
        bail!(
            "{} and {} cannot be compared: {why}",
            args.baseline.display(),
            args.current.display()
        );
    }
    let outcome = gate(&baseline, &current, &tolerances);
    print!("{}: {}", current.dataset.name, outcome_md(&outcome));
    Ok(if outcome.regressions.is_empty() {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    })
}

fn synth(args: SynthArgs) -> Result<ExitCode> {
    let mut scenario = Scenario::by_name(&args.scenario).with_context(|| {
        format!(
            "unknown scenario {:?}: expected paper or marina-like",
            args.scenario
        )
    })?;
    scenario.scanner.sensor = SensorModel::sweep_with_sigma_alpha_deg(args.sigma_alpha_deg)
        .context("--sigma-alpha-deg")?;
    scenario.scanner.noise = !args.no_noise;
    scenario.scanner.motion_distortion = args.motion_distortion;
    if let Some(n) = args.scans {
        scenario.n_scans = n;
    }
    if let Some(dt) = args.dt {
        scenario.dt_s = dt;
    }
    if let Some(v) = args.speed {
        scenario.speed_mps = v;
    }
    if let Some(seed) = args.seed {
        scenario.seed = seed;
    }
    if let Some(f) = args.gross_error_fraction {
        scenario.scanner.gross_error_fraction = f;
    }
    let ds = synthetic::generate(&scenario)?;
    datasets::csvdir::write(&args.out, &ds)
        .with_context(|| format!("writing {}", args.out.display()))?;
    println!("{} scans written to {}", ds.scans.len(), args.out.display());
    Ok(ExitCode::SUCCESS)
}

/// Writes `<stem>.md` and `<stem>.json` (pretty, newline-terminated) into `dir`, atomically.
fn write_md_json(
    dir: &mut OutputDir,
    stem: &str,
    md: &str,
    value: &impl serde::Serialize,
) -> Result<()> {
    dir.write(&format!("{stem}.md"), md.as_bytes())?;
    let json = serde_json::to_string_pretty(value)? + "\n";
    dir.write(&format!("{stem}.json"), json.as_bytes())?;
    Ok(())
}

fn scaling(args: ScalingArgs) -> Result<ExitCode> {
    let spec = builtin(&args.variant).with_context(|| {
        format!(
            "unknown variant {:?}: expected one of {}",
            args.variant,
            builtin_names().join(", ")
        )
    })?;
    let result = eval::scaling::measure(&spec, &args.beams, args.budget_s)?;
    let mut dir = OutputDir::open(&args.out, args.force)?;
    let md = eval::scaling::scaling_md(&result);
    write_md_json(&mut dir, "scaling", &md, &result)?;
    eval::plots::write_scaling(&mut dir, &result)?;
    print!("{md}");
    Ok(ExitCode::SUCCESS)
}

fn list() -> Result<ExitCode> {
    print!(
        "{}",
        eval::listing::listing(&builtins(), &stage_families(), &section_docs())
    );
    Ok(ExitCode::SUCCESS)
}

/// The dataset `--dataset` names (through the loader registry, [`datasets::source`]), with
/// the flags that set loader options (`--data-dir`, `--dt`, `--scans`, `--scenario-seed`,
/// `--carmen-*`) and the sensor model of `--sensor`.
fn load_dataset(args: &DataArgs) -> Result<Dataset> {
    let mut source: DatasetSource = args.dataset.parse()?;
    let flags: [(&str, Option<String>); 6] = [
        (
            "data_dir",
            args.data_dir.as_ref().map(|d| d.display().to_string()),
        ),
        ("dt_s", args.dt.map(|v| v.to_string())),
        ("scans", args.scans.map(|v| v.to_string())),
        ("seed", args.scenario_seed.map(|v| v.to_string())),
        ("fov_deg", args.carmen_fov_deg.map(|v| v.to_string())),
        (
            "max_range_m",
            args.carmen_max_range_m.map(|v| v.to_string()),
        ),
    ];
    for (key, value) in flags {
        if let Some(value) = value {
            source.set_from_flag(key, value)?;
        }
    }
    let mut ds = source.open()?;
    if let Some(overrides) = &args.sensor {
        override_sensor(&mut ds, overrides).context("--sensor")?;
    }
    Ok(ds)
}
