//! A 2D LIDAR scan: each return's range and bearing beside its Cartesian point (eq. 10).

use nalgebra::{Point2, Vector2};

use crate::error::{Degeneracy, ScanRole};
use crate::IcpError;

/// One valid return: the point of eq. 10 and the polar reading it came from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Return {
    /// `(r cos α, r sin α)`, metres, in the scan frame.
    pub point: Point2<f64>,
    /// Range `r`, metres (> 0).
    pub range_m: f64,
    /// Bearing `α`, radians, measured from the scan frame's `+x` towards `+y`.
    pub bearing_rad: f64,
}

/// A validated scan. Construction drops "no return" readings (range NaN or 0) and counts them;
/// anything else that is not a finite, non-negative reading is an error.
#[derive(Clone, Debug, PartialEq)]
pub struct Scan {
    returns: Vec<Return>,
    timestamp_s: Option<f64>,
    no_returns: usize,
}

impl Scan {
    /// Builds a scan from parallel ranges (metres) and bearings (radians).
    ///
    /// A range that is NaN or exactly 0 means "no return": it is dropped and counted in
    /// [`Scan::no_returns`], whatever its bearing. A range that is infinite or negative, or a
    /// non-finite bearing beside a valid range, is an error.
    pub fn from_polar(ranges_m: &[f64], bearings_rad: &[f64]) -> Result<Self, IcpError> {
        if ranges_m.len() != bearings_rad.len() {
            return Err(IcpError::LengthMismatch {
                what: "bearings",
                expected: ranges_m.len(),
                got: bearings_rad.len(),
            });
        }
        let mut returns = Vec::with_capacity(ranges_m.len());
        let mut no_returns = 0;
        for (index, (&r, &a)) in ranges_m.iter().zip(bearings_rad).enumerate() {
            if r.is_nan() || r == 0.0 {
                no_returns += 1;
                continue;
            }
            if r.is_infinite() {
                return Err(IcpError::NonFinite {
                    what: "range",
                    index,
                    value: r,
                });
            }
            if r < 0.0 {
                return Err(IcpError::NegativeRange { index, value: r });
            }
            if !a.is_finite() {
                return Err(IcpError::NonFinite {
                    what: "bearing",
                    index,
                    value: a,
                });
            }
            let (s, c) = a.sin_cos();
            returns.push(Return {
                point: Point2::new(r * c, r * s), // eq. 10
                range_m: r,
                bearing_rad: a,
            });
        }
        Ok(Self {
            returns,
            timestamp_s: None,
            no_returns,
        })
    }

    /// Builds a scan from Cartesian points in the scan frame, keeping them exactly and deriving
    /// `r = |p|` and `α = atan2(y, x)`. A point at the sensor origin (`r = 0`) is a no-return.
    pub fn from_cartesian(points: &[[f64; 2]]) -> Result<Self, IcpError> {
        let mut returns = Vec::with_capacity(points.len());
        let mut no_returns = 0;
        for (index, &[x, y]) in points.iter().enumerate() {
            for value in [x, y] {
                if !value.is_finite() {
                    return Err(IcpError::NonFinite {
                        what: "coordinate",
                        index,
                        value,
                    });
                }
            }
            let range_m = x.hypot(y);
            if range_m == 0.0 {
                no_returns += 1;
                continue;
            }
            returns.push(Return {
                point: Point2::new(x, y),
                range_m,
                bearing_rad: y.atan2(x),
            });
        }
        Ok(Self {
            returns,
            timestamp_s: None,
            no_returns,
        })
    }

    /// The same scan with a timestamp, seconds (must be finite).
    pub fn with_timestamp(mut self, timestamp_s: f64) -> Result<Self, IcpError> {
        if !timestamp_s.is_finite() {
            return Err(IcpError::NonFinite {
                what: "timestamp",
                index: 0,
                value: timestamp_s,
            });
        }
        self.timestamp_s = Some(timestamp_s);
        Ok(self)
    }

    /// The valid returns, in input order.
    pub fn returns(&self) -> &[Return] {
        &self.returns
    }

    /// Number of valid returns.
    pub fn len(&self) -> usize {
        self.returns.len()
    }

    /// True when the scan has no valid return.
    pub fn is_empty(&self) -> bool {
        self.returns.is_empty()
    }

    /// Readings dropped as "no return" (range NaN or 0).
    pub fn no_returns(&self) -> usize {
        self.no_returns
    }

    /// Acquisition time, seconds, when known.
    pub fn timestamp_s(&self) -> Option<f64> {
        self.timestamp_s
    }
}

/// Smallest number of points a registration accepts.
pub const MIN_POINTS: usize = 3;

/// Largest-eigenvalue floor of the point scatter, m²: below it the points coincide.
pub const COINCIDENT_SCATTER_M2: f64 = 1e-12;

/// Eigenvalue ratio floor of the point scatter: below it the points are collinear.
pub const COLLINEAR_EIGEN_RATIO: f64 = 1e-10;

