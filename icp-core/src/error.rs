//! Typed errors for everything a caller can get wrong.

use std::fmt;

use serde::{Deserialize, Serialize};

/// Which scan of a pair an error is about.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum ScanRole {
    /// Scan k, the scan being moved.
    Source,
    /// Scan k+1, the scan matched against.
    Reference,
}

impl fmt::Display for ScanRole {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            ScanRole::Source => "source",
            ScanRole::Reference => "reference",
        })
    }
}

/// How a point set is degenerate.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Degeneracy {
    /// All points (nearly) coincide: neither rotation nor translation is observable.
    Coincident,
    /// All points lie (nearly) on one line: translation along it is not observable.
    Collinear,
}

impl fmt::Display for Degeneracy {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Degeneracy::Coincident => "all points coincide",
            Degeneracy::Collinear => "all points are collinear",
        })
    }
}

/// Errors of scan construction and registration.
#[derive(Debug, thiserror::Error, Clone, PartialEq, Serialize, Deserialize)]
pub enum IcpError {
    /// Ranges and bearings (or two parallel inputs) differ in length.
    #[error("mismatched lengths: {what} has {got} values, expected {expected}")]
    LengthMismatch {
        #[serde(deserialize_with = "crate::static_str::deserialize")]
        what: crate::static_str::StaticStr,
        expected: usize,
        got: usize,
    },
    /// A value that must be finite is NaN or infinite.
    #[error("non-finite {what} at index {index}: {value}")]
    NonFinite {
        #[serde(deserialize_with = "crate::static_str::deserialize")]
        what: crate::static_str::StaticStr,
        index: usize,
        value: f64,
    },
    /// A vector that must have a direction (a surface normal) is zero.
    #[error("zero-length {what} at index {index}")]
    ZeroLength {
        #[serde(deserialize_with = "crate::static_str::deserialize")]
        what: crate::static_str::StaticStr,
        index: usize,
    },
    /// A range below zero.
    #[error("negative range at index {index}: {value} m")]
    NegativeRange { index: usize, value: f64 },
    /// Fewer points than the registration needs.
    #[error("{role} scan has {got} usable points, at least {need} are needed")]
    TooFewPoints {
        role: ScanRole,
        got: usize,
        need: usize,
    },
    /// The point set cannot constrain a rigid motion.
    #[error("{role} scan is ill-conditioned: {kind}")]
    Degenerate { role: ScanRole, kind: Degeneracy },
    /// A coordinate the nearest-neighbour index cannot hold.
    #[error("coordinate out of the matcher's range at point {index}: {value}")]
    CoordinateOutOfRange { index: usize, value: f64 },
    /// A parameter outside its domain.
    #[error("invalid parameter {name} = {value}: {reason}")]
    InvalidParameter {
        #[serde(deserialize_with = "crate::static_str::deserialize")]
        name: crate::static_str::StaticStr,
        value: f64,
        #[serde(deserialize_with = "crate::static_str::deserialize")]
        reason: crate::static_str::StaticStr,
    },
    /// A pair weight that is NaN, infinite or negative.
    #[error("pair {pair} has an invalid weight {value}")]
    InvalidWeight { pair: usize, value: f64 },
    /// A batch pair weighting (`weighting::BatchWeighting`) failed or returned weights that are not one
    /// per pair, finite and ≥ 0.
    #[error("the pair weighting failed at iteration {iteration}: {why}")]
    WeightingFailed {
        /// The minimisation step (from 0).
        iteration: usize,
        /// What went wrong.
        why: String,
    },
    /// The weights of all pairs sum to zero (or are not finite).
    #[error("the pair weights sum to {sum}: no pair constrains the motion")]
    DegenerateWeights { sum: f64 },
    /// The minimiser produced a non-finite transform.
    #[error("the minimiser produced a non-finite transform")]
    NonFiniteTransform,
    /// An estimator outside this crate (a pose that the `assess` module would assess) gave no
    /// estimate for the pair: a failure of that estimator.
    #[error("no estimate: {why}")]
    NoEstimate {
        /// Why, in words (e.g. the file has no pose for one of the scans).
        why: String,
    },
    /// A global search (see the `global` module) that would need more memory or time than its
    /// limit: too many grid cells, or too many rotation candidates.
    #[error("the global search needs {count} {what}, more than the limit of {max}")]
    GlobalSearchTooLarge {
        /// What there are too many of.
        #[serde(deserialize_with = "crate::static_str::deserialize")]
        what: crate::static_str::StaticStr,
        /// How many there would be.
        count: f64,
        /// The limit.
        max: f64,
    },
    /// The stages or their parameters are invalid.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// The surface estimates handed to a registration are not those of its scan, or were
    /// made with other parameters than the method's.
    #[error("the {role} scan's surface estimates {why}")]
    SurfacesMismatch {
        /// Which scan.
        role: ScanRole,
        /// What does not match.
        #[serde(deserialize_with = "crate::static_str::deserialize")]
        why: crate::static_str::StaticStr,
    },
}

