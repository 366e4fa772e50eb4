//! The options of `icp-eval run` and `compare`, shared by the command line, the Python
//! package (`icp_bench.run`) and a sharded run's plan, so all three run the same chains on
//! the same data: the run's own ([`RunOptions`], which make its [`EvalSetup`]), what they do
//! to the built-in variants (`--matcher`, `--huber-c`, `--seed`) and to the dataset
//! (`--sensor`).

use datasets::{Dataset, LoadWarning};
use icp_core::global::GlobalParams;
use icp_core::sensor::{SensorOverrideError, SensorOverrides};
use icp_core::variants::VariantSpec;
use icp_core::{ConfigError, SensorModel};
use serde::{Deserialize, Serialize};

use crate::error::EvalError;
use crate::run::covariance::CovarianceMode;
use crate::run::estimates::EstimatesSpec;
use crate::run::init::InitChain;
use crate::run::sequence_setup::{SequenceMode, SequencePrior};
use crate::run::setup::{EvalSetup, GlobalChecks, OffsetChoice, ReferenceChecks};
use crate::run::start_gate::StartGate;

/// The options of a run (`run` and `compare`) that its setup takes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RunOptions {
    /// Reference time alignment.
    pub offset: OffsetChoice,
    /// Reference plausibility checks.
    pub reference_checks: ReferenceChecks,
    /// Where registrations start.
    pub init: InitChain,
    /// The global search's parameters.
    pub global: GlobalParams,
    /// Whether results are checked against the global search.
    pub global_check: GlobalChecks,
    /// How registrations started close to the motion gate their correspondences.
    #[serde(default)]
    pub start_gate: StartGate,
    /// Where each registration's covariance comes from.
    #[serde(default)]
    pub covariance: CovarianceMode,
    /// External estimates evaluated after the variants, with their files' SHA-256.
    #[serde(default)]
    pub estimates: Vec<EstimatesSpec>,
    /// Every variant also registers `k → k+ℓ` for `2 ≤ ℓ ≤ lags` (`--lags`; 1: consecutive
    /// pairs only, see [`crate::run::lags`]).
    #[serde(default = "one_lag")]
    pub lags: usize,
    /// Each variant also smoothed over the scan sequence in these modes (`--sequence`; see
    /// the `sequence` module of `run`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub sequence: Vec<SequenceMode>,
    /// The smoothers' motion prior (`--motion-prior`).
    #[serde(default, skip_serializing_if = "SequencePrior::is_default")]
    pub motion_prior: SequencePrior,
}

/// `lags` of options written before `--lags` existed: consecutive pairs only.
pub fn one_lag() -> usize {
    1
}

impl RunOptions {
    /// The setup of a run of `variants` on `ds` with these options (the external estimates
    /// read for the pairs of `ds`, each file checked against its recorded SHA-256).
    pub fn setup(&self, variants: &[VariantSpec], ds: &Dataset) -> Result<EvalSetup, EvalError> {
        let (pairs, _) = ds.consecutive_pairs();
        let estimates = self
            .estimates
            .iter()
            .map(|e| e.load(ds, &pairs))
            .collect::<Result<Vec<_>, _>>()?;
        Ok(EvalSetup::from_specs(variants, self.offset)?
            .with_reference_checks(self.reference_checks)
            .with_init(self.init.clone())
            .with_global(self.global, self.global_check)
            .with_start_gate(self.start_gate)
            .with_covariance(self.covariance)
            .with_estimates(estimates)
            .with_lags(self.lags)
            .with_sequence(&self.sequence, self.motion_prior))
    }
}

/// The options that apply to the built-in variants, where a variant has the parameter.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BuiltinOptions {
    /// Nearest-neighbour matcher kind (`matcher.kind`).
    pub matcher: Option<String>,
    /// Factor c of the robust threshold (`robust.c`).
    pub huber_c: Option<f64>,
    /// Seed of a random selection (`selection.seed`).
    pub seed: Option<u64>,
}

impl BuiltinOptions {
    /// The built-in `spec` for data of `sensor`, with these options.
    pub fn apply(
        &self,
        spec: VariantSpec,
        sensor: SensorModel,
    ) -> Result<VariantSpec, ConfigError> {
        let mut spec = VariantSpec { sensor, ..spec };
        let params: [(&str, Option<serde_json::Value>); 3] = [
            ("matcher.kind", self.matcher.as_deref().map(Into::into)),
            ("robust.c", self.huber_c.map(Into::into)),
            ("selection.seed", self.seed.map(Into::into)),
        ];
        for (path, value) in params {
            if let Some(value) = value {
                spec = spec.with_param(path, value)?.unwrap_or(spec);
            }
        }
        Ok(spec)
    }
}

/// `ds` with its sensor model overridden by `overrides` (`--sensor`). The model is the user's
/// where the overrides give it: a warning that it was assumed is updated, or dropped when
/// every value is given.
pub fn override_sensor(
    ds: &mut Dataset,
    overrides: &SensorOverrides,
) -> Result<(), SensorOverrideError> {
    ds.sensor = overrides.apply(ds.sensor)?;
    let whole = overrides.sigma_r_const_m.is_some()
        && overrides.sigma_r_per_m.is_some()
        && overrides.sigma_alpha_deg.is_some();
    let effective = ds.sensor;
    ds.warnings.retain_mut(|w| match w {
        LoadWarning::AssumedSensorModel { sensor, of } => {
            *sensor = effective;
            *of = format!("{of}, with --sensor's values");
            !whole
        }
        _ => true,
    });
    Ok(())
}

/// Refuses the options about the reference (its time offset, its checks) on a dataset that has
/// none, where they would do nothing: `given` are those the user set, named as written
/// (`--reference-offset` on the command line, `reference_offset` in Python).
pub fn refuse_reference_options(ds: &Dataset, given: &[&'static str]) -> Result<(), EvalError> {
    match given.first() {
        Some(&option) if ds.reference.is_none() => Err(EvalError::NotApplicable {
            option,
            dataset: ds.provenance.name.clone(),
            why: "it has no reference to align in time or check",
        }),
        _ => Ok(()),
    }
}
