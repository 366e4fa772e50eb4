//! The weighted SVD (Kabsch) solution of eq. 14, in closed form.

use nalgebra::{Isometry2, Matrix2, Point2, Translation2, UnitComplex, Vector2};

use super::Minimizer;
use crate::matching::Correspondence;
use crate::metric::Metric;
use crate::pairs::PairSet;
use crate::registry::{Kind, NoParams, StageKind, StageSpec};
use crate::IcpError;

/// The registered kind.
pub const KIND: Kind<NoParams, dyn Minimizer> = Kind::new(
    "weighted_kabsch",
    "closed-form weighted SVD of the point-to-point cost, with the reflection guard (Naus & Marchel 2019, eqs. 15–20)",
    |_, _| Box::new(WeightedKabsch),
);

/// Weighted Kabsch (Naus & Marchel 2019, eqs. 15–20; the printed eqs. 16, 19 and 20 have
/// index and direction slips, this is the standard solution of eq. 14): weighted centroids
/// `m_p`, `m_q` (eq. 15); `C = Σ w (p − m_p)(q − m_q)ᵀ / Σ w`; the paper's `C = U Σ Vᵀ`,
/// `R = V diag(1, det(V Uᵀ)) Uᵀ` (the reflection guard); `T = m_q − R m_p`.
///
/// In 2D that SVD solution has a closed form, `θ = atan2(C₀₁ − C₁₀, C₀₀ + C₁₁)`, used here:
/// no iteration, and two identical scans give exactly zero motion. The tests hold it against
/// nalgebra's SVD with the reflection guard and the solution written from the point sums.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct WeightedKabsch;

/// Weighted centroids and cross-covariance of the pairs (eqs. 15, 17, 18).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WeightedMoments {
    /// Weighted centroid of the moved source points, `m_p`.
    pub m_p: Vector2<f64>,
    /// Weighted centroid of the reference points, `m_q`.
    pub m_q: Vector2<f64>,
    /// `C = Σ w (p − m_p)(q − m_q)ᵀ / Σ w`.
    pub cross_cov: Matrix2<f64>,
    /// `Σ w`.
    pub weight_sum: f64,
}

/// The weighted moments of the pairs; checks every weight.
pub fn weighted_moments(
    src: &[Point2<f64>],
    dst: &[Point2<f64>],
    pairs: &[Correspondence],
    weights: &[f64],
) -> Result<WeightedMoments, IcpError> {
    if weights.len() != pairs.len() {
        return Err(IcpError::LengthMismatch {
            what: "weights",
            expected: pairs.len(),
            got: weights.len(),
        });
    }
    // Written out coordinate by coordinate, each sum in pair order with the operations of
    // the vector forms (`sp += p * w`, `c += (p − m_p)(q − m_q)ᵀ w`): the same numbers.
    let mut w_sum = 0.0;
    let (mut sp_x, mut sp_y, mut sq_x, mut sq_y) = (0.0, 0.0, 0.0, 0.0);
    // Every weight must be finite and not negative. Checked at the end: a negative one makes
    // the smallest negative, an infinite or NaN one makes the sum so (and a sum can also
    // overflow: then the weights are searched for nothing).
    let mut w_min = f64::INFINITY;
    for (pair, &w) in pairs.iter().zip(weights) {
        w_min = w_min.min(w);
        let (p, q) = (src[pair.src], dst[pair.dst]);
        w_sum += w;
        sp_x += p.x * w;
        sp_y += p.y * w;
        sq_x += q.x * w;
        sq_y += q.y * w;
    }
    if w_min < 0.0 || !w_sum.is_finite() {
        if let Some((i, &w)) = weights
            .iter()
            .enumerate()
            .find(|(_, w)| !w.is_finite() || **w < 0.0)
        {
            return Err(IcpError::InvalidWeight { pair: i, value: w });
        }
    }
    if !(w_sum > 0.0 && w_sum.is_finite()) {
        return Err(IcpError::DegenerateWeights { sum: w_sum });
    }
    let (m_p, m_q) = (
        Vector2::new(sp_x, sp_y) / w_sum,
        Vector2::new(sq_x, sq_y) / w_sum,
    ); // eq. 15
    let (mut c00, mut c01, mut c10, mut c11) = (0.0, 0.0, 0.0, 0.0);
    for (pair, &w) in pairs.iter().zip(weights) {
        let (p, q) = (src[pair.src], dst[pair.dst]);
        let (ax, ay) = (p.x - m_p.x, p.y - m_p.y);
        let (bx, by) = (q.x - m_q.x, q.y - m_q.y);
        c00 += ax * bx * w;
        c01 += ax * by * w;
        c10 += ay * bx * w;
        c11 += ay * by * w;
    }
    let c = Matrix2::new(c00, c01, c10, c11);
    Ok(WeightedMoments {
        m_p,
        m_q,
        cross_cov: c / w_sum,
        weight_sum: w_sum,
    })
}

