//! The Cramér–Rao lower bound (CRB) of the relative pose `t_ref_src` between two noisy 2D LIDAR
//! scans of surfaces whose true normals are known (Censi 2007, "On achievable accuracy for
//! range-finder localization", ICRA), with the sensor error model of Naus & Marchel (2019),
//! eqs. 8 and 9.
//!
//! The bound answers "how well could *any* unbiased estimator register these two scans?", so
//! that a method's RMSE can be reported as a multiple of it. It is built in two steps:
//! [`scan_information`] gives the Fisher information of one scan's pose against a known map, and
//! [`relative_pose_bound`] propagates the information of both scans to `t_ref_src`.
//!
//! # Derivation
//!
//! ## One return
//! Return `i` has nominal bearing `α_i` and range `r_i`, at `p_i = r_i u_r(α_i)` in its scan
//! frame (eq. 10; `u_r = (cos α, sin α)`, `u_t = (−sin α, cos α)`). Its point is uncertain by the
//! covariance of eq. 8, `C_i = σ_r(r_i)² u_r u_rᵀ + (σ_α r_i)² u_t u_tᵀ`. It lies on a locally
//! straight surface with unit normal `n_i` (scan frame). Sliding the point along the surface
//! changes nothing that could be observed, so only the normal component carries information
//! (Censi 2007): the measurement is the normal distance of the point to the
//! surface, whose variance is eq. 9 taken along the normal,
//!
//! ```text
//! σ²_n,i = n_iᵀ C_i n_i = σ_r(r_i)² cos²β_i + (σ_α r_i)² sin²β_i,      (eq. 9 along n_i)
//! ```
//!
//! `β_i` the incidence angle between the beam and the normal. Censi writes the same thing for a
//! range reading: a beam that leaves at `α + ε_α` hits a surface inclined by `β` at a range
//! longer by `r tan β · ε_α`, so the range variance is `σ_ρ² = σ_r² + (σ_α r tan β)²`, and a
//! range error `e` moves the point by `e cos β` along the normal: `σ²_n = σ_ρ² cos²β`, the
//! expression above (his `σ²/cos²β` form of the information). Both views agree to first order
//! with a simulator that reports the range of the deflected beam at the nominal bearing.
//!
//! ## Jacobian of the normal distance
//! Let the scan's pose be `T` (world ← scan) and the surface the world line `mᵀx = d` with
//! `m = R_T n_i`. Perturbing the pose on the right, `T·exp(δ)` with `δ = (δx, δy, δθ)` in the
//! scan frame, gives `exp(δ) p = p + (δx, δy) + δθ J p + O(δ²)`, `J = [[0, −1], [1, 0]]`, so the
//! normal distance `h_i(δ) = mᵀ T exp(δ) p_i − d` has the gradient
//!
//! ```text
//! ∂h_i/∂δ = [n_x, n_y, n_iᵀ J p_i] = [n_x, n_y, p_x n_y − p_y n_x] =: J_iᵀ.
//! ```
//!
//! ## Information of one scan
//! The returns' noises are independent and Gaussian, so the Fisher information of the pose is
//!
//! ```text
//! I = Σ_i J_i J_iᵀ / σ²_n,i        (units: m⁻² on (x, y), m⁻¹rad⁻¹ across, rad⁻² on θ)
//! ```
//!
//! and `I⁻¹` bounds the covariance of the scan's pose estimated against the *known* surfaces
//! (Censi 2007's localization bound). The information that the pose dependence of `σ²_n`
//! itself would carry (the `½ tr(C⁻¹∂C C⁻¹∂C)` term of a Gaussian) is left out: for the Sweep,
//! whose σ's grow in proportion to `r`, it is of order `2 (∂σ_r/∂r)²` ≈ 4·10⁻⁵ of the above,
//! and no least-squares estimator uses it.
//!
//! ## Relative pose
//! Scan k (source, pose `T_s`) and scan k+1 (reference, pose `T_r`) have independent noise, so
//! the joint information over `(δ_s, δ_r)` is `diag(I_src, I_ref)`. The relative pose is
//! `t_ref_src = T_r⁻¹ T_s`, with translation `t` and rotation `R` (angle `θ`); in its
//! coordinates `g = (tx, ty, θ)`:
//!
//! * `T_s exp(δ_s)` gives `t_ref_src exp(δ_s) = (t + R δ_s,xy, θ + δθ_s)`, so
//!   `A = ∂g/∂δ_s = [[R, 0], [0, 1]]`;
//! * `T_r exp(δ_r)` gives `exp(−δ_r) t_ref_src = (R(−δθ_r) t − δ_r,xy, θ − δθ_r)`
//!   `= (t − δθ_r J t − δ_r,xy, θ − δθ_r) + O(δ²)`, so `B = ∂g/∂δ_r = [[−I, −J t], [0, −1]]`.
//!
//! The CRB of a function `g` of the parameters is `G I⁻¹ Gᵀ` with `G = [A B]`:
//!
//! ```text
//! Cov(ĝ) ⪰ A I_src⁻¹ Aᵀ + B I_ref⁻¹ Bᵀ.
//! ```
//!
//! Both Jacobians are checked against finite differences of `T_r⁻¹ T_s` in the tests
//! ([`relative_pose_jacobians`]).
//!
//! ## Why this bounds scan-to-scan registration
//! A scan matcher does not know the surfaces: it estimates them from the noisy scans too. The
//! bound above treats the map as known. Knowing nuisance parameters can only add information
//! (the Schur complement of the full Fisher matrix is ⪯ its pose block), so the true bound of
//! scan-to-scan registration is at least this one: this is a valid, possibly loose, lower bound.
//! Like every CRB it holds for unbiased estimators; ICP is unbiased to first order in the noise.
//!
//! ## Unobservable directions
//! A corridor (parallel walls only) leaves translation along the walls unobserved, and a
//! scanner at the centre of a round basin leaves its rotation unobserved: `I` is singular and
//! the bound infinite. [`relative_pose_bound`] reports that as [`RelativeBound::Unbounded`]
//! instead of a NaN or a huge number. "Singular" needs a common unit for translation and
//! rotation: a rotation `δθ` is counted as the displacement `L δθ` it causes at the scan's RMS
//! range `L` ([`ScanInformation::lever_m`]). When the condition number of the information in
//! those units, `S I S` with `S = diag(1, 1, 1/L)` (m⁻² throughout), exceeds [`MAX_CONDITION`],
//! the bound is declared unbounded. The decision does not depend on the units the caller uses
//! (`L` scales with them), and, unlike equilibrating by `diag(I)`, it does not hide a coordinate
//! that is observed a million times worse than the others but uncorrelated with them.
//!
//! # Use
//! A CRB is evaluated at the truth: build each scan's [`BoundReturn`]s from its *noise-free*
//! ranges, nominal bearings and the true surface normals (of the returns the scan really has,
//! after dropouts), and pass the true `t_ref_src`. [`PoseBound::trans_m`] and
//! [`PoseBound::rot_rad`] are the bounds on the RMS translation and rotation errors.
//!
//! # Validation
//! Besides a closed form and finite differences (unit tests), `tests/bound.rs` runs the
//! numerical oracle: in a harbour basin of known walls, both scans drawn as the simulator draws
//! them (Sweep model, 720 beams), each scan's pose fitted to the known walls by weighted
//! point-to-line Gauss–Newton, 2000 trials. Its RMS errors sit on the bound: RMSE / bound
//! = 1.015 ± 0.012 (translation) and 0.997 ± 0.016 (rotation); with 30 000 trials
//! 0.996 ± 0.003 and 1.002 ± 0.004.

