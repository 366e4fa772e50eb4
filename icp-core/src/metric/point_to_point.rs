//! Point-to-point: the paper's metric (Naus & Marchel 2019, eq. 14).

use nalgebra::{Isometry2, Vector3};
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use super::{center, check_gate, turn, weighted, within, Metric, NormalEquations};
use crate::pairs::PairSet;
use crate::registry::{Kind, ParamError, Params, StageKind, StageSpec};

/// `e = R p + T − q`, `Ω = I`: the squared distance between the pair's points (eq. 14). The
/// residual is the pair distance.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(default, deny_unknown_fields)]
pub struct PointToPoint {
    /// Pairs farther apart than this are not used, metres; null: every pair is used (the
    /// paper's variants).
    pub max_pair_distance_m: Option<f64>,
}

impl Params for PointToPoint {
    fn validate(&self) -> Result<(), ParamError> {
        check_gate(self.max_pair_distance_m)
    }
}

/// The registered kind.
pub const KIND: Kind<PointToPoint, dyn Metric> = Kind::new(
    "point_to_point",
    "the distance between the matched points (Naus & Marchel 2019, eq. 14; Besl & McKay 1992)",
    |p, _| Box::new(p),
);

impl Metric for PointToPoint {
    fn spec(&self) -> StageSpec {
        StageSpec::of(KIND.name(), self)
    }

    fn default_minimizer(&self) -> StageSpec {
        StageSpec::kind("weighted_kabsch")
    }

    fn isotropic(&self) -> bool {
        true
    }

    fn residuals(&self, _set: &PairSet<'_>, pair_distance_m: &[f64], out: &mut Vec<f64>) {
        out.clear();
        if self.max_pair_distance_m.is_none() {
            // No gate: every pair is used, its residual its distance.
            out.extend_from_slice(pair_distance_m);
            return;
        }
        out.extend(pair_distance_m.iter().map(|&d| {
            if within(self.max_pair_distance_m, d) {
                d
            } else {
                f64::NAN
            }
        }));
    }

    fn normal_equations(&self, set: &PairSet<'_>, weights: &[f64]) -> NormalEquations {
        let mut eq = NormalEquations::about(center(set));
        for (i, w) in weighted(weights) {
            let c = set.pairs[i];
            let m = set.src_moved[c.src];
            let e = m - set.dst_points[c.dst];
            let (tx, ty) = turn(&m, &eq.center);
            // Two rows of J: [1, 0, tx] and [0, 1, ty].
            for (j, r) in [
                (Vector3::new(1.0, 0.0, tx), e.x),
                (Vector3::new(0.0, 1.0, ty), e.y),
            ] {
                eq.hessian += j * j.transpose() * w;
                eq.gradient += j * (w * r);
            }
            eq.cost += w * e.norm_squared();
            eq.weight_sum += w;
        }
        eq
    }

    fn cost(&self, set: &PairSet<'_>, weights: &[f64], increment: &Isometry2<f64>) -> f64 {
        weighted(weights)
            .map(|(i, w)| {
                let c = set.pairs[i];
                w * (increment * set.src_moved[c.src] - set.dst_points[c.dst]).norm_squared()
            })
            .sum()
    }
}
