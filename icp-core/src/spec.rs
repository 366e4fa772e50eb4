//! A registration method as data ([`VariantSpec`]): what a configuration file holds, each stage
//! a registered kind with its parameters. Building it into a chain is `variants`' work.

use serde::{Deserialize, Serialize};

use crate::error::ConfigError;
use crate::registry::StageSpec;
use crate::surface::SurfaceParams;
use crate::{SensorModel, Termination};

/// One registration method as data: what a configuration file holds. A stage missing from a
/// file takes the paper's (equal-count selection, grid matching, point-to-point), and the
/// minimiser the metric's own (weighted Kabsch for point-to-point, Gauss-Newton otherwise).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VariantSpec {
    /// Name in reports, e.g. `HD_ICP`.
    pub name: String,
    /// Where the method comes from (citation, Table 1 row), free text.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub source: Option<String>,
    /// Point selection (Alg. 1 step 1).
    #[serde(default = "default_selection")]
    pub selection: StageSpec,
    /// Nearest-neighbour matcher (Alg. 1 step 2).
    #[serde(default = "default_matcher")]
    pub matcher: StageSpec,
    /// How the surface (normal, covariance) behind each return is estimated.
    #[serde(default)]
    pub surfaces: SurfaceParams,
    /// The error metric of eq. 14.
    #[serde(default = "default_metric")]
    pub metric: StageSpec,
    /// Pair weighting (Alg. 1 step 3).
    pub weighting: StageSpec,
    /// Robust rejection (Alg. 1 step 4).
    pub robust: StageSpec,
    /// Minimisation (Alg. 1 step 5); `None`: the metric's own.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub minimizer: Option<StageSpec>,
    /// Error model of the returns, for the weights and the metrics that use it.
    #[serde(default)]
    pub sensor: SensorModel,
    /// Convergence rule (Alg. 1 step 6).
    #[serde(default)]
    pub termination: Termination,
    /// Returns that move against the scene, found over the sequence and left out of a second
    /// registration (beyond Alg. 1, see [`crate::moving`]); `none` by default.
    #[serde(default = "default_moving")]
    pub moving: StageSpec,
}

/// `Ok` when `name` can name a variant's files (`trajectory_<name>.tum`): letters, digits and
/// `_ - + .`, not empty, not starting with a dot.
pub fn check_name(name: &str) -> Result<(), ConfigError> {
    let bad = |reason| {
        Err(ConfigError::Name {
            name: name.to_owned(),
            reason,
        })
    };
    if name.is_empty() {
        return bad("must not be empty");
    }
    if name.starts_with('.') {
        return bad("must not start with a dot");
    }
    if !name
        .chars()
        .all(|c| c.is_ascii_alphanumeric() || "_-+.".contains(c))
    {
        return bad("only letters, digits and _ - + . (it names the run's files)");
    }
    Ok(())
}

fn default_moving() -> StageSpec {
    StageSpec::kind("none")
}

fn default_selection() -> StageSpec {
    StageSpec::kind("equal_count")
}

fn default_matcher() -> StageSpec {
    StageSpec::kind("grid")
}

fn default_metric() -> StageSpec {
    StageSpec::kind("point_to_point")
}
