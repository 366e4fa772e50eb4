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

use nalgebra::Isometry2;
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
        if !(dt_s.is_finite() && dt_s > 0.0) {
            return Err(IcpError::InvalidParameter {
                name: "dt_s",
                value: dt_s,
                reason: "the time between scans must be finite and positive",
            });
        }
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
    fn bad_time_step_is_an_error() {
        let t = Isometry2::identity();
        for dt in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            assert!(
                MovementParams::from_registration(&t, dt, 0.0, BearingSense::Clockwise).is_err()
            );
        }
    }
}