/// Checks that a point set can constrain a 2D rigid motion: at least [`MIN_POINTS`] points
/// whose scatter matrix is neither (nearly) zero nor (nearly) rank one.
pub fn check_geometry<'a>(
    points: impl ExactSizeIterator<Item = &'a Point2<f64>> + Clone,
    role: ScanRole,
) -> Result<(), IcpError> {
    let n = points.len();
    if n < MIN_POINTS {
        return Err(IcpError::TooFewPoints {
            role,
            got: n,
            need: MIN_POINTS,
        });
    }
    let mean = points
        .clone()
        .fold(Vector2::zeros(), |acc, p| acc + p.coords)
        / n as f64;
    let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
    for p in points {
        let d = p.coords - mean;
        sxx += d.x * d.x;
        sxy += d.x * d.y;
        syy += d.y * d.y;
    }
    let (sxx, sxy, syy) = (sxx / n as f64, sxy / n as f64, syy / n as f64);
    // Eigenvalues of the symmetric 2x2 scatter, in closed form.
    let half_trace = 0.5 * (sxx + syy);
    let radius = (0.25 * (sxx - syy).powi(2) + sxy * sxy).sqrt();
    let (l_max, l_min) = (half_trace + radius, (half_trace - radius).max(0.0));
    if l_max.is_nan() || l_max <= COINCIDENT_SCATTER_M2 {
        return Err(IcpError::Degenerate {
            role,
            kind: Degeneracy::Coincident,
        });
    }
    if l_min <= COLLINEAR_EIGEN_RATIO * l_max {
        return Err(IcpError::Degenerate {
            role,
            kind: Degeneracy::Collinear,
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn polar_drops_and_counts_no_returns() {
        let scan =
            Scan::from_polar(&[1.0, f64::NAN, 0.0, 2.0], &[0.0, 0.1, f64::NAN, 1.0]).unwrap();
        assert_eq!(scan.len(), 2);
        assert_eq!(scan.no_returns(), 2);
        let r = scan.returns()[1];
        assert_eq!(r.range_m, 2.0);
        assert!((r.point - Point2::new(2.0 * 1f64.cos(), 2.0 * 1f64.sin())).norm() < 1e-15);
    }

    #[test]
    fn polar_rejects_bad_readings() {
        assert_eq!(
            Scan::from_polar(&[1.0, 2.0], &[0.0]),
            Err(IcpError::LengthMismatch {
                what: "bearings",
                expected: 2,
                got: 1
            })
        );
        assert_eq!(
            Scan::from_polar(&[1.0, -2.0], &[0.0, 0.0]),
            Err(IcpError::NegativeRange {
                index: 1,
                value: -2.0
            })
        );
        assert!(matches!(
            Scan::from_polar(&[f64::INFINITY], &[0.0]),
            Err(IcpError::NonFinite {
                what: "range",
                index: 0,
                ..
            })
        ));
        assert!(matches!(
            Scan::from_polar(&[1.0], &[f64::NAN]),
            Err(IcpError::NonFinite {
                what: "bearing",
                index: 0,
                ..
            })
        ));
        assert!(matches!(
            Scan::from_cartesian(&[[0.0, f64::NEG_INFINITY]]),
            Err(IcpError::NonFinite {
                what: "coordinate",
                index: 0,
                ..
            })
        ));
        assert!(Scan::from_polar(&[1.0], &[0.0])
            .unwrap()
            .with_timestamp(f64::NAN)
            .is_err());
    }

    #[test]
    fn cartesian_keeps_points_and_derives_polar() {
        let scan = Scan::from_cartesian(&[[3.0, 4.0], [0.0, 0.0], [-1.0, 0.0]]).unwrap();
        assert_eq!(scan.len(), 2);
        assert_eq!(scan.no_returns(), 1);
        assert_eq!(scan.returns()[0].point, Point2::new(3.0, 4.0));
        assert_eq!(scan.returns()[0].range_m, 5.0);
        assert!((scan.returns()[1].bearing_rad - std::f64::consts::PI).abs() < 1e-15);
    }

    #[test]
    fn geometry_check_flags_degenerate_sets() {
        let pts = |v: &[[f64; 2]]| {
            v.iter()
                .map(|&[x, y]| Point2::new(x, y))
                .collect::<Vec<_>>()
        };
        let two = pts(&[[0.0, 0.0], [1.0, 1.0]]);
        assert!(matches!(
            check_geometry(two.iter(), ScanRole::Source),
            Err(IcpError::TooFewPoints {
                got: 2,
                need: 3,
                ..
            })
        ));
        let same = pts(&[[5.0, 5.0]; 4]);
        assert_eq!(
            check_geometry(same.iter(), ScanRole::Reference),
            Err(IcpError::Degenerate {
                role: ScanRole::Reference,
                kind: Degeneracy::Coincident
            })
        );
        let line = pts(&[[0.0, 1.0], [1.0, 3.0], [2.0, 5.0], [3.0, 7.0]]);
        assert_eq!(
            check_geometry(line.iter(), ScanRole::Source),
            Err(IcpError::Degenerate {
                role: ScanRole::Source,
                kind: Degeneracy::Collinear
            })
        );
        let far_line = pts(&[[1e9, 1e9], [1e9 + 1.0, 1e9 + 1.0], [1e9 + 2.0, 1e9 + 2.0]]);
        assert!(check_geometry(far_line.iter(), ScanRole::Source).is_err());
        let triangle = pts(&[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]);
        assert!(check_geometry(triangle.iter(), ScanRole::Source).is_ok());
    }
}
