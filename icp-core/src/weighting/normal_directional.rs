//! Directional weights taken along the reference surface normal: the paper's eq. 9 evaluated in
//! the direction the point-to-line and plane-to-plane residuals measure.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use super::{PairView, PairWeighting};
use crate::registry::{Kind, ParamError, Params, StageKind, StageSpec};
use crate::SensorModel;

/// Parameters of [`NormalDirectional`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(default, deny_unknown_fields)]
pub struct NormalDirectionalParams {
    /// The weight is `σ_n^(−power)`: 1 weighs by the inverse standard deviation like the
    /// paper's eq. 11, 2 by the inverse variance (maximum likelihood for a point-to-line
    /// residual), dimensionless.
    pub power: f64,
}

impl Default for NormalDirectionalParams {
    fn default() -> Self {
        Self { power: 1.0 }
    }
}

impl Params for NormalDirectionalParams {
    fn validate(&self) -> Result<(), ParamError> {
        ParamError::check_positive("power", self.power)
    }
}

/// `w = σ_n^(−power)` with `σ_n² = nᵀ (R Cov_p Rᵀ + Cov_q) n`: the variance of the
/// point-to-line residual from the sensor model, i.e. eq. 9 of each point evaluated along the
/// reference normal `n` (each point's covariance, eq. 8, in its own scan's frame; `R` the
/// current rotation). Where the reference point has no usable normal, each point contributes its
/// variance averaged over all directions, `M²/2` (eq. 5), as [`super::Directional`] does for a
/// pair without a direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NormalDirectional {
    /// The error model of both scans.
    pub sensor: SensorModel,
    /// The exponent on `σ_n`.
    pub power: f64,
}

/// The registered kind.
pub const KIND: Kind<NormalDirectionalParams, dyn PairWeighting> = Kind::new(
    "normal_directional",
    "w = σn^(−power), σn² = nᵀ(R Cov_p Rᵀ + Cov_q)n: eq. 9 of both points along the reference normal (Naus & Marchel 2019, eqs. 8, 9, 11 with the normal of Censi 2008 / Chen & Medioni 1991)",
    |p, ctx| {
        Box::new(NormalDirectional {
            sensor: ctx.sensor,
            power: p.power,
        })
    },
);

impl PairWeighting for NormalDirectional {
    fn spec(&self) -> StageSpec {
        StageSpec::of(KIND.name(), &NormalDirectionalParams { power: self.power })
    }

    /// Without trigonometry: the cosine² between the normal and a point's beam is
    /// `(n · R p)² / r²` for the source point (its beam direction in scan k+1's axes is `R p`)
    /// and `(n · q)² / r²` for the reference point; eq. 9 in the beam frame needs only that.
    #[inline]
    fn weight(&self, pair: &PairView<'_>) -> f64 {
        let (src, dst) = (pair.src, pair.dst);
        let variance = match pair.normal {
            Some(n) => {
                let beam_src = pair.rotation_ref_src * src.point.coords;
                let cos2 = |dot: f64, r: f64| (dot * dot / (r * r)).min(1.0);
                self.sensor
                    .directional_variance_cos2(src.range_m, cos2(n.dot(&beam_src), src.range_m))
                    + self.sensor.directional_variance_cos2(
                        dst.range_m,
                        cos2(n.dot(&dst.point.coords), dst.range_m),
                    )
            }
            None => {
                0.5 * (self.sensor.mean_error_sq(src.range_m)
                    + self.sensor.mean_error_sq(dst.range_m))
            }
        };
        if self.power == 1.0 {
            1.0 / variance.sqrt()
        } else {
            variance.powf(-0.5 * self.power)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::{ret, view};
    use super::*;
    use nalgebra::{UnitComplex, Vector2};

    #[test]
    fn equals_the_matrix_form_of_eq_9_along_the_normal() {
        let sensor = SensorModel {
            sigma_r_const_m: 0.01,
            ..SensorModel::sweep()
        };
        for (i, power) in [(0, 1.0), (1, 2.0), (2, 1.5)] {
            let theta = -0.3 + 0.2 * i as f64;
            let (src, dst) = (ret(9.0, 0.4 + 0.1 * i as f64), ret(11.0, 0.9));
            let n = Vector2::new((0.7f64 + i as f64).cos(), (0.7f64 + i as f64).sin());
            let rot = UnitComplex::new(theta);
            let r = rot.to_rotation_matrix().into_inner();
            let cov = r * sensor.covariance(src.range_m, src.bearing_rad) * r.transpose()
                + sensor.covariance(dst.range_m, dst.bearing_rad);
            let sigma2 = (n.transpose() * cov * n)[(0, 0)];
            let mut v = view(&src, &dst, Some(n));
            v.rotation_ref_src = rot;
            let w = NormalDirectional { sensor, power }.weight(&v);
            let want = sigma2.powf(-0.5 * power);
            assert!((w - want).abs() < 1e-12 * want, "{w} vs {want}");
        }
    }

    #[test]
    fn a_normal_along_the_beams_weighs_by_the_range_error_only() {
        // n along both beams (α = 0): σn² = σ_r(k)² + σ_r(k+1)², by hand.
        let sensor = SensorModel::sweep();
        let (src, dst) = (ret(10.0, 0.0), ret(20.0, 0.0));
        let w = NormalDirectional { sensor, power: 1.0 }.weight(&view(
            &src,
            &dst,
            Some(Vector2::new(-1.0, 0.0)),
        ));
        let hand = 1.0 / (0.04258f64.powi(2) + 0.08516f64.powi(2)).sqrt();
        assert!((w - hand).abs() < 1e-12 * hand);
        // Without a normal: the direction average of each point, M²/2.
        let w = NormalDirectional { sensor, power: 1.0 }.weight(&view(&src, &dst, None));
        let avg = 0.5 * (sensor.mean_error_sq(10.0) + sensor.mean_error_sq(20.0));
        assert!((w - 1.0 / avg.sqrt()).abs() < 1e-12 * w);
    }
}
