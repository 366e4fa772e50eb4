//! `icp-eval`: the command line of the evaluation harness.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{bail, Context, Result};
use clap::{Args, Parser, Subcommand};
use datasets::synthetic::{self, Scenario};
use datasets::{marina, Dataset};
use eval::basin::BasinOptions;
use eval::compare::{compare, compare_md, CompareOptions};
use eval::consistency::CovarianceMode;
use eval::gate::{gate, incompatibility, outcome_md, Tolerances};
use eval::init::{InitChain, MODES};
use eval::report::RunReport;
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

#[derive(Args)]
struct DataArgs {
    /// marina | synthetic[:paper|marina-like] | carmen:PATH (.log or .log.gz) | csv:DIR
    #[arg(long)]
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
    /// CARMEN only: field of view of the laser, degrees.
    #[arg(long, default_value_t = 180.0)]
    carmen_fov_deg: f64,
    /// CARMEN only: readings at or beyond this range are no-returns, metres.
    #[arg(long, default_value_t = 50.0)]
    carmen_max_range_m: f64,
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
    /// Output directory.
    #[arg(long)]
    out: PathBuf,
    #[command(flatten)]
    common: Common,
}

/// The global search's rotation modes on the command line.
#[derive(Clone, Copy, clap::ValueEnum)]
enum GlobalRotation {
    Full,
    Histogram,
}

impl RunArgs {
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
fn set_param(spec: VariantSpec, path: &str, value: serde_json::Value) -> Result<VariantSpec> {
    Ok(spec
        .with_param(path, value)
        .with_context(|| format!("variant {}", spec.name))?
        .unwrap_or(spec))
}

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
    let mut specs = Vec::new();
    for n in &names {
        let mut spec = builtin(n).with_context(|| {
            format!(
                "unknown variant {n:?}: expected one of {}, or --config FILE",
                builtin_names().join(", ")
            )
        })?;
        // The shared options apply to the built-in variants, where they have the parameter.
        spec.sensor = ds.sensor;
        if let Some(m) = &args.matcher {
            spec = set_param(spec, "matcher.kind", m.as_str().into())?;
        }
        if let Some(c) = args.huber_c {
            spec = set_param(spec, "robust.c", c.into())?;
        }
        if let Some(seed) = args.seed {
            spec = set_param(spec, "selection.seed", seed.into())?;
        }
        specs.push(spec);
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
    let setup = EvalSetup::from_specs(
        &resolve_variants(&args.variants, &ds)?,
        args.reference_offset,
    )?
    .with_reference_checks(args.reference_checks)
    .with_init(args.init.clone())
    .with_global(args.global()?, args.global_check)
    .with_covariance(args.covariance);
    let (report, _) = evaluate_and_write(&ds, &setup, &args.out, &args.common)?;
    println!("{}", eval::output::table_md(&report));
    Ok(ExitCode::SUCCESS)
}

fn compare_cmd(args: CompareArgs) -> Result<ExitCode> {
    let run = &args.run;
    let ds = load_dataset(&run.data)?;
    let variants = resolve_variants(&run.variants, &ds)?;
    let setup = EvalSetup::from_specs(&variants, run.reference_offset)?
        .with_reference_checks(run.reference_checks)
        .with_init(run.init.clone())
        .with_global(run.global()?, run.global_check)
        .with_covariance(run.covariance);
    let (report, mut dir) = evaluate_and_write(&ds, &setup, &run.out, &run.common)?;
    let options = CompareOptions {
        resamples: args.bootstrap,
        seed: args.bootstrap_seed,
    };
    let rows = compare(&report, &options);
    let md = compare_md(&report, &rows, &options);
    let json = serde_json::json!({ "options": options, "comparisons": rows });
    write_md_json(&mut dir, "compare", &md, &json)?;
    println!("{md}");
    if let Some(text) = &args.sweep {
        let (param, values) = eval::sweep::parse_sweep(text)
            .map_err(anyhow::Error::msg)
            .context("--sweep")?;
        let bar = progress(run.common.quiet, "sweep");
        let result = in_pool(run.common.threads, || {
            eval::sweep::sweep(&ds, &setup, &variants, param, &values, &bar)
        })??;
        let md = eval::sweep::sweep_md(&result);
        write_md_json(&mut dir, "sweep", &md, &result)?;
        if !run.common.no_plots {
            eval::plots::write_sweep(&mut dir, &result)?;
        }
        println!("{md}");
    }
    Ok(ExitCode::SUCCESS)
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
    let mut dir =
        OutputDir::open(&args.out, args.common.force).context("opening the output directory")?;
    let bar = progress(args.common.quiet, "basin");
    let report = in_pool(args.common.threads, || {
        eval::basin::run(&ds, &setup.variants, &options, &bar)
    })??;
    bar.finish_and_clear();
    dir.write("basin.csv", &eval::basin::basin_csv(&report)?)?;
    let md = eval::basin::basin_md(&report);
    write_md_json(&mut dir, "basin", &md, &report)?;
    if !args.common.no_plots {
        eval::plots::write_basin(&mut dir, &report)?;
    }
    println!("{md}");
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

/// The dataset `--dataset` names, with the spacing of `--dt` and the sensor model of
/// `--sensor`.
fn load_dataset(args: &DataArgs) -> Result<Dataset> {
    let (kind, rest) = args.dataset.split_once(':').unwrap_or((&args.dataset, ""));
    let mut ds = match kind {
        "marina" => {
            let dir = marina::find_data_dir(args.data_dir.as_deref())?;
            marina::load(&dir, &marina::MarinaOptions { dt_s: args.dt.unwrap_or(1.0), ..Default::default() })?
        }
        "synthetic" => {
            let name = if rest.is_empty() { "paper" } else { rest };
            let mut scenario = Scenario::by_name(name)
                .with_context(|| format!("unknown synthetic scenario {name:?}: expected paper or marina-like"))?;
            if let Some(seed) = args.scenario_seed {
                scenario.seed = seed;
            }
            if let Some(dt) = args.dt {
                scenario.dt_s = dt;
            }
            if let Some(n) = args.scans {
                scenario.n_scans = n;
            }
            synthetic::generate(&scenario)?
        }
        "carmen" if !rest.is_empty() => {
            let options = datasets::carmen::CarmenOptions {
                fov_deg: args.carmen_fov_deg,
                max_range_m: args.carmen_max_range_m,
                ..Default::default()
            };
            datasets::carmen::load(Path::new(rest), &options)?
        }
        "csv" if !rest.is_empty() => datasets::csvdir::load(Path::new(rest))?,
        other => bail!("unknown dataset {other:?}: expected marina, synthetic[:scenario], carmen:PATH or csv:DIR"),
    };
    if let (Some(dt), "carmen" | "csv") = (args.dt, kind) {
        ds.set_dt_s(dt).context("--dt")?;
    }
    if let Some(overrides) = &args.sensor {
        ds.sensor = overrides.apply(ds.sensor).context("--sensor")?;
    }
    Ok(ds)
}
