//! The smoother's two factors, linearised: the motion prior between consecutive scans (white
//! noise on acceleration or on jerk) and a registration at any lag. Poses are `(x m, y m, θ rad)` of
//! `t_world_body`, updated additively; twists are `(surge m/s, sway m/s, yaw rad/s)` in the body
//! frame.

use nalgebra::{Matrix2, Matrix3, SMatrix, SVector, Vector2, Vector3};

use super::Geometry;

/// Wraps an angle to (−π, π].
pub(crate) fn wrap_rad(angle_rad: f64) -> f64 {
    let a =
        (angle_rad + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI;
    if a <= -std::f64::consts::PI {
        a + std::f64::consts::TAU
    } else {
        a
    }
}

/// `∂R(θ)ᵀv/∂θ = −S R(θ)ᵀ v` with `S = [[0, −1], [1, 0]]`.
fn s_times(v: Vector2<f64>) -> Vector2<f64> {
    Vector2::new(-v.y, v.x)
}

fn rot_t(geometry: Geometry, theta_rad: f64) -> Matrix2<f64> {
    match geometry {
        Geometry::Se2 => {
            let (s, c) = theta_rad.sin_cos();
            Matrix2::new(c, s, -s, c)
        }
        Geometry::Linear => Matrix2::identity(),
    }
}

/// `V(φ)⁻¹ = [[a, b], [−b, a]]` of SE(2)'s logarithm, `a = (φ/2)·cot(φ/2)`, `b = φ/2`, and its
/// derivative in φ. Below 1e-4 rad the Taylor series (error < 1e-17).
fn v_inv(phi_rad: f64) -> (Matrix2<f64>, Matrix2<f64>) {
    let (a, da) = if phi_rad.abs() < 1e-4 {
        let p2 = phi_rad * phi_rad;
        (1.0 - p2 / 12.0, -phi_rad / 6.0)
    } else {
        let h = 0.5 * phi_rad;
        let a = h / h.tan();
        let da = 0.5 / h.tan() - 0.5 * h / h.sin().powi(2);
        (a, da)
    };
    let b = 0.5 * phi_rad;
    (Matrix2::new(a, b, -b, a), Matrix2::new(da, 0.5, -0.5, da))
}

/// `Log(t_body_k_body_k1)` as `(ρ, φ)`: the constant body twist times Δt that moves `pose_k`
/// onto `pose_k1`, with its Jacobians against both poses.
pub(crate) fn log_between(
    geometry: Geometry,
    pose_k: &Vector3<f64>,
    pose_k1: &Vector3<f64>,
) -> (Vector3<f64>, Matrix3<f64>, Matrix3<f64>) {
    let dp = Vector2::new(pose_k1.x - pose_k.x, pose_k1.y - pose_k.y);
    let rt = rot_t(geometry, pose_k.z);
    let d = rt * dp;
    let (phi, vi, dvi) = match geometry {
        Geometry::Se2 => {
            let phi = wrap_rad(pose_k1.z - pose_k.z);
            let (vi, dvi) = v_inv(phi);
            (phi, vi, dvi)
        }
        Geometry::Linear => (pose_k1.z - pose_k.z, Matrix2::identity(), Matrix2::zeros()),
    };
    let rho = vi * d;
    let mut j_k = Matrix3::zeros();
    let mut j_k1 = Matrix3::zeros();
    let m = vi * rt;
    j_k.fixed_view_mut::<2, 2>(0, 0).copy_from(&(-m));
    j_k1.fixed_view_mut::<2, 2>(0, 0).copy_from(&m);
    let d_phi = dvi * d;
    let d_theta_k = match geometry {
        Geometry::Se2 => -(vi * s_times(d)) - d_phi,
        Geometry::Linear => Vector2::zeros(),
    };
    j_k.fixed_view_mut::<2, 1>(0, 2).copy_from(&d_theta_k);
    j_k1.fixed_view_mut::<2, 1>(0, 2).copy_from(&d_phi);
    j_k[(2, 2)] = -1.0;
    j_k1[(2, 2)] = 1.0;
    (Vector3::new(rho.x, rho.y, phi), j_k, j_k1)
}

/// The prior between scans k and k+1, linearised, for a state of `O = R/3` 3-vectors per scan
/// (`B = 2O` Jacobian blocks): pose `T`, twist `ϖ` and, for white noise on jerk, body
/// acceleration `α`. Its residual holds `O` 3-vectors: what the Taylor expansion of the state at
/// k leaves unexplained at k+1 (Barfoot, Tong & Särkkä 2014 for `O = 2`, STEAM's
/// constant-velocity prior on SE(2); Tang, Yoon & Barfoot 2019 for `O = 3`):
/// - `e₀ = Log(T_k⁻¹T_k+1) − Δt·ϖ_k (− Δt²/2·α_k)`,
/// - `e₁ = ϖ_k+1 − ϖ_k (− Δt·α_k)`,
/// - `e₂ = α_k+1 − α_k` (white noise on jerk only),
///
/// with Jacobians against `[T_k, ϖ_k, (α_k,) T_k+1, ϖ_k+1, (α_k+1)]`.
///
/// STEAM's velocity residual is `J⁻¹(ξ)·ϖ_k+1 − ϖ_k`; since `ξ ≈ Δt·ϖ_k+1` and `ad(ϖ)ϖ = 0`,
/// `J⁻¹(ξ)ϖ_k+1 − ϖ_k+1 = ½ ad(ξ)ϖ_k+1 + …` is of the order of Δt² times the acceleration, and is
/// left out (so is its like in the acceleration's residual).
pub(crate) struct PriorLinearised<const R: usize, const B: usize> {
    pub residual: SVector<f64, R>,
    pub jacobians: [SMatrix<f64, R, 3>; B],
}

/// `Δtⁿ/n!`, the Taylor coefficient of a state's n-th derivative.
fn taylor(dt_s: f64, n: usize) -> f64 {
    match n {
        0 => 1.0,
        1 => dt_s,
        _ => dt_s.powi(n as i32) / (1..=n).product::<usize>() as f64,
    }
}

/// [`PriorLinearised`] at the states of scan k (`at_k`: pose, twist and, for `O = 3`,
/// acceleration) and of scan k+1 (`at_k1`).
pub(crate) fn prior<const R: usize, const B: usize>(
    geometry: Geometry,
    at_k: &[Vector3<f64>],
    at_k1: &[Vector3<f64>],
    dt_s: f64,
) -> PriorLinearised<R, B> {
    let order = R / 3;
    debug_assert!(B == 2 * order && at_k.len() == order && at_k1.len() == order);
    let (xi, j_pk, j_pk1) = log_between(geometry, &at_k[0], &at_k1[0]);
    let mut residual = SVector::<f64, R>::zeros();
    let mut jacobians = [SMatrix::<f64, R, 3>::zeros(); B];
    for i in 0..order {
        // What scan k's expansion predicts of derivative i at k+1, subtracted.
        let mut e = if i == 0 { xi } else { at_k1[i] };
        for (j, d) in at_k.iter().enumerate().skip(i.max(1)) {
            let c = taylor(dt_s, j - i);
            e -= d * c;
            jacobians[j]
                .fixed_view_mut::<3, 3>(3 * i, 0)
                .copy_from(&(-Matrix3::identity() * c));
        }
        residual.fixed_rows_mut::<3>(3 * i).copy_from(&e);
        if i > 0 {
            jacobians[order + i]
                .fixed_view_mut::<3, 3>(3 * i, 0)
                .copy_from(&Matrix3::identity());
        }
    }
    jacobians[0].fixed_view_mut::<3, 3>(0, 0).copy_from(&j_pk);
    jacobians[order]
        .fixed_view_mut::<3, 3>(0, 0)
        .copy_from(&j_pk1);
    PriorLinearised {
        residual,
        jacobians,
    }
}

/// Per axis, `A(Δt)⁻¹ = [C_ij / Δt^(2O−1−i−j)]` for a state of `O` derivatives, `C` for
/// `O = 2` (`A = [[Δt³/3, Δt²/2], [Δt²/2, Δt]]`) and `O = 3` (`A = [[Δt⁵/20, Δt⁴/8, Δt³/6],
/// [Δt⁴/8, Δt³/3, Δt²/2], [Δt³/6, Δt²/2, Δt]]`).
const A_INVERSE: [[[f64; 3]; 3]; 2] = [
    [[12.0, -6.0, 0.0], [-6.0, 4.0, 0.0], [0.0, 0.0, 0.0]],
    [
        [720.0, -360.0, 60.0],
        [-360.0, 192.0, -36.0],
        [60.0, -36.0, 9.0],
    ],
];

/// Entry `(i, j)` of `A(Δt)⁻¹` for a state of `order` (2 or 3) derivatives, with `scale` times
/// `C_ij` (2 sums an off-diagonal entry's two places at once).
pub(crate) fn a_inverse(order: usize, dt_s: f64, i: usize, j: usize, scale: f64) -> f64 {
    scale * A_INVERSE[order - 2][i][j] / dt_s.powi((2 * order - 1 - i - j) as i32)
}

/// `ln det A(Δt)⁻¹` per axis for a state of `order` derivatives ([`a_inverse`]).
pub(crate) fn ln_det_a_inverse(order: usize, dt_s: f64) -> f64 {
    let mut a = Matrix3::identity();
    for i in 0..order {
        for j in 0..order {
            a[(i, j)] = a_inverse(order, dt_s, i, j, 1.0);
        }
    }
    a.determinant().ln()
}

/// `A₀₀(Δt)`: the variance of the position's residual over a step per unit `q`, for a state of
/// `order` derivatives (`Δt³/3`, `Δt⁵/20`).
pub(crate) fn position_variance(order: usize, dt_s: f64) -> f64 {
    let power = 2 * order - 1;
    let factorial = (1..order).product::<usize>() as f64;
    dt_s.powi(power as i32) / (power as f64 * factorial * factorial)
}

/// The information `Q⁻¹` of the prior over `dt_s` for a state of `R/3` derivatives:
/// `Q = A(Δt) ⊗ Qc`, `Qc = diag(qc)`, so `Q⁻¹ = A(Δt)⁻¹ ⊗ Qc⁻¹` ([`a_inverse`]).
pub(crate) fn prior_information<const R: usize>(qc: &[f64; 3], dt_s: f64) -> SMatrix<f64, R, R> {
    let order = R / 3;
    let mut info = SMatrix::<f64, R, R>::zeros();
    for (axis, &q) in qc.iter().enumerate() {
        let qi = 1.0 / q;
        for i in 0..order {
            for j in 0..order {
                info[(axis + 3 * i, axis + 3 * j)] = a_inverse(order, dt_s, i, j, 1.0) * qi;
            }
        }
    }
    info
}

/// The parameters `(x, y, θ)` of `t_ref_src = T_reference⁻¹ T_source` predicted by two poses,
/// with its Jacobians against the source's and the reference's pose.
pub(crate) fn relative(
    geometry: Geometry,
    pose_src: &Vector3<f64>,
    pose_ref: &Vector3<f64>,
) -> (Vector3<f64>, Matrix3<f64>, Matrix3<f64>) {
    let rt = rot_t(geometry, pose_ref.z);
    let dp = Vector2::new(pose_src.x - pose_ref.x, pose_src.y - pose_ref.y);
    let t = rt * dp;
    let theta = match geometry {
        Geometry::Se2 => wrap_rad(pose_src.z - pose_ref.z),
        Geometry::Linear => pose_src.z - pose_ref.z,
    };
    let mut j_src = Matrix3::zeros();
    let mut j_ref = Matrix3::zeros();
    j_src.fixed_view_mut::<2, 2>(0, 0).copy_from(&rt);
    j_ref.fixed_view_mut::<2, 2>(0, 0).copy_from(&(-rt));
    if geometry == Geometry::Se2 {
        j_ref.fixed_view_mut::<2, 1>(0, 2).copy_from(&(-s_times(t)));
    }
    j_src[(2, 2)] = 1.0;
    j_ref[(2, 2)] = -1.0;
    (Vector3::new(t.x, t.y, theta), j_src, j_ref)
}

/// The parameters of `A ∘ B` (first B, then A: `t = t_A + R(θ_A) t_B`, `θ = θ_A + θ_B`) from
/// those of A (`outer`) and B (`inner`), with its Jacobians against both.
pub(crate) fn compose(
    geometry: Geometry,
    outer: &Vector3<f64>,
    inner: &Vector3<f64>,
) -> (Vector3<f64>, Matrix3<f64>, Matrix3<f64>) {
    let r = rot_t(geometry, outer.z).transpose();
    let t = Vector2::new(outer.x, outer.y) + r * Vector2::new(inner.x, inner.y);
    let theta = match geometry {
        Geometry::Se2 => wrap_rad(outer.z + inner.z),
        Geometry::Linear => outer.z + inner.z,
    };
    let mut j_outer = Matrix3::identity();
    if geometry == Geometry::Se2 {
        let lever = s_times(r * Vector2::new(inner.x, inner.y));
        j_outer.fixed_view_mut::<2, 1>(0, 2).copy_from(&lever);
    }
    let mut j_inner = Matrix3::identity();
    j_inner.fixed_view_mut::<2, 2>(0, 0).copy_from(&r);
    (Vector3::new(t.x, t.y, theta), j_outer, j_inner)
}

/// The difference of two parameter vectors of a pose, with its angle wrapped (SE(2)).
pub(crate) fn pose_minus(geometry: Geometry, a: &Vector3<f64>, b: &Vector3<f64>) -> Vector3<f64> {
    let d = a - b;
    match geometry {
        Geometry::Se2 => Vector3::new(d.x, d.y, wrap_rad(d.z)),
        Geometry::Linear => d,
    }
}

/// The pose reached from `pose` by the constant body twist `xi` (already times Δt).
pub(crate) fn exp_from(geometry: Geometry, pose: &Vector3<f64>, xi: &Vector3<f64>) -> Vector3<f64> {
    match geometry {
        Geometry::Se2 => {
            let phi = xi.z;
            // V(φ) = (1/φ)[[sin φ, −(1 − cos φ)], [1 − cos φ, sin φ]], → I as φ → 0.
            let (a, b) = if phi.abs() < 1e-4 {
                (1.0 - phi * phi / 6.0, phi / 2.0)
            } else {
                (phi.sin() / phi, (1.0 - phi.cos()) / phi)
            };
            let d = Vector2::new(a * xi.x - b * xi.y, b * xi.x + a * xi.y);
            let (s, c) = pose.z.sin_cos();
            Vector3::new(
                pose.x + c * d.x - s * d.y,
                pose.y + s * d.x + c * d.y,
                wrap_rad(pose.z + phi),
            )
        }
        Geometry::Linear => pose + xi,
    }
}

/// The Huber weight of a factor whose Mahalanobis distance is `d`, threshold `k`.
pub(crate) fn huber_weight(d: f64, k: f64) -> f64 {
    if d <= k {
        1.0
    } else {
        k / d
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn numeric<F: Fn(&Vector3<f64>) -> Vector3<f64>>(f: F, x: &Vector3<f64>) -> Matrix3<f64> {
        let mut j = Matrix3::zeros();
        for c in 0..3 {
            let mut xp = *x;
            let mut xm = *x;
            xp[c] += 1e-6;
            xm[c] -= 1e-6;
            j.set_column(c, &((f(&xp) - f(&xm)) / 2e-6));
        }
        j
    }

    #[test]
    fn jacobians_match_central_differences() {
        let a = Vector3::new(1.3, -0.4, 0.7);
        let b = Vector3::new(2.1, 0.9, 1.05);
        let (_, j_k, j_k1) = log_between(Geometry::Se2, &a, &b);
        let n_k = numeric(|x| log_between(Geometry::Se2, x, &b).0, &a);
        let n_k1 = numeric(|x| log_between(Geometry::Se2, &a, x).0, &b);
        assert!((j_k - n_k).abs().max() < 1e-8, "{j_k} {n_k}");
        assert!((j_k1 - n_k1).abs().max() < 1e-8, "{j_k1} {n_k1}");
        let (_, j_s, j_r) = relative(Geometry::Se2, &a, &b);
        let n_s = numeric(|x| relative(Geometry::Se2, x, &b).0, &a);
        let n_r = numeric(|x| relative(Geometry::Se2, &a, x).0, &b);
        assert!((j_s - n_s).abs().max() < 1e-8);
        assert!((j_r - n_r).abs().max() < 1e-8);
    }

    #[test]
    fn composition_matches_isometries_and_its_jacobians_central_differences() {
        let a = Vector3::new(0.8, -1.1, 2.6);
        let b = Vector3::new(-0.4, 0.3, 1.2);
        let (c, j_a, j_b) = compose(Geometry::Se2, &a, &b);
        let iso = |p: &Vector3<f64>| nalgebra::Isometry2::new(Vector2::new(p.x, p.y), p.z);
        let product = iso(&a) * iso(&b);
        let expected = Vector3::new(
            product.translation.x,
            product.translation.y,
            product.rotation.angle(),
        );
        assert!((c - expected).abs().max() < 1e-12, "{c} {expected}");
        let n_a = numeric(|x| compose(Geometry::Se2, x, &b).0, &a);
        let n_b = numeric(|x| compose(Geometry::Se2, &a, x).0, &b);
        assert!((j_a - n_a).abs().max() < 1e-8, "{j_a} {n_a}");
        assert!((j_b - n_b).abs().max() < 1e-8, "{j_b} {n_b}");
    }

    #[test]
    fn the_priors_information_inverts_its_covariance() {
        // A per unit q, written out independently of `A_INVERSE`.
        let a = |order: usize, dt: f64| -> nalgebra::DMatrix<f64> {
            let full = [
                [dt.powi(5) / 20.0, dt.powi(4) / 8.0, dt.powi(3) / 6.0],
                [dt.powi(4) / 8.0, dt.powi(3) / 3.0, dt.powi(2) / 2.0],
                [dt.powi(3) / 6.0, dt.powi(2) / 2.0, dt],
            ];
            let skip = 3 - order;
            nalgebra::DMatrix::from_fn(order, order, |i, j| full[i + skip][j + skip])
        };
        for order in [2, 3] {
            for dt in [0.05, 0.5, 1.0, 3.7] {
                let inv = nalgebra::DMatrix::from_fn(order, order, |i, j| {
                    a_inverse(order, dt, i, j, 1.0)
                });
                let a = a(order, dt);
                assert!((position_variance(order, dt) / a[(0, 0)] - 1.0).abs() < 1e-12);
                let product = a * inv;
                let off = (product - nalgebra::DMatrix::identity(order, order))
                    .abs()
                    .max();
                assert!(off < 1e-9, "order {order}, Δt {dt}: {off:e}");
            }
        }
        // And the 9×9 information over three axes of their own q.
        let (qc, dt) = ([0.3, 0.02, 1e-4], 0.7);
        let info = prior_information::<9>(&qc, dt);
        let full = [
            [dt.powi(5) / 20.0, dt.powi(4) / 8.0, dt.powi(3) / 6.0],
            [dt.powi(4) / 8.0, dt.powi(3) / 3.0, dt.powi(2) / 2.0],
            [dt.powi(3) / 6.0, dt.powi(2) / 2.0, dt],
        ];
        let q = SMatrix::<f64, 9, 9>::from_fn(|r, c| {
            if r % 3 == c % 3 {
                full[r / 3][c / 3] * qc[r % 3]
            } else {
                0.0
            }
        });
        let off = (q * info - SMatrix::<f64, 9, 9>::identity()).abs().max();
        assert!(off < 1e-9, "{off:e}");
    }

    #[test]
    fn the_jerk_priors_jacobians_match_central_differences() {
        let at_k = [
            Vector3::new(1.3, -0.4, 0.7),
            Vector3::new(2.0, 0.2, 0.3),
            Vector3::new(0.1, -0.05, 0.02),
        ];
        let at_k1 = [
            Vector3::new(3.1, 0.9, 1.05),
            Vector3::new(2.2, 0.1, 0.35),
            Vector3::new(0.12, -0.04, 0.01),
        ];
        let dt = 0.9;
        let lin = prior::<9, 6>(Geometry::Se2, &at_k, &at_k1, dt);
        for block in 0..6 {
            let (scan, d) = (block / 3, block % 3);
            let mut numeric = SMatrix::<f64, 9, 3>::zeros();
            for c in 0..3 {
                let residual = |h: f64| {
                    let (mut a, mut b) = (at_k, at_k1);
                    let v = if scan == 0 { &mut a[d] } else { &mut b[d] };
                    v[c] += h;
                    prior::<9, 6>(Geometry::Se2, &a, &b, dt).residual
                };
                numeric.set_column(c, &((residual(1e-6) - residual(-1e-6)) / 2e-6));
            }
            let off = (lin.jacobians[block] - numeric).abs().max();
            assert!(off < 1e-8, "block {block}: {off:e}");
        }
        // Where the expansion holds exactly (no rotation, the acceleration constant), the
        // residual is zero.
        let still = [
            Vector3::zeros(),
            Vector3::new(2.0, 0.0, 0.0),
            Vector3::new(0.4, 0.0, 0.0),
        ];
        let end = [
            Vector3::new(2.0 * dt + 0.2 * dt * dt, 0.0, 0.0),
            Vector3::new(2.0 + 0.4 * dt, 0.0, 0.0),
            still[2],
        ];
        let lin = prior::<9, 6>(Geometry::Se2, &still, &end, dt);
        assert!(lin.residual.abs().max() < 1e-12, "{}", lin.residual);
    }

    #[test]
    fn log_inverts_exp() {
        let pose = Vector3::new(3.0, -2.0, 2.9);
        for xi in [
            Vector3::new(1.5, 0.2, 0.4),
            Vector3::new(-0.3, 0.1, -1e-6),
            Vector3::new(0.7, -0.2, 0.0),
        ] {
            let end = exp_from(Geometry::Se2, &pose, &xi);
            let (back, _, _) = log_between(Geometry::Se2, &pose, &end);
            assert!((back - xi).abs().max() < 1e-12, "{xi} {back}");
        }
    }
}
