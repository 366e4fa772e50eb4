//! Gauss-Newton on SE(2), with Levenberg–Marquardt damping where a step raises the cost.

use nalgebra::Isometry2;
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use super::Minimizer;
use crate::metric::Metric;
use crate::pairs::PairSet;
use crate::registry::{Kind, ParamError, Params, StageKind, StageSpec};
use crate::IcpError;

/// One Gauss-Newton step of the metric's cost per matching: `δ = −H⁻¹ g` from its normal
/// equations (3 × 3, solved by Cholesky), applied as a turn `δθ` about the moved points'
/// centroid and a shift `(δx, δy)` (see [`crate::metric::NormalEquations`]). When that step
/// raises the cost over the same pairs (or `H` is not positive definite), the step is damped
/// as Levenberg–Marquardt does, `(H + λ diag H) δ = −g`, with `λ` from `lm_lambda_start`
/// growing tenfold per try; after `lm_max_tries` tries without a lower cost the increment is
/// the identity (and the update rule of [`crate::Termination`] stops the iteration).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(default, deny_unknown_fields)]
pub struct GaussNewton {
    /// The first damping factor tried after a rejected step, dimensionless (> 0).
    pub lm_lambda_start: f64,
    /// Damped tries after the undamped step, at most.
    pub lm_max_tries: usize,
}

impl Default for GaussNewton {
    fn default() -> Self {
        Self {
            lm_lambda_start: 1e-4,
            lm_max_tries: 8,
        }
    }
}

impl Params for GaussNewton {
    fn validate(&self) -> Result<(), ParamError> {
        ParamError::check_positive("lm_lambda_start", self.lm_lambda_start)
    }
}

/// The registered kind.
pub const KIND: Kind<GaussNewton, dyn Minimizer> = Kind::new(
    "gauss_newton",
    "one Gauss-Newton step on SE(2) per matching, damped Levenberg–Marquardt style where it raises the cost (any metric)",
    |p, _| Box::new(p),
);

impl Minimizer for GaussNewton {
    fn spec(&self) -> StageSpec {
        StageSpec::of(KIND.name(), self)
    }

    fn solve(
        &self,
        set: &PairSet<'_>,
        weights: &[f64],
        metric: &dyn Metric,
    ) -> Result<Isometry2<f64>, IcpError> {
        let ne = metric.normal_equations(set, weights);
        if !(ne.weight_sum > 0.0 && ne.weight_sum.is_finite()) {
            return Err(IcpError::DegenerateWeights { sum: ne.weight_sum });
        }
        let mut lambda = 0.0;
        for _ in 0..=self.lm_max_tries {
            let mut h = ne.hessian;
            for k in 0..3 {
                h[(k, k)] += lambda * ne.hessian[(k, k)];
            }
            if let Some(cholesky) = h.cholesky() {
                let delta = -cholesky.solve(&ne.gradient);
                if !delta.iter().all(|v| v.is_finite()) {
                    return Err(IcpError::NonFiniteTransform);
                }
                let step = ne.increment(&delta);
                if metric.cost(set, weights, &step) <= ne.cost {
                    return Ok(step);
                }
            }
            lambda = if lambda == 0.0 {
                self.lm_lambda_start
            } else {
                lambda * 10.0
            };
        }
        Ok(Isometry2::identity())
    }
}
