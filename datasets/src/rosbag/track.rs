//! Reference poses at scan stamps: rigid poses interpolated (linear in position,
//! shortest-arc in yaw), and GNSS fixes turned into positions in a local tangent plane with a
//! course over ground.

use std::f64::consts::PI;

use super::messages::{Fix, StampedPose};

/// The angle wrapped into `(−π, π]`, radians.
pub fn wrap_pi(angle_rad: f64) -> f64 {
    let a = angle_rad.rem_euclid(2.0 * PI);
    if a > PI {
        a - 2.0 * PI
    } else {
        a
    }
}

/// `poses` (sorted by stamp, stamps distinct) at time `t_s`: linear in position and
/// shortest-arc in yaw between the two poses around `t_s`; `None` outside their time span.
pub fn interpolate(poses: &[StampedPose], t_s: f64) -> Option<StampedPose> {
    let first = poses.first()?;
    let last = poses.last()?;
    if !(first.stamp_s..=last.stamp_s).contains(&t_s) {
        return None;
    }
    // The first pose at or after t_s; its predecessor is before t_s (or it is exact).
    let i = poses.partition_point(|p| p.stamp_s < t_s);
    let b = poses[i];
    if b.stamp_s == t_s || i == 0 {
        return Some(StampedPose { stamp_s: t_s, ..b });
    }
    let a = poses[i - 1];
    let f = (t_s - a.stamp_s) / (b.stamp_s - a.stamp_s);
    Some(StampedPose {
        stamp_s: t_s,
        x_m: a.x_m + f * (b.x_m - a.x_m),
        y_m: a.y_m + f * (b.y_m - a.y_m),
        yaw_rad: wrap_pi(a.yaw_rad + f * wrap_pi(b.yaw_rad - a.yaw_rad)),
    })
}

/// Sorts by stamp (stable) and keeps the first of poses with equal stamps; returns how many
/// were dropped as duplicates.
pub fn sort_dedup(poses: &mut Vec<StampedPose>) -> usize {
    poses.sort_by(|a, b| a.stamp_s.total_cmp(&b.stamp_s));
    let n = poses.len();
    poses.dedup_by(|later, earlier| later.stamp_s == earlier.stamp_s);
    n - poses.len()
}

/// WGS 84 semi-major axis, metres.
const WGS84_A_M: f64 = 6_378_137.0;
/// WGS 84 flattening.
const WGS84_F: f64 = 1.0 / 298.257_223_563;

/// Earth-centred, Earth-fixed coordinates of a geodetic position, metres (WGS 84).
fn ecef_m(latitude_deg: f64, longitude_deg: f64, altitude_m: f64) -> [f64; 3] {
    let (lat, lon) = (latitude_deg.to_radians(), longitude_deg.to_radians());
    let e2 = WGS84_F * (2.0 - WGS84_F);
    let n = WGS84_A_M / (1.0 - e2 * lat.sin().powi(2)).sqrt();
    [
        (n + altitude_m) * lat.cos() * lon.cos(),
        (n + altitude_m) * lat.cos() * lon.sin(),
        (n * (1.0 - e2) + altitude_m) * lat.sin(),
    ]
}

/// East and north of `fix` in the local tangent plane (ENU) about `origin`, metres: the ECEF
/// difference rotated into the origin's east-north-up axes. Altitudes that are not finite
/// (NaN: unknown) count as the origin's.
pub fn enu_m(origin: &Fix, fix: &Fix) -> (f64, f64) {
    let alt0 = if origin.altitude_m.is_finite() {
        origin.altitude_m
    } else {
        0.0
    };
    let alt = if fix.altitude_m.is_finite() {
        fix.altitude_m
    } else {
        alt0
    };
    let p0 = ecef_m(origin.latitude_deg, origin.longitude_deg, alt0);
    let p = ecef_m(fix.latitude_deg, fix.longitude_deg, alt);
    let d = [p[0] - p0[0], p[1] - p0[1], p[2] - p0[2]];
    let (lat, lon) = (
        origin.latitude_deg.to_radians(),
        origin.longitude_deg.to_radians(),
    );
    let east = -lon.sin() * d[0] + lon.cos() * d[1];
    let north = -lat.sin() * lon.cos() * d[0] - lat.sin() * lon.sin() * d[1] + lat.cos() * d[2];
    (east, north)
}

/// Smallest displacement between the fixes around a fix from which its course over ground is
/// taken, metres; below it (standing still, or GNSS noise) the previous course is kept.
pub const MIN_COURSE_DISPLACEMENT_M: f64 = 0.05;

