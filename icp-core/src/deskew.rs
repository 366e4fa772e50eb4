//! Motion distortion taken out of a scan (issue 35, item 5): a scanner that turns its beam
//! through a sweep takes each return from where the vessel is at that return's time, yet
//! reports it in one frame. Given the vessel's body twist over the sweep (surge, sway, yaw
//! rate, held constant: the smoother's twist of the scan, [`crate::sequence::ScanEstimate`]),
//! [`deskew`] moves each return to where the scanner saw it from at the scan's reference time.
//!
//! # Frames and times
//! A return taken `τ` seconds after the scan's reference time, from the scanner's pose
//! `t_ref_at(τ) = Exp(τ·ϖ)` (the body frame at the reference time, constant twist `ϖ`: the
//! smoother's prior, `T_k+1 = T_k Exp(Δt ϖ_k)`), at range `r` and bearing `α`, is reported
//! as the point `p = (r cos α, r sin α)` (eq. 10) although it lies at `t_ref_at(τ) · p` in the
//! reference frame. [`deskew`] gives that point, with the exact SE(2) exponential (the
//! smoother's, `V(φ)` in closed form), not its first-order `p + τ(v + ω × p)`: over a 0.2 s
//! revolution turning 10°/s the first order misses ~6e-4 of the range across.
//!
//! [`Sweep`] states when each return was taken from its bearing: the beam turns at a constant
//! rate, counter-clockwise, through `span_rad` from `start_bearing_rad` at the reference time,
//! in `duration_s`. The synthetic scanners' revolution ([`Sweep::revolution`]) starts at
//! bearing 0 (the scan frame's `+x`) at the scan's timestamp and turns once in the rotation
//! period (`datasets::synthetic`: beam `j` of `N` at `t + T·j/N`, bearing `φ₀ + 2πj/N` with a
//! phase `φ₀` below one beam): the time read from the bearing is late by `T·φ₀/2π`, less than
//! one beam's time.

use nalgebra::{Isometry2, Point2, Vector3};

use crate::scan::{ReadingTruth, Scan};
use crate::sequence::{exp_from, wrap_rad, Geometry};
use crate::IcpError;

/// The vessel's body twist, held constant over a sweep.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BodyTwist {
    /// Along the scan frame's `+x`, m/s.
    pub surge_mps: f64,
    /// Along the scan frame's `+y`, m/s.
    pub sway_mps: f64,
    /// Counter-clockwise (from `+x` towards `+y`), rad/s.
    pub yaw_rate_radps: f64,
}

impl BodyTwist {
    /// `(surge, sway, yaw)` as the smoother's [`crate::sequence::ScanEstimate::twist`] has it.
    pub fn from_vector(twist: &Vector3<f64>) -> Self {
        Self {
            surge_mps: twist.x,
            sway_mps: twist.y,
            yaw_rate_radps: twist.z,
        }
    }

    /// The scanner's pose `dt_s` after the reference time, in the reference frame:
    /// `Exp(dt_s · ϖ)`, exactly.
    pub fn pose_after(&self, dt_s: f64) -> Isometry2<f64> {
        let xi = Vector3::new(self.surge_mps, self.sway_mps, self.yaw_rate_radps) * dt_s;
        let p = exp_from(Geometry::Se2, &Vector3::zeros(), &xi);
        // Not the wrapped p.z: a sweep may turn by more than π.
        Isometry2::new(p.xy(), xi.z)
    }

    fn check(&self) -> Result<(), IcpError> {
        for (name, value) in [
            ("surge_mps", self.surge_mps),
            ("sway_mps", self.sway_mps),
            ("yaw_rate_radps", self.yaw_rate_radps),
        ] {
            if !value.is_finite() {
                return Err(IcpError::InvalidParameter {
                    name,
                    value,
                    reason: "the twist must be finite",
                });
            }
        }
        Ok(())
    }
}

/// When a scan's returns were taken: the beam turns counter-clockwise at a constant rate through
/// `span_rad` from `start_bearing_rad`, in `duration_s`, starting at the scan's reference time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sweep {
    /// Seconds from the sweep's start to its end (≥ 0; 0: every return at one instant).
    pub duration_s: f64,
    /// Bearing at the reference time, radians.
    pub start_bearing_rad: f64,
    /// Bearings swept in `duration_s`, radians (> 0).
    pub span_rad: f64,
}

