//! `icp_bench.run(uri, variants, weightings, out=DIR, **options) -> dict`: the harness's
//! `run` (`icp-eval run`), with the command line's options as keywords, the same files
//! written, `summary.json` returned; a weighting written in Python enters as one more
//! variant. `icp_bench.compare` adds `icp-eval compare`'s comparison. The GIL is released
//! while the run runs.

use std::path::PathBuf;
use std::str::FromStr;

use eval::measure::compare::{self as comparisons, CompareOptions};
use eval::pipeline::evaluate;
use eval::render::outdir::OutputDir;
use eval::render::studies::{comparison_json, write_comparison};
use eval::render::write_outputs;
use eval::run::covariance::CovarianceMode;
use eval::run::estimates::EstimatesSpec;
use eval::run::init::InitChain;
use eval::run::options::BuiltinOptions;
use eval::run::options::RunOptions;
use eval::run::options::{override_sensor, refuse_reference_options};
use eval::run::sequence_setup::{SequenceMode, SequencePrior};
use eval::run::setup::GlobalChecks;
use eval::run::setup::OffsetChoice;
use eval::run::setup::ReferenceChecks;
use eval::run::start_gate::StartGate;
use eval::run::status::StatusKind;
use icp_core::global::{GlobalParams, RotationMode};
use icp_core::sensor::SensorOverrides;
use icp_core::variants::{builtin, builtin_names, VariantSpec, TABLE1};
use icp_core::Registrar;
use indicatif::ProgressBar;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyString};

use crate::convert::{from_python, to_python};
use crate::errors::{config_error, dataset_error, eval_error, ConfigError, WeightingError};
use crate::register::variant_spec;
use crate::weighting::PyWeighting;

/// The keyword options, named as the command line's flags (with `_` for `-`).
const OPTIONS: [&str; 19] = [
    "reference_offset",
    "reference_checks",
    "init",
    "global_check",
    "start_gate",
    "global_window_m",
    "global_rotation",
    "covariance",
    "estimates",
    "lags",
    "sequence",
    "motion_prior",
    "matcher",
    "huber_c",
    "seed",
    "sensor",
    "threads",
    "plots",
    "force",
];

/// The keyword options of a run, read as the command line reads its flags.
struct Options<'py> {
    given: Option<&'py Bound<'py, PyDict>>,
}

impl<'py> Options<'py> {
    /// `Err` naming the first keyword that is no option.
    fn check(&self) -> PyResult<()> {
        for key in self.given.iter().flat_map(|d| d.keys()) {
            let key: String = key.extract()?;
            if !OPTIONS.contains(&key.as_str()) {
                return Err(ConfigError::new_err(format!(
                    "unknown option {key:?}: expected one of {}",
                    OPTIONS.join(", ")
                )));
            }
        }
        Ok(())
    }