use nalgebra::{Isometry2, Matrix2, Matrix3, SymmetricEigen, Vector2, Vector3};

use crate::error::ScanRole;
use crate::{IcpError, SensorModel};

/// Largest condition number of a scan's information matrix, with rotation counted as the arc
/// at the scan's RMS range (see the module documentation), for which the bound is still
/// reported as finite. Beyond it the inverse loses more than `10¹⁰ · 2.2·10⁻¹⁶ ≈ 2·10⁻⁶` of its
/// relative precision and one direction is observed `10⁵` times worse (in standard deviation)
/// than the best-observed one. A corridor's null direction shows up as `~10¹⁶` or infinity;
/// walls 1° from parallel stay far below the limit (about `10⁴`).
pub const MAX_CONDITION: f64 = 1e10;

/// One LIDAR return on a surface whose normal is known.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BoundReturn {
    /// Range, metres (positive).
    pub range_m: f64,
    /// Nominal bearing in the scan frame, radians (eq. 10: the point is `(r cos α, r sin α)`).
    pub bearing_rad: f64,
    /// Normal of the surface at the return, in the scan frame. Any non-zero length (it is
    /// normalised) and either sign.
    pub normal: Vector2<f64>,
}

impl BoundReturn {
    /// The return's point in its scan frame, metres (eq. 10).
    pub fn point_m(&self) -> Vector2<f64> {
        let (s, c) = self.bearing_rad.sin_cos();
        Vector2::new(self.range_m * c, self.range_m * s)
    }

    /// Gradient of the normal distance with respect to the scan pose perturbed on the right,
    /// `[n_x, n_y, p_x n_y − p_y n_x]` for the unit normal `n`: dimensionless on `(δx, δy)`,
    /// metres per radian on `δθ`. `normal` must be non-zero (see [`scan_information`]).
    pub fn jacobian(&self) -> Vector3<f64> {
        let n = self.normal.normalize();
        let p = self.point_m();
        Vector3::new(n.x, n.y, p.x * n.y - p.y * n.x)
    }

    /// Variance of the point along the surface normal, m² (eq. 9 along `n`, from eq. 8):
    /// `σ_r² cos²β + (σ_α r)² sin²β`. `normal` must be non-zero (see [`scan_information`]).
    pub fn normal_variance_m2(&self, sensor: &SensorModel) -> f64 {
        let n = self.normal.normalize();
        (n.transpose() * sensor.covariance(self.range_m, self.bearing_rad) * n)[(0, 0)]
    }

