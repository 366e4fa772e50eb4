//! Gauss-Newton's optimum, over fixed pairs, equals a brute-force minimisation of the same
//! cost: on small random problems, for every metric, no increment found by a derivative-free
//! pattern search lowers the cost at the pose where Gauss-Newton stops.

use icp_core::matching::Correspondence;
use icp_core::metric::{Metric, METRICS};
use icp_core::minimize::{GaussNewton, Minimizer};
use icp_core::pairs::PairSet;
use icp_core::registry::{BuildContext, StageSpec};
use icp_core::scan::Return;
use icp_core::surface::SurfacePoint;
use icp_core::SensorModel;
use nalgebra::{Isometry2, Point2, Vector2};
use proptest::prelude::*;

/// A small problem: returns with surfaces, their reference partners moved by a rigid motion
/// and disturbed, pairs fixed one to one, and weights.
struct Problem {
    src: Vec<Return>,
    dst: Vec<Return>,
    dst_points: Vec<Point2<f64>>,
    src_surfaces: Vec<Option<SurfacePoint>>,
    dst_surfaces: Vec<Option<SurfacePoint>>,
    pairs: Vec<Correspondence>,
    weights: Vec<f64>,
}

fn ret(p: Point2<f64>) -> Return {
    Return {
        point: p,
        range_m: p.coords.norm(),
        bearing_rad: p.y.atan2(p.x),
    }
}

fn surface(angle: f64, along_m2: f64, mean: Point2<f64>) -> SurfacePoint {
    let t = Vector2::new(angle.cos(), angle.sin());
    let n = Vector2::new(-t.y, t.x);
    SurfacePoint {
        normal: n,
        covariance: t * t.transpose() * along_m2 + n * n.transpose() * (0.01 * along_m2),
        mean,
    }
}

/// `points`: (x, y, surface angle, disturbance along x, along y, weight).
fn problem(points: &[(f64, f64, f64, f64, f64, f64)], truth: Isometry2<f64>) -> Problem {
    let src: Vec<Return> = points
        .iter()
        .map(|&(x, y, ..)| ret(Point2::new(x, y)))
        .collect();
    let dst: Vec<Return> = points
        .iter()
        .zip(&src)
        .map(|(&(_, _, _, dx, dy, _), r)| ret(truth * r.point + Vector2::new(dx, dy)))
        .collect();
    let src_surfaces = points
        .iter()
        .zip(&src)
        .map(|(&(_, _, a, dx, _, _), r)| {
            Some(surface(a, 0.05, r.point + Vector2::new(0.3 * dx, 0.0)))
        })
        .collect();
    let dst_surfaces = points
        .iter()
        .zip(&dst)
        .map(|(&(_, _, a, _, dy, _), r)| {
            Some(surface(
                a + truth.rotation.angle(),
                0.08,
                r.point + Vector2::new(0.0, 0.3 * dy),
            ))
        })
        .collect();
    Problem {
        dst_points: dst.iter().map(|r| r.point).collect(),
        pairs: (0..points.len())
            .map(|i| Correspondence {
                src: i,
                dst: i,
                dist_sq: 0.0,
            })
            .collect(),
        weights: points.iter().map(|p| p.5).collect(),
        src,
        dst,
        src_surfaces,
        dst_surfaces,
    }
}

impl Problem {
    /// The pairs seen at the estimate `t`.
    fn set<'a>(&'a self, moved: &'a [Point2<f64>], t: &Isometry2<f64>) -> PairSet<'a> {
        PairSet {
            pairs: &self.pairs,
            src: &self.src,
            dst: &self.dst,
            src_moved: moved,
            dst_points: &self.dst_points,
            src_surfaces: &self.src_surfaces,
            dst_surfaces: &self.dst_surfaces,
            t_ref_src: *t,
        }
    }

    fn moved(&self, t: &Isometry2<f64>) -> Vec<Point2<f64>> {
        self.src.iter().map(|r| t * r.point).collect()
    }
}

/// Gauss-Newton steps over the fixed pairs until the step is negligible.
fn gauss_newton(p: &Problem, metric: &dyn Metric) -> Isometry2<f64> {
    let mut t = Isometry2::identity();
    for _ in 0..200 {
        let moved = p.moved(&t);
        let step = GaussNewton::default()
            .solve(&p.set(&moved, &t), &p.weights, metric)
            .unwrap();
        t = step * t;
        if step.translation.vector.norm() < 1e-13 && step.rotation.angle().abs() < 1e-14 {
            break;
        }
    }
    t
}

