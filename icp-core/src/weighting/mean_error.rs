//! Mean-error weights (Naus & Marchel 2019, eqs. 11 and 13): the HM_ICP variant.

use super::{PairView, PairWeighting};
use crate::registry::{Kind, NoParams, StageKind, StageSpec};
use crate::SensorModel;

/// `w = 1 / sqrt(M²(k) + M²(k+1))` with `M² = (σ_α r)² + σ_r²` of each point (eqs. 5, 11, 13).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeanError {
    /// The error model of both scans.
    pub sensor: SensorModel,
}

/// The registered kind.
pub const KIND: Kind<NoParams, dyn PairWeighting> = Kind::new(
    "mean_error",
    "w = 1/sqrt(M²(k) + M²(k+1)), M² the mean position error of each point (Naus & Marchel 2019, eqs. 5, 11, 13: HM_ICP)",
    |_, ctx| Box::new(MeanError { sensor: ctx.sensor }),
);

impl PairWeighting for MeanError {
    fn spec(&self) -> StageSpec {
        StageSpec::kind(KIND.name())
    }

    #[inline]
    fn weight(&self, pair: &PairView<'_>) -> f64 {
        let g = self.sensor.mean_error_sq(pair.src.range_m)
            + self.sensor.mean_error_sq(pair.dst.range_m);
        1.0 / g.sqrt()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scan::Return;
    use nalgebra::{Point2, UnitComplex};

    #[test]
    fn hand_computed_weight() {
        // r = 10 m and 20 m, σ_α = 0.5°, σ_r = 0.004258 r.
        let ret = |r: f64| Return {
            point: Point2::new(r, 0.0),
            range_m: r,
            bearing_rad: 0.0,
        };
        let (a, b) = (ret(10.0), ret(20.0));
        let view = PairView {
            src: &a,
            dst: &b,
            src_moved: a.point,
            rotation_ref_src: UnitComplex::identity(),
            normal: None,
        };
        let s = 0.5f64.to_radians();
        let g = (s * 10.0).powi(2) + 0.04258f64.powi(2) + (s * 20.0).powi(2) + 0.08516f64.powi(2);
        let w = MeanError {
            sensor: SensorModel::sweep(),
        }
        .weight(&view);
        assert!((w - 1.0 / g.sqrt()).abs() < 1e-12 * w);
        assert!((w - 4.6057).abs() < 1e-4, "{w}");
    }
}
