//! Inverse-range weights: the worked example of adding a pair-weighting scheme.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use super::{PairView, PairWeighting};
use crate::registry::{Kind, ParamError, Params, StageKind, StageSpec};

/// `w = 1 / (r₀ + (r_k + r_k+1) / 2)`: trusts near returns more than far ones, with no sensor
/// model. The idea behind it is the paper's eq. 5 without the range-independent terms: the
/// across-beam error `σ_α r` grows with range. `r₀` keeps the weight of very near returns
/// bounded.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(default, deny_unknown_fields)]
pub struct InverseRange {
    /// Range added to the mean range before inverting, metres (> 0).
    pub r0_m: f64,
}

impl Default for InverseRange {
    fn default() -> Self {
        Self { r0_m: 1.0 }
    }
}

impl Params for InverseRange {
    fn validate(&self) -> Result<(), ParamError> {
        ParamError::check_positive("r0_m", self.r0_m)
    }
}

/// The registered kind.
pub const KIND: Kind<InverseRange, dyn PairWeighting> = Kind::new(
    "inverse_range",
    "w = 1/(r0 + mean range): near returns trusted more (icp-bench worked example of a new scheme)",
    |p, _| Box::new(p),
);

impl PairWeighting for InverseRange {
    fn spec(&self) -> StageSpec {
        StageSpec::of(KIND.name(), self)
    }

    #[inline]
    fn weight(&self, pair: &PairView<'_>) -> f64 {
        1.0 / (self.r0_m + 0.5 * (pair.src.range_m + pair.dst.range_m))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scan::Return;
    use nalgebra::{Point2, UnitComplex};

    #[test]
    fn hand_computed_weight_and_positivity() {
        let ret = |r: f64| Return {
            point: Point2::new(r, 0.0),
            range_m: r,
            bearing_rad: 0.0,
        };
        let w = InverseRange { r0_m: 1.0 };
        let (a, b) = (ret(10.0), ret(20.0));
        let view = |a: &Return, b: &Return| {
            w.weight(&PairView {
                src: a,
                dst: b,
                src_moved: a.point,
                rotation_ref_src: UnitComplex::identity(),
                normal: None,
            })
        };
        assert_eq!(view(&a, &b), 1.0 / 16.0);
        for (ra, rb) in [(1e-9, 1e-9), (0.5, 40.0), (1e6, 1e6)] {
            let v = view(&ret(ra), &ret(rb));
            assert!(v.is_finite() && v > 0.0);
        }
    }
}
