//! What to evaluate: the methods, where they start, how their results are checked and how the
//! reference is aligned ([`EvalSetup`]), and the pairs a setup registers ([`checked_pairs`]).

use datasets::{Dataset, ScanPair, SkippedPair};
use icp_core::global::GlobalParams;
use icp_core::variants::VariantSpec;
use icp_core::{ConfigError, Registrar};
use serde::{Deserialize, Serialize};

use crate::error::EvalError;
use crate::run::covariance::CovarianceMode;
use crate::run::estimates::ExternalEstimates;
use crate::run::init::InitChain;
use crate::run::sequence_setup::{SequenceMode, SequencePrior, SequenceSetup};
use crate::run::start_gate::{self, StartGate};

/// How the reference is aligned in time with the scans.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "mode", content = "scans", rename_all = "snake_case")]
pub enum OffsetChoice {
    /// Apply this many scans (0: none).
    Fixed(i64),
    /// Apply the estimated offset.
    Auto,
}

impl std::str::FromStr for OffsetChoice {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        if s.eq_ignore_ascii_case("auto") {
            return Ok(Self::Auto);
        }
        s.parse::<i64>()
            .map(Self::Fixed)
            .map_err(|_| format!("expected an integer number of scans or 'auto', got {s:?}"))
    }
}

/// What to evaluate.
pub struct EvalSetup {
    /// The registration methods, in order: built-in or configured chains, or written in user
    /// code (each reports what it is through [`Registrar::spec`]).
    pub variants: Vec<Box<dyn Registrar>>,
    /// Reference time alignment.
    pub offset: OffsetChoice,
    /// Whether reference steps are tested for plausibility.
    pub reference_checks: ReferenceChecks,
    /// Where each registration starts.
    pub init: InitChain,
    /// The global search's parameters (for `--init global` and the result checks).
    pub global: GlobalParams,
    /// Whether every result is checked against the pair's global search (a result far from a
    /// clearly better pose is flagged suspect).
    pub global_check: GlobalChecks,
    /// How registrations started close to the motion gate their correspondences.
    pub start_gate: StartGate,
    /// Where each registration's covariance comes from.
    pub covariance: CovarianceMode,
    /// Estimates made elsewhere, evaluated after the variants like one more variant each
    /// (see [`crate::run::estimates`]).
    pub estimates: Vec<ExternalEstimates>,
    /// Every variant also registers `k → k+ℓ` for `2 ≤ ℓ ≤ lags` (1: consecutive pairs only;
    /// see [`crate::run::lags`]).
    pub lags: usize,
    /// Each variant's registrations also smoothed over the scan sequence in these modes, as
    /// estimators `V+batch`, `V+causal` (made by the `sequence` module of `run`).
    pub sequence: SequenceSetup,
}

/// Whether registrations are checked against a global search of their pair.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "snake_case")]
pub enum GlobalChecks {
    /// Every result is scored on the reference's likelihood grid against the search's best.
    On,
    /// No search is made for the check (the paper's run).
    #[default]
    Off,
}

impl EvalSetup {
    /// The chains `specs` describe, built, with the reference alignment `offset`, the
    /// reference checks on and no covariance.
    pub fn from_specs(specs: &[VariantSpec], offset: OffsetChoice) -> Result<Self, ConfigError> {
        let setup = Self {
            variants: specs
                .iter()
                .map(|s| Ok(Box::new(s.build()?) as Box<dyn Registrar>))
                .collect::<Result<_, ConfigError>>()?,
            offset,
            reference_checks: ReferenceChecks::On,
            init: InitChain::default(),
            global: GlobalParams::default(),
            global_check: GlobalChecks::Off,
            start_gate: StartGate::default(),
            covariance: CovarianceMode::Off,
            estimates: Vec::new(),
            lags: 1,
            sequence: SequenceSetup::default(),
        };
        Ok(setup.with_covariance(CovarianceMode::Off))
    }

    /// The same setup smoothing each variant over the scan sequence in `modes` under `prior`.
    pub fn with_sequence(mut self, modes: &[SequenceMode], prior: SequencePrior) -> Self {
        self.sequence = SequenceSetup::new(modes, &self.variants).with_prior(prior);
        self
    }

    /// The same setup registering across lags up to `lags`.
    pub fn with_lags(mut self, lags: usize) -> Self {
        self.lags = lags;
        self
    }

    /// The same setup with the external estimates `estimates` (evaluated after the variants).
    pub fn with_estimates(mut self, estimates: Vec<ExternalEstimates>) -> Self {
        self.estimates = estimates;
        self
    }

