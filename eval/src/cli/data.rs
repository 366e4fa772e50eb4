//! `--dataset` and the flags that set loader options: the dataset a command reads.

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Args;
use datasets::{Dataset, DatasetSource};
use eval::run::options::override_sensor;
use icp_core::sensor::SensorOverrides;

/// `--dataset`'s one-line help: the registered kinds.
pub(crate) fn dataset_help_short() -> String {
    format!(
        "{} (options: KIND:TARGET?KEY=VALUE&...; see --help and docs/formats.md)",
        datasets::source::syntaxes()
    )
}

#[derive(Args)]
pub(crate) struct DataArgs {
    /// The dataset (kinds and options listed by --help, generated from the loader registry).
    #[arg(long, help = dataset_help_short(), long_help = datasets::source::help())]
    pub(crate) dataset: String,
    /// Marina only: directory of the files (or of a marina/ folder); refused for other
    /// datasets.
    #[arg(long)]
    pub(crate) data_dir: Option<PathBuf>,
    /// Time between scans, s, where the data have no timestamps: marina (default 1.0),
    /// synthetic (default: the scenario's spacing), a csv whose scans.csv has none. Refused for
    /// carmen, rosbag and a csv whose every scan has a timestamp (the time between two scans
    /// is theirs).
    #[arg(long)]
    pub(crate) dt: Option<f64>,
    /// The first N scans (N >= 2) of any dataset; more than it has: all of them, as the report
    /// says. Synthetic: N scans generated (the harbour is built around their track).
    #[arg(long)]
    pub(crate) scans: Option<usize>,
    /// Synthetic only: seed of the scenario (default: the scenario's own); refused for other
    /// datasets.
    #[arg(long)]
    pub(crate) scenario_seed: Option<u64>,
    /// CARMEN only: field of view of the laser, degrees (default 180; or ?fov_deg=); refused
    /// for other datasets.
    #[arg(long)]
    pub(crate) carmen_fov_deg: Option<f64>,
    /// CARMEN only: readings at or beyond this range are no-returns, metres (default 50; or
    /// ?max_range_m=); refused for other datasets.
    #[arg(long)]
    pub(crate) carmen_max_range_m: Option<f64>,
    /// The sensor model of this run, as overrides of the dataset's:
    /// sigma_r_const_m=M,sigma_r_per_m=M_PER_M,sigma_alpha_deg=DEG (any of them). The
    /// built-in variants' weights, the metrics and the noise bound use it; the data are not
    /// changed.
    #[arg(long)]
    pub(crate) sensor: Option<SensorOverrides>,
}

/// The dataset `--dataset` names (through the loader registry, [`datasets::source`]), with
/// the flags that set loader options (`--data-dir`, `--dt`, `--scans`, `--scenario-seed`,
/// `--carmen-*`: a flag the dataset's kind has no option for is refused) and the sensor model
/// of `--sensor`.
pub(crate) fn load_dataset(args: &DataArgs) -> Result<Dataset> {
    let mut source: DatasetSource = args.dataset.parse()?;
    let flags: [(&str, Option<String>); 6] = [
        (
            "--data-dir",
            args.data_dir.as_ref().map(|d| d.display().to_string()),
        ),
        ("--dt", args.dt.map(|v| v.to_string())),
        ("--scans", args.scans.map(|v| v.to_string())),
        ("--scenario-seed", args.scenario_seed.map(|v| v.to_string())),
        (
            "--carmen-fov-deg",
            args.carmen_fov_deg.map(|v| v.to_string()),
        ),
        (
            "--carmen-max-range-m",
            args.carmen_max_range_m.map(|v| v.to_string()),
        ),
    ];
    for (flag, value) in flags {
        if let Some(value) = value {
            source.set_from_flag(flag, value)?;
        }
    }
    let mut ds = source.open()?;
    if let Some(first) = ds.first_scans.filter(|f| f.requested > f.available) {
        eprintln!("note: {}: {first}", ds.provenance.name);
    }
    if let Some(overrides) = &args.sensor {
        override_sensor(&mut ds, overrides).context("--sensor")?;
    }
    Ok(ds)
}