impl Sweep {
    /// One counter-clockwise turn from bearing 0 in `duration_s`: the synthetic scanners'.
    pub fn revolution(duration_s: f64) -> Self {
        Self {
            duration_s,
            start_bearing_rad: 0.0,
            span_rad: std::f64::consts::TAU,
        }
    }

    /// Each return's time after the reference time, seconds, from its bearing. A bearing
    /// outside `[start, start + span]` is an error (the sweep does not say when it was taken),
    /// as is a duration or span out of its domain; without a duration every return is at the
    /// reference time, whatever its bearing (a fan cast from one pose).
    pub fn offsets_s(&self, scan: &Scan) -> Result<Vec<f64>, IcpError> {
        if !(self.duration_s.is_finite() && self.duration_s >= 0.0) {
            return Err(IcpError::InvalidParameter {
                name: "sweep duration_s",
                value: self.duration_s,
                reason: "must be finite and non-negative",
            });
        }
        if !(self.span_rad.is_finite() && self.span_rad > 0.0 && self.start_bearing_rad.is_finite())
        {
            return Err(IcpError::InvalidParameter {
                name: "sweep span_rad",
                value: self.span_rad,
                reason: "must be finite and positive, from a finite start bearing",
            });
        }
        if self.duration_s == 0.0 {
            return Ok(vec![0.0; scan.len()]);
        }
        scan.returns()
            .iter()
            .map(|r| {
                let swept = r.bearing_rad - self.start_bearing_rad;
                if (0.0..=self.span_rad).contains(&swept) {
                    Ok(self.duration_s * swept / self.span_rad)
                } else {
                    Err(IcpError::InvalidParameter {
                        name: "bearing",
                        value: r.bearing_rad,
                        reason: "outside the sweep: when it was taken is not known",
                    })
                }
            })
            .collect()
    }
}