/// A variant's configuration that cannot be built: what is wrong, naming the stage and the
/// parameter (generated from the registered kinds, see the `registry` module).
#[derive(Debug, thiserror::Error, Clone, PartialEq, Serialize, Deserialize)]
pub enum ConfigError {
    /// No kind of this name is registered in the family.
    #[error("unknown {family} kind {kind:?}: expected one of {known}")]
    UnknownKind {
        /// The stage family, e.g. `weighting`.
        #[serde(deserialize_with = "crate::static_str::deserialize")]
        family: crate::static_str::StaticStr,
        /// The name given.
        kind: String,
        /// The registered names.
        known: String,
    },
    /// The kind's parameters do not parse or fail its validation.
    #[error("{family} {kind:?}: {why}")]
    BadParameters {
        /// The stage family.
        #[serde(deserialize_with = "crate::static_str::deserialize")]
        family: crate::static_str::StaticStr,
        /// The kind.
        kind: String,
        /// What is wrong, naming the parameter.
        why: String,
    },
    /// A parameter of a section that is not a stage (sensor, surfaces, termination).
    #[error("{section}.{}", .source)]
    Section {
        /// The section, e.g. `termination`.
        #[serde(deserialize_with = "crate::static_str::deserialize")]
        section: crate::static_str::StaticStr,
        /// The parameter and what is wrong with it.
        source: ParamError,
    },
    /// Two stages that cannot work together.
    #[error("{0}")]
    Incompatible(String),
    /// A variant name that cannot name the files of a run.
    #[error("variant name {name:?}: {reason}")]
    Name {
        /// The name given.
        name: String,
        /// What is wrong with it.
        #[serde(deserialize_with = "crate::static_str::deserialize")]
        reason: crate::static_str::StaticStr,
    },
}

/// A parameter outside its domain: which one, its value and why.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error, serde::Serialize, serde::Deserialize)]
#[error("{parameter} = {value}: {reason}")]
pub struct ParamError {
    /// The parameter's name, as written in a configuration file.
    #[serde(deserialize_with = "crate::static_str::deserialize")]
    pub parameter: crate::static_str::StaticStr,
    /// Its value, as given.
    pub value: String,
    /// What it must be.
    #[serde(deserialize_with = "crate::static_str::deserialize")]
    pub reason: crate::static_str::StaticStr,
}

impl ParamError {
    /// `parameter` has the bad `value` for `reason`.
    pub fn new(parameter: &'static str, value: impl fmt::Display, reason: &'static str) -> Self {
        Self {
            parameter,
            value: value.to_string(),
            reason,
        }
    }

    /// `Ok` when `value` is finite and positive.
    pub fn check_positive(parameter: &'static str, value: f64) -> Result<(), Self> {
        if value.is_finite() && value > 0.0 {
            Ok(())
        } else {
            Err(Self::new(parameter, value, "must be finite and positive"))
        }
    }

    /// `Ok` when `value` is finite and not negative.
    pub fn check_non_negative(parameter: &'static str, value: f64) -> Result<(), Self> {
        if value.is_finite() && value >= 0.0 {
            Ok(())
        } else {
            Err(Self::new(
                parameter,
                value,
                "must be finite and non-negative",
            ))
        }
    }
}
