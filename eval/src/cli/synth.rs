//! `icp-eval synth`: a synthetic harbour dataset written in our CSV format.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{bail, Context, Result};
use clap::Args;
use datasets::synthetic::{self, Corridor, ScannerConfig, Scenario};
use datasets::Dataset;
use icp_core::SensorModel;

#[derive(Args)]
pub(crate) struct SynthArgs {
    /// Scenario: paper (865 scans every 0.2 s), marina-like (177 scans every 1 s), rough
    /// (the paper's run with a real vessel's and scanner's error sources) or corridor (an
    /// indoor robot in office corridors with a SICK LMS, 440 scans every 1 s).
    #[arg(long, default_value = "paper")]
    pub(crate) scenario: String,
    /// Number of scans (default: the scenario's).
    #[arg(long)]
    pub(crate) scans: Option<usize>,
    /// Time between scans, s.
    #[arg(long)]
    pub(crate) dt: Option<f64>,
    /// Mean speed over ground, m/s.
    #[arg(long)]
    pub(crate) speed: Option<f64>,
    /// Seed of the world and the noise.
    #[arg(long)]
    pub(crate) seed: Option<u64>,
    /// Bearing standard deviation, degrees (the Sweep's and the corridor's SICK LMS's 0.5°).
    #[arg(long, default_value_t = SensorModel::SWEEP_SIGMA_ALPHA_DEG)]
    pub(crate) sigma_alpha_deg: f64,
    /// Exact returns (no range or bearing noise).
    #[arg(long)]
    pub(crate) no_noise: bool,
    /// Fraction of spurious returns (spray, water).
    #[arg(long)]
    pub(crate) gross_error_fraction: Option<f64>,
    /// Take each beam at its own time within the revolution.
    #[arg(long)]
    pub(crate) motion_distortion: bool,
    /// The rough scenario's moving boats: a JSON file listing them (see
    /// configs/boats/harbour.json, the built-in three, the default) or `none`.
    #[arg(long, value_name = "FILE|none")]
    pub(crate) boats: Option<String>,
    /// Output directory (scans.csv with each return's true surface normal and moving label,
    /// poses.csv, dataset.json).
    #[arg(long)]
    pub(crate) out: PathBuf,
}

pub(crate) fn synth(args: SynthArgs) -> Result<ExitCode> {
    let ds = if args.scenario == Corridor::NAME {
        corridor(&args)?
    } else {
        harbour(&args)?
    };
    datasets::csvdir::write(&args.out, &ds)
        .with_context(|| format!("writing {}", args.out.display()))?;
    println!("{} scans written to {}", ds.scans.len(), args.out.display());
    Ok(ExitCode::SUCCESS)
}

/// The corridor scenario, refusing the harbour's options (`--boats` as `run` does).
fn corridor(args: &SynthArgs) -> Result<Dataset> {
    let refused = [
        (args.dt.is_some(), "--dt", Corridor::PLANNED_PER_SCAN),
        (args.speed.is_some(), "--speed", Corridor::PLANNED_PER_SCAN),
        (
            args.motion_distortion,
            "--motion-distortion",
            "its scanner's 13 ms sweep is taken from one pose",
        ),
    ];
    if let Some((_, flag, why)) = refused.iter().find(|r| r.0) {
        bail!("{flag} does not apply to the corridor scenario: {why}");
    }
    let mut c = Corridor::default();
    c.scanner.sensor.sigma_alpha_rad = args.sigma_alpha_deg.to_radians();
    shared(args, &mut c.n_scans, &mut c.seed, &mut c.scanner);
    Ok(synthetic::generate_corridor_without_boats(
        &c,
        args.boats.as_deref(),
    )?)
}

/// A harbour scenario.
fn harbour(args: &SynthArgs) -> Result<Dataset> {
    let mut scenario = Scenario::by_name(&args.scenario).with_context(|| {
        format!(
            "unknown scenario {:?}: expected {}",
            args.scenario,
            Scenario::NAMES
        )
    })?;
    scenario.scanner.sensor = SensorModel::sweep_with_sigma_alpha_deg(args.sigma_alpha_deg)
        .context("--sigma-alpha-deg")?;
    scenario.scanner.motion_distortion |= args.motion_distortion;
    shared(
        args,
        &mut scenario.n_scans,
        &mut scenario.seed,
        &mut scenario.scanner,
    );
    if let Some(dt) = args.dt {
        scenario.dt_s = dt;
    }
    if let Some(v) = args.speed {
        scenario.speed_mps = v;
    }
    Ok(synthetic::generate_with_boats(
        &scenario,
        args.boats.as_deref(),
    )?)
}

/// The options every scenario takes: the number of scans, the seed, exact returns and the
/// share of spurious ones.
fn shared(args: &SynthArgs, n_scans: &mut usize, seed: &mut u64, scanner: &mut ScannerConfig) {
    scanner.noise = !args.no_noise;
    *n_scans = args.scans.unwrap_or(*n_scans);
    *seed = args.seed.unwrap_or(*seed);
    if let Some(f) = args.gross_error_fraction {
        scanner.gross_error_fraction = f;
    }
}