/// The increment `(x, y, θ)` about the origin that a pattern search finds lowest for `cost`,
/// from zero: steps of 0.2 m and 0.02 rad, halved whenever no neighbour of the 26 improves, down
/// to 1e-10.
fn pattern_search(cost: impl Fn(Isometry2<f64>) -> f64) -> (Vector2<f64>, f64, f64) {
    let (mut x, mut y, mut th) = (0.0, 0.0, 0.0);
    let mut best = cost(Isometry2::identity());
    let (mut step_m, mut step_rad) = (0.2, 0.02);
    while step_m > 1e-10 {
        let mut improved = false;
        for dx in [-1.0, 0.0, 1.0] {
            for dy in [-1.0, 0.0, 1.0] {
                for dt in [-1.0, 0.0, 1.0] {
                    let c = (x + dx * step_m, y + dy * step_m, th + dt * step_rad);
                    let v = cost(Isometry2::new(Vector2::new(c.0, c.1), c.2));
                    if v < best {
                        (best, x, y, th, improved) = (v, c.0, c.1, c.2, true);
                    }
                }
            }
        }
        if !improved {
            step_m *= 0.5;
            step_rad *= 0.5;
        }
    }
    (Vector2::new(x, y), th, best)
}

fn metrics() -> Vec<(String, Box<dyn Metric>)> {
    let ctx = BuildContext {
        sensor: SensorModel::sweep(),
    };
    let mut out = Vec::new();
    for anchor in ["neighbourhood_means", "returns"] {
        for spec in [
            StageSpec::kind("point_to_line").with("anchor", anchor),
            StageSpec::kind("plane_to_plane").with("anchor", anchor),
            StageSpec::kind("plane_to_plane")
                .with("anchor", anchor)
                .with("covariance", "surface_and_sensor"),
        ] {
            out.push((spec.to_string(), METRICS.build(&spec, &ctx).unwrap()));
        }
    }
    let p2p = StageSpec::kind("point_to_point");
    out.push((p2p.to_string(), METRICS.build(&p2p, &ctx).unwrap()));
    out
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]

    #[test]
    fn gauss_newton_stops_where_a_brute_force_search_finds_nothing_lower(
        points in prop::collection::vec(
            (-20.0..20.0f64, -20.0..20.0f64, 0.0..3.1f64, -0.05..0.05f64, -0.05..0.05f64, 0.2..2.0f64),
            5..14,
        ),
        (tx, ty, theta) in (-1.0..1.0f64, -1.0..1.0f64, -0.3..0.3f64),
    ) {
        // Two points (almost) on top of each other make an ill-conditioned problem, whose
        // optimum Gauss-Newton reaches only to the conditioning's precision (a shrunk case of
        // coincident points missed the 1e-12 relative cost check by 2.9e-12): the property is
        // stated for well-posed problems; degenerate ones are the conditioning flag's.
        let apart = points.iter().enumerate().all(|(i, a)| {
            points[..i].iter().all(|b| (a.0 - b.0).hypot(a.1 - b.1) > 0.5)
        });
        prop_assume!(apart);
        let p = problem(&points, Isometry2::new(Vector2::new(tx, ty), theta));
        for (name, metric) in metrics() {
            let t = gauss_newton(&p, metric.as_ref());
            // The same cost as Gauss-Newton's last step sees (Ω held at its rotation), as a
            // function of an increment about the origin.
            let moved = p.moved(&t);
            let set = p.set(&moved, &t);
            let cost = |inc: Isometry2<f64>| metric.cost(&set, &p.weights, &inc);
            let (shift, turn, lowest) = pattern_search(cost);
            let at_gn = metric.cost(&set, &p.weights, &Isometry2::identity());
            // The cost's own rounding: each residual is a difference of coordinates up to
            // ~40 m, so it carries about ε·40 m of error, and the cost Σ w e² about
            // 2·ε·40·Σ w|e| ≤ 2·ε·40·sqrt(Σw · cost) (Cauchy–Schwarz); a search that gains
            // less than that has found nothing (seen: 2e-19 at a cost of 1.2e-7).
            let weight_sum: f64 = p.weights.iter().sum();
            let rounding = 8.0 * f64::EPSILON * 40.0 * (weight_sum * at_gn).sqrt();
            prop_assert!(
                lowest >= at_gn - 1e-12 * at_gn - rounding,
                "{name}: the search lowered the cost from {at_gn} to {lowest}"
            );
            prop_assert!(
                shift.norm() < 1e-6 && turn.abs() < 1e-7,
                "{name}: the search's minimum is {shift:?}, {turn} rad from Gauss-Newton's"
            );
        }
    }
}

/// A check of the check: from a pose away from the optimum, the search does find lower costs.
#[test]
fn the_search_finds_a_displaced_minimum() {
    let points: Vec<_> = (0..8)
        .map(|i| {
            let a = i as f64 * 0.8;
            (8.0 * a.cos(), 6.0 * a.sin(), a + 1.0, 0.01, -0.02, 1.0)
        })
        .collect();
    let p = problem(&points, Isometry2::new(Vector2::new(0.4, -0.2), 0.1));
    let (_, metric) = &metrics()[1];
    let t = Isometry2::identity();
    let moved = p.moved(&t);
    let set = p.set(&moved, &t);
    let (shift, _, lowest) = pattern_search(|inc| metric.cost(&set, &p.weights, &inc));
    assert!(lowest < metric.cost(&set, &p.weights, &Isometry2::identity()));
    assert!(shift.norm() > 0.1, "{shift:?}");
}
