//! `icp-eval`: the command line of the evaluation harness.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{bail, Context, Result};
use clap::{Args, Parser, Subcommand};
use datasets::synthetic::{self, Scenario};
use datasets::{marina, Dataset};
use eval::{evaluate, write_outputs, EvalSetup, OffsetChoice};
use icp_core::matching::MatcherKind;
use icp_core::variants::{SelectionKind, Variant, VariantConfig};
use icp_core::SensorModel;
use indicatif::{ProgressBar, ProgressStyle};

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
    /// Generate a synthetic harbour dataset and write it in our CSV format.
    Synth(SynthArgs),
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
    /// Output directory (scans.csv, poses.csv, dataset.json).
    #[arg(long)]
    out: PathBuf,
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
}

#[derive(Args)]
struct ReproduceArgs {
    /// Directory holding the marina files (or a `marina/` folder); else $ICP_DATA_DIR, then ./datasets.
    #[arg(long)]
    data_dir: Option<PathBuf>,
    /// Output directory.
    #[arg(long, default_value = "reports/reproduction")]
    out: PathBuf,
    #[command(flatten)]
    common: Common,
}

#[derive(Args)]
struct RunArgs {
    /// marina | synthetic[:paper|marina-like] | carmen:PATH (.log or .log.gz) | csv:DIR
    #[arg(long)]
    dataset: String,
    /// CARMEN only: field of view of the laser, degrees.
    #[arg(long, default_value_t = 180.0)]
    carmen_fov_deg: f64,
    /// CARMEN only: readings at or beyond this range are no-returns, metres.
    #[arg(long, default_value_t = 50.0)]
    carmen_max_range_m: f64,
    /// Directory of the marina files.
    #[arg(long)]
    data_dir: Option<PathBuf>,
    /// Variants, comma-separated (K_ICP, H_ICP, HM_ICP, HD_ICP).
    #[arg(long, value_delimiter = ',', default_values_t = Variant::ALL.to_vec())]
    variants: Vec<Variant>,
    /// Nearest-neighbour matcher: kdtree, delaunay or brute.
    #[arg(long, default_value_t = MatcherKind::Kdtree)]
    matcher: MatcherKind,
    /// Nominal time between scans, s, where scans carry no timestamps (marina: 1.0;
    /// synthetic: the scenario's spacing).
    #[arg(long)]
    dt: Option<f64>,
    /// Bearing standard deviation of the sensor model behind the HM/HD weights, degrees
    /// (default: the dataset's model; the data itself is not changed).
    #[arg(long)]
    sigma_alpha_deg: Option<f64>,
    /// Synthetic only: number of scans (default: the scenario's).
    #[arg(long)]
    scans: Option<usize>,
    /// Seed of the point selection (default 0) and, for synthetic data, of the scenario
    /// (default: the scenario's own).
    #[arg(long)]
    seed: Option<u64>,
    /// Reference time offset in scans, or `auto` to apply the estimated one.
    #[arg(long, default_value = "0")]
    reference_offset: OffsetChoice,
    /// Output directory.
    #[arg(long)]
    out: PathBuf,
    #[command(flatten)]
    common: Common,
}

fn main() -> ExitCode {
    match run(Cli::parse()) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::from(2)
        }
    }
}

fn run(cli: Cli) -> Result<ExitCode> {
    match cli.command {
        Command::Reproduce(args) => reproduce(args),
        Command::Run(args) => run_one(args),
        Command::Synth(args) => synth(args),
    }
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

fn evaluate_and_write(
    ds: &Dataset,
    setup: &EvalSetup,
    out: &Path,
    common: &Common,
) -> Result<String> {
    let bar = progress(common.quiet, &ds.provenance.name);
    let report = in_pool(common.threads, || evaluate(ds, setup, &bar))??;
    write_outputs(out, ds, &report, !common.no_plots)
        .with_context(|| format!("writing the reports to {}", out.display()))?;
    Ok(eval::output::table_md(&report))
}

fn reproduce(args: ReproduceArgs) -> Result<ExitCode> {
    let setup = EvalSetup {
        variants: Variant::ALL.to_vec(),
        config: VariantConfig::default(),
        offset: OffsetChoice::Fixed(0),
    };
    match marina::find_data_dir(args.data_dir.as_deref()) {
        Ok(dir) => {
            let ds = marina::load(&dir, &marina::MarinaOptions::default())
                .with_context(|| format!("loading the marina data from {}", dir.display()))?;
            let out = args.out.join("marina");
            println!("{}", evaluate_and_write(&ds, &setup, &out, &args.common)?);
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
    println!("{}", evaluate_and_write(&ds, &setup, &out, &args.common)?);
    println!("(synthetic reports in {})", out.display());
    Ok(ExitCode::SUCCESS)
}

fn run_one(args: RunArgs) -> Result<ExitCode> {
    let mut ds = load_dataset(&args)?;
    if let Some(deg) = args.sigma_alpha_deg {
        let sensor = SensorModel {
            sigma_alpha_rad: deg.to_radians(),
            ..ds.sensor
        };
        sensor.validate().context("--sigma-alpha-deg")?;
        ds.sensor = sensor;
    }
    let setup = EvalSetup {
        variants: args.variants.clone(),
        config: VariantConfig {
            sensor: ds.sensor,
            matcher: args.matcher,
            selection: SelectionKind::EqualCount {
                seed: args.seed.unwrap_or(0),
            },
            ..VariantConfig::default()
        },
        offset: args.reference_offset,
    };
    if setup.variants.is_empty() {
        bail!("--variants names no variant");
    }
    println!(
        "{}",
        evaluate_and_write(&ds, &setup, &args.out, &args.common)?
    );
    Ok(ExitCode::SUCCESS)
}

fn load_dataset(args: &RunArgs) -> Result<Dataset> {
    let (kind, rest) = args.dataset.split_once(':').unwrap_or((&args.dataset, ""));
    match kind {
        "marina" => {
            let dir = marina::find_data_dir(args.data_dir.as_deref())?;
            let dt_s = args.dt.unwrap_or(1.0);
            Ok(marina::load(&dir, &marina::MarinaOptions { dt_s, ..Default::default() })?)
        }
        "synthetic" => {
            let name = if rest.is_empty() { "paper" } else { rest };
            let mut scenario = Scenario::by_name(name).with_context(|| {
                format!("unknown synthetic scenario {name:?}: expected paper or marina-like")
            })?;
            if let Some(seed) = args.seed {
                scenario.seed = seed;
            }
            if let Some(dt) = args.dt {
                scenario.dt_s = dt;
            }
            if let Some(n) = args.scans {
                scenario.n_scans = n;
            }
            Ok(synthetic::generate(&scenario)?)
        }
        "carmen" if !rest.is_empty() => {
            let options = datasets::carmen::CarmenOptions {
                fov_deg: args.carmen_fov_deg,
                max_range_m: args.carmen_max_range_m,
                ..Default::default()
            };
            let mut ds = datasets::carmen::load(Path::new(rest), &options)?;
            if let Some(dt) = args.dt {
                ds.dt_s = dt;
            }
            Ok(ds)
        }
        "csv" if !rest.is_empty() => {
            let mut ds = datasets::csvdir::load(Path::new(rest))?;
            if let Some(dt) = args.dt {
                ds.dt_s = dt;
            }
            Ok(ds)
        }
        other => bail!("unknown dataset {other:?}: expected marina, synthetic[:scenario], carmen:PATH or csv:DIR"),
    }
}