    /// The value of option `key`, when given (and not None).
    fn raw(&self, key: &str) -> PyResult<Option<Bound<'py, PyAny>>> {
        Ok(match self.given {
            Some(d) => d.get_item(key)?.filter(|v| !v.is_none()),
            None => None,
        })
    }

    /// Option `key` extracted as a `T`.
    fn get<T: for<'a> FromPyObject<'a, 'py>>(&self, key: &str) -> PyResult<Option<T>> {
        self.raw(key)?
            .map(|v| {
                v.extract::<T>()
                    .map_err(|e| ConfigError::new_err(format!("option {key}: {}", e.into())))
            })
            .transpose()
    }

    /// Option `key` read from its text as the command line reads it (a number is taken as
    /// its text), else `default`'s text.
    fn parse<T: FromStr>(&self, key: &str, default: &str) -> PyResult<T>
    where
        T::Err: std::fmt::Display,
    {
        let text = match self.raw(key)? {
            Some(v) => v.str()?.to_string(),
            None => default.to_owned(),
        };
        T::from_str(&text).map_err(|e| ConfigError::new_err(format!("option {key}={text}: {e}")))
    }

    /// Option `key` as one of the words of a `T` (`on`/`off`, `full`/`histogram`), else
    /// `default`.
    fn word<T: serde::de::DeserializeOwned>(&self, key: &str, default: T) -> PyResult<T> {
        match self.raw(key)? {
            Some(v) => from_python(&v, &format!("option {key}")),
            None => Ok(default),
        }
    }

    /// The harness's options of a run.
    fn run_options(&self) -> PyResult<RunOptions> {
        let global = GlobalParams {
            window_m: self
                .get("global_window_m")?
                .unwrap_or(GlobalParams::default().window_m),
            rotation: self.word("global_rotation", RotationMode::Histogram)?,
            ..GlobalParams::default()
        };
        global
            .validate()
            .map_err(|e| ConfigError::new_err(format!("option global_window_m: {e}")))?;
        let estimates = self
            .get::<Vec<String>>("estimates")?
            .unwrap_or_default()
            .iter()
            .map(|text| {
                EstimatesSpec::from_str(text)
                    .map_err(|e| ConfigError::new_err(format!("option estimates {text:?}: {e}")))
            })
            .collect::<PyResult<_>>()?;
        Ok(RunOptions {
            offset: self.parse::<OffsetChoice>("reference_offset", "0")?,
            reference_checks: self.word("reference_checks", ReferenceChecks::On)?,
            init: self.parse::<InitChain>("init", "identity")?,
            global,
            global_check: self.word("global_check", GlobalChecks::On)?,
            start_gate: self.parse::<StartGate>("start_gate", "auto")?,
            covariance: self.parse::<CovarianceMode>("covariance", "extended")?,
            estimates,
            lags: self.parse::<usize>("lags", "1")?,
            sequence: self.sequence()?,
            motion_prior: self.word("motion_prior", SequencePrior::WhiteAcceleration)?,
        })
    }

    /// `--sequence`'s modes: a list of words (`["batch", "causal"]`) or the command line's
    /// comma-separated text (`"batch,causal"`); none by default.
    fn sequence(&self) -> PyResult<Vec<SequenceMode>> {
        let Some(v) = self.raw("sequence")? else {
            return Ok(Vec::new());
        };
        let words: Vec<String> = match v.extract::<String>() {
            Ok(text) => text.split(',').map(str::to_owned).collect(),
            Err(_) => v.extract().map_err(|_| {
                ConfigError::new_err(format!(
                    "option sequence: expected a list of modes or \"batch,causal\", got {}",
                    v.repr().map_or_else(|_| "?".to_owned(), |r| r.to_string())
                ))
            })?,
        };
        words
            .iter()
            .map(|w| {
                serde_json::from_value(serde_json::Value::String(w.trim().to_owned())).map_err(
                    |_| {
                        ConfigError::new_err(format!(
                            "option sequence: unknown mode {w:?}: expected batch or causal"
                        ))
                    },
                )
            })
            .collect()
    }

    /// The sensor overrides: a dict of `sigma_r_const_m`, `sigma_r_per_m`, `sigma_alpha_deg`,
    /// or the command line's text.
    fn sensor(&self) -> PyResult<Option<SensorOverrides>> {
        let Some(v) = self.raw("sensor")? else {
            return Ok(None);
        };
        let text = match v.cast::<PyDict>() {
            Ok(d) => d
                .iter()
                .map(|(k, v)| Ok(format!("{}={}", k.str()?, v.str()?)))
                .collect::<PyResult<Vec<_>>>()?
                .join(","),
            Err(_) => v.str()?.to_string(),
        };
        SensorOverrides::from_str(&text)
            .map(Some)
            .map_err(|e| ConfigError::new_err(format!("option sensor={text}: {e}")))
    }
}

/// The built-in variant `name`, `Err` naming the choices.
fn builtin_spec(name: &str) -> PyResult<VariantSpec> {
    builtin(name).ok_or_else(|| {
        ConfigError::new_err(format!(
            "unknown variant {name:?}: expected one of {}, or a variant spec as a dict",
            builtin_names().join(", ")
        ))
    })
}

