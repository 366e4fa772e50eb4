//! The convergence rule, Algorithm 1 step 6.

use serde::{Deserialize, Serialize};

use crate::IcpError;

/// Stops the iteration when the mean pair distance changes by less than
/// `mean_dist_change_eps_m` between two iterations (the paper's loop condition, printed
/// inverted, corrected here), or after `max_iterations` minimisation steps.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Termination {
    /// Largest number of minimisation steps.
    pub max_iterations: usize,
    /// Convergence threshold on the change of the mean pair distance, metres.
    pub mean_dist_change_eps_m: f64,
}

impl Default for Termination {
    fn default() -> Self {
        Self {
            max_iterations: 100,
            mean_dist_change_eps_m: 1e-6,
        }
    }
}

impl Termination {
    /// Checks that at least one iteration is allowed and the threshold is finite and >= 0.
    pub fn validate(&self) -> Result<(), IcpError> {
        if self.max_iterations == 0 {
            return Err(IcpError::InvalidParameter {
                name: "max_iterations",
                value: 0.0,
                reason: "at least one iteration is needed",
            });
        }
        if !self.mean_dist_change_eps_m.is_finite() || self.mean_dist_change_eps_m < 0.0 {
            return Err(IcpError::InvalidParameter {
                name: "mean_dist_change_eps_m",
                value: self.mean_dist_change_eps_m,
                reason: "must be finite and non-negative",
            });
        }
        Ok(())
    }

    /// True when the change from `previous_m` to `current_m` is below the threshold.
    pub fn converged(&self, previous_m: f64, current_m: f64) -> bool {
        (previous_m - current_m).abs() < self.mean_dist_change_eps_m
    }
}

/// Why the iteration stopped. Reaching the iteration limit is an outcome, not an error.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StopReason {
    /// The mean pair distance settled.
    Converged,
    /// `max_iterations` steps were taken without settling.
    MaxIterations,
}