    fn validate(&self, index: usize) -> Result<(), IcpError> {
        for (what, value) in [
            ("range_m", self.range_m),
            ("bearing_rad", self.bearing_rad),
            ("normal.x", self.normal.x),
            ("normal.y", self.normal.y),
        ] {
            if !value.is_finite() {
                return Err(IcpError::NonFinite { what, index, value });
            }
        }
        if self.range_m < 0.0 {
            return Err(IcpError::NegativeRange {
                index,
                value: self.range_m,
            });
        }
        if self.range_m == 0.0 {
            return Err(IcpError::InvalidParameter {
                name: "range_m",
                value: 0.0,
                reason: "a return needs a positive range",
            });
        }
        let len = self.normal.norm();
        if !(len > 0.0 && len.is_finite()) {
            return Err(IcpError::InvalidParameter {
                name: "normal",
                value: len,
                reason: "the surface normal must have a positive, finite length",
            });
        }
        Ok(())
    }
}

/// Fisher information of one scan's pose against known surfaces, over the right perturbation
/// `(δx m, δy m, δθ rad)` in the scan frame. Units: m⁻² on the translation block, rad⁻² on
/// `θ`, m⁻¹rad⁻¹ across. Symmetric and positive semi-definite by construction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScanInformation {
    matrix: Matrix3<f64>,
    lever_m: f64,
}

impl ScanInformation {
    /// Wraps an information matrix computed elsewhere, after checking that it is finite,
    /// symmetric (to 1e-12 relative) and positive semi-definite (to 1e-12 relative).
    /// `lever_m` (metres per radian, positive) converts a rotation into the displacement it
    /// causes when judging whether the matrix is singular: the RMS range of the returns.
    pub fn from_matrix(matrix: Matrix3<f64>, lever_m: f64) -> Result<Self, IcpError> {
        if !(lever_m.is_finite() && lever_m > 0.0) {
            return Err(IcpError::InvalidParameter {
                name: "lever_m",
                value: lever_m,
                reason: "the lever length must be finite and positive",
            });
        }
        for (index, &value) in matrix.iter().enumerate() {
            if !value.is_finite() {
                return Err(IcpError::NonFinite {
                    what: "information matrix",
                    index,
                    value,
                });
            }
        }
        let scale = matrix.amax();
        let asym = (matrix - matrix.transpose()).amax();
        if asym > 1e-12 * scale {
            return Err(IcpError::InvalidParameter {
                name: "information matrix asymmetry",
                value: asym,
                reason: "an information matrix is symmetric",
            });
        }
        let sym = (matrix + matrix.transpose()) * 0.5;
        let min = SymmetricEigen::new(sym).eigenvalues.min();
        if min < -1e-12 * scale {
            return Err(IcpError::InvalidParameter {
                name: "information matrix eigenvalue",
                value: min,
                reason: "an information matrix is positive semi-definite",
            });
        }
        Ok(Self {
            matrix: sym,
            lever_m,
        })
    }

    /// The matrix, over `(δx m, δy m, δθ rad)`.
    pub fn matrix(&self) -> &Matrix3<f64> {
        &self.matrix
    }

    /// The length that converts a rotation into a displacement when judging whether the
    /// matrix is singular, metres per radian: the RMS range of the returns (1 m without any).
    pub fn lever_m(&self) -> f64 {
        self.lever_m
    }

    /// The CRB of this scan's own pose against the known surfaces, `I⁻¹` over
    /// `(δx m, δy m, δθ rad)` in the scan frame, or the unobserved direction.
    pub fn pose_bound(&self, role: ScanRole) -> Result<PoseBound, Unobservable> {
        invert(self, role).map(|covariance| PoseBound { covariance })
    }
}

/// Fisher information of a scan's pose from its returns and the sensor model:
/// `I = Σ J_i J_iᵀ / σ²_n,i` (see the module documentation; Censi 2007, with the noise of
/// eqs. 8 and 9 of Naus & Marchel 2019). No returns give the zero matrix.
///
/// Errors: an invalid sensor model ([`SensorModel::validate`]), a non-finite field, a
/// non-positive range or a zero normal (the error's index is the return's position).
pub fn scan_information(
    returns: impl IntoIterator<Item = BoundReturn>,
    sensor: &SensorModel,
) -> Result<ScanInformation, IcpError> {
    sensor.validate()?;
    let mut matrix = Matrix3::zeros();
    let (mut count, mut sum_r2) = (0usize, 0.0);
    for (index, ret) in returns.into_iter().enumerate() {
        ret.validate(index)?;
        let j = ret.jacobian();
        // Positive: σ_r(r) > 0 and σ_α r > 0 for a valid model and r > 0, and cos² + sin² = 1.
        let var = ret.normal_variance_m2(sensor);
        matrix += j * j.transpose() / var;
        count += 1;
        sum_r2 += ret.range_m * ret.range_m;
    }
    let lever_m = if count > 0 {
        (sum_r2 / count as f64).sqrt()
    } else {
        1.0
    };
    // Each term j jᵀ is exactly symmetric in floating point, so the sum is too.
    Ok(ScanInformation { matrix, lever_m })
}