/// A run made and its files written.
struct Written {
    ds: datasets::Dataset,
    report: eval::measure::report::RunReport,
    dir: OutputDir,
    plots: bool,
}

/// Runs `variants` and the Python `weightings` over the dataset `uri` with `options` (the
/// command line's) and writes the run's files into `out`.
fn run_and_write<'py>(
    py: Python<'py>,
    uri: &str,
    variants: Option<Vec<Bound<'py, PyAny>>>,
    weightings: Option<&Bound<'py, PyDict>>,
    out: PathBuf,
    options: &Options<'py>,
) -> PyResult<Written> {
    options.check()?;
    let run_options = options.run_options()?;
    let builtin_options = BuiltinOptions {
        matcher: options.get("matcher")?,
        huber_c: options.get("huber_c")?,
        seed: options.get("seed")?,
    };
    let sensor = options.sensor()?;
    let threads: Option<usize> = options.get("threads")?;
    let plots: bool = options.get("plots")?.unwrap_or(true);
    let force: bool = options.get("force")?.unwrap_or(false);
    let mut ds = py
        .detach(|| datasets::source::open(uri))
        .map_err(dataset_error)?;
    if let Some(overrides) = &sensor {
        override_sensor(&mut ds, overrides)
            .map_err(|e| ConfigError::new_err(format!("option sensor: {e}")))?;
    }
    let mut given = Vec::new();
    for key in ["reference_offset", "reference_checks"] {
        if options.raw(key)?.is_some() {
            given.push(key);
        }
    }
    refuse_reference_options(&ds, &given).map_err(eval_error)?;
    let builtin_for = |spec: VariantSpec| {
        let name = spec.name.clone();
        builtin_options
            .apply(spec, ds.sensor)
            .map_err(|e| ConfigError::new_err(format!("variant {name}: {e}")))
    };
    let given = match variants {
        Some(v) => v,
        None => TABLE1
            .iter()
            .map(|n| PyString::new(py, n).into_any())
            .collect(),
    };
    let mut specs = Vec::new();
    for v in &given {
        let spec = variant_spec(v)?;
        let spec = if v.is_instance_of::<PyString>() {
            builtin_for(spec)?
        } else {
            spec.validate()
                .map_err(|e| ConfigError::new_err(format!("variant {}: {e}", spec.name)))?;
            spec
        };
        specs.push(spec);
    }
    let mut setup = run_options.setup(&specs, &ds).map_err(eval_error)?;
    let mut python_names = Vec::new();
    for (name, entry) in weightings.iter().flat_map(|d| d.iter()) {
        let name: String = name.extract()?;
        let (base, func): (String, Bound<'py, PyAny>) = entry.extract().map_err(|_| {
            ConfigError::new_err(format!(
                "weighting {name}: expected (BASE_VARIANT, fn), a built-in name and a callable"
            ))
        })?;
        if !func.is_callable() {
            return Err(ConfigError::new_err(format!(
                "weighting {name}: {} is not callable",
                func.repr()?
            )));
        }
        let spec = builtin_for(builtin_spec(&base)?)?;
        let weighting = PyWeighting::new(&func, &base, spec.sensor)?;
        let chain = spec
            .build()
            .map_err(config_error)?
            .named(&name)
            .with_batch_weighting(weighting);
        python_names.push(name);
        setup.variants.push(Box::new(chain) as Box<dyn Registrar>);
    }
    if setup.variants.is_empty() {
        return Err(ConfigError::new_err("no variant to run"));
    }
    if threads == Some(0) {
        return Err(ConfigError::new_err("option threads: at least 1"));
    }

    let mut dir = OutputDir::open(&out, force).map_err(eval_error)?;
    let report = py
        .detach(|| {
            let go = || evaluate(&ds, &setup, &ProgressBar::hidden());
            match threads {
                None => Ok(go()),
                Some(n) => rayon::ThreadPoolBuilder::new()
                    .num_threads(n)
                    .build()
                    .map(|pool| pool.install(go))
                    .map_err(|e| ConfigError::new_err(format!("option threads: {e}"))),
            }
        })?
        .map_err(eval_error)?;
    // A Python weighting that failed stops the run with its first failure, in pair order.
    if let Some(failed) = report.pairs.iter().find(|r| {
        r.status == StatusKind::Failed
            && python_names.contains(&r.variant)
            && r.status_reason.starts_with(WEIGHTING_FAILED)
    }) {
        return Err(WeightingError::new_err(format!(
            "variant {}, pair {} (scans {} → {}): {}",
            failed.variant, failed.pair, failed.source, failed.reference, failed.status_reason
        )));
    }
    write_outputs(&mut dir, &ds, &report, plots).map_err(eval_error)?;
    Ok(Written {
        ds,
        report,
        dir,
        plots,
    })
}

