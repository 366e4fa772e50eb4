//! Plane-to-plane, 2D generalised ICP (Segal et al. 2009, "Generalized-ICP", RSS): each pair's
//! difference weighed by the inverse of the two points' combined covariance.

use nalgebra::{Isometry2, Matrix2, Matrix2x3, Vector2};
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use super::{
    center, check_gate, difference_noise, e_jacobian, sandwich_over, turn, weighted, within,
    Anchor, Ends, Metric, NormalEquations,
};
use crate::covariance::Sandwich;
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
    /// Where the ends of a pair are taken: neighbourhood_means or returns.
    pub anchor: Anchor,
    /// Pairs farther apart than this are not used, metres; null: no gate.
    pub max_pair_distance_m: Option<f64>,
}

impl Params for PlaneToPlaneParams {
    fn validate(&self) -> Result<(), ParamError> {
        check_gate(self.max_pair_distance_m)
    }
}

/// `e = R p + T − q` weighed by `Ω = (C_q + R C_p Rᵀ)⁻¹`, `p` and `q` the pair's ends (by
/// default the means of the two returns' neighbourhoods: see [`Anchor`]), each `C` the point's surface
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
    /// The ends of pair `i` and its `Ω`, when both returns have a surface estimate and `Ω`
    /// exists.
    #[inline]
    fn terms(&self, set: &PairSet<'_>, i: usize) -> Option<(Ends, Matrix2<f64>)> {
        let c = set.pairs[i];
        let sp = set.src_surfaces[c.src]?;
        let ends = self.params.anchor.ends(set, i)?;
        let r = set.t_ref_src.rotation.to_rotation_matrix().into_inner();
        let (mut cp, mut cq) = (sp.covariance, ends.surface.covariance);
        if self.params.covariance == SurfaceCovariance::SurfaceAndSensor {
            let (rp, rq) = (&set.src[c.src], &set.dst[c.dst]);
            cp += self.sensor.covariance_at(&rp.point, rp.range_m);
            cq += self.sensor.covariance_at(&rq.point, rq.range_m);
        }
        Some((ends, (cq + r * cp * r.transpose()).try_inverse()?))
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
        out.extend(pair_distance_m.iter().enumerate().map(|(i, &d)| {
            let c = set.pairs[i];
            match (set.src_surfaces[c.src], self.params.anchor.ends(set, i)) {
                (Some(_), Some(ends)) if within(self.params.max_pair_distance_m, d) => {
                    ends.normal_residual().abs()
                }
                _ => f64::NAN,
            }
        }));
    }

    fn normal_equations(&self, set: &PairSet<'_>, weights: &[f64]) -> NormalEquations {
        let mut eq = NormalEquations::about(center(set));
        for (i, w) in weighted(weights) {
            let Some((ends, omega)) = self.terms(set, i) else {
                continue;
            };
            let e: Vector2<f64> = ends.source - ends.reference;
            let (tx, ty) = turn(&ends.source, &eq.center);
            let j = Matrix2x3::new(1.0, 0.0, tx, 0.0, 1.0, ty);
            let omega_e = omega * e;
            eq.hessian += j.transpose() * omega * j * w;
            eq.gradient += j.transpose() * omega_e * w;
            eq.cost += w * e.dot(&omega_e);
            eq.weight_sum += w;
        }
        eq
    }

    fn cost(&self, set: &PairSet<'_>, weights: &[f64], increment: &Isometry2<f64>) -> f64 {
        let mut cost = 0.0;
        for (i, w) in weighted(weights) {
            if let Some((ends, omega)) = self.terms(set, i) {
                let e = increment * ends.source - ends.reference;
                cost += w * e.dot(&(omega * e));
            }
        }
        cost
    }

    fn sandwich(
        &self,
        set: &PairSet<'_>,
        weights: &[f64],
        sensor: &SensorModel,
    ) -> Option<Sandwich> {
        Some(sandwich_over(set, weights, |sums, i, w| {
            if let Some((ends, omega)) = self.terms(set, i) {
                let jac = e_jacobian(&ends.source, &sums.center);
                let noise = difference_noise(set, i, sensor);
                let e = ends.source - ends.reference;
                sums.add(&ends.source, &jac, &omega, &noise, &e, w);
            }
        }))
    }
}
