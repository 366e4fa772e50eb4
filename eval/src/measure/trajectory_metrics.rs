//! Trajectory metrics with evo's semantics (Grupp, `MichaelGrupp/evo`): absolute trajectory
//! error after a rigid SE(2) alignment (`evo_ape tum reference.tum trajectory_X.tum -a`) and
//! relative pose error over pose pairs a number of frames apart or a path length apart
//! (`evo_rpe ... --delta D --delta_unit m`). Pure functions on planar poses: no I/O.
//!
//! The alignment is Umeyama's least-squares rigid fit without scale (Umeyama 1991, eqs. 34–43;
//! evo `core/geometry.py` `umeyama_alignment`), in closed form for the plane: with centred
//! points `x'` (estimate) and `y'` (reference), the rotation angle is
//! `atan2(Σ x' × y', Σ x' · y')` and `t = μ_y − R μ_x`. This is the SVD solution with its
//! reflection guard, written out for 2×2.

use nalgebra::{Isometry2, Point2, Vector2};
use serde::{Deserialize, Serialize};

use icp_core::motion::wrap_deg;

/// evo's statistics of an error array (`core/metrics.py` `PE.get_statistic`): the numbers
/// `evo_ape`/`evo_rpe` print and write to a result's `stats.json`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct EvoStats {
    /// Root mean square.
    pub rmse: f64,
    /// Mean.
    pub mean: f64,
    /// Median (numpy's: the mean of the middle two for an even count).
    pub median: f64,
    /// Population standard deviation (numpy's `std`, n in the denominator).
    pub std: f64,
    /// Smallest value.
    pub min: f64,
    /// Largest value.
    pub max: f64,
    /// Sum of squares.
    pub sse: f64,
}

impl EvoStats {
    /// The statistics of `errors`; `None` when empty or when a value is not finite.
    pub fn of(errors: &[f64]) -> Option<EvoStats> {
        if errors.is_empty() || errors.iter().any(|e| !e.is_finite()) {
            return None;
        }
        let n = errors.len() as f64;
        let sse: f64 = errors.iter().map(|e| e * e).sum();
        let mean = errors.iter().sum::<f64>() / n;
        let var = errors.iter().map(|e| (e - mean).powi(2)).sum::<f64>() / n;
        let mut sorted = errors.to_vec();
        sorted.sort_by(f64::total_cmp);
        let mid = sorted.len() / 2;
        let median = if sorted.len() % 2 == 1 {
            sorted[mid]
        } else {
            0.5 * (sorted[mid - 1] + sorted[mid])
        };
        Some(EvoStats {
            rmse: (sse / n).sqrt(),
            mean,
            median,
            std: var.sqrt(),
            min: sorted[0],
            max: sorted[sorted.len() - 1],
            sse,
        })
    }
}

/// The rigid transform `T` minimising `Σ ‖y_i − T x_i‖²` (Umeyama without scale, in the
/// plane). `None` when the points are fewer than two or all coincide (nothing fixes the
/// rotation), or when the two lists differ in length.
pub fn umeyama_se2(x: &[Point2<f64>], y: &[Point2<f64>]) -> Option<Isometry2<f64>> {
    if x.len() != y.len() || x.len() < 2 {
        return None;
    }
    let n = x.len() as f64;
    let mean = |p: &[Point2<f64>]| p.iter().map(|p| p.coords).sum::<Vector2<f64>>() / n;
    let (mx, my) = (mean(x), mean(y));
    let (mut dot, mut cross) = (0.0, 0.0);
    for (a, b) in x.iter().zip(y) {
        let (a, b) = (a.coords - mx, b.coords - my);
        dot += a.dot(&b);
        cross += a.x * b.y - a.y * b.x;
    }
    // Both sums vanish exactly when the cross-covariance is zero (rank < 1).
    let scale = x
        .iter()
        .chain(y)
        .map(|p| p.coords.norm())
        .fold(1.0, f64::max);
    if dot.hypot(cross) <= f64::EPSILON * scale * scale {
        return None;
    }
    let rotation = nalgebra::UnitComplex::new(cross.atan2(dot));
    let t = my - rotation * mx;
    Some(Isometry2::from_parts(t.into(), rotation))
}

