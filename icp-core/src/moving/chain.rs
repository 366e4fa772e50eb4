//! The poses of a scan's neighbours in the sequence, chained from the registrations of
//! consecutive scans, and across the steps those leave untrusted by registrations that skip
//! them (bridges), with their first-order covariances. Steps predicted from the trusted ones
//! on either side ([`super::predicted`]) come to the chain as trusted steps.

use std::collections::BTreeMap;

use nalgebra::{Isometry2, Matrix3, Vector2};

/// One registration of scan i onto scan i+1: `t_next_this` and its covariance over
/// `(tx m, ty m, θ rad)`.
pub type Step = (Isometry2<f64>, Matrix3<f64>);

/// Registrations over steps the chain does not trust: `bridges[&i] = (c, step)` registers scan
/// `i` onto scan `c > i + 1`, where the step from `i` is not trusted, skipping the scans
/// between.
pub type Bridges = BTreeMap<usize, (usize, Step)>;

/// `t_j_k` for every `j` within `lag` of `k` (`j ≠ k`, nearest first on each side), each with
/// its covariance, chained through `steps[i]` (scan `i` onto `i + 1`; `None`: not trusted)
/// and `bridges`: going forward, a bridge where the step is not trusted; going back, a bridge
/// wherever one ends, the scan just before its end placed by its own step, if trusted, as a
/// leaf. The other scans a bridge skips are not placed from beyond it. A neighbour whose chain
/// crosses an untrusted step without a bridge is left out. Returns `(j, t_j_k, Σ)`.
pub fn neighbour_poses(
    steps: &[Option<Step>],
    bridges: &Bridges,
    k: usize,
    lag: usize,
) -> Vec<(usize, Isometry2<f64>, Matrix3<f64>)> {
    let mut out = Vec::with_capacity(2 * lag);
    // Forward: t_{j}_k = step(i → j) · t_{i}_k, through a bridge where the step from i is
    // not trusted.
    let (mut pose, mut i) = ((Isometry2::identity(), Matrix3::zeros()), k);
    loop {
        let (j, step) = match steps.get(i) {
            Some(Some(step)) => (i + 1, step),
            _ => match bridges.get(&i) {
                Some((to, bridge)) => (*to, bridge),
                None => break,
            },
        };
        if j > k + lag {
            break;
        }
        pose = compose(step, &pose);
        out.push((j, pose.0, pose.1));
        i = j;
    }
    // Backward: t_{j}_k = step(j → i)⁻¹ · t_{i}_k. A bridge that ends at i reaches past the
    // scans it skips; the scan just before i is still placed by its own step, as a leaf.
    let (mut pose, mut i) = ((Isometry2::identity(), Matrix3::zeros()), k);
    loop {
        let bridge = bridges.iter().find(|(_, (c, _))| *c == i);
        let consecutive = i.checked_sub(1).and_then(|h| steps.get(h)?.as_ref());
        let (j, step) = match (bridge, consecutive) {
            (Some((&from, (_, bridge))), leaf) => {
                if let Some(step) = leaf.filter(|_| i - 1 + lag >= k) {
                    let placed = compose(&inverse(step), &pose);
                    out.push((i - 1, placed.0, placed.1));
                }
                (from, bridge)
            }
            (None, Some(step)) => (i - 1, step),
            (None, None) => break,
        };
        if j + lag < k {
            break;
        }
        pose = compose(&inverse(step), &pose);
        out.push((j, pose.0, pose.1));
        i = j;
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

    /// A bridge carries the chain over the untrusted steps it spans, both ways, skipping the
    /// scans between; the lag still bounds how far the chain reaches.
    #[test]
    fn bridges_span_untrusted_steps() {
        let step = |x: f64, th: f64| (Isometry2::new(Vector2::new(x, 0.1), th), Matrix3::zeros());
        let (s0, s2, s3, b) = (
            step(1.0, 0.1),
            step(1.1, 0.02),
            step(0.9, -0.05),
            step(2.1, 0.2),
        );
        // Step 1 is not trusted; the bridge registers scan 1 onto scan 3, skipping scan 2.
        let steps = vec![Some(s0), None, Some(s2), Some(s3)];
        let bridges = Bridges::from([(1, (3, b))]);
        let placed = |k, lag| -> Vec<(usize, Isometry2<f64>)> {
            neighbour_poses(&steps, &bridges, k, lag)
                .into_iter()
                .map(|(j, t, _)| (j, t))
                .collect()
        };
        let check = |got: Vec<(usize, Isometry2<f64>)>, expected: &[(usize, Isometry2<f64>)]| {
            assert_eq!(
                got.iter().map(|n| n.0).collect::<Vec<_>>(),
                expected.iter().map(|n| n.0).collect::<Vec<_>>()
            );
            for ((j, t), (_, e)) in got.iter().zip(expected) {
                assert!((vec3(t) - vec3(e)).norm() < 1e-12, "{j}: {t} vs {e}");
            }
        };
        check(
            placed(0, 4),
            &[(1, s0.0), (3, b.0 * s0.0), (4, s3.0 * b.0 * s0.0)],
        );
        // Backward the bridge is taken where it ends, and the scan it skips is placed by its
        // own step as a leaf.
        check(
            placed(4, 4),
            &[
                (3, s3.0.inverse()),
                (2, (s3.0 * s2.0).inverse()),
                (1, (s3.0 * b.0).inverse()),
                (0, (s3.0 * b.0 * s0.0).inverse()),
            ],
        );
        // The lag bounds the reach in scans, a bridge's skip included.
        check(placed(0, 2), &[(1, s0.0)]);
        check(placed(3, 1), &[(4, s3.0), (2, s2.0.inverse())]);
        // Without the bridge the chain stops at the untrusted step.
        assert_eq!(neighbour_poses(&steps, &Bridges::new(), 0, 4).len(), 1);
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
            let (_, mean, cov) = neighbour_poses(&steps, &Bridges::new(), k, 2)
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
        let none = Bridges::new();
        assert_eq!(neighbour_poses(&cut, &none, 0, 2).len(), 1);
        assert_eq!(neighbour_poses(&cut, &none, 2, 2).len(), 0);
    }
}