/// A finite Cramér–Rao bound on the covariance of a pose estimate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PoseBound {
    /// Lower bound of the covariance over `(tx m, ty m, θ rad)`: m² on the translation block,
    /// rad² on `θ`, m·rad across.
    pub covariance: Matrix3<f64>,
}

impl PoseBound {
    /// Bound on the RMS translation error, `sqrt(Cov_xx + Cov_yy)`, metres.
    pub fn trans_m(&self) -> f64 {
        (self.covariance[(0, 0)] + self.covariance[(1, 1)]).sqrt()
    }

    /// Bound on the RMS rotation error, `sqrt(Cov_θθ)`, radians.
    pub fn rot_rad(&self) -> f64 {
        self.covariance[(2, 2)].sqrt()
    }

    /// Bound on the RMS rotation error, degrees.
    pub fn rot_deg(&self) -> f64 {
        self.rot_rad().to_degrees()
    }

    /// The translation block, m².
    pub fn translation_covariance_m2(&self) -> Matrix2<f64> {
        self.covariance.fixed_view::<2, 2>(0, 0).into_owned()
    }
}

/// A scan whose information leaves a direction of its pose (practically) unobserved.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Unobservable {
    /// The scan whose information is singular.
    pub scan: ScanRole,
    /// The least-observed direction of that scan's pose perturbation, over
    /// `(δx m, δy m, L·δθ m)` in its scan frame (`L` = [`ScanInformation::lever_m`]: the
    /// rotation as the arc at the RMS range), normalised to length 1 (sign arbitrary).
    pub direction: Vector3<f64>,
    /// Condition number of the information matrix in those units (infinite when a direction
    /// carries no information at all), above [`MAX_CONDITION`].
    pub condition: f64,
}

/// The outcome of [`relative_pose_bound`]: a finite bound, or none because a scan leaves a
/// direction unobserved (a corridor).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RelativeBound {
    /// The covariance of any unbiased estimate of `t_ref_src` is at least this.
    Bounded(PoseBound),
    /// The bound is infinite: the named scan does not constrain its pose.
    Unbounded(Unobservable),
}

impl RelativeBound {
    /// The finite bound, if there is one.
    pub fn bounded(&self) -> Option<&PoseBound> {
        match self {
            RelativeBound::Bounded(b) => Some(b),
            RelativeBound::Unbounded(_) => None,
        }
    }
}

/// Jacobians `(A, B)` of the coordinates `(tx m, ty m, θ rad)` of `t_ref_src = T_ref⁻¹ T_src`
/// with respect to the right perturbations `δ_s` of `T_src` and `δ_r` of `T_ref`:
/// `A = [[R, 0], [0, 1]]`, `B = [[−I, −J t], [0, −1]]`, with `R` and `t` the rotation and
/// translation of `t_ref_src` and `J = [[0, −1], [1, 0]]`.
pub fn relative_pose_jacobians(t_ref_src: &Isometry2<f64>) -> (Matrix3<f64>, Matrix3<f64>) {
    let r = t_ref_src.rotation.to_rotation_matrix().into_inner();
    let t = t_ref_src.translation.vector;
    let jt = Vector2::new(-t.y, t.x);
    let a = Matrix3::new(
        r[(0, 0)],
        r[(0, 1)],
        0.0,
        r[(1, 0)],
        r[(1, 1)],
        0.0,
        0.0,
        0.0,
        1.0,
    );
    let b = Matrix3::new(-1.0, 0.0, -jt.x, 0.0, -1.0, -jt.y, 0.0, 0.0, -1.0);
    (a, b)
}

/// The Cramér–Rao bound of `t_ref_src` (over `(tx m, ty m, θ rad)`) from the information of
/// the source scan, of the reference scan, and the true relative pose:
/// `A I_src⁻¹ Aᵀ + B I_ref⁻¹ Bᵀ` (see the module documentation and
/// [`relative_pose_jacobians`]). [`RelativeBound::Unbounded`] when either information matrix
/// has a condition number above [`MAX_CONDITION`] (rotation counted as the arc at the scan's
/// RMS range).
///
/// Errors: a non-finite `t_ref_src`.
pub fn relative_pose_bound(
    info_src: &ScanInformation,
    info_ref: &ScanInformation,
    t_ref_src: &Isometry2<f64>,
) -> Result<RelativeBound, IcpError> {
    let t = t_ref_src.translation.vector;
    let coords = [("t_ref_src.x", t.x), ("t_ref_src.y", t.y)];
    let angle = t_ref_src.rotation.angle();
    for (index, (what, value)) in coords
        .into_iter()
        .chain([("t_ref_src.angle", angle)])
        .enumerate()
    {
        if !value.is_finite() {
            return Err(IcpError::NonFinite { what, index, value });
        }
    }
    let cov_src = match invert(info_src, ScanRole::Source) {
        Ok(c) => c,
        Err(u) => return Ok(RelativeBound::Unbounded(u)),
    };
    let cov_ref = match invert(info_ref, ScanRole::Reference) {
        Ok(c) => c,
        Err(u) => return Ok(RelativeBound::Unbounded(u)),
    };
    let (a, b) = relative_pose_jacobians(t_ref_src);
    let covariance = a * cov_src * a.transpose() + b * cov_ref * b.transpose();
    // Symmetrise the rounding away.
    let covariance = (covariance + covariance.transpose()) * 0.5;
    Ok(RelativeBound::Bounded(PoseBound { covariance }))
}

