//! Plane-to-plane, 2D generalised ICP (Segal et al. 2009, "Generalized-ICP", RSS): each pair's
//! difference weighed by the inverse of the two points' combined covariance.

use nalgebra::{Isometry2, Matrix2, Matrix2x3, Matrix3, Vector2, Vector3};
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use super::{center, check_gate, turn, within, Metric, NormalEquations};
use crate::pairs::PairSet;
use crate::registry::{Kind, ParamError, Params, StageKind, StageSpec};
use crate::SensorModel;

/// Which covariance each point carries.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum SurfaceCovariance {
    /// The regularised covariance of its surface neighbourhood (generalised ICP's).
    #[default]
    Surface,
    /// That plus the sensor's covariance of the return (Naus & Marchel 2019, eq. 8).
    SurfaceAndSensor,
}

/// Parameters of [`PlaneToPlane`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(default, deny_unknown_fields)]
pub struct PlaneToPlaneParams {
    /// The covariance of each point: surface, or surface_and_sensor.
    pub covariance: SurfaceCovariance,
    /// Pairs farther apart than this are not used, metres; null: no gate.
    pub max_pair_distance_m: Option<f64>,
}

impl Params for PlaneToPlaneParams {
    fn validate(&self) -> Result<(), ParamError> {
        check_gate(self.max_pair_distance_m)
    }
}

/// `e = R p + T − q` weighed by `Ω = (C_q + R C_p Rᵀ)⁻¹`, each `C` the point's surface
/// covariance (in its own scan's frame; see [`crate::surface`]), plus its sensor covariance
/// (eq. 8) with [`SurfaceCovariance::SurfaceAndSensor`]. `Ω` is taken at the current rotation
/// and held during a step. Pairs where either point has no usable surface estimate are not
/// used. The residual (for the robust kernel and the stop rule) is the distance along the
/// reference normal, metres.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlaneToPlane {
    /// The parameters.
    pub params: PlaneToPlaneParams,
    /// The error model of both scans.
    pub sensor: SensorModel,
}

/// The registered kind.
pub const KIND: Kind<PlaneToPlaneParams, dyn Metric> = Kind::new(
    "plane_to_plane",
    "2D generalised ICP: e weighed by (C_q + R C_p Rᵀ)⁻¹ from the surface covariances, optionally plus the sensor's (Segal et al. 2009; Naus & Marchel 2019, eq. 8)",
    |params, ctx| {
        Box::new(PlaneToPlane {
            params,
            sensor: ctx.sensor,
        })
    },
);

impl PlaneToPlane {
    /// `Ω` of pair `i`, when both points have a surface estimate and it is invertible.
    #[inline]
    fn information(&self, set: &PairSet<'_>, i: usize) -> Option<Matrix2<f64>> {
        let c = set.pairs[i];
        let (sp, sq) = (set.src_surfaces[c.src]?, set.dst_surfaces[c.dst]?);
        let r = set.rotation_ref_src.to_rotation_matrix().into_inner();
        let (mut cp, mut cq) = (sp.covariance, sq.covariance);
        if self.params.covariance == SurfaceCovariance::SurfaceAndSensor {
            let (p, q) = (&set.src[c.src], &set.dst[c.dst]);
            cp += self.sensor.covariance(p.range_m, p.bearing_rad);
            cq += self.sensor.covariance(q.range_m, q.bearing_rad);
        }
        (cq + r * cp * r.transpose()).try_inverse()
    }
}

impl Metric for PlaneToPlane {
    fn spec(&self) -> StageSpec {
        StageSpec::of(KIND.name(), &self.params)
    }

    fn needs_source_surfaces(&self) -> bool {
        true
    }

    fn residuals(&self, set: &PairSet<'_>, pair_distance_m: &[f64], out: &mut Vec<f64>) {
        out.clear();
        out.extend(set.pairs.iter().zip(pair_distance_m).map(|(c, &d)| {
            match (set.src_surfaces[c.src], set.dst_surfaces[c.dst]) {
                (Some(_), Some(s)) if within(self.params.max_pair_distance_m, d) => s
                    .normal
                    .dot(&(set.src_moved[c.src] - set.dst_points[c.dst]))
                    .abs(),
                _ => f64::NAN,
            }
        }));
    }

    fn normal_equations(&self, set: &PairSet<'_>, weights: &[f64]) -> NormalEquations {
        let c0 = center(set);
        let (mut h, mut g, mut cost, mut weight_sum) =
            (Matrix3::zeros(), Vector3::zeros(), 0.0, 0.0);
        for (i, (c, &w)) in set.pairs.iter().zip(weights).enumerate() {
            if w <= 0.0 {
                continue;
            }
            let Some(omega) = self.information(set, i) else {
                continue;
            };
            let m = set.src_moved[c.src];
            let e: Vector2<f64> = m - set.dst_points[c.dst];
            let (tx, ty) = turn(&m, &c0);
            let j = Matrix2x3::new(1.0, 0.0, tx, 0.0, 1.0, ty);
            let omega_e = omega * e;
            h += j.transpose() * omega * j * w;
            g += j.transpose() * omega_e * w;
            cost += w * e.dot(&omega_e);
            weight_sum += w;
        }
        NormalEquations {
            center: c0,
            hessian: h,
            gradient: g,
            cost,
            weight_sum,
        }
    }

    fn cost(&self, set: &PairSet<'_>, weights: &[f64], increment: &Isometry2<f64>) -> f64 {
        let mut cost = 0.0;
        for (i, (c, &w)) in set.pairs.iter().zip(weights).enumerate() {
            if w <= 0.0 {
                continue;
            }
            if let Some(omega) = self.information(set, i) {
                let e = increment * set.src_moved[c.src] - set.dst_points[c.dst];
                cost += w * e.dot(&(omega * e));
            }
        }
        cost
    }
}
