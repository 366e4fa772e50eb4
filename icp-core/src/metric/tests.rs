//! The metrics' normal equations against finite differences of their own cost, and their
//! residuals by hand.

use nalgebra::{Isometry2, Matrix2, Point2, UnitComplex, Vector2, Vector3};

use super::*;
use crate::matching::Correspondence;
use crate::registry::BuildContext;
use crate::scan::Return;
use crate::surface::SurfacePoint;
use crate::SensorModel;

/// A few pairs with surfaces, moved off their partners.
struct Fixture {
    pairs: Vec<Correspondence>,
    src: Vec<Return>,
    dst: Vec<Return>,
    moved: Vec<Point2<f64>>,
    dst_points: Vec<Point2<f64>>,
    src_surfaces: Vec<Option<SurfacePoint>>,
    dst_surfaces: Vec<Option<SurfacePoint>>,
    t: Isometry2<f64>,
}

fn ret(p: Point2<f64>) -> Return {
    Return {
        point: p,
        range_m: p.coords.norm(),
        bearing_rad: p.y.atan2(p.x),
    }
}

/// A surface along `angle` whose neighbourhood mean is `mean`.
fn surface(angle: f64, along_m2: f64, mean: Point2<f64>) -> Option<SurfacePoint> {
    let t = Vector2::new(angle.cos(), angle.sin());
    let n = Vector2::new(-t.y, t.x);
    Some(SurfacePoint {
        normal: n,
        covariance: t * t.transpose() * along_m2 + n * n.transpose() * (1e-3 * along_m2),
        mean,
    })
}

fn fixture() -> Fixture {
    let rotation = UnitComplex::new(0.3);
    let t = Isometry2::from_parts(Vector2::new(0.4, -0.2).into(), rotation);
    let n = 12;
    let src: Vec<Return> = (0..n)
        .map(|i| {
            let a = i as f64 * 0.5;
            ret(Point2::new(
                (6.0 + i as f64) * a.cos(),
                (6.0 + i as f64) * a.sin(),
            ))
        })
        .collect();
    let moved: Vec<Point2<f64>> = src.iter().map(|r| t * r.point).collect();
    let dst: Vec<Return> = moved
        .iter()
        .enumerate()
        .map(|(i, m)| ret(m + Vector2::new(0.05 * (i as f64).sin(), 0.07 * (i as f64).cos())))
        .collect();
    Fixture {
        pairs: (0..n)
            .map(|i| Correspondence {
                src: i,
                dst: (i * 5) % n,
                dist_sq: (moved[i] - dst[(i * 5) % n].point).norm_squared(),
            })
            .collect(),
        dst_points: dst.iter().map(|r| r.point).collect(),
        src_surfaces: (0..n)
            .map(|i| {
                surface(
                    0.2 * i as f64,
                    0.1,
                    src[i].point + Vector2::new(-0.01, 0.015),
                )
            })
            .collect(),
        // Means a little off the returns, as a noisy return is off its neighbourhood's line.
        dst_surfaces: (0..n)
            .map(|i| {
                let mean = dst[i].point + Vector2::new(0.01, -0.02 * (i as f64).cos());
                (i != 3)
                    .then(|| surface(1.0 - 0.3 * i as f64, 0.2, mean))
                    .flatten()
            })
            .collect(),
        src,
        dst,
        moved,
        t,
    }
}

impl Fixture {
    fn set(&self) -> PairSet<'_> {
        PairSet {
            pairs: &self.pairs,
            src: &self.src,
            dst: &self.dst,
            src_moved: &self.moved,
            dst_points: &self.dst_points,
            src_surfaces: &self.src_surfaces,
            dst_surfaces: &self.dst_surfaces,
            t_ref_src: self.t,
        }
    }
}

fn metrics() -> Vec<(String, Box<dyn Metric>)> {
    let ctx = BuildContext {
        sensor: SensorModel::sweep(),
    };
    let mut out = Vec::new();
    for kind in METRICS.kinds {
        out.push((
            kind.name().to_owned(),
            METRICS.build(&StageSpec::kind(kind.name()), &ctx).unwrap(),
        ));
    }
    out.push((
        "plane_to_plane+sensor".into(),
        METRICS
            .build(
                &StageSpec::kind("plane_to_plane").with("covariance", "surface_and_sensor"),
                &ctx,
            )
            .unwrap(),
    ));
    out
}