/// Whether a reflection of the plane fits `x` onto `y` better than every rotation (the
/// rotation fit scores `hypot(Σ x'·y', Σ x'×y')`, the reflection fit the same with `x'`
/// mirrored). evo aligns in SE(3): on planar poses a reflection of the plane is a proper 3D
/// rotation (a half turn about an in-plane axis, z = 0 kept), so where one fits better
/// `evo_ape -a` mirrors the estimate and its ATE is not the SE(2) one given here (a badly
/// failed trajectory, e.g. HD_ICP from the identity on CARMEN aces).
pub fn reflection_fits_better(x: &[Point2<f64>], y: &[Point2<f64>]) -> bool {
    if x.len() != y.len() || x.is_empty() {
        return false;
    }
    let n = x.len() as f64;
    let mean = |p: &[Point2<f64>]| p.iter().map(|p| p.coords).sum::<Vector2<f64>>() / n;
    let (mx, my) = (mean(x), mean(y));
    let score = |mirror: f64| {
        let (mut dot, mut cross) = (0.0, 0.0);
        for (a, b) in x.iter().zip(y) {
            let (a, b) = (a.coords - mx, b.coords - my);
            let a = Vector2::new(a.x, mirror * a.y);
            dot += a.dot(&b);
            cross += a.x * b.y - a.y * b.x;
        }
        dot.hypot(cross)
    };
    score(-1.0) > score(1.0)
}

/// Per-pose or per-pair errors, translation (m) and rotation angle (degrees, `|θ|`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PoseErrors {
    /// `‖t(E_i)‖`, m.
    pub trans_m: Vec<f64>,
    /// `|angle(E_i)|`, degrees.
    pub rot_deg: Vec<f64>,
    /// The index in the pose lists each error belongs to (the second pose of an RPE pair).
    pub at: Vec<usize>,
}

/// The positions of `poses`.
pub fn positions(poses: &[Isometry2<f64>]) -> Vec<Point2<f64>> {
    poses.iter().map(|p| p.translation.vector.into()).collect()
}

/// The absolute trajectory error: `estimate` aligned to `reference` by [`umeyama_se2`] on
/// the positions, then per pose `E_i = reference_i⁻¹ · (T · estimate_i)` (evo `APE`,
/// `translation_part` and `rotation_angle_deg`). The poses are already associated (same
/// length, pose i with pose i). `None` when the alignment is not defined.
pub fn ate(
    estimate: &[Isometry2<f64>],
    reference: &[Isometry2<f64>],
) -> Option<(Isometry2<f64>, PoseErrors)> {
    let align = umeyama_se2(&positions(estimate), &positions(reference))?;
    let mut errors = PoseErrors::default();
    for (i, (e, r)) in estimate.iter().zip(reference).enumerate() {
        let err = r.inverse() * (align * e);
        errors.trans_m.push(err.translation.vector.norm());
        errors.rot_deg.push(abs_angle_deg(&err));
        errors.at.push(i);
    }
    Some((align, errors))
}

/// Consecutive pose pairs `(i, i + delta)` (evo `filter_pairs_by_index`, not all pairs).
pub fn pairs_by_frames(poses: usize, delta: usize) -> Vec<(usize, usize)> {
    if delta == 0 {
        return Vec::new();
    }
    (0..poses.saturating_sub(delta))
        .step_by(delta)
        .map(|i| (i, i + delta))
        .collect()
}

/// Consecutive segments of `poses` at least `delta_m` of path long (evo
/// `filter_pairs_by_path` with `all_pairs = False`): from pose 0, the path length is summed
/// pose to pose and a segment ends at the first pose where it reaches `delta_m`, the next
/// starting there. evo takes the path of the *estimated* trajectory unless
/// `--pairs_from_reference`; pass the poses whose path you mean.
pub fn pairs_by_path(poses: &[Isometry2<f64>], delta_m: f64) -> Vec<(usize, usize)> {
    let Some(first) = poses.first() else {
        return Vec::new();
    };
    let mut ids = vec![0];
    let mut previous = first;
    let mut path_m = 0.0;
    for (i, pose) in poses.iter().enumerate().skip(1) {
        path_m += (pose.translation.vector - previous.translation.vector).norm();
        previous = pose;
        if path_m >= delta_m {
            ids.push(i);
            path_m = 0.0;
        }
    }
    ids.windows(2).map(|w| (w[0], w[1])).collect()
}

