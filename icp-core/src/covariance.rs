//! The covariance of a registration's `t_ref_src` over `(tx m, ty m, θ rad)`: Censi's closed
//! form (Censi 2007, "An accurate closed-form estimate of ICP's covariance", ICRA) for the
//! surface metrics, computed once after the ICP loop from its final pairs and weights.
//!
//! # Derivation
//! At the solution `x̂` the gradient of the cost `J(z, x) = Σ_i w_i e_iᵀ Ω_i e_i` vanishes;
//! perturbing the measurements `z` (both scans' returns) by `δz` moves it by (implicit function
//! theorem, Censi 2007 eq. 4)
//!
//! ```text
//! δx = −(∂²J/∂x²)⁻¹ (∂²J/∂z∂x) δz,
//! Cov(x̂) = (∂²J/∂x²)⁻¹ (∂²J/∂z∂x) Σ_z (∂²J/∂z∂x)ᵀ (∂²J/∂x²)⁻¹.
//! ```
//!
//! With `e_i = R p_i + T − q_i`, `Ω_i` and `w_i` held at the solution (the weights of the final
//! iteration, robust factor included), `∂²J/∂x² = 2H`, `H = Σ w Eᵢᵀ Ω E_i` (`E_i = ∂e_i/∂δ`,
//! the metric's Jacobian over the increment `δ`, see `metric::NormalEquations`) and
//! `∂²J/∂z∂x δz = 2 Σ w E_iᵀ Ω_i δe_i` to first order (the term in `e_i` itself vanishes with
//! the residuals); the factors 2 cancel. A pair's end moves by its return's noise, so `δe_i = R δp_i − δq_i` and
//!
//! ```text
//! Cov(δ̂) = H⁻¹ M H⁻¹,   M = Σ_i w_i² E_iᵀ Ω_i (R C_p,i Rᵀ + C_q,i) Ω_i E_i,
//! ```
//!
//! `C` the sensor covariance of eq. 8 (Naus & Marchel 2019) of the pair's source return (scan
//! frame k) and reference return (frame k+1): both scans are noisy. Point-to-line is the case
//! `Ω = n nᵀ`, where the middle term is `Σ w² j jᵀ nᵀ(R C_p Rᵀ + C_q)n` (eq. 9 along the normal).
//!
//! ## Neighbourhood means
//! By default the metrics take a pair's ends at the means of the returns' neighbourhoods
//! (`metric::Anchor`); a mean of `k` returns carries `1/k` of each one's noise, but
//! each return enters the `k` means around it, whose pairs have nearly the same `E` and `n`: the
//! contributions add back to one return's. To first order, with every return in about one pair,
//! `M` is the sum above with each pair charged its own two returns' noise.
//!
//! ## Left out
//! The noise of the normals (it enters through the residual along the tangent), the dependence
//! of the matching on the noise (valid for point-to-line, not point-to-point: Bonnabel et al.
//! 2016, so point-to-point has no closed form here), the sampling of surfaces by discrete beams
//! and any bias of the sensor. Callers account for them by an inflation measured on data with
//! exact truth (see `eval`'s consistency report), or by the grouped jackknife over sectors
//! ([`Sandwich::jackknife_covariance`]), which sees what the residuals show.
//!
//! ## Coordinates
//! The increment `δ` turns about the centre `c` of the moved source points and is applied on
//! the left, `t' = R(δθ)(t − c) + c + δ_xy`, so the covariance of `(tx, ty, θ)` is
//! `G Cov(δ̂) Gᵀ` with `G = [[I, J(t − c)], [0, 1]]`, `J(v) = (−v_y, v_x)`.
//!
//! ## Unbounded
//! A direction the final pairs do not constrain (a corridor's axis) makes `H` singular. In
//! the units of [`crate::bound`] (rotation as the arc at the RMS distance `L` of the moved
//! points from `c`), a condition number of `H` above [`crate::bound::MAX_CONDITION`] gives
//! [`Covariance::Unbounded`] with the direction, never a NaN or a huge number.

use nalgebra::{Isometry2, Matrix2, Matrix2x3, Matrix3, Point2, SymmetricEigen, Vector3};

use crate::bound::MAX_CONDITION;

/// The covariance of a registration's `t_ref_src` over `(tx m, ty m, θ rad)`.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum Covariance {
    /// A finite covariance: m² on the translation block, rad² on `θ`, m·rad across.
    Bounded(Matrix3<f64>),
    /// The final pairs leave a direction unconstrained: its variance is unbounded.
    Unbounded {
        /// The least-constrained direction over `(δx m, δy m, L·δθ m)` (unit length, sign
        /// arbitrary), `L` the RMS distance of the moved source points from their centre.
        direction: Vector3<f64>,
        /// Condition number of `H` in those units (infinite when a direction carries nothing),
        /// above [`MAX_CONDITION`].
        condition: f64,
    },
}

impl Covariance {
    /// The finite covariance, if there is one.
    pub fn bounded(&self) -> Option<&Matrix3<f64>> {
        match self {
            Covariance::Bounded(c) => Some(c),
            Covariance::Unbounded { .. } => None,
        }
    }