#[test]
fn normal_equations_are_the_derivatives_of_the_cost() {
    let f = fixture();
    let set = f.set();
    let mut dists = Vec::new();
    let mut residuals = Vec::new();
    for (name, metric) in metrics() {
        dists.clear();
        dists.extend(set.pairs.iter().map(|p| p.dist_sq.sqrt()));
        metric.residuals(&set, &dists, &mut residuals);
        let weights: Vec<f64> = residuals
            .iter()
            .enumerate()
            .map(|(i, r)| {
                if r.is_nan() {
                    0.0
                } else {
                    0.5 + 0.1 * i as f64
                }
            })
            .collect();
        let ne = metric.normal_equations(&set, &weights);
        let cost = |d: Vector3<f64>| metric.cost(&set, &weights, &ne.increment(&d));
        assert!(
            (cost(Vector3::zeros()) - ne.cost).abs() < 1e-9 * ne.cost.max(1.0),
            "{name}"
        );
        // The cost is quadratic in δ up to the rotation's curvature: its gradient is 2g, and
        // its Hessian at 0 is 2H plus the rotation's second-order term (checked on x, y).
        let h = 1e-6;
        for k in 0..3 {
            let mut e = Vector3::zeros();
            e[k] = h;
            let slope = (cost(e) - cost(-e)) / (2.0 * h);
            assert!(
                (slope - 2.0 * ne.gradient[k]).abs() < 1e-5 * (1.0 + ne.gradient[k].abs()),
                "{name} gradient {k}: {slope} vs {}",
                2.0 * ne.gradient[k]
            );
        }
        for (i, j) in [(0, 0), (0, 1), (1, 1)] {
            let mut a = Vector3::zeros();
            a[i] = 1e-3;
            let mut b = Vector3::zeros();
            b[j] = 1e-3;
            let second = (cost(a + b) - cost(a - b) - cost(b - a) + cost(-a - b)) / (4e-6);
            assert!(
                (second - 2.0 * ne.hessian[(i, j)]).abs() < 1e-6 * (1.0 + ne.hessian[(i, j)].abs()),
                "{name} hessian {i}{j}: {second} vs {}",
                2.0 * ne.hessian[(i, j)]
            );
        }
        assert!(
            (ne.hessian - ne.hessian.transpose()).norm() <= 1e-12 * ne.hessian.norm(),
            "{name}"
        );
    }
}

#[test]
fn residuals_by_hand_and_unusable_pairs() {
    let f = fixture();
    let set = f.set();
    let dists: Vec<f64> = set.pairs.iter().map(|p| p.dist_sq.sqrt()).collect();
    let mut out = Vec::new();
    PointToPoint::default().residuals(&set, &dists, &mut out);
    assert_eq!(out, dists);
    for (anchor, returns) in [(Anchor::NeighbourhoodMeans, false), (Anchor::Returns, true)] {
        PointToLine {
            anchor,
            ..PointToLine::default()
        }
        .residuals(&set, &dists, &mut out);
        for (i, c) in set.pairs.iter().enumerate() {
            match set.dst_surfaces[c.dst] {
                None => assert!(out[i].is_nan(), "pair {i} has no reference normal"),
                Some(s) => {
                    let (p, q) = if returns {
                        (set.src_moved[c.src], set.dst_points[c.dst])
                    } else {
                        // The source mean moved like its return.
                        let sp = set.src_surfaces[c.src].unwrap();
                        let p = set.t_ref_src * sp.mean;
                        (p, s.mean)
                    };
                    let e = p - q;
                    assert_eq!(out[i], s.normal.dot(&e).abs());
                    if returns {
                        assert!(out[i] <= dists[i] * (1.0 + 1e-12));
                    }
                }
            }
        }
    }
    let gated = PointToLine {
        max_pair_distance_m: Some(0.05),
        ..PointToLine::default()
    };
    gated.residuals(&set, &dists, &mut out);
    for (i, &d) in dists.iter().enumerate() {
        assert_eq!(out[i].is_nan(), d > 0.05 || set.dst_normal(i).is_none());
    }
}

#[test]
fn plane_to_plane_information_is_the_inverse_combined_covariance() {
    // One pair, both surfaces along x: Ω = (C_q + R C_p Rᵀ)⁻¹ by hand at R = I.
    let p = ret(Point2::new(5.0, 1.0));
    let q = ret(Point2::new(5.0, 1.1));
    let (sp, sq) = (surface(0.0, 0.1, p.point), surface(0.0, 0.1, q.point));
    let pairs = [Correspondence {
        src: 0,
        dst: 0,
        dist_sq: 0.01,
    }];
    let set = PairSet {
        pairs: &pairs,
        src: &[p],
        dst: &[q],
        src_moved: &[p.point],
        dst_points: &[q.point],
        src_surfaces: &[sp],
        dst_surfaces: &[sq],
        t_ref_src: Isometry2::identity(),
    };
    let metric = PlaneToPlane {
        params: PlaneToPlaneParams::default(),
        sensor: SensorModel::sweep(),
    };
    let ne = metric.normal_equations(&set, &[1.0]);
    // C = 2 diag(0.1, 1e-4): Ω = diag(5, 5000); e = (0, −0.1): cost 5000 · 0.01 = 50.
    let omega = Matrix2::new(5.0, 0.0, 0.0, 5000.0);
    assert!((ne.cost - 50.0).abs() < 1e-9, "{}", ne.cost);
    assert!((ne.hessian.fixed_view::<2, 2>(0, 0) - omega).norm() < 1e-9);
}