/// The relative pose error over `pairs`: per pair `(i, j)`,
/// `E = (Q_i⁻¹ Q_j)⁻¹ (P_i⁻¹ P_j)` with `Q` the reference and `P` the estimate (evo `RPE`,
/// eq. of Sturm et al. 2012 as in `rpe_base`). Pairs out of range are skipped.
pub fn rpe(
    estimate: &[Isometry2<f64>],
    reference: &[Isometry2<f64>],
    pairs: &[(usize, usize)],
) -> PoseErrors {
    let mut errors = PoseErrors::default();
    for &(i, j) in pairs {
        let (Some(pi), Some(pj), Some(qi), Some(qj)) = (
            estimate.get(i),
            estimate.get(j),
            reference.get(i),
            reference.get(j),
        ) else {
            continue;
        };
        let err = (qi.inverse() * qj).inverse() * (pi.inverse() * pj);
        errors.trans_m.push(err.translation.vector.norm());
        errors.rot_deg.push(abs_angle_deg(&err));
        errors.at.push(j);
    }
    errors
}

fn abs_angle_deg(pose: &Isometry2<f64>) -> f64 {
    wrap_deg(pose.rotation.angle().to_degrees()).abs()
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Matrix2, Vector2};
    use rand::{Rng, SeedableRng};

    fn pose(x: f64, y: f64, deg: f64) -> Isometry2<f64> {
        Isometry2::new(Vector2::new(x, y), deg.to_radians())
    }

    /// Umeyama by SVD of the 2×2 cross-covariance with the reflection guard (eqs. 38–43): an
    /// oracle written the general way, against the closed form.
    fn umeyama_svd(x: &[Point2<f64>], y: &[Point2<f64>]) -> Isometry2<f64> {
        let n = x.len() as f64;
        let mx = x.iter().map(|p| p.coords).sum::<Vector2<f64>>() / n;
        let my = y.iter().map(|p| p.coords).sum::<Vector2<f64>>() / n;
        let mut cov = Matrix2::zeros();
        for (a, b) in x.iter().zip(y) {
            cov += (b.coords - my) * (a.coords - mx).transpose() / n;
        }
        let svd = cov.svd(true, true);
        let (u, v_t) = (svd.u.unwrap(), svd.v_t.unwrap());
        let mut s = Matrix2::identity();
        if u.determinant() * v_t.determinant() < 0.0 {
            s[(1, 1)] = -1.0;
        }
        let r = u * s * v_t;
        let angle = r[(1, 0)].atan2(r[(0, 0)]);
        let rotation = nalgebra::UnitComplex::new(angle);
        Isometry2::from_parts((my - rotation * mx).into(), rotation)
    }

    #[test]
    fn umeyama_recovers_an_exact_rigid_transform() {
        let truth = pose(3.0, -2.0, 37.0);
        let x: Vec<Point2<f64>> = [(0.0, 0.0), (4.0, 0.0), (4.0, 3.0), (1.0, 5.0)]
            .iter()
            .map(|&(a, b)| Point2::new(a, b))
            .collect();
        let y: Vec<Point2<f64>> = x.iter().map(|p| truth * p).collect();
        let got = umeyama_se2(&x, &y).unwrap();
        assert!((got.translation.vector - truth.translation.vector).norm() < 1e-12);
        assert!((got.rotation.angle() - truth.rotation.angle()).abs() < 1e-12);
    }

    #[test]
    fn umeyama_matches_the_svd_solution_on_noisy_points() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(15);
        for _ in 0..200 {
            let n = rng.random_range(2..30);
            let truth = pose(
                rng.random_range(-50.0..50.0),
                rng.random_range(-50.0..50.0),
                rng.random_range(-180.0..180.0),
            );
            let x: Vec<Point2<f64>> = (0..n)
                .map(|_| Point2::new(rng.random_range(-20.0..20.0), rng.random_range(-20.0..20.0)))
                .collect();
            let y: Vec<Point2<f64>> = x
                .iter()
                .map(|p| {
                    truth * p
                        + Vector2::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0))
                })
                .collect();
            let got = umeyama_se2(&x, &y).unwrap();
            let oracle = umeyama_svd(&x, &y);
            assert!((got.translation.vector - oracle.translation.vector).norm() < 1e-9);
            assert!(
                wrap_deg((got.rotation.angle() - oracle.rotation.angle()).to_degrees()).abs()
                    < 1e-9
            );
        }
    }

    #[test]
    fn a_mirrored_track_is_fitted_better_by_a_reflection() {
        let x: Vec<Point2<f64>> = [(0.0, 0.0), (4.0, 0.0), (4.0, 3.0), (1.0, 5.0)]
            .iter()
            .map(|&(a, b)| Point2::new(a, b))
            .collect();
        let turned = pose(3.0, -2.0, 37.0);
        let rotated: Vec<Point2<f64>> = x.iter().map(|p| turned * p).collect();
        let mirrored: Vec<Point2<f64>> = rotated.iter().map(|p| Point2::new(p.x, -p.y)).collect();
        assert!(!reflection_fits_better(&x, &rotated));
        assert!(reflection_fits_better(&x, &mirrored));
    }

    #[test]
    fn umeyama_refuses_coincident_points() {
        let p = [Point2::new(1.0, 1.0); 3];
        assert!(umeyama_se2(&p, &p).is_none());
        assert!(umeyama_se2(&p[..1], &p[..1]).is_none());
        assert!(umeyama_se2(&p[..2], &p[..1]).is_none());
    }

    /// A 10 m square walked counter-clockwise, one pose every 5 m, heading along the path.
    fn square() -> Vec<Isometry2<f64>> {
        vec![
            pose(0.0, 0.0, 0.0),
            pose(5.0, 0.0, 0.0),
            pose(10.0, 0.0, 90.0),
            pose(10.0, 5.0, 90.0),
            pose(10.0, 10.0, 180.0),
            pose(5.0, 10.0, 180.0),
            pose(0.0, 10.0, 270.0),
            pose(0.0, 5.0, 270.0),
        ]
    }

    #[test]
    fn ate_of_a_rigidly_moved_square_is_zero_and_one_perturbed_pose_is_by_hand() {
        let reference = square();
        let offset = pose(100.0, -40.0, 30.0);
        let mut estimate: Vec<Isometry2<f64>> = reference.iter().map(|p| offset * p).collect();
        let (_, e) = ate(&estimate, &reference).unwrap();
        assert!(e.trans_m.iter().all(|&d| d < 1e-9), "{e:?}");
        assert!(e.rot_deg.iter().all(|&d| d < 1e-9), "{e:?}");
        // Move pose 2 by d along the direction from the centroid (5, 5) to it, and turn it 2°.
        // With x' = y' + δ (centred), the fit's Σ x'×y' gains Σ δ_i × y'_i = d·dir × y'_2 = 0:
        // the rotation stays, and the fit only shifts by the centroid's move d·dir/n. So the
        // errors are d(1 − 1/n) at pose 2 and d/n at the n − 1 others; 2° and 0° in rotation.
        let dir = (reference[2].translation.vector - Vector2::new(5.0, 5.0)).normalize();
        let d = 0.8;
        let moved = Isometry2::new(dir * d, 0.0) * reference[2];
        estimate[2] = offset * moved * pose(0.0, 0.0, 2.0);
        let (_, e) = ate(&estimate, &reference).unwrap();
        let n = 8.0;
        for (i, &t) in e.trans_m.iter().enumerate() {
            let want = if i == 2 { d * (1.0 - 1.0 / n) } else { d / n };
            assert!((t - want).abs() < 1e-9, "pose {i}: {t} vs {want}");
        }
        for (i, &r) in e.rot_deg.iter().enumerate() {
            let want = if i == 2 { 2.0 } else { 0.0 };
            assert!((r - want).abs() < 1e-9, "pose {i}: {r} vs {want}");
        }
        let stats = EvoStats::of(&e.trans_m).unwrap();
        let rmse = ((7.0 * (d / n).powi(2) + (d * (1.0 - 1.0 / n)).powi(2)) / n).sqrt();
        assert!((stats.rmse - rmse).abs() < 1e-12);
        assert!((stats.max - 0.7).abs() < 1e-12 && (stats.min - 0.1).abs() < 1e-12);
        assert!((stats.median - 0.1).abs() < 1e-12);
    }

    #[test]
    fn rpe_per_pair_and_by_path_by_hand() {
        let reference = square();
        let offset = pose(-3.0, 7.0, -75.0);
        let mut estimate: Vec<Isometry2<f64>> = reference.iter().map(|p| offset * p).collect();
        // Pose 3 is 0.5 m off along its own heading (the reference's +y there) and 1° turned.
        estimate[3] = offset * reference[3] * pose(0.5, 0.0, 1.0);
        let pairs = pairs_by_frames(estimate.len(), 1);
        assert_eq!(pairs, (0..7).map(|i| (i, i + 1)).collect::<Vec<_>>());
        let e = rpe(&estimate, &reference, &pairs);
        // Pair 2→3: E = Q_rel⁻¹ Q_rel D = D = (0.5 m, 1°). Pair 3→4: E = Q⁻¹ D⁻¹ Q with
        // Q = Q3⁻¹Q4 = ((5, 0), 90°); the translation of Q⁻¹ X Q is R_Qᵀ(t_X + R_X t_Q − t_Q),
        // of norm ‖t_X + R_X t_Q − t_Q‖ with X = D⁻¹ = ((−0.5 cos 1°, 0.5 sin 1°), −1°).
        let c = 1f64.to_radians();
        let inv = Vector2::new(-0.5 * c.cos(), 0.5 * c.sin());
        let step = Vector2::new(5.0, 0.0);
        let rotated = Vector2::new(step.x * c.cos(), -step.x * c.sin());
        let want_34 = (inv + rotated - step).norm();
        let want = [0.0, 0.0, 0.5, want_34, 0.0, 0.0, 0.0];
        for (k, (&t, w)) in e.trans_m.iter().zip(want).enumerate() {
            assert!((t - w).abs() < 1e-9, "pair {k}: {t} vs {w}");
        }
        let want_rot = [0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0];
        for (k, (&r, w)) in e.rot_deg.iter().zip(want_rot).enumerate() {
            assert!((r - w).abs() < 1e-9, "pair {k}: {r} vs {w}");
        }
        // Every 10 m of the reference's path: 0→2, 2→4, 4→6 (6→7 is only 5 m).
        let poses_ref_path = pairs_by_path(&reference, 10.0);
        assert_eq!(poses_ref_path, [(0, 2), (2, 4), (4, 6)]);
        let by_path = rpe(&estimate, &reference, &poses_ref_path);
        // Over 2→4 pose 3's error cancels: both ends are exact.
        assert!(by_path.trans_m.iter().all(|&t| t < 1e-9), "{by_path:?}");
        assert_eq!(by_path.at, [2, 4, 6]);
        // A segment ends where the path first reaches delta: 7.5 m needs two 5 m steps.
        assert_eq!(pairs_by_path(&reference, 7.5), [(0, 2), (2, 4), (4, 6)]);
        assert_eq!(pairs_by_path(&reference, 5.0).len(), 7);
        assert!(pairs_by_path(&reference, 100.0).is_empty());
        assert_eq!(pairs_by_frames(8, 3), [(0, 3), (3, 6)]);
    }

    #[test]
    fn evo_statistics_by_hand() {
        let s = EvoStats::of(&[1.0, 2.0, 3.0, 4.0]).unwrap();
        assert_eq!(s.mean, 2.5);
        assert_eq!(s.median, 2.5);
        assert_eq!(s.sse, 30.0);
        assert!((s.rmse - 7.5f64.sqrt()).abs() < 1e-15);
        assert!((s.std - 1.25f64.sqrt()).abs() < 1e-15);
        assert_eq!((s.min, s.max), (1.0, 4.0));
        assert_eq!(EvoStats::of(&[3.0, 1.0, 2.0]).unwrap().median, 2.0);
        assert!(EvoStats::of(&[]).is_none());
        assert!(EvoStats::of(&[1.0, f64::NAN]).is_none());
    }
}