    /// True when a direction is unconstrained.
    pub fn is_unbounded(&self) -> bool {
        matches!(self, Covariance::Unbounded { .. })
    }
}

/// Angular sectors (about the reference scanner) of the grouped jackknife
/// ([`Sandwich::jackknife_covariance`]): 45° each.
pub const JACKKNIFE_SECTORS: usize = 8;

/// The sums of the closed form over the final pairs of a registration, about the centre of
/// the increment's turn (see the module documentation).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sandwich {
    /// The centre `c` of the increment's turn.
    pub center: Point2<f64>,
    /// `H = Σ w Eᵀ Ω E`.
    pub hessian: Matrix3<f64>,
    /// `M = Σ w² Eᵀ Ω Σ_e Ω E`, `Σ_e` the covariance of the pair's difference.
    pub middle: Matrix3<f64>,
    /// Per sector of [`JACKKNIFE_SECTORS`]: its pairs' part of `H`.
    sector_hessian: [Matrix3<f64>; JACKKNIFE_SECTORS],
    /// Per sector: the sum of its pairs' scores `g = w Eᵀ Ω e` at the solution.
    sector_score: [Vector3<f64>; JACKKNIFE_SECTORS],
    /// `Σ |m − c|²` over the pairs added, m².
    spread_m2: f64,
    /// Pairs added.
    count: usize,
}

impl Sandwich {
    /// No pair yet, about `center`.
    pub(crate) fn about(center: Point2<f64>) -> Self {
        Self {
            center,
            hessian: Matrix3::zeros(),
            middle: Matrix3::zeros(),
            sector_hessian: [Matrix3::zeros(); JACKKNIFE_SECTORS],
            sector_score: [Vector3::zeros(); JACKKNIFE_SECTORS],
            spread_m2: 0.0,
            count: 0,
        }
    }

    /// Adds a pair's part of `H` and its score `g = w Eᵀ Ω e` to the sector of its moved
    /// source end (its bearing from the reference scanner).
    #[inline]
    fn add_to_sector(&mut self, moved: &Point2<f64>, hessian: &Matrix3<f64>, g: &Vector3<f64>) {
        let turn = (moved.y.atan2(moved.x) + std::f64::consts::PI) / std::f64::consts::TAU;
        let sector = ((turn * JACKKNIFE_SECTORS as f64) as usize).min(JACKKNIFE_SECTORS - 1);
        self.sector_hessian[sector] += hessian;
        self.sector_score[sector] += g;
    }

    /// Adds a pair of weight `w` whose moved source end is `moved`, with Jacobian `e_jac`
    /// (`∂e/∂δ`), weight matrix `omega`, difference covariance `noise` (m²) and residual
    /// `e` (m) at the solution.
    #[inline]
    pub(crate) fn add(
        &mut self,
        moved: &Point2<f64>,
        e_jac: &Matrix2x3<f64>,
        omega: &Matrix2<f64>,
        noise: &Matrix2<f64>,
        e: &nalgebra::Vector2<f64>,
        w: f64,
    ) {
        let a = omega * e_jac; // Ω E
        let h = e_jac.transpose() * a * w;
        self.hessian += h;
        self.middle += a.transpose() * noise * a * (w * w);
        self.add_to_sector(moved, &h, &(a.transpose() * e * w));
        self.spread_m2 += (moved - self.center).norm_squared();
        self.count += 1;
    }

    /// Adds a pair of weight `w` with a scalar residual (point-to-line: `Ω = n nᵀ`), whose
    /// moved source end is `moved`, gradient `j = Eᵀn`, residual variance `variance_m2` and
    /// residual `r` (m) at the solution: the same sums as [`Sandwich::add`] with `Ω = n nᵀ`,
    /// `nᵀ Σ_e n = variance_m2`.
    #[inline]
    pub(crate) fn add_scalar(
        &mut self,
        moved: &Point2<f64>,
        j: &Vector3<f64>,
        variance_m2: f64,
        r: f64,
        w: f64,
    ) {
        let jj = j * j.transpose();
        self.hessian += jj * w;
        self.middle += jj * (w * w * variance_m2);
        self.add_to_sector(moved, &(jj * w), &(j * (w * r)));
        self.spread_m2 += (moved - self.center).norm_squared();
        self.count += 1;
    }

    /// The RMS distance of the added moved source ends from the centre, m (0 without pairs).
    pub fn lever_m(&self) -> f64 {
        if self.count == 0 {
            0.0
        } else {
            (self.spread_m2 / self.count as f64).sqrt()
        }
    }

    /// The covariance of `(tx, ty, θ)` of `t_ref_src`, the estimate the sums were made at.
    pub fn covariance(&self, t_ref_src: &Isometry2<f64>) -> Covariance {
        self.covariance_with(&self.middle, t_ref_src)
    }