/// GNSS fixes (sorted by stamp, stamps distinct) as planar positions east/north of the first
/// fix, with the course over ground in the `yaw_rad` field: the direction (radians from east
/// towards north) of the displacement between the fixes before and after each fix (one-sided
/// at the ends), held from the previous fix when that displacement is under
/// [`MIN_COURSE_DISPLACEMENT_M`] (the first defined course before any).
pub fn gnss_track(fixes: &[Fix]) -> Vec<StampedPose> {
    let Some(origin) = fixes.first() else {
        return Vec::new();
    };
    let xy: Vec<(f64, f64)> = fixes.iter().map(|f| enu_m(origin, f)).collect();
    let n = xy.len();
    let course: Vec<Option<f64>> = (0..n)
        .map(|i| {
            let (a, b) = (xy[i.saturating_sub(1)], xy[(i + 1).min(n - 1)]);
            let (dx, dy) = (b.0 - a.0, b.1 - a.1);
            (dx.hypot(dy) >= MIN_COURSE_DISPLACEMENT_M).then(|| dy.atan2(dx))
        })
        .collect();
    let mut held = course.iter().flatten().next().copied().unwrap_or(0.0);
    fixes
        .iter()
        .zip(xy)
        .zip(course)
        .map(|((f, (x_m, y_m)), c)| {
            held = c.unwrap_or(held);
            StampedPose {
                stamp_s: f.stamp_s,
                x_m,
                y_m,
                yaw_rad: held,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pose(stamp_s: f64, x_m: f64, y_m: f64, yaw_rad: f64) -> StampedPose {
        StampedPose {
            stamp_s,
            x_m,
            y_m,
            yaw_rad,
        }
    }

    #[test]
    fn interpolation_is_linear_and_takes_the_short_way_round() {
        let poses = [pose(1.0, 0.0, 0.0, 3.0), pose(3.0, 2.0, -4.0, -3.0)];
        let mid = interpolate(&poses, 2.0).unwrap();
        assert_eq!((mid.x_m, mid.y_m), (1.0, -2.0));
        // From 3.0 to −3.0 the short way passes π, not 0.
        assert!((mid.yaw_rad.abs() - PI).abs() < 1e-12, "{}", mid.yaw_rad);
        let quarter = interpolate(&poses, 1.5).unwrap();
        let expected = wrap_pi(3.0 + 0.25 * (2.0 * PI - 6.0));
        assert!((quarter.yaw_rad - expected).abs() < 1e-12);
        assert_eq!(interpolate(&poses, 1.0).unwrap().yaw_rad, 3.0);
        assert_eq!(interpolate(&poses, 3.0).unwrap().x_m, 2.0);
        assert_eq!(interpolate(&poses, 0.999), None);
        assert_eq!(interpolate(&poses, 3.001), None);
    }

    #[test]
    fn enu_of_small_offsets_matches_the_local_radii() {
        // At latitude 54.4° (a Baltic harbour), 1e-4° of latitude is M·dφ and 1e-4° of
        // longitude N·cos φ·dλ, with the meridional and prime-vertical radii M and N.
        let fix = |lat: f64, lon: f64| Fix {
            stamp_s: 0.0,
            status: 0,
            latitude_deg: lat,
            longitude_deg: lon,
            altitude_m: 10.0,
        };
        let o = fix(54.4, 18.6);
        let e2 = WGS84_F * (2.0 - WGS84_F);
        let phi = 54.4f64.to_radians();
        let w = 1.0 - e2 * phi.sin().powi(2);
        let m = WGS84_A_M * (1.0 - e2) / w.powf(1.5) + 10.0;
        let n = WGS84_A_M / w.sqrt() + 10.0;
        let d = 1e-4f64.to_radians();
        let (e, nn) = enu_m(&o, &fix(54.4 + 1e-4, 18.6));
        assert!(e.abs() < 1e-6 && (nn - m * d).abs() < 1e-3, "{e} {nn}");
        let (e, nn) = enu_m(&o, &fix(54.4, 18.6 + 1e-4));
        assert!(
            (e - n * phi.cos() * d).abs() < 1e-3 && nn.abs() < 1e-3,
            "{e} {nn}"
        );
    }

    #[test]
    fn course_over_ground_holds_while_standing_still() {
        let positions = [
            (0.0, 0.0),
            (1.0, 1.0),
            (2.0, 2.0),
            (2.0, 2.0),
            (2.0, 2.0),
            (2.0, 3.0),
        ];
        let fixes: Vec<Fix> = positions
            .iter()
            .enumerate()
            .map(|(k, &(e, n))| Fix {
                stamp_s: k as f64,
                status: 0,
                // Small offsets about the equator and prime meridian: east ≈ a·dλ, north ≈ M·dφ.
                latitude_deg: (n / 6_335_439.0f64).to_degrees(),
                longitude_deg: (e / WGS84_A_M).to_degrees(),
                altitude_m: f64::NAN,
            })
            .collect();
        let track = gnss_track(&fixes);
        let deg: Vec<f64> = track.iter().map(|p| p.yaw_rad.to_degrees()).collect();
        for (k, expected) in [45.0, 45.0, 45.0, 45.0, 90.0, 90.0].iter().enumerate() {
            assert!((deg[k] - expected).abs() < 1e-3, "fix {k}: {deg:?}");
        }
        assert!((track[5].x_m - 2.0).abs() < 1e-3 && (track[5].y_m - 3.0).abs() < 1e-3);
    }
}
