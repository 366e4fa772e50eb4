//! The poses of a scan's neighbours in the sequence, chained from the registrations of
//! consecutive scans, with their first-order covariances.

use nalgebra::{Isometry2, Matrix3, Vector2};

/// One registration of scan i onto scan i+1: `t_next_this` and its covariance over
/// `(tx m, ty m, θ rad)`.
pub type Step = (Isometry2<f64>, Matrix3<f64>);

/// `t_j_k` for every `j` within `lag` of `k` (`j ≠ k`, nearest first on each side), each with
/// its covariance, chained through `steps[i]` (scan `i` onto `i + 1`; `None`: not trusted).
/// A neighbour whose chain crosses a missing step is left out. Returns `(j, t_j_k, Σ)`.
pub fn neighbour_poses(
    steps: &[Option<Step>],
    k: usize,
    lag: usize,
) -> Vec<(usize, Isometry2<f64>, Matrix3<f64>)> {
    let mut out = Vec::with_capacity(2 * lag);
    // Forward: t_{j}_k = step(j−1) · t_{j−1}_k.
    let mut pose = (Isometry2::identity(), Matrix3::zeros());
    for j in k + 1..=k + lag {
        let Some(Some(step)) = steps.get(j - 1) else {
            break;
        };
        pose = compose(step, &pose);
        out.push((j, pose.0, pose.1));
    }
    // Backward: t_{j}_k = t_{j}_{j+1} · t_{j+1}_k, t_{j}_{j+1} = step(j)⁻¹.
    let mut pose = (Isometry2::identity(), Matrix3::zeros());
    for j in (k.saturating_sub(lag)..k).rev() {
        let Some(Some(step)) = steps.get(j) else {
            break;
        };
        pose = compose(&inverse(step), &pose);
        out.push((j, pose.0, pose.1));
    }
    out
}

/// `b · a` with its covariance, `a` and `b` independent: a left perturbation of `a`'s
/// translation turns with `b`, one of `b`'s rotation swings `a`'s translation.
fn compose(b: &Step, a: &Step) -> Step {
    let (tb, cb) = b;
    let (ta, ca) = a;
    let rb = tb.rotation.to_rotation_matrix().into_inner();
    let swung = tb.rotation * ta.translation.vector;
    let mut ja = Matrix3::identity();
    ja.fixed_view_mut::<2, 2>(0, 0).copy_from(&rb);
    let mut jb = Matrix3::identity();
    jb.fixed_view_mut::<2, 1>(0, 2)
        .copy_from(&Vector2::new(-swung.y, swung.x));
    (tb * ta, ja * ca * ja.transpose() + jb * cb * jb.transpose())
}

/// `t⁻¹` with its covariance.
fn inverse(step: &Step) -> Step {
    let (t, c) = step;
    let inv = t.inverse();
    // t⁻¹ = (q, −θ), q = −Rᵀ p: ∂q/∂p = −Rᵀ, ∂q/∂θ = J(Rᵀ p) = J(−q), J(v) = (−v_y, v_x).
    let rt = inv.rotation.to_rotation_matrix().into_inner();
    let q = inv.translation.vector;
    let mut j = Matrix3::zeros();
    j.fixed_view_mut::<2, 2>(0, 0).copy_from(&(-rt));
    j.fixed_view_mut::<2, 1>(0, 2)
        .copy_from(&Vector2::new(q.y, -q.x));
    j[(2, 2)] = -1.0;
    (inv, j * c * j.transpose())
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;
    use rand_distr::StandardNormal;

    fn vec3(t: &Isometry2<f64>) -> nalgebra::Vector3<f64> {
        nalgebra::Vector3::new(t.translation.x, t.translation.y, t.rotation.angle())
    }

    /// The chained covariances against a Monte-Carlo of the chain itself.
    #[test]
    fn chained_covariances_match_monte_carlo() {
        let steps: Vec<Option<Step>> = vec![
            Some((
                Isometry2::new(Vector2::new(1.0, 0.2), 0.3),
                Matrix3::from_diagonal(&nalgebra::Vector3::new(1e-4, 4e-4, 1e-5)),
            )),
            Some((
                Isometry2::new(Vector2::new(0.8, -0.1), -0.2),
                Matrix3::from_diagonal(&nalgebra::Vector3::new(2e-4, 1e-4, 3e-5)),
            )),
        ];
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let mut draw = |s: &Step| {
            let d = s.1.map(f64::sqrt);
            let n = |rng: &mut ChaCha8Rng| -> f64 { rng.sample(StandardNormal) };
            let e = nalgebra::Vector3::new(
                d[(0, 0)] * n(&mut rng),
                d[(1, 1)] * n(&mut rng),
                d[(2, 2)] * n(&mut rng),
            );
            // The covariance is over the parameters (tx, ty, θ) themselves.
            Isometry2::new(
                s.0.translation.vector + Vector2::new(e.x, e.y),
                s.0.rotation.angle() + e.z,
            )
        };
        for (k, j) in [(0usize, 2usize), (2, 0), (1, 0)] {
            let (_, mean, cov) = neighbour_poses(&steps, k, 2)
                .into_iter()
                .find(|n| n.0 == j)
                .unwrap();
            let n = 40_000;
            let mut acc = Matrix3::zeros();
            for _ in 0..n {
                let (a, b) = (
                    draw(steps[0].as_ref().unwrap()),
                    draw(steps[1].as_ref().unwrap()),
                );
                let t = match (k, j) {
                    (0, 2) => b * a,
                    (2, 0) => (b * a).inverse(),
                    _ => a.inverse(),
                };
                let mut e = vec3(&t) - vec3(&mean);
                e.z = (e.z + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU)
                    - std::f64::consts::PI;
                acc += e * e.transpose();
            }
            let mc = acc / n as f64;
            for i in 0..3 {
                let rel = (mc[(i, i)] - cov[(i, i)]).abs() / cov[(i, i)];
                assert!(
                    rel < 0.05,
                    "({k}→{j}) variance {i}: {} vs {}",
                    mc[(i, i)],
                    cov[(i, i)]
                );
            }
        }
        // A missing step cuts the chain.
        let cut = vec![steps[0], None];
        assert_eq!(neighbour_poses(&cut, 0, 2).len(), 1);
        assert_eq!(neighbour_poses(&cut, 2, 2).len(), 0);
    }
}
