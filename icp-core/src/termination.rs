//! The convergence rule, Algorithm 1 step 6.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::error::ParamError;

/// Stops the iteration when the mean residual of the metric (the mean pair distance for
/// point-to-point, as in the paper) changes by less than `mean_residual_change_eps_m` between
/// two iterations (the paper's loop condition, printed inverted, corrected here), when an
/// increment is smaller than both `update_translation_eps_m` and `update_rotation_eps_rad`
/// (for Gauss-Newton minimisers; 0 turns that rule off, as for the paper's variants), when
/// `stop_on_repeated_matching` is set and the matching repeats one of the [`CYCLE_MEMORY`]
/// matchings before the previous one (the iteration would go round a loop of correspondences
/// for ever; CSM's PLICP stops on such loops too, Censi 2008), or after `max_iterations`
/// minimisation steps.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(default, deny_unknown_fields)]
pub struct Termination {
    /// Largest number of minimisation steps.
    pub max_iterations: usize,
    /// Convergence threshold on the change of the mean residual, metres.
    #[serde(alias = "mean_dist_change_eps_m")]
    pub mean_residual_change_eps_m: f64,
    /// An increment whose translation is below this (and rotation below
    /// `update_rotation_eps_rad`) ends the iteration, metres; 0: never.
    pub update_translation_eps_m: f64,
    /// An increment whose rotation is below this (and translation below
    /// `update_translation_eps_m`) ends the iteration, radians; 0: never.
    pub update_rotation_eps_rad: f64,
    /// Stop when the correspondences repeat those of one of the last few iterations before the
    /// previous one: a loop the iteration would go round for ever.
    pub stop_on_repeated_matching: bool,
}

/// How many past matchings the loop rule remembers.
pub const CYCLE_MEMORY: usize = 8;

impl Default for Termination {
    fn default() -> Self {
        Self {
            max_iterations: 100,
            mean_residual_change_eps_m: 1e-6,
            update_translation_eps_m: 0.0,
            update_rotation_eps_rad: 0.0,
            stop_on_repeated_matching: false,
        }
    }
}

impl Termination {
    /// Checks that at least one iteration is allowed and every threshold is finite and >= 0.
    pub fn validate(&self) -> Result<(), ParamError> {
        if self.max_iterations == 0 {
            return Err(ParamError::new(
                "max_iterations",
                0,
                "at least one iteration is needed",
            ));
        }
        ParamError::check_non_negative(
            "mean_residual_change_eps_m",
            self.mean_residual_change_eps_m,
        )?;
        ParamError::check_non_negative("update_translation_eps_m", self.update_translation_eps_m)?;
        ParamError::check_non_negative("update_rotation_eps_rad", self.update_rotation_eps_rad)
    }

    /// True when the change from `previous_m` to `current_m` is below the threshold.
    pub fn converged(&self, previous_m: f64, current_m: f64) -> bool {
        (previous_m - current_m).abs() < self.mean_residual_change_eps_m
    }

    /// True when an increment of `translation_m` and `rotation_rad` (magnitudes) is small
    /// enough to stop.
    pub fn small_update(&self, translation_m: f64, rotation_rad: f64) -> bool {
        translation_m < self.update_translation_eps_m && rotation_rad < self.update_rotation_eps_rad
    }
}

/// Why the iteration stopped. Reaching the iteration limit is an outcome, not an error.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StopReason {
    /// The mean residual settled.
    Converged,
    /// An increment was below the update thresholds.
    SmallUpdate,
    /// The correspondences repeated those of an earlier iteration: a loop.
    RepeatedMatching,
    /// `max_iterations` steps were taken without settling.
    MaxIterations,
    /// Nothing was iterated: the pose was estimated elsewhere and assessed at its value
    /// (the `assess` module).
    Given,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rules_and_validation() {
        let t = Termination {
            update_translation_eps_m: 1e-6,
            update_rotation_eps_rad: 1e-7,
            ..Termination::default()
        };
        assert!(t.converged(0.1, 0.1 + 5e-7));
        assert!(!t.converged(0.1, 0.1 + 2e-6));
        assert!(t.small_update(5e-7, 5e-8));
        assert!(!t.small_update(5e-7, 2e-7));
        assert!(!Termination::default().small_update(0.0, 0.0));
        let bad = Termination {
            max_iterations: 0,
            ..t
        };
        assert_eq!(bad.validate().unwrap_err().parameter, "max_iterations");
        let bad = Termination {
            update_rotation_eps_rad: f64::NAN,
            ..t
        };
        assert_eq!(
            bad.validate().unwrap_err().parameter,
            "update_rotation_eps_rad"
        );
        let old: Termination =
            serde_json::from_str(r#"{"max_iterations": 5, "mean_dist_change_eps_m": 1e-3}"#)
                .unwrap();
        assert_eq!(old.mean_residual_change_eps_m, 1e-3);
    }
}
