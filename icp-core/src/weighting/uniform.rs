//! Uniform weights: the unweighted point-to-point ICP of K_ICP and H_ICP.

use super::{PairView, PairWeighting};

/// Every pair weighs 1 (K_ICP and H_ICP in the paper's Table 1).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Uniform;

impl PairWeighting for Uniform {
    #[inline]
    fn weight(&self, _pair: &PairView<'_>) -> f64 {
        1.0
    }
}
