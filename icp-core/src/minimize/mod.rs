//! Minimisation, Algorithm 1 step 5: the rigid increment that lowers the metric's cost.

use nalgebra::Isometry2;

use crate::metric::Metric;
use crate::pairs::PairSet;
use crate::registry::{Family, StageSpec};
use crate::IcpError;

mod gauss_newton;
mod weighted_kabsch;

pub use gauss_newton::GaussNewton;
pub use weighted_kabsch::{kabsch, weighted_moments, WeightedKabsch, WeightedMoments};

/// Every registered minimiser, one line each.
pub static MINIMIZERS: Family<dyn Minimizer> = Family {
    name: "minimizer",
    summary: "Alg. 1 step 5: the increment minimising the metric's weighted cost (eq. 14)",
    kinds: &[&weighted_kabsch::KIND, &gauss_newton::KIND],
};

/// Solves for the rigid increment `t_ref_moved` that minimises (or lowers) the weighted cost
/// of `metric` over the pairs.
pub trait Minimizer: Send + Sync {
    /// What this stage is, as configuration data.
    fn spec(&self) -> StageSpec {
        StageSpec::unregistered::<Self>()
    }

    /// `Err` saying why this minimiser cannot minimise `metric`'s cost.
    fn check(&self, metric: &dyn Metric) -> Result<(), String> {
        let _ = metric;
        Ok(())
    }

    /// The increment, applied on the left of the current estimate: `weights[i]` is the final
    /// weight of `set.pairs[i]`.
    fn solve(
        &self,
        set: &PairSet<'_>,
        weights: &[f64],
        metric: &dyn Metric,
    ) -> Result<Isometry2<f64>, IcpError>;
}
