//! A scan plane tilted by roll and pitch: where a beam goes, how far it reaches before it meets
//! the water, and whether it passes over a wall.
//!
//! The scanner sits `height_m` above the water with its plane level at rest. A beam at bearing
//! `α` in that plane, turned by pitch `θ` (bow up) and roll `φ` (starboard down), points along
//! `u = R_x(φ) R_y(−θ) (cos α, sin α, 0)`: its horizontal azimuth is `atan2(u_y, u_x)` and its
//! elevation `ε = asin(u_z)` (`≈ θ cos α + φ sin α`). A vertical wall at horizontal distance
//! `d` along the azimuth is met at the slant range `d / cos ε` (longer than `d` by `1/cos ε`)
//! and at the height `height + d tan ε`; a beam pointing down meets the water at the
//! horizontal distance `height / tan(−ε)`.

/// Where one tilted beam goes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TiltedBeam {
    /// Horizontal azimuth in the scanner's (yaw) frame, radians.
    pub azimuth_rad: f64,
    /// `cos ε`: slant range = horizontal distance / `cos ε`.
    pub cos_elevation: f64,
    /// `tan ε`: the beam climbs by `tan ε` per metre of horizontal distance.
    pub tan_elevation: f64,
}

/// What a tilted beam meets first.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Meets {
    /// The surface, at this slant range, m.
    Surface(f64),
    /// The water, at this slant range, m.
    Water(f64),
    /// Nothing: it passes over the surface's top (or meets nothing at all).
    Nothing,
}

impl TiltedBeam {
    /// The beam at `bearing_rad` with the scan plane rolled by `roll_rad` and pitched by
    /// `pitch_rad`.
    pub fn new(bearing_rad: f64, roll_rad: f64, pitch_rad: f64) -> Self {
        let (sa, ca) = bearing_rad.sin_cos();
        let (sp, cp) = (-pitch_rad).sin_cos();
        // R_y(−θ) (cos α, sin α, 0) = (cos θ cos α, sin α, sin θ cos α) with −θ's sign.
        let v = [cp * ca, sa, -sp * ca];
        let (sr, cr) = roll_rad.sin_cos();
        // R_x(φ): y' = c y − s z, z' = s y + c z.
        let u = [v[0], cr * v[1] - sr * v[2], sr * v[1] + cr * v[2]];
        let horizontal = u[0].hypot(u[1]);
        Self {
            azimuth_rad: u[1].atan2(u[0]),
            cos_elevation: horizontal,
            tan_elevation: u[2] / horizontal,
        }
    }

    /// What the beam from `height_m` above the water meets, given the horizontal distance
    /// `surface_m` to the nearest surface along its azimuth (if any) and that surface's top
    /// above the water, m.
    pub fn meets(&self, height_m: f64, surface: Option<(f64, f64)>) -> Meets {
        let water_m = if self.tan_elevation < 0.0 {
            height_m / -self.tan_elevation
        } else {
            f64::INFINITY
        };
        match surface {
            Some((d, _)) if water_m < d => Meets::Water(water_m / self.cos_elevation),
            Some((d, top_m)) => {
                if height_m + d * self.tan_elevation <= top_m {
                    Meets::Surface(d / self.cos_elevation)
                } else {
                    Meets::Nothing
                }
            }
            None if water_m.is_finite() => Meets::Water(water_m / self.cos_elevation),
            None => Meets::Nothing,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_level_plane_changes_nothing() {
        for a in [0.0, 0.7, 2.0, -1.2] {
            let b = TiltedBeam::new(a, 0.0, 0.0);
            assert!((b.azimuth_rad - a).abs() < 1e-15);
            assert_eq!(b.cos_elevation, 1.0);
            assert_eq!(b.tan_elevation, 0.0);
            assert_eq!(b.meets(0.6, Some((20.0, 1.5))), Meets::Surface(20.0));
        }
    }

    /// The check: pitch θ lengthens the range straight ahead to a vertical wall by
    /// exactly 1/cos θ, and roll does the same abeam.
    #[test]
    fn tilt_lengthens_the_range_to_a_vertical_wall_by_one_over_cos() {
        let (d, tilt) = (12.0, 3f64.to_radians());
        let ahead = TiltedBeam::new(0.0, 0.0, tilt);
        let Meets::Surface(r) = ahead.meets(0.6, Some((d, 5.0))) else {
            panic!("the wall is high enough");
        };
        assert!((r - d / tilt.cos()).abs() < 1e-12, "{r}");
        assert!((ahead.tan_elevation - tilt.tan()).abs() < 1e-15);
        let abeam = TiltedBeam::new(std::f64::consts::FRAC_PI_2, tilt, 0.0);
        let Meets::Surface(r) = abeam.meets(0.6, Some((d, 5.0))) else {
            panic!("the wall is high enough");
        };
        assert!((r - d / tilt.cos()).abs() < 1e-12, "{r}");
        assert!((abeam.azimuth_rad - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
    }

    #[test]
    fn a_beam_pointing_down_meets_the_water_and_one_pointing_up_passes_over() {
        let tilt = 2f64.to_radians();
        // Bow down 2°, scanner 0.6 m up: the water at 0.6/tan 2° = 17.18 m ahead.
        let down = TiltedBeam::new(0.0, 0.0, -tilt);
        let water = 0.6 / tilt.tan();
        assert_eq!(
            down.meets(0.6, Some((30.0, 1.5))),
            Meets::Water(water / tilt.cos())
        );
        assert_eq!(down.meets(0.6, None), Meets::Water(water / tilt.cos()));
        // A wall nearer than the water is met.
        assert!(matches!(
            down.meets(0.6, Some((10.0, 1.5))),
            Meets::Surface(_)
        ));
        // Bow up 2°: at 30 m the beam is 0.6 + 1.05 m up, over a 1.5 m quay, under a 2 m one.
        let up = TiltedBeam::new(0.0, 0.0, tilt);
        assert_eq!(up.meets(0.6, Some((30.0, 1.5))), Meets::Nothing);
        assert!(matches!(
            up.meets(0.6, Some((30.0, 2.0))),
            Meets::Surface(_)
        ));
        assert_eq!(up.meets(0.6, None), Meets::Nothing);
    }
}
