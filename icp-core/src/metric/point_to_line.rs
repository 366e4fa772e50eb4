//! Point-to-line: the distance from the moved source point to the reference surface's tangent
//! line (Chen & Medioni 1991, point-to-plane; Censi 2008, PLICP, in 2D).

use nalgebra::{Isometry2, Vector3};
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use super::{
    center, check_gate, normal_noise, sandwich_over, turn, weighted, within, Anchor, Metric,
    NormalEquations,
};
use crate::covariance::Sandwich;
use crate::pairs::PairSet;
use crate::registry::{Kind, ParamError, Params, StageKind, StageSpec};
use crate::SensorModel;

/// `r = nᵀ (R p + T − q)`, `Ω = n nᵀ`, with `n` the reference surface normal at the matched
/// return, and `p`, `q` the pair's ends: by default the means of the two returns'
/// neighbourhoods (see [`Anchor`] and [`crate::surface`]). Pairs whose reference return has no
/// usable normal are not used (and counted). The residual is `|r|`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(default, deny_unknown_fields)]
pub struct PointToLine {
    /// Pairs farther apart than this are not used, metres; null: no gate.
    pub max_pair_distance_m: Option<f64>,
    /// Where the ends of a pair are taken: neighbourhood_means or returns.
    pub anchor: Anchor,
}

impl Params for PointToLine {
    fn validate(&self) -> Result<(), ParamError> {
        check_gate(self.max_pair_distance_m)
    }
}

/// The registered kind.
pub const KIND: Kind<PointToLine, dyn Metric> = Kind::new(
    "point_to_line",
    "the distance along the reference surface normal (Chen & Medioni 1991; Censi 2008)",
    |p, _| Box::new(p),
);

impl Metric for PointToLine {
    fn spec(&self) -> StageSpec {
        StageSpec::of(KIND.name(), self)
    }

    fn needs_source_surfaces(&self) -> bool {
        self.anchor.needs_source_surfaces()
    }

    fn residuals(&self, set: &PairSet<'_>, pair_distance_m: &[f64], out: &mut Vec<f64>) {
        out.clear();
        out.extend(pair_distance_m.iter().enumerate().map(
            |(i, &d)| match self.anchor.ends(set, i) {
                Some(ends) if within(self.max_pair_distance_m, d) => ends.normal_residual().abs(),
                _ => f64::NAN,
            },
        ));
    }

    fn normal_equations(&self, set: &PairSet<'_>, weights: &[f64]) -> NormalEquations {
        let mut eq = NormalEquations::about(center(set));
        for (i, w) in weighted(weights) {
            let Some(ends) = self.anchor.ends(set, i) else {
                continue;
            };
            let (n, r) = (ends.surface.normal, ends.normal_residual());
            let (tx, ty) = turn(&ends.source, &eq.center);
            let j = Vector3::new(n.x, n.y, n.x * tx + n.y * ty);
            eq.hessian += j * j.transpose() * w;
            eq.gradient += j * (w * r);
            eq.cost += w * r * r;
            eq.weight_sum += w;
        }
        eq
    }

    fn cost(&self, set: &PairSet<'_>, weights: &[f64], increment: &Isometry2<f64>) -> f64 {
        let mut cost = 0.0;
        for (i, w) in weighted(weights) {
            if let Some(ends) = self.anchor.ends(set, i) {
                let r = ends
                    .surface
                    .normal
                    .dot(&(increment * ends.source - ends.reference));
                cost += w * r * r;
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
            if let Some(ends) = self.anchor.ends(set, i) {
                let n = ends.surface.normal;
                let (tx, ty) = turn(&ends.source, &sums.center);
                let j = Vector3::new(n.x, n.y, n.x * tx + n.y * ty);
                let r = ends.normal_residual();
                sums.add_scalar(&ends.source, &j, normal_noise(set, i, &n, sensor), r, w);
            }
        }))
    }
}