/// `scan` with each return moved to where the scanner saw it from at the reference time: the
/// return taken `offsets_s[i]` after it (aligned with [`Scan::returns`]), the vessel moving by
/// `twist`. Range and bearing follow the moved point (the bearing kept on its branch, so a
/// revolution's bearings stay in order); truth and timestamp are kept (the true normals are in
/// the scan frame, which is the reference time's). A moved point at the scanner (range 0) or
/// not finite is an error rather than a dropped return, so indices into the scan stay valid.
pub fn deskew(scan: &Scan, offsets_s: &[f64], twist: &BodyTwist) -> Result<Scan, IcpError> {
    twist.check()?;
    if offsets_s.len() != scan.len() {
        return Err(IcpError::LengthMismatch {
            what: "sweep time offsets",
            expected: scan.len(),
            got: offsets_s.len(),
        });
    }
    let mut ranges_m = Vec::with_capacity(scan.len());
    let mut bearings_rad = Vec::with_capacity(scan.len());
    for (index, (r, &dt_s)) in scan.returns().iter().zip(offsets_s).enumerate() {
        if !dt_s.is_finite() {
            return Err(IcpError::NonFinite {
                what: "sweep time offset",
                index,
                value: dt_s,
            });
        }
        let moved: Point2<f64> = twist.pose_after(dt_s) * r.point;
        let range_m = moved.coords.norm();
        if !(range_m.is_finite() && range_m > 0.0) {
            return Err(IcpError::ZeroLength {
                what: "deskewed return",
                index,
            });
        }
        ranges_m.push(range_m);
        bearings_rad.push(r.bearing_rad + wrap_rad(moved.y.atan2(moved.x) - r.bearing_rad));
    }
    let truth = ReadingTruth {
        true_normals: scan.true_normals(),
        moving: scan.moving(),
    };
    let moved = Scan::from_polar_with_truth(&ranges_m, &bearings_rad, truth)?;
    match scan.timestamp_s() {
        Some(t) => moved.with_timestamp(t),
        None => Ok(moved),
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::{Rotation2, Vector2};
    use std::f64::consts::TAU;

    use super::*;

    /// The scanner's pose `tau` after the reference time under the constant body twist `t`,
    /// from geometry rather than the exponential's closed form: with a yaw rate `ω` the body
    /// turns by `ωτ` about its instantaneous centre of rotation `c = (−v, u)/ω` (where the
    /// body velocity `(u, v) + ω × c` vanishes), without one it goes straight.
    fn pose_truth(t: &BodyTwist, tau: f64) -> Isometry2<f64> {
        let (u, v, w) = (t.surge_mps, t.sway_mps, t.yaw_rate_radps);
        if w == 0.0 {
            return Isometry2::new(Vector2::new(u * tau, v * tau), 0.0);
        }
        let c = Vector2::new(-v / w, u / w);
        Isometry2::new(c + Rotation2::new(w * tau) * (-c), w * tau)
    }

    /// One revolution of `beams` beams over `sweep_s`, beam `j` at bearing `2πj/beams` taken
    /// `sweep_s·j/beams` after the start (the synthetic scanner's timing, phase 0), each cast
    /// from the pose `twist` has reached then against `hit` (distance along a ray from an
    /// origin in a direction, reference frame; `None`: no return), and reported as if from the
    /// start pose. Returns the ranges, bearings and the points hit (reference frame).
    #[allow(clippy::type_complexity)]
    fn revolution(
        twist: &BodyTwist,
        sweep_s: f64,
        beams: usize,
        hit: &dyn Fn(Point2<f64>, Vector2<f64>) -> Option<f64>,
    ) -> (Vec<f64>, Vec<f64>, Vec<Option<Point2<f64>>>) {
        let mut out = (Vec::new(), Vec::new(), Vec::new());
        for j in 0..beams {
            let bearing = TAU * j as f64 / beams as f64;
            let pose = pose_truth(twist, sweep_s * j as f64 / beams as f64);
            let dir = pose.rotation * Vector2::new(bearing.cos(), bearing.sin());
            let origin = Point2::from(pose.translation.vector);
            let t = hit(origin, dir);
            out.0.push(t.unwrap_or(f64::NAN));
            out.1.push(bearing);
            out.2.push(t.map(|t| origin + t * dir));
        }
        out
    }

    /// The wall `x = 10 m` ahead, where the beam meets it at a shallow enough angle.
    fn wall(origin: Point2<f64>, dir: Vector2<f64>) -> Option<f64> {
        (dir.x > 0.3).then(|| (10.0 - origin.x) / dir.x)
    }

    /// A rectangular basin around the scanner, 27 m by 17 m.
    fn basin(origin: Point2<f64>, dir: Vector2<f64>) -> Option<f64> {
        let along = |o: f64, d: f64, lo: f64, hi: f64| {
            if d > 0.0 {
                (hi - o) / d
            } else if d < 0.0 {
                (lo - o) / d
            } else {
                f64::INFINITY
            }
        };
        Some(along(origin.x, dir.x, -12.0, 15.0).min(along(origin.y, dir.y, -8.0, 9.0)))
    }

    #[test]
    fn a_wall_seen_while_moving_and_turning_lies_on_the_wall_once_deskewed() {
        let sweep = Sweep::revolution(0.2);
        for twist in [
            // Straight, with sway; turning at 20°/s while under way; turning on the spot.
            (4.0, 0.6, 0.0),
            (4.0, 0.6, 0.35),
            (0.0, 0.0, -0.5),
        ]
        .map(|(u, v, w)| BodyTwist {
            surge_mps: u,
            sway_mps: v,
            yaw_rate_radps: w,
        }) {
            let (ranges, bearings, _) = revolution(&twist, sweep.duration_s, 720, &wall);
            let scan = Scan::from_polar(&ranges, &bearings).unwrap();
            let off_wall = |s: &Scan| {
                s.returns()
                    .iter()
                    .map(|r| (r.point.x - 10.0).abs())
                    .fold(0.0, f64::max)
            };
            // The distortion is real: the returns as reported stray from the wall.
            assert!(off_wall(&scan) > 0.05, "{twist:?}: {}", off_wall(&scan));
            let offsets = sweep.offsets_s(&scan).unwrap();
            let straight = deskew(&scan, &offsets, &twist).unwrap();
            assert_eq!(straight.len(), scan.len());
            assert!(
                off_wall(&straight) < 1e-12,
                "{twist:?}: {}",
                off_wall(&straight)
            );
        }
    }

    #[test]
    fn a_distorted_revolution_deskews_back_to_the_points_the_beams_hit() {
        let twist = BodyTwist {
            surge_mps: 5.0,
            sway_mps: -0.8,
            yaw_rate_radps: 0.25,
        };
        let (ranges, bearings, hits) = revolution(&twist, 0.2, 750, &basin);
        // Truth rides along: every third return labelled moving, a normal on each.
        let moving: Vec<bool> = (0..ranges.len()).map(|j| j % 3 == 0).collect();
        let normals: Vec<Option<Vector2<f64>>> = (0..ranges.len())
            .map(|j| Some(Vector2::new(1.0, j as f64 * 1e-3).normalize()))
            .collect();
        let truth = ReadingTruth {
            true_normals: Some(&normals),
            moving: Some(&moving),
        };
        let scan = Scan::from_polar_with_truth(&ranges, &bearings, truth)
            .unwrap()
            .with_timestamp(12.5)
            .unwrap();
        let offsets = Sweep::revolution(0.2).offsets_s(&scan).unwrap();
        let out = deskew(&scan, &offsets, &twist).unwrap();
        let mut worst_before: f64 = 0.0;
        for ((before, after), hit) in scan.returns().iter().zip(out.returns()).zip(&hits) {
            let hit = hit.unwrap();
            worst_before = worst_before.max((before.point - hit).norm());
            assert!((after.point - hit).norm() < 1e-12 * hit.coords.norm());
            assert!((after.range_m - hit.coords.norm()).abs() < 1e-12 * after.range_m);
            // The bearing stays on the revolution's branch, in order.
            assert!((after.bearing_rad - before.bearing_rad).abs() < 0.2);
        }
        assert!(worst_before > 0.5, "{worst_before}");
        assert_eq!(out.timestamp_s(), Some(12.5));
        assert_eq!(out.moving(), scan.moving());
        assert_eq!(out.true_normals(), scan.true_normals());
        // Without motion nothing moves.
        let still = BodyTwist::from_vector(&Vector3::zeros());
        let same = deskew(&scan, &offsets, &still).unwrap();
        for (a, b) in scan.returns().iter().zip(same.returns()) {
            assert!((a.point - b.point).norm() < 1e-13 * a.range_m);
        }
    }

    #[test]
    fn the_exponential_is_exact_over_a_large_turn() {
        // Half a turn in one sweep: the closed form against the geometry, and beyond ±π.
        let twist = BodyTwist {
            surge_mps: 2.0,
            sway_mps: 1.0,
            yaw_rate_radps: 4.0,
        };
        for tau in [1e-9, 0.01, 0.5, 0.9, 2.0] {
            let (a, b) = (twist.pose_after(tau), pose_truth(&twist, tau));
            assert!((a.translation.vector - b.translation.vector).norm() < 1e-14 * 4.0);
            assert!((a.rotation.angle_to(&b.rotation)).abs() < 1e-14);
        }
    }

    #[test]
    fn bad_input_is_an_error_naming_it() {
        let scan = Scan::from_polar(&[5.0, 6.0], &[0.5, 1.0]).unwrap();
        let twist = BodyTwist {
            surge_mps: 1.0,
            sway_mps: 0.0,
            yaw_rate_radps: 0.0,
        };
        assert!(matches!(
            deskew(&scan, &[0.0], &twist),
            Err(IcpError::LengthMismatch { got: 1, .. })
        ));
        assert!(matches!(
            deskew(&scan, &[0.0, f64::NAN], &twist),
            Err(IcpError::NonFinite { index: 1, .. })
        ));
        let bad = BodyTwist {
            yaw_rate_radps: f64::INFINITY,
            ..twist
        };
        assert!(matches!(
            deskew(&scan, &[0.0, 0.1], &bad),
            Err(IcpError::InvalidParameter {
                name: "yaw_rate_radps",
                ..
            })
        ));
        // A return 1 m astern, taken when the scanner had come 1 m ahead: at the scanner.
        let at = Scan::from_cartesian(&[[-1.0, 0.0]]).unwrap();
        assert!(matches!(
            deskew(&at, &[1.0], &twist),
            Err(IcpError::ZeroLength { index: 0, .. })
        ));
        // A fan from −90° does not fit a revolution from bearing 0.
        let fan = Scan::from_polar(&[5.0, 6.0], &[-1.5, 1.0]).unwrap();
        assert!(matches!(
            Sweep::revolution(0.1).offsets_s(&fan),
            Err(IcpError::InvalidParameter {
                name: "bearing",
                ..
            })
        ));
        assert!(Sweep::revolution(-0.1).offsets_s(&scan).is_err());
        // Without a sweep the fan is one instant.
        assert_eq!(Sweep::revolution(0.0).offsets_s(&fan).unwrap(), [0.0, 0.0]);
        let offsets = Sweep::revolution(0.2).offsets_s(&scan).unwrap();
        assert_eq!(offsets, [0.2 * 0.5 / TAU, 0.2 * 1.0 / TAU]);
    }
}
