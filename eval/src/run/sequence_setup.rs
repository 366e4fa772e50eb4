//! What `--sequence` asks for: the smoothers' modes and the estimators they add (see
//! the `sequence` module, which makes them).

use icp_core::sequence::{MotionPrior, PriorChoice};
use icp_core::Registrar;
use serde::{Deserialize, Serialize};

/// A smoother's mode on the command line.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "snake_case")]
pub enum SequenceMode {
    /// Every scan from the whole run.
    Batch,
    /// Every scan from the scans up to it only (what a vessel has live).
    Causal,
    /// Every scan from the whole run, with the registrations made again on scans deskewed by
    /// the batch smoother's twists (the `deskew` module; needs the dataset's `sweep_s`).
    Deskew,
}

impl SequenceMode {
    /// The suffix of its estimators' names: `V+batch`, `V+causal`, `V+deskew`.
    pub fn suffix(self) -> &'static str {
        match self {
            Self::Batch => "+batch",
            Self::Causal => "+causal",
            Self::Deskew => "+deskew",
        }
    }
}

/// The smoothers' motion prior on the command line (`icp_core::sequence::MotionPrior`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "snake_case")]
#[value(rename_all = "snake_case")]
pub enum SequencePrior {
    /// White noise on acceleration: a constant velocity between scans (the default).
    #[default]
    WhiteAcceleration,
    /// White noise on jerk: a constant acceleration between scans, each scan's state holding
    /// its body acceleration.
    WhiteJerk,
    /// Both, and per variant the one under which its registrations are likelier (the
    /// smoother's evidence; costs both estimations).
    Likelier,
}

impl SequencePrior {
    /// The smoother's choice.
    pub fn choice(self) -> PriorChoice {
        match self {
            Self::WhiteAcceleration => PriorChoice::Given(MotionPrior::WhiteAcceleration),
            Self::WhiteJerk => PriorChoice::Given(MotionPrior::WhiteJerk),
            Self::Likelier => PriorChoice::Likelier,
        }
    }

    /// The name of a prior the smoother used.
    pub fn of(prior: MotionPrior) -> Self {
        match prior {
            MotionPrior::WhiteAcceleration => Self::WhiteAcceleration,
            MotionPrior::WhiteJerk => Self::WhiteJerk,
        }
    }

    /// Whether it is the default (left out of the options written).
    pub fn is_default(&self) -> bool {
        *self == Self::default()
    }
}

/// The smoothed estimators of a run: the modes, the variants smoothed (those whose metric has
/// a covariance: not point-to-point), the estimators' names (variant-major) and the smoothers'
/// motion prior.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SequenceSetup {
    modes: Vec<SequenceMode>,
    variants: Vec<usize>,
    names: Vec<String>,
    prior: SequencePrior,
}

impl SequenceSetup {
    /// Each of `variants` whose metric gives a covariance in each of `modes` (a mode given
    /// twice counts once).
    pub fn new(modes: &[SequenceMode], variants: &[Box<dyn Registrar>]) -> Self {
        let mut unique: Vec<SequenceMode> = Vec::new();
        for m in modes {
            if !unique.contains(m) {
                unique.push(*m);
            }
        }
        let smoothed: Vec<usize> = (0..variants.len())
            .filter(|&v| variants[v].spec().metric.kind != "point_to_point")
            .collect();
        let names = smoothed
            .iter()
            .flat_map(|&v| {
                unique
                    .iter()
                    .map(move |m| format!("{}{}", variants[v].name(), m.suffix()))
            })
            .collect();
        Self {
            variants: if unique.is_empty() {
                Vec::new()
            } else {
                smoothed
            },
            modes: unique,
            names,
            prior: SequencePrior::default(),
        }
    }

    /// The same estimators smoothed under `prior`.
    pub fn with_prior(self, prior: SequencePrior) -> Self {
        Self { prior, ..self }
    }

    /// The smoothers' motion prior.
    pub fn prior(&self) -> SequencePrior {
        self.prior
    }

    /// The variants smoothed (indices into the setup's variants).
    pub fn variants(&self) -> &[usize] {
        &self.variants
    }

    /// The modes.
    pub fn modes(&self) -> &[SequenceMode] {
        &self.modes
    }

    /// The estimators' names, variant-major.
    pub fn names(&self) -> impl Iterator<Item = &str> {
        self.names.iter().map(String::as_str)
    }

    /// True when nothing is smoothed.
    pub fn is_empty(&self) -> bool {
        self.names.is_empty()
    }
}