/// Runs `variants` (built-in names, to which the options apply, or specs as dicts, taken as
/// written; default: the four of Table 1) and the Python `weightings`
/// (`{NAME: (BASE_VARIANT, fn)}`) over every consecutive pair of the dataset `uri`, writes
/// the files of `icp-eval run` into `out` and returns `summary.json` as a dict. Each `fn` gets
/// a dict per iteration (the stub's `Weighting`: ranges and points in metres, bearings and
/// `rotation_rad` in radians, each return's `src_sigma_r_m`, `dst_sigma_r_m` (metres) and
/// `src_sigma_alpha_rad`, `dst_sigma_alpha_rad` (radians) from the variant's sensor model) and
/// returns one weight per pair.
#[pyfunction]
#[pyo3(signature = (uri, variants=None, weightings=None, *, out, **options))]
pub fn run<'py>(
    py: Python<'py>,
    uri: &str,
    variants: Option<Vec<Bound<'py, PyAny>>>,
    weightings: Option<&Bound<'py, PyDict>>,
    out: PathBuf,
    options: Option<&'py Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyAny>> {
    let run = run_and_write(
        py,
        uri,
        variants,
        weightings,
        out,
        &Options { given: options },
    )?;
    let summary = eval::render::json::summary_json(&run.report).map_err(eval_error)?;
    py.import("json")?.call_method1("loads", (summary,))
}

/// [`run`], then every pair of variants compared as `icp-eval compare` does (per-pair
/// differences of |SOG error| and |ΔCOG error|: bootstrap interval of the mean with
/// `bootstrap` resamples seeded by `bootstrap_seed`, Wilcoxon and Holm-adjusted p-values):
/// writes its files and `compare.md` and `compare.json` into `out` and returns
/// `compare.json` as a dict.
#[pyfunction]
#[pyo3(signature = (uri, variants=None, weightings=None, *, out, bootstrap=10_000, bootstrap_seed=0, **options))]
#[allow(clippy::too_many_arguments)]
pub fn compare<'py>(
    py: Python<'py>,
    uri: &str,
    variants: Option<Vec<Bound<'py, PyAny>>>,
    weightings: Option<&Bound<'py, PyDict>>,
    out: PathBuf,
    bootstrap: usize,
    bootstrap_seed: u64,
    options: Option<&'py Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyAny>> {
    let mut run = run_and_write(
        py,
        uri,
        variants,
        weightings,
        out,
        &Options { given: options },
    )?;
    let compare_options = CompareOptions {
        resamples: bootstrap,
        seed: bootstrap_seed,
    };
    let rows = comparisons::compare(&run.report, &compare_options);
    let json = comparison_json(&rows, &compare_options);
    py.detach(|| {
        write_comparison(
            &mut run.dir,
            &run.ds,
            &run.report,
            &rows,
            &compare_options,
            None,
            run.plots,
        )
    })
    .map_err(eval_error)?;
    to_python(py, &json)
}

/// How icp-core's error for a failed batch weighting begins
/// (`IcpError::WeightingFailed`).
const WEIGHTING_FAILED: &str = "the pair weighting failed at iteration ";
