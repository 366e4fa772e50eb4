//! Movement parameters from a registration (Naus & Marchel 2019, eqs. 23–25).
//!
//! # Sign convention
//! Registration gives `t_ref_src`, which maps scan k into scan k+1; the vessel's own motion from
//! k to k+1 is its inverse, so the vessel turns by `−θ` in the scan frame when `t_ref_src`
//! rotates by `θ`. Navigational heading grows *clockwise* seen from above. Whether a positive
//! scan-frame angle is clockwise depends on the sensor: a LIDAR whose bearings grow
//! counter-clockwise (the mathematical sense) gives `ΔHDG = +θ`; one whose bearings grow
//! clockwise (a mirrored frame) gives `ΔHDG = −θ`. The [`BearingSense`] of a dataset is
//! declared by its loader and checked against the reference heading on data.

use nalgebra::{Isometry2, Matrix3};
use serde::{Deserialize, Serialize};

use crate::IcpError;

/// The sense, seen from above, in which a scanner's bearings grow.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum BearingSense {
    /// Bearings grow counter-clockwise (mathematical sense).
    CounterClockwise,
    /// Bearings grow clockwise (navigational sense).
    Clockwise,
}

/// SOG, ΔCOG, ROT and HDG from one registration.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct MovementParams {
    /// Speed over ground `‖T‖ / Δt`, m/s (eq. 23).
    pub sog_mps: f64,
    /// Per-scan heading change, degrees in (−180, 180], clockwise positive: the ΔCOG of the
    /// paper's Table 1 (eq. 24, with atan2 instead of the printed arcsin).
    pub dcog_deg: f64,
    /// Rate of turn `ΔCOG / Δt`, degrees per second, clockwise positive (eq. 25).
    pub rot_dps: f64,
    /// Heading after the step, `HDG₀ + ΔCOG`, degrees in [0, 360).
    pub hdg_deg: f64,
}

impl MovementParams {
    /// Movement parameters of the step registered by `t_ref_src`, taken over `dt_s` seconds
    /// from heading `hdg0_deg`, for a scanner whose bearings grow in `sense`.
    pub fn from_registration(
        t_ref_src: &Isometry2<f64>,
        dt_s: f64,
        hdg0_deg: f64,
        sense: BearingSense,
    ) -> Result<Self, IcpError> {
        check_dt(dt_s)?;
        if !hdg0_deg.is_finite() {
            return Err(IcpError::NonFinite {
                what: "hdg0_deg",
                index: 0,
                value: hdg0_deg,
            });
        }
        let theta_deg = t_ref_src.rotation.angle().to_degrees(); // atan2, not the printed arcsin
        let dcog_deg = wrap_deg(match sense {
            BearingSense::CounterClockwise => theta_deg,
            BearingSense::Clockwise => -theta_deg,
        });
        Ok(Self {
            sog_mps: t_ref_src.translation.vector.norm() / dt_s, // eq. 23
            dcog_deg,
            rot_dps: dcog_deg / dt_s, // eq. 25
            hdg_deg: wrap_360(hdg0_deg + dcog_deg),
        })
    }
}

/// First-order standard errors of SOG, ΔCOG and ROT from the covariance `C` of `(tx m, ty m,
/// θ rad)` of `t_ref_src` (see [`crate::covariance`]).
///
/// Propagation through eqs. 23–25: `SOG = ‖t‖/Δt` has the gradient `(t/‖t‖, 0)/Δt`, so
/// `σ_SOG = √(uᵀ C_xy u)/Δt` with `u = t/‖t‖`; `ΔCOG = ±θ` (the sign of the [`BearingSense`]
/// does not change a variance), `σ_ΔCOG = √C_θθ`, in degrees; `ROT = ΔCOG/Δt`,
/// `σ_ROT = σ_ΔCOG/Δt`. At `‖t‖ = 0` the norm has no gradient; `σ_SOG` is then taken as
/// `√(tr C_xy)/Δt`, the RMS of `‖δt‖/Δt`. The linearisation holds while `‖t‖` is large
/// against `σ`: below that, SOG's distribution is skewed (a Rice distribution).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct MovementSigmas {
    /// Standard error of SOG, m/s.
    pub sog_mps: f64,
    /// Standard error of ΔCOG, degrees.
    pub dcog_deg: f64,
    /// Standard error of ROT, degrees per second.
    pub rot_dps: f64,
}