    /// The grouped (delete-one-sector) jackknife of `(tx, ty, θ)`: the solution without
    /// sector `s`'s pairs moves, to first order, by `δ_s = (H − H_s)⁻¹ g_s` (`g_s` the sector's
    /// scores, their total vanishing at the solution), and `Cov = (S − 1)/S Σ_s δ_s δ_sᵀ` over
    /// the `S` sectors with pairs (Efron & Stein 1981; clusters of correlated errors:
    /// Cameron & Miller 2015). Errors shared within a sector and a sector that pulls against
    /// the rest (a moving boat, a wall's distortion) show here when no single residual is
    /// large. A sector whose removal leaves `H` (near) singular carries a direction alone; its
    /// move is taken with the whole `H`, `δ_s = H⁻¹ g_s` (the cluster-robust sandwich's term).
    /// Unbounded where the closed form is.
    pub fn jackknife_covariance(&self, t_ref_src: &Isometry2<f64>) -> Covariance {
        let closed = self.covariance(t_ref_src);
        if closed.is_unbounded() {
            return closed;
        }
        let scale = Vector3::new(1.0, 1.0, 1.0 / self.lever_m());
        let inverse = |m: &Matrix3<f64>| {
            let scaled = Matrix3::from_fn(|i, j| scale[i] * m[(i, j)] * scale[j]);
            let eig = SymmetricEigen::new(scaled);
            let (min, max) = eig
                .eigenvalues
                .iter()
                .fold((f64::INFINITY, 0.0f64), |(lo, hi), v| {
                    (lo.min(*v), hi.max(*v))
                });
            (min > 0.0 && max / min <= MAX_CONDITION).then(|| {
                eig.eigenvectors
                    * Matrix3::from_diagonal(&eig.eigenvalues.map(|v| 1.0 / v))
                    * eig.eigenvectors.transpose()
            })
        };
        let Some(whole) = inverse(&self.hessian) else {
            return closed;
        };
        let mut sum = Matrix3::zeros();
        let mut used = 0usize;
        for (h_s, g_s) in self.sector_hessian.iter().zip(&self.sector_score) {
            if h_s.iter().all(|v| *v == 0.0) {
                continue;
            }
            let inv = inverse(&(self.hessian - h_s)).unwrap_or(whole);
            let scaled_g = g_s.component_mul(&scale);
            let delta = (inv * scaled_g).component_mul(&scale);
            sum += delta * delta.transpose();
            used += 1;
        }
        if used < 2 {
            return closed;
        }
        let cov_delta = sum * ((used - 1) as f64 / used as f64);
        Covariance::Bounded(self.in_pose_coordinates(&cov_delta, t_ref_src))
    }

    /// `G Cov(δ) Gᵀ` (symmetrised): from the increment about the centre to `(tx, ty, θ)`.
    fn in_pose_coordinates(
        &self,
        cov_delta: &Matrix3<f64>,
        t_ref_src: &Isometry2<f64>,
    ) -> Matrix3<f64> {
        let v = t_ref_src.translation.vector - self.center.coords;
        let g = Matrix3::new(1.0, 0.0, -v.y, 0.0, 1.0, v.x, 0.0, 0.0, 1.0);
        let c = g * cov_delta * g.transpose();
        (c + c.transpose()) * 0.5
    }

    fn covariance_with(&self, middle: &Matrix3<f64>, t_ref_src: &Isometry2<f64>) -> Covariance {
        let lever = self.lever_m();
        let unbounded = |direction: Vector3<f64>, condition: f64| Covariance::Unbounded {
            direction,
            condition,
        };
        if !(lever > 0.0 && lever.is_finite()) {
            return unbounded(Vector3::z(), f64::INFINITY);
        }
        let s = Vector3::new(1.0, 1.0, 1.0 / lever);
        let scaled = Matrix3::from_fn(|i, j| s[i] * self.hessian[(i, j)] * s[j]);
        if !scaled.iter().all(|v| v.is_finite()) {
            return unbounded(Vector3::z(), f64::INFINITY);
        }
        let eig = SymmetricEigen::new(scaled);
        let (mut lo, mut hi) = (0, 0);
        for k in 1..3 {
            if eig.eigenvalues[k] < eig.eigenvalues[lo] {
                lo = k;
            }
            if eig.eigenvalues[k] > eig.eigenvalues[hi] {
                hi = k;
            }
        }
        let (min, max) = (eig.eigenvalues[lo], eig.eigenvalues[hi]);
        let condition = if min > 0.0 { max / min } else { f64::INFINITY };
        if condition.is_nan() || condition > MAX_CONDITION {
            return unbounded(eig.eigenvectors.column(lo).into_owned(), condition);
        }
        // H⁻¹ = S (S H S)⁻¹ S, from the eigen-decomposition.
        let inv_scaled = eig.eigenvectors
            * Matrix3::from_diagonal(&eig.eigenvalues.map(|v| 1.0 / v))
            * eig.eigenvectors.transpose();
        let h_inv = Matrix3::from_fn(|i, j| s[i] * inv_scaled[(i, j)] * s[j]);
        let cov_delta = h_inv * middle * h_inv;
        Covariance::Bounded(self.in_pose_coordinates(&cov_delta, t_ref_src))
    }
}