/// `I⁻¹` computed as `S (S I S)⁻¹ S` with `S = diag(1, 1, 1/L)`, `L` the lever length, or
/// the least-observed direction when `S I S` (m⁻² throughout) is too ill-conditioned.
fn invert(info: &ScanInformation, scan: ScanRole) -> Result<Matrix3<f64>, Unobservable> {
    let s = Vector3::new(1.0, 1.0, 1.0 / info.lever_m);
    let scaled = Matrix3::from_fn(|i, j| s[i] * info.matrix[(i, j)] * s[j]);
    let eig = SymmetricEigen::new(scaled);
    let (kmin, lmin) = eig.eigenvalues.argmin();
    let lmax = eig.eigenvalues.max();
    let condition = if lmin > 0.0 {
        lmax / lmin
    } else {
        f64::INFINITY
    };
    let unobservable = || Unobservable {
        scan,
        direction: eig.eigenvectors.column(kmin).into_owned(),
        condition,
    };
    if condition > MAX_CONDITION {
        return Err(unobservable());
    }
    let inv = scaled.cholesky().ok_or_else(unobservable)?.inverse();
    Ok(Matrix3::from_fn(|i, j| s[i] * inv[(i, j)] * s[j]))
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Point2;

    fn sweep() -> SensorModel {
        SensorModel::sweep()
    }

    /// Returns on the wall `x = a` (normal (1, 0)) at heights `±h`, and on the wall `y = b`
    /// (normal (0, 1)) at abscissae `±k`: by symmetry the information is diagonal.
    fn two_walls(a: f64, h: f64, b: f64, k: f64) -> Vec<BoundReturn> {
        let ret = |x: f64, y: f64, n: Vector2<f64>| BoundReturn {
            range_m: x.hypot(y),
            bearing_rad: y.atan2(x),
            normal: n,
        };
        vec![
            ret(a, h, Vector2::x()),
            ret(a, -h, Vector2::x()),
            ret(k, b, Vector2::y()),
            ret(-k, b, -Vector2::y()), // the normal's sign does not matter
        ]
    }

    #[test]
    fn two_orthogonal_walls_closed_form() {
        // Sweep: σ_r = κ r, so on the wall x = a at height h, where r cos β = a and
        // r sin β = h, eq. 9 along the normal is σ_n² = κ² a² + σ_α² h² exactly.
        let model = sweep();
        let kappa = SensorModel::SWEEP_SIGMA_R_PER_M;
        let sa = model.sigma_alpha_rad;
        let (a, h, b, k) = (10.0, 4.0, 6.0, 3.0);
        let var1 = kappa * kappa * a * a + sa * sa * h * h;
        let var2 = kappa * kappa * b * b + sa * sa * k * k;
        // J = [1, 0, −y] on the first wall, [0, 1, x] on the second; the cross terms cancel.
        let expected = Matrix3::from_diagonal(&Vector3::new(
            2.0 / var1,
            2.0 / var2,
            2.0 * h * h / var1 + 2.0 * k * k / var2,
        ));
        let info = scan_information(two_walls(a, h, b, k), &model).unwrap();
        let m = info.matrix();
        for i in 0..3 {
            for j in 0..3 {
                let tol = 1e-12 * expected[(i, i)].max(expected[(j, j)]);
                assert!(
                    (m[(i, j)] - expected[(i, j)]).abs() <= tol,
                    "({i},{j}): {} vs {}",
                    m[(i, j)],
                    expected[(i, j)]
                );
            }
        }

        // The reference scan sees other walls: (a', h', b', k').
        let (a2, h2, b2, k2) = (7.0, 5.0, 9.0, 2.0);
        let var1r = kappa * kappa * a2 * a2 + sa * sa * h2 * h2;
        let var2r = kappa * kappa * b2 * b2 + sa * sa * k2 * k2;
        let (e1, e2, e3) = (
            2.0 / var1r,
            2.0 / var2r,
            2.0 * h2 * h2 / var1r + 2.0 * k2 * k2 / var2r,
        );
        let (d1, d2, d3) = (expected[(0, 0)], expected[(1, 1)], expected[(2, 2)]);
        let info_ref = scan_information(two_walls(a2, h2, b2, k2), &model).unwrap();
        let t = Isometry2::new(Vector2::new(0.8, -0.6), 0.05);
        let bound = relative_pose_bound(&info, &info_ref, &t).unwrap();
        let bound = bound.bounded().copied().unwrap();
        // By hand: A diag(1/d) Aᵀ has trace 1/d1 + 1/d2 on translation and 1/d3 on θ;
        // B diag(1/e) Bᵀ adds 1/e1 + 1/e2 + |t|²/e3 on translation (|J t| = |t|) and 1/e3 on θ,
        // with the cross term J t / e3 (B's −J t times B's −1).
        let t2 = 0.8f64 * 0.8 + 0.6 * 0.6;
        let trans2 = 1.0 / d1 + 1.0 / d2 + 1.0 / e1 + 1.0 / e2 + t2 / e3;
        let rot2 = 1.0 / d3 + 1.0 / e3;
        assert!((bound.trans_m() - trans2.sqrt()).abs() < 1e-12 * trans2.sqrt());
        assert!((bound.rot_rad() - rot2.sqrt()).abs() < 1e-12 * rot2.sqrt());
        let c = bound.covariance;
        let (cs, sn) = (0.05f64.cos(), 0.05f64.sin());
        // Translation block: R diag(1/d1, 1/d2) Rᵀ + diag(1/e1, 1/e2) + (J t)(J t)ᵀ / e3.
        let jt = Vector2::new(0.6, 0.8);
        let xx = cs * cs / d1 + sn * sn / d2 + 1.0 / e1 + jt.x * jt.x / e3;
        let xy = cs * sn * (1.0 / d1 - 1.0 / d2) + jt.x * jt.y / e3;
        let yy = sn * sn / d1 + cs * cs / d2 + 1.0 / e2 + jt.y * jt.y / e3;
        let expected = Matrix3::new(
            xx,
            xy,
            jt.x / e3,
            xy,
            yy,
            jt.y / e3,
            jt.x / e3,
            jt.y / e3,
            rot2,
        );
        assert!(
            (c - expected).amax() < 1e-12 * expected.amax(),
            "{c} vs {expected}"
        );
        assert!((bound.rot_deg() - bound.rot_rad().to_degrees()).abs() < 1e-15);
    }

    fn perturb(d: &Vector3<f64>) -> Isometry2<f64> {
        // Same first derivative as exp(δ), which is all a finite difference sees.
        Isometry2::new(Vector2::new(d.x, d.y), d.z)
    }

    fn coord_diff(a: &Isometry2<f64>, b: &Isometry2<f64>) -> Vector3<f64> {
        let d = a.translation.vector - b.translation.vector;
        Vector3::new(d.x, d.y, (a.rotation / b.rotation).angle())
    }

    #[test]
    fn jacobians_match_finite_differences() {
        let poses = [
            (Vector2::new(3.0, -2.0), 0.3, Vector2::new(4.1, -1.5), 0.35),
            (Vector2::new(-10.0, 5.0), 3.1, Vector2::new(-9.0, 4.0), -3.1), // across ±π
            (Vector2::new(0.0, 0.0), 0.0, Vector2::new(20.0, -7.0), 1.2),
            (Vector2::new(1.0, 2.0), -2.0, Vector2::new(1.0, 2.0), 2.5),
        ];
        let h = 1e-6;
        for (ts, as_, tr, ar) in poses {
            let t_src = Isometry2::new(ts, as_);
            let t_ref = Isometry2::new(tr, ar);
            let rel = t_ref.inverse() * t_src;
            let (a, b) = relative_pose_jacobians(&rel);
            for k in 0..3 {
                let mut d = Vector3::zeros();
                d[k] = h;
                let plus = t_ref.inverse() * (t_src * perturb(&d));
                let minus = t_ref.inverse() * (t_src * perturb(&-d));
                let col = coord_diff(&plus, &minus) / (2.0 * h);
                assert!(
                    (col - a.column(k)).amax() < 1e-7,
                    "A col {k}: {col} vs {}",
                    a.column(k)
                );
                let plus = (t_ref * perturb(&d)).inverse() * t_src;
                let minus = (t_ref * perturb(&-d)).inverse() * t_src;
                let col = coord_diff(&plus, &minus) / (2.0 * h);
                assert!(
                    (col - b.column(k)).amax() < 1e-7,
                    "B col {k}: {col} vs {}",
                    b.column(k)
                );
            }
        }
    }

    /// Range along the nominal ray `α` of a scanner at `pose` (world ← scan) to the world line
    /// `mᵀx = d`.
    fn ray_range(pose: &Isometry2<f64>, alpha: f64, m: &Vector2<f64>, d: f64) -> f64 {
        let o = pose.translation.vector;
        let u = pose.rotation * Vector2::new(alpha.cos(), alpha.sin());
        (d - m.dot(&o)) / m.dot(&u)
    }

    #[test]
    fn information_equals_censi_range_form() {
        // Censi's form, computed independently: the range along each fixed nominal ray as a
        // function of the pose perturbation (finite differences), with the range variance
        // σ_r² + (σ_α r tan β)² of a beam deflected by the bearing error.
        let model = SensorModel {
            sigma_r_const_m: 0.01,
            ..sweep()
        };
        let pose = Isometry2::new(Vector2::new(1.5, -0.7), 0.4);
        let walls: [(Vector2<f64>, f64); 4] = [
            (Vector2::new(1.0, 0.0), 12.0),
            (Vector2::new(0.6, 0.8), 9.0),
            (Vector2::new(-0.8, 0.6), 7.0),
            (Vector2::new(0.0, -1.0), 5.0),
        ];
        let mut returns = Vec::new();
        let mut censi = Matrix3::zeros();
        let h = 1e-6;
        for (w, (m, d)) in walls.iter().enumerate() {
            for j in 0..9 {
                // Beams around the wall's foot of the perpendicular, incidences up to ~50°.
                let n = pose.rotation.inverse() * m;
                let foot = n.y.atan2(n.x);
                let alpha = foot + (j as f64 - 4.0) * 0.14 + 0.01 * w as f64;
                let r = ray_range(&pose, alpha, m, *d);
                assert!(r > 0.0);
                returns.push(BoundReturn {
                    range_m: r,
                    bearing_rad: alpha,
                    normal: n,
                });
                let mut grad = Vector3::zeros();
                for k in 0..3 {
                    let mut dk = Vector3::zeros();
                    dk[k] = h;
                    grad[k] = (ray_range(&(pose * perturb(&dk)), alpha, m, *d)
                        - ray_range(&(pose * perturb(&-dk)), alpha, m, *d))
                        / (2.0 * h);
                }
                let cos_b = n.dot(&Vector2::new(alpha.cos(), alpha.sin())).abs();
                let tan_b = (1.0 - cos_b * cos_b).sqrt() / cos_b;
                let var_rho =
                    model.sigma_r_m(r).powi(2) + (model.sigma_alpha_rad * r * tan_b).powi(2);
                censi += grad * grad.transpose() / var_rho;
            }
        }
        let info = scan_information(returns.iter().copied(), &model).unwrap();
        let rel = (info.matrix() - censi).amax() / censi.amax();
        assert!(rel < 1e-6, "{}\nvs\n{censi}", info.matrix());

        // And the Jacobian is the derivative of the point-to-line distance.
        for ret in &returns {
            let n = ret.normal.normalize();
            let p = Point2::from(ret.point_m());
            let m = pose.rotation * n;
            let d = m.dot(&(pose * p).coords);
            let mut grad = Vector3::zeros();
            for k in 0..3 {
                let mut dk = Vector3::zeros();
                dk[k] = h;
                let f = |e: &Vector3<f64>| m.dot(&(pose * perturb(e) * p).coords) - d;
                grad[k] = (f(&dk) - f(&-dk)) / (2.0 * h);
            }
            assert!((grad - ret.jacobian()).amax() < 1e-7);
        }
    }

    #[test]
    fn corridor_is_unbounded() {
        // Two parallel walls y = ±3, seen 40 m each way (longer than the range): nothing
        // constrains motion along x. Also with the corridor turned in the scan frame.
        let model = sweep();
        for turn in [0.0, 0.3, -1.2] {
            let along = Vector2::new(f64::cos(turn), f64::sin(turn));
            let normal = Vector2::new(-along.y, along.x);
            let mut returns = Vec::new();
            for i in -40..=40 {
                for side in [-3.0, 3.0] {
                    let p = along * (i as f64) + normal * side;
                    returns.push(BoundReturn {
                        range_m: p.norm(),
                        bearing_rad: p.y.atan2(p.x),
                        normal,
                    });
                }
            }
            let corridor = scan_information(returns, &model).unwrap();
            let good = scan_information(two_walls(10.0, 4.0, 6.0, 3.0), &model).unwrap();
            let t = Isometry2::new(Vector2::new(1.0, 0.1), 0.02);
            for (src, refr, role) in [
                (&corridor, &good, ScanRole::Source),
                (&good, &corridor, ScanRole::Reference),
            ] {
                match relative_pose_bound(src, refr, &t).unwrap() {
                    RelativeBound::Unbounded(u) => {
                        assert_eq!(u.scan, role);
                        assert!(u.condition > MAX_CONDITION);
                        // The unobserved direction is translation along the corridor.
                        assert!(
                            u.direction.xy().dot(&along).abs() > 1.0 - 1e-6,
                            "{turn}: {}",
                            u.direction
                        );
                    }
                    other => panic!("turn {turn}: expected unbounded, got {other:?}"),
                }
            }
            assert!(corridor.pose_bound(ScanRole::Source).is_err());
        }
        // No returns at all: nothing observed.
        let empty = scan_information(std::iter::empty(), &model).unwrap();
        assert!(matches!(
            empty.pose_bound(ScanRole::Source),
            Err(Unobservable { condition, .. }) if condition.is_infinite()
        ));
    }

    #[test]
    fn a_slightly_open_corridor_is_bounded_and_large() {
        // Walls 1° apart: ill-conditioned but observed; the bound is finite and much larger
        // along the corridor than across it.
        let model = sweep();
        let mut returns = Vec::new();
        for (side, tilt) in [(-3.0, 0.0f64), (3.0, 1f64.to_radians())] {
            let along = Vector2::new(tilt.cos(), tilt.sin());
            let normal = Vector2::new(-along.y, along.x);
            for i in -30..=30 {
                let p = along * (i as f64) + normal * side;
                returns.push(BoundReturn {
                    range_m: p.norm(),
                    bearing_rad: p.y.atan2(p.x),
                    normal,
                });
            }
        }
        let info = scan_information(returns, &model).unwrap();
        let b = info.pose_bound(ScanRole::Source).unwrap();
        assert!(b.covariance[(0, 0)] > 100.0 * b.covariance[(1, 1)]);
        assert!(b.trans_m().is_finite());
        let m = info.matrix();
        let l = info.lever_m();
        let s = Vector3::new(1.0, 1.0, 1.0 / l);
        let e = SymmetricEigen::new(Matrix3::from_fn(|i, j| s[i] * m[(i, j)] * s[j])).eigenvalues;
        // Far below MAX_CONDITION: x is observed through sin 1° of the tilted wall's normal.
        let condition = e.max() / e.min();
        assert!((1e3..1e6).contains(&condition), "{condition}");
    }

    #[test]
    fn invalid_inputs_are_errors() {
        let model = sweep();
        let ok = BoundReturn {
            range_m: 5.0,
            bearing_rad: 0.1,
            normal: Vector2::x(),
        };
        let bad = [
            BoundReturn {
                range_m: f64::NAN,
                ..ok
            },
            BoundReturn {
                range_m: -1.0,
                ..ok
            },
            BoundReturn { range_m: 0.0, ..ok },
            BoundReturn {
                bearing_rad: f64::INFINITY,
                ..ok
            },
            BoundReturn {
                normal: Vector2::zeros(),
                ..ok
            },
            BoundReturn {
                normal: Vector2::new(f64::NAN, 1.0),
                ..ok
            },
        ];
        for b in bad {
            assert!(scan_information([ok, b], &model).is_err(), "{b:?}");
        }
        let bad_model = SensorModel {
            sigma_alpha_rad: 0.0,
            ..model
        };
        assert!(scan_information([ok], &bad_model).is_err());
        // A non-unit normal is normalised.
        let scaled = BoundReturn {
            normal: Vector2::new(3.0, 0.0),
            ..ok
        };
        assert_eq!(
            scan_information([scaled], &model).unwrap(),
            scan_information([ok], &model).unwrap()
        );
        assert!(ScanInformation::from_matrix(Matrix3::from_element(f64::NAN), 1.0).is_err());
        assert!(ScanInformation::from_matrix(
            Matrix3::new(1.0, 2.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0),
            1.0
        )
        .is_err());
        assert!(ScanInformation::from_matrix(-Matrix3::identity(), 1.0).is_err());
        for lever in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            assert!(ScanInformation::from_matrix(Matrix3::identity(), lever).is_err());
        }
        let good = ScanInformation::from_matrix(Matrix3::identity(), 1.0).unwrap();
        let nan_pose = Isometry2::new(Vector2::new(f64::NAN, 0.0), 0.0);
        assert!(relative_pose_bound(&good, &good, &nan_pose).is_err());
    }

    #[test]
    fn the_decision_does_not_depend_on_units() {
        // Rotation in milliradians: I' = S I S with S = diag(1, 1, 10⁻³) and a lever of
        // L/1000 metres per milliradian. Same decision, the same covariance back in radians.
        let model = sweep();
        let info = scan_information(two_walls(10.0, 4.0, 6.0, 3.0), &model).unwrap();
        let s = Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, 1e-3));
        let scaled =
            ScanInformation::from_matrix(s * info.matrix() * s, info.lever_m() * 1e-3).unwrap();
        let c1 = info.pose_bound(ScanRole::Source).unwrap().covariance;
        let c2 = scaled.pose_bound(ScanRole::Source).unwrap().covariance;
        let back = s * c2 * s;
        assert!((back - c1).amax() < 1e-12 * c1.amax());
        // And the corridor stays unbounded in those units.
        let corridor = ScanInformation::from_matrix(
            s * Matrix3::from_diagonal(&Vector3::new(0.0, 1e4, 1e6)) * s,
            1e-2,
        )
        .unwrap();
        assert!(corridor.pose_bound(ScanRole::Source).is_err());
    }

    #[test]
    fn a_round_basin_seen_from_its_centre_leaves_rotation_unobserved() {
        // Every normal passes through the scanner: p × n = 0, rotation is not observed, yet
        // the translation is, and nothing correlates the two (equilibrating by diag(I) would
        // miss this once rounding leaves a tiny I_θθ).
        let model = sweep();
        let returns = (0..360).map(|j| {
            let a = (j as f64).to_radians();
            BoundReturn {
                range_m: 15.0,
                bearing_rad: a,
                normal: Vector2::new(a.cos(), a.sin()),
            }
        });
        let info = scan_information(returns, &model).unwrap();
        assert!(info.matrix()[(2, 2)] < 1e-20 * info.matrix()[(0, 0)]);
        match info.pose_bound(ScanRole::Reference) {
            Err(u) => {
                assert_eq!(u.scan, ScanRole::Reference);
                assert!(u.direction.z.abs() > 1.0 - 1e-9, "{}", u.direction);
            }
            Ok(b) => panic!("expected unobservable, got {b:?}"),
        }
    }
}