impl MovementSigmas {
    /// The standard errors of the movement parameters of `t_ref_src` over `dt_s` seconds,
    /// whose covariance is `cov`. Errors: a non-positive or non-finite `dt_s`, a non-finite
    /// `cov`.
    pub fn propagate(
        t_ref_src: &Isometry2<f64>,
        cov: &Matrix3<f64>,
        dt_s: f64,
    ) -> Result<Self, IcpError> {
        check_dt(dt_s)?;
        if let Some((index, &value)) = cov.iter().enumerate().find(|(_, v)| !v.is_finite()) {
            return Err(IcpError::NonFinite {
                what: "covariance",
                index,
                value,
            });
        }
        let t = t_ref_src.translation.vector;
        let norm = t.norm();
        let var_sog = if norm > 0.0 {
            let u = t / norm;
            u.x * u.x * cov[(0, 0)] + 2.0 * u.x * u.y * cov[(0, 1)] + u.y * u.y * cov[(1, 1)]
        } else {
            cov[(0, 0)] + cov[(1, 1)]
        };
        let dcog_deg = cov[(2, 2)].max(0.0).sqrt().to_degrees();
        Ok(Self {
            sog_mps: var_sog.max(0.0).sqrt() / dt_s, // eq. 23
            dcog_deg,                                // eq. 24
            rot_dps: dcog_deg / dt_s,                // eq. 25
        })
    }
}

/// `Err` unless the time between the scans, `dt_s`, is finite and positive.
fn check_dt(dt_s: f64) -> Result<(), IcpError> {
    if dt_s.is_finite() && dt_s > 0.0 {
        Ok(())
    } else {
        Err(IcpError::InvalidParameter {
            name: "dt_s",
            value: dt_s,
            reason: "the time between scans must be finite and positive",
        })
    }
}

/// Wraps an angle to (−180°, 180°].
pub fn wrap_deg(angle_deg: f64) -> f64 {
    let a = (angle_deg + 180.0).rem_euclid(360.0) - 180.0;
    if a == -180.0 {
        180.0
    } else {
        a
    }
}

