//! Uniform weights: the unweighted point-to-point ICP of K_ICP and H_ICP.

use super::{PairView, PairWeighting};
use crate::registry::{Kind, NoParams, StageKind, StageSpec};

/// Every pair weighs 1 (K_ICP and H_ICP in the paper's Table 1).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Uniform;

/// The registered kind.
pub const KIND: Kind<NoParams, dyn PairWeighting> = Kind::new(
    "uniform",
    "every pair weighs 1 (K_ICP and H_ICP, Naus & Marchel 2019, Table 1)",
    |_, _| Box::new(Uniform),
);

impl PairWeighting for Uniform {
    fn spec(&self) -> StageSpec {
        StageSpec::kind(KIND.name())
    }

    #[inline]
    fn weight(&self, _pair: &PairView<'_>) -> f64 {
        1.0
    }
}
