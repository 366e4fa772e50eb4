//! The extended covariance: the closed form made to hold beyond the sensor model.
//!
//! Censi's closed form (`icp_core::covariance`) carries only the noise the dataset's sensor
//! model states. Real scans carry more: grazing-incidence and heavy-tailed range errors, mixed
//! pixels, a tilted scan plane, motion within the revolution, objects that move. The extended
//! covariance is the direction-wise larger ([`directional_max`]) of the closed form `C` (times
//! its inflation, `closed_form_inflation` in the `covariance` module) and the grouped jackknife `C_jk` of the same final
//! pairs over eight 45° sectors (`icp_core::covariance::Sandwich::jackknife_covariance`): how
//! far the solution moves when each sector's pairs are left out. `C_jk` sees the errors the
//! residuals show, and errors shared within a sector that no single residual shows (a moving
//! boat, a distorted wall); it needs no model and no re-registration: a few 3×3 solves per
//! registration.
//!
//! Chosen on the rough harbour and aces, checked on the paper harbour and marina (see the
//! README, "How far to trust a number"). Two other candidates were measured and left out: an
//! a-posteriori variance factor from an autocorrelation-consistent sandwich of the residuals
//! (rough harbour HD_PL_ICP ANEES/3 4.1, 60 % inside: residuals alone miss the shared errors),
//! and a floor (any floor that brings the rough harbour inside its interval takes the paper
//! harbour's ANEES/3 below 0.8). The perturbed-restart term is a mode of its own
//! (the `restarts` module).

use icp_core::{Covariance, Registration};
use nalgebra::Matrix3;

use crate::run::covariance::{reported, CovarianceMode};

/// The direction-wise larger of `closed` and `empirical`: in the metric of `closed` (`C =
/// L Lᵀ`), the eigenvalues `λ` of `L⁻¹ E L⁻ᵀ` raised to at least 1, `L V max(1, Λ) Vᵀ Lᵀ`:
/// `closed` where the data agree with it, `empirical` along the directions where they show
/// more. `None` when `closed` is not positive definite.
pub fn directional_max(closed: &Matrix3<f64>, empirical: &Matrix3<f64>) -> Option<Matrix3<f64>> {
    let l = closed.cholesky()?.l();
    let l_inv = l.try_inverse()?;
    let e = l_inv * empirical * l_inv.transpose();
    let eig = nalgebra::SymmetricEigen::new((e + e.transpose()) * 0.5);
    let lifted = eig.eigenvectors
        * Matrix3::from_diagonal(&eig.eigenvalues.map(|v| v.max(1.0)))
        * eig.eigenvectors.transpose();
    let c = l * lifted * l.transpose();
    let c = (c + c.transpose()) * 0.5;
    c.iter().all(|v| v.is_finite()).then_some(c)
}

/// The extended covariance of `reg` (the module documentation), its closed form times
/// `inflation`: unbounded where the closed form is, `None` where there is none.
pub fn extended(reg: &Registration, inflation: f64) -> Option<Covariance> {
    let closed = reported(&reg.covariance?, CovarianceMode::ClosedForm, inflation);
    let Covariance::Bounded(c) = closed else {
        return Some(closed);
    };
    let lifted = match reg.jackknife_covariance {
        Some(Covariance::Bounded(e)) => directional_max(&c, &e).unwrap_or(c),
        _ => c,
    };
    Some(Covariance::Bounded(lifted))
}

/// The covariance of `reg` as the report uses it under `mode`: [`extended`] for
/// [`CovarianceMode::Extended`], else [`reported`].
pub fn of_registration(
    reg: &Registration,
    mode: CovarianceMode,
    inflation: f64,
) -> Option<Covariance> {
    match mode {
        CovarianceMode::Extended => extended(reg, inflation),
        _ => Some(reported(&reg.covariance?, mode, inflation)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_directional_max_keeps_the_larger_along_each_direction() {
        let c = Matrix3::new(4e-4, 1e-5, 0.0, 1e-5, 2e-4, 1e-6, 0.0, 1e-6, 1e-6);
        // Against itself, or anything smaller, it is itself.
        assert!((directional_max(&c, &c).unwrap() - c).norm() < 1e-18);
        assert!((directional_max(&c, &(c * 0.5)).unwrap() - c).norm() < 1e-18);
        assert!((directional_max(&c, &(c * 4.0)).unwrap() - c * 4.0).norm() < 1e-15);
        // diag(1, 1, 1) against diag(4, 0.25, 1): diag(4, 1, 1).
        let e = Matrix3::from_diagonal(&nalgebra::Vector3::new(4.0, 0.25, 1.0));
        let m = directional_max(&Matrix3::identity(), &e).unwrap();
        let want = Matrix3::from_diagonal(&nalgebra::Vector3::new(4.0, 1.0, 1.0));
        assert!((m - want).norm() < 1e-12, "{m}");
        assert_eq!(directional_max(&Matrix3::zeros(), &e), None);
    }
}