/// Wraps an angle to [0°, 360°).
pub fn wrap_360(angle_deg: f64) -> f64 {
    let a = angle_deg.rem_euclid(360.0);
    if a >= 360.0 {
        0.0
    } else {
        a
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector2;

    #[test]
    fn wrapping() {
        assert_eq!(wrap_deg(180.0), 180.0);
        assert_eq!(wrap_deg(-180.0), 180.0);
        assert_eq!(wrap_deg(190.0), -170.0);
        assert_eq!(wrap_deg(-190.0), 170.0);
        assert_eq!(wrap_deg(720.5), 0.5);
        assert_eq!(wrap_360(-10.0), 350.0);
        assert_eq!(wrap_360(360.0), 0.0);
        assert_eq!(wrap_360(-1e-20), 0.0);
    }

    #[test]
    fn vessel_turning_to_starboard() {
        // A vessel moving 1.2 m ahead and turning 2° clockwise (to starboard) in 1 s.
        // In a counter-clockwise scan frame (x ahead, y to port) its pose at k+1 in frame k is
        // translation (1.2, 0) and rotation −2°; scans register by the inverse of that pose.
        let pose_k_k1 = Isometry2::new(Vector2::new(1.2, 0.0), (-2.0f64).to_radians());
        let t_ref_src = pose_k_k1.inverse();
        let m = MovementParams::from_registration(
            &t_ref_src,
            1.0,
            359.0,
            BearingSense::CounterClockwise,
        )
        .unwrap();
        assert!((m.sog_mps - 1.2).abs() < 1e-12);
        assert!((m.dcog_deg - 2.0).abs() < 1e-12);
        assert!((m.rot_dps - 2.0).abs() < 1e-12);
        assert!((m.hdg_deg - 1.0).abs() < 1e-9);
        // The same motion seen by a clockwise scanner (y to starboard) is mirrored.
        let mirrored = Isometry2::new(Vector2::new(1.2, 0.0), 2.0f64.to_radians()).inverse();
        let c = MovementParams::from_registration(&mirrored, 0.5, 0.0, BearingSense::Clockwise)
            .unwrap();
        assert!((c.dcog_deg - 2.0).abs() < 1e-12 && (c.rot_dps - 4.0).abs() < 1e-12);
        assert!((c.sog_mps - 2.4).abs() < 1e-12);
    }

    #[test]
    fn propagation_agrees_with_a_monte_carlo_of_eqs_23_to_25() {
        use nalgebra::{Cholesky, Vector3};
        use rand::SeedableRng;
        use rand_distr::{Distribution, StandardNormal};
        let t = Isometry2::new(Vector2::new(0.9, -0.4), 0.03);
        let cov = Matrix3::new(4e-4, 1e-4, 2e-6, 1e-4, 2.5e-4, -1e-6, 2e-6, -1e-6, 9e-6);
        let dt = 0.5;
        let sig = MovementSigmas::propagate(&t, &cov, dt).unwrap();
        let l = Cholesky::new(cov).unwrap().l();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(23);
        const N: usize = 20_000;
        let (mut sog, mut dcog, mut rot) = (Vec::new(), Vec::new(), Vec::new());
        for _ in 0..N {
            let z = Vector3::from_fn(|_, _| StandardNormal.sample(&mut rng));
            let d = l * z;
            let g = Isometry2::new(
                t.translation.vector + Vector2::new(d.x, d.y),
                t.rotation.angle() + d.z,
            );
            let m =
                MovementParams::from_registration(&g, dt, 10.0, BearingSense::Clockwise).unwrap();
            sog.push(m.sog_mps);
            dcog.push(m.dcog_deg);
            rot.push(m.rot_dps);
        }
        let sd = |v: &[f64]| {
            let mean = v.iter().sum::<f64>() / v.len() as f64;
            (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (v.len() - 1) as f64).sqrt()
        };
        // A sample standard deviation of N draws has relative standard error 1/√(2(N−1))
        // (0.5 %); the curvature of ‖t‖ adds ~σ²/(2‖t‖²) ≈ 0.02 % here.
        let se = 1.0 / (2.0 * (N - 1) as f64).sqrt();
        for (what, mc, first) in [
            ("sog", sd(&sog), sig.sog_mps),
            ("dcog", sd(&dcog), sig.dcog_deg),
            ("rot", sd(&rot), sig.rot_dps),
        ] {
            assert!(
                (mc / first - 1.0).abs() < 3.0 * se,
                "{what}: {mc} vs {first}"
            );
        }
        // Bad input: a NaN covariance or time step is an error, not a NaN sigma.
        let mut bad = cov;
        bad[(1, 1)] = f64::NAN;
        assert!(MovementSigmas::propagate(&t, &bad, dt).is_err());
        assert!(MovementSigmas::propagate(&t, &cov, 0.0).is_err());
        // At rest: √(tr C_xy)/Δt.
        let rest = MovementSigmas::propagate(&Isometry2::identity(), &cov, dt).unwrap();
        assert!((rest.sog_mps - (6.5e-4f64).sqrt() / dt).abs() < 1e-15);
    }

    #[test]
    fn bad_time_step_is_an_error() {
        let t = Isometry2::identity();
        for dt in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            assert!(
                MovementParams::from_registration(&t, dt, 0.0, BearingSense::Clockwise).is_err()
            );
        }
    }
}