    /// What the runner is asked for every pair: the init chain, the global search, whether
    /// each result is checked against it and whether its ambiguity is assessed (the extended
    /// covariance modes'). One place for the run, its shards and the registrations made again.
    pub fn run_plan(&self) -> crate::run::runner::RunPlan<'_> {
        crate::run::runner::RunPlan {
            chain: &self.init,
            global: &self.global,
            check: self.global_check == GlobalChecks::On,
            ambiguity: self.covariance.is_extended(),
        }
    }

    /// For tests: a plan that checks every result against `global`'s search and assesses its
    /// ambiguity, from the default init chain.
    #[cfg(test)]
    pub(crate) fn checking_plan(global: &GlobalParams) -> crate::run::runner::RunPlan<'_> {
        static CHAIN: std::sync::OnceLock<InitChain> = std::sync::OnceLock::new();
        crate::run::runner::RunPlan {
            chain: CHAIN.get_or_init(InitChain::default),
            global,
            check: true,
            ambiguity: true,
        }
    }

    /// The methods the runner runs: the variants (with `close`, their close-start twins from
    /// [`Self::close_start_variants`]), then the external estimates.
    pub fn methods<'a>(
        &'a self,
        close: &'a [Option<Box<dyn Registrar>>],
    ) -> crate::run::runner::Methods<'a> {
        crate::run::runner::Methods {
            registrars: &self.variants,
            close,
            external: &self.estimates,
        }
    }

    /// The names of the methods, in the order of their results: the variants, then the
    /// external estimators.
    pub fn method_names(&self) -> Vec<&str> {
        self.variants
            .iter()
            .map(|v| v.name())
            .chain(self.estimates.iter().map(|e| e.source.name.as_str()))
            .collect()
    }

    /// The names of the estimators the report has: the methods, then the smoothed ones
    /// (`V+batch`, `V+causal`, made from the methods' results when the report is made).
    pub fn reported_names(&self) -> Vec<&str> {
        let mut names = self.method_names();
        names.extend(self.sequence.names());
        names
    }

    /// The same setup with the correspondence gate `gate` of registrations started at the
    /// global search.
    pub fn with_start_gate(mut self, gate: StartGate) -> Self {
        self.start_gate = gate;
        self
    }

    /// Per variant, the spec a close start (the global search's pose or the reference,
    /// [`crate::run::init::InitMode::is_close`]) runs instead of it, when the chain has such starts and they are
    /// gated ([`crate::run::start_gate`]); empty when none is.
    /// A variant with a stage written in user code (its spec does not build) runs as it is.
    pub fn close_start_specs(&self) -> Result<Vec<Option<VariantSpec>>, ConfigError> {
        let Some(gate_m) = self
            .init
            .close_starts()
            .then(|| self.start_gate.metres(&self.global))
            .flatten()
        else {
            return Ok(Vec::new());
        };
        self.variants
            .iter()
            .map(|v| {
                let spec = v.spec();
                match spec.build() {
                    Ok(_) => start_gate::gated(&spec, gate_m),
                    Err(_) => Ok(None),
                }
            })
            .collect()
    }

    /// Per variant, the registrar a close start runs instead of it (built from
    /// [`Self::close_start_specs`]), for the runner's plan.
    pub fn close_start_variants(&self) -> Result<Vec<Option<Box<dyn Registrar>>>, ConfigError> {
        self.close_start_specs()?
            .into_iter()
            .map(|s| {
                s.map(|s| {
                    let mut chain = s.build()?;
                    chain.set_jackknife(self.covariance.is_extended());
                    Ok(Box::new(chain) as Box<dyn Registrar>)
                })
                .transpose()
            })
            .collect()
    }

    /// The same setup with the covariances of `mode` (its variants compute the jackknife
    /// only when `mode` uses it).
    pub fn with_covariance(mut self, mode: CovarianceMode) -> Self {
        self.covariance = mode;
        for variant in &mut self.variants {
            variant.set_jackknife(mode.is_extended());
        }
        self
    }

    /// The same setup with the global search's parameters `global` and checks `check`.
    pub fn with_global(mut self, global: GlobalParams, check: GlobalChecks) -> Self {
        self.global = global;
        self.global_check = check;
        self
    }

    /// The same setup with the initial guesses of `init`.
    pub fn with_init(mut self, init: InitChain) -> Self {
        self.init = init;
        self
    }

    /// The same setup with the reference checks `checks`.
    pub fn with_reference_checks(mut self, checks: ReferenceChecks) -> Self {
        self.reference_checks = checks;
        self
    }
}

/// Whether a run tests its reference steps for plausibility.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "snake_case")]
pub enum ReferenceChecks {
    /// Flag implausible steps (`measure::reference::flag_implausible`) and leave them out of the "plausible"
    /// statistics: for measured references (GNSS, SLAM-corrected poses).
    #[default]
    On,
    /// Take every step with a reference as plausible: for ground truth.
    Off,
}

/// The consecutive pairs of `ds` (and those skipped) that `setup` registers, once `setup` is
/// checked against `ds`: what `pipeline::evaluate` and a shard of a run (the `shard` module) start from.
pub fn checked_pairs(
    ds: &Dataset,
    setup: &EvalSetup,
) -> Result<(Vec<ScanPair>, Vec<SkippedPair>), EvalError> {
    let (pairs, skipped) = ds.consecutive_pairs();
    if pairs.is_empty() && skipped.is_empty() {
        return Err(EvalError::NothingToRegister {
            dataset: ds.provenance.name.clone(),
            scans: ds.scans.len(),
        });
    }
    let names = setup.method_names();
    for (i, name) in names.iter().enumerate() {
        icp_core::variants::check_name(name)?;
        if names[..i].contains(name) {
            return Err(EvalError::DuplicateName((*name).to_owned()));
        }
    }
    setup.init.check(ds)?;
    Ok((pairs, skipped))
}