impl Minimizer for WeightedKabsch {
    fn spec(&self) -> StageSpec {
        StageSpec::kind(KIND.name())
    }

    fn check(&self, metric: &dyn Metric) -> Result<(), String> {
        if metric.isotropic() {
            Ok(())
        } else {
            Err(format!(
                "minimizer weighted_kabsch solves the point-to-point cost only; metric {} needs gauss_newton",
                metric.spec().kind
            ))
        }
    }

    fn solve(
        &self,
        set: &PairSet<'_>,
        weights: &[f64],
        _metric: &dyn Metric,
    ) -> Result<Isometry2<f64>, IcpError> {
        kabsch(set.src_moved, set.dst_points, set.pairs, weights)
    }
}

/// The increment `t_ref_moved` minimising `Σ w_i ‖R p_i + T − q_i‖²` over `pairs`, with
/// `src[pair.src]` the moved source points and `dst[pair.dst]` the reference points.
pub fn kabsch(
    src: &[Point2<f64>],
    dst: &[Point2<f64>],
    pairs: &[Correspondence],
    weights: &[f64],
) -> Result<Isometry2<f64>, IcpError> {
    let WeightedMoments {
        m_p,
        m_q,
        cross_cov: c,
        ..
    } = weighted_moments(src, dst, pairs, weights)?;
    // tr(R C) = cos θ (C00 + C11) + sin θ (C01 − C10) is largest at this θ: the proper
    // rotation of the SVD solution with the reflection guard (eqs. 18–20).
    let theta = (c[(0, 1)] - c[(1, 0)]).atan2(c[(0, 0)] + c[(1, 1)]);
    let rotation = UnitComplex::new(theta);
    let t = m_q - rotation * m_p; // eq. 20 (T = m_q − R m_p)
    if !(t.x.is_finite() && t.y.is_finite() && theta.is_finite()) {
        return Err(IcpError::NonFiniteTransform);
    }
    Ok(Isometry2::from_parts(Translation2::from(t), rotation))
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn identity_pairs(n: usize) -> Vec<Correspondence> {
        (0..n)
            .map(|i| Correspondence {
                src: i,
                dst: i,
                dist_sq: 0.0,
            })
            .collect()
    }

    /// nalgebra's SVD of the cross-covariance with the reflection guard: the paper's recipe,
    /// an oracle for the closed form.
    fn nalgebra_svd_rotation(c: &Matrix2<f64>) -> f64 {
        let svd = c.svd(true, true);
        let (u, v) = (svd.u.unwrap(), svd.v_t.unwrap().transpose());
        let guard = Matrix2::new(1.0, 0.0, 0.0, (v * u.transpose()).determinant().signum());
        let r = v * guard * u.transpose();
        r[(1, 0)].atan2(r[(0, 0)])
    }

    /// The 2D solution written from the point sums: θ = atan2(Σw (p×q), Σw (p·q)).
    fn closed_form(src: &[Point2<f64>], dst: &[Point2<f64>], w: &[f64]) -> f64 {
        let WeightedMoments { m_p, m_q, .. } =
            weighted_moments(src, dst, &identity_pairs(src.len()), w).unwrap();
        let (mut cross, mut dot) = (0.0, 0.0);
        for ((p, q), &w) in src.iter().zip(dst).zip(w) {
            let (p, q) = (p.coords - m_p, q.coords - m_q);
            cross += w * (p.x * q.y - p.y * q.x);
            dot += w * (p.x * q.x + p.y * q.y);
        }
        cross.atan2(dot)
    }

    proptest! {
        #[test]
        fn recovers_a_known_isometry_and_agrees_with_oracles(
            pts in prop::collection::vec((-30.0..30.0f64, -30.0..30.0f64, 0.1..10.0f64), 3..60),
            theta in -3.1..3.1f64,
            tx in -5.0..5.0f64,
            ty in -5.0..5.0f64,
            noise in prop::collection::vec((-0.05..0.05f64, -0.05..0.05f64), 60),
        ) {
            let t = Isometry2::new(Vector2::new(tx, ty), theta);
            let src: Vec<_> = pts.iter().map(|&(x, y, _)| Point2::new(x, y)).collect();
            let w: Vec<_> = pts.iter().map(|&(_, _, w)| w).collect();
            prop_assume!(crate::scan::check_geometry(src.iter(), crate::error::ScanRole::Source).is_ok());
            let pairs = identity_pairs(src.len());
            // Exact data: the transform itself.
            let dst: Vec<_> = src.iter().map(|p| t * p).collect();
            let est = kabsch(&src, &dst, &pairs, &w).unwrap();
            prop_assert!((est.translation.vector - t.translation.vector).norm() < 1e-9);
            prop_assert!((est.rotation.angle() - t.rotation.angle()).abs() < 1e-10);
            // Noisy data: the closed form, the SVD and the solution from the point sums agree on
            // the least-squares optimum.
            let noisy: Vec<_> = dst.iter().zip(&noise).map(|(q, &(a, b))| q + Vector2::new(a, b)).collect();
            let est = kabsch(&src, &noisy, &pairs, &w).unwrap();
            let c = weighted_moments(&src, &noisy, &pairs, &w).unwrap().cross_cov;
            let wrap = |a: f64| (a + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI;
            prop_assert!(wrap(est.rotation.angle() - closed_form(&src, &noisy, &w)).abs() < 1e-9);
            prop_assert!(wrap(est.rotation.angle() - nalgebra_svd_rotation(&c)).abs() < 1e-9);
        }
    }

    #[test]
    fn reflection_guard_returns_a_rotation() {
        // dst is src mirrored about the x axis: the unguarded SVD would return a reflection.
        let src = [
            Point2::new(1.0, 0.5),
            Point2::new(-2.0, 1.0),
            Point2::new(0.5, -3.0),
            Point2::new(3.0, 2.0),
        ];
        let dst: Vec<_> = src.iter().map(|p| Point2::new(p.x, -p.y)).collect();
        let w = [1.0; 4];
        let est = kabsch(&src, &dst, &identity_pairs(4), &w).unwrap();
        let r = est.rotation.to_rotation_matrix().into_inner();
        assert!((r.determinant() - 1.0).abs() < 1e-12);
        let WeightedMoments {
            m_p,
            m_q,
            cross_cov: c,
            ..
        } = weighted_moments(&src, &dst, &identity_pairs(4), &w).unwrap();
        assert!(
            c.determinant() < 0.0,
            "the test needs a reflection-type cross-covariance"
        );
        assert!((est.rotation.angle() - closed_form(&src, &dst, &w)).abs() < 1e-9);
        assert!((est * Point2::from(m_p) - Point2::from(m_q)).norm() < 1e-12);
    }

    #[test]
    fn identical_point_sets_give_exactly_the_identity() {
        let src: Vec<_> = (0..50)
            .map(|i| Point2::new((i as f64 * 0.7).sin() * 20.0, (i as f64 * 1.3).cos() * 15.0))
            .collect();
        let w: Vec<f64> = (0..50).map(|i| 0.5 + (i % 7) as f64).collect();
        let est = kabsch(&src, &src, &identity_pairs(50), &w).unwrap();
        assert_eq!(est, Isometry2::identity());
    }

    #[test]
    fn bad_weights_are_errors() {
        let src = [
            Point2::new(0.0, 0.0),
            Point2::new(1.0, 0.0),
            Point2::new(0.0, 1.0),
        ];
        let p = identity_pairs(3);
        assert_eq!(
            kabsch(&src, &src, &p, &[0.0; 3]),
            Err(IcpError::DegenerateWeights { sum: 0.0 })
        );
        assert!(matches!(
            kabsch(&src, &src, &p, &[1.0, f64::NAN, 1.0]),
            Err(IcpError::InvalidWeight { pair: 1, .. })
        ));
        assert!(matches!(
            kabsch(&src, &src, &p, &[1.0]),
            Err(IcpError::LengthMismatch { .. })
        ));
    }
}
