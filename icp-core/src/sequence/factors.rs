//! The smoother's two factors, linearised: the white-noise-on-acceleration motion prior between
//! consecutive scans and a registration at any lag. Poses are `(x m, y m, θ rad)` of
//! `t_world_body`, updated additively; twists are `(surge m/s, sway m/s, yaw rad/s)` in the body
//! frame.

use nalgebra::{Matrix2, Matrix3, SMatrix, SVector, Vector2, Vector3};

use super::Geometry;

/// A 6-vector (prior residual: pose part then twist part).
pub(crate) type Vector6 = SVector<f64, 6>;
/// A 6×6 matrix.
pub(crate) type Matrix6 = SMatrix<f64, 6, 6>;
/// A 6×3 Jacobian block (prior residual against one 3-vector).
pub(crate) type Matrix6x3 = SMatrix<f64, 6, 3>;

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

/// The prior between scans k and k+1 (Barfoot, Tong & Särkkä 2014; STEAM's constant-velocity
/// prior on SE(2)), linearised: residual `e = [Log(T_k⁻¹T_k+1) − Δt·ϖ_k ; ϖ_k+1 − ϖ_k]` and its
/// Jacobians against `pose_k`, `twist_k`, `pose_k1`, `twist_k1`.
///
/// STEAM's velocity residual is `J⁻¹(ξ)·ϖ_k+1 − ϖ_k`; since `ξ ≈ Δt·ϖ_k+1` and `ad(ϖ)ϖ = 0`,
/// `J⁻¹(ξ)ϖ_k+1 − ϖ_k+1 = ½ ad(ξ)ϖ_k+1 + …` is of the order of Δt² times the acceleration, and is
/// left out.
pub(crate) struct PriorLinearised {
    pub residual: Vector6,
    pub jacobians: [Matrix6x3; 4],
}

pub(crate) fn prior(
    geometry: Geometry,
    pose_k: &Vector3<f64>,
    twist_k: &Vector3<f64>,
    pose_k1: &Vector3<f64>,
    twist_k1: &Vector3<f64>,
    dt_s: f64,
) -> PriorLinearised {
    let (xi, j_pk, j_pk1) = log_between(geometry, pose_k, pose_k1);
    let e_pos = xi - twist_k * dt_s;
    let e_vel = twist_k1 - twist_k;
    let mut residual = Vector6::zeros();
    residual.fixed_rows_mut::<3>(0).copy_from(&e_pos);
    residual.fixed_rows_mut::<3>(3).copy_from(&e_vel);
    let mut jacobians = [Matrix6x3::zeros(); 4];
    jacobians[0].fixed_view_mut::<3, 3>(0, 0).copy_from(&j_pk);
    jacobians[1]
        .fixed_view_mut::<3, 3>(0, 0)
        .copy_from(&(-Matrix3::identity() * dt_s));
    jacobians[1]
        .fixed_view_mut::<3, 3>(3, 0)
        .copy_from(&(-Matrix3::identity()));
    jacobians[2].fixed_view_mut::<3, 3>(0, 0).copy_from(&j_pk1);
    jacobians[3]
        .fixed_view_mut::<3, 3>(3, 0)
        .copy_from(&Matrix3::identity());
    PriorLinearised {
        residual,
        jacobians,
    }
}

/// The information `Q⁻¹` of the prior over `dt_s`: `Q = [[Δt³/3, Δt²/2], [Δt²/2, Δt]] ⊗ Qc`,
/// `Qc = diag(qc)`, so `Q⁻¹ = [[12/Δt³, −6/Δt²], [−6/Δt², 4/Δt]] ⊗ Qc⁻¹`.
pub(crate) fn prior_information(qc: &[f64; 3], dt_s: f64) -> Matrix6 {
    let mut info = Matrix6::zeros();
    for (axis, &q) in qc.iter().enumerate() {
        let qi = 1.0 / q;
        info[(axis, axis)] = 12.0 / dt_s.powi(3) * qi;
        info[(axis, axis + 3)] = -6.0 / dt_s.powi(2) * qi;
        info[(axis + 3, axis)] = -6.0 / dt_s.powi(2) * qi;
        info[(axis + 3, axis + 3)] = 4.0 / dt_s * qi;
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
