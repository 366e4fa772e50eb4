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
    /// The true surface normal behind each return (unit, scan frame), aligned with `returns`;
    /// empty when no return's normal is known. Kept apart so that [`Return`] stays small.
    true_normals: Vec<Option<Vector2<f64>>>,
    /// Whether each return came from a moving object, aligned with `returns`; empty when the
    /// scan is unlabelled.
    moving: Vec<bool>,
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
            if is_no_return(r) {
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
            true_normals: Vec::new(),
            moving: Vec::new(),
            timestamp_s: None,
            no_returns,
        })
    }

    /// Like [`Scan::from_polar`], with what a data generator knows about each reading
    /// ([`ReadingTruth`]).
    ///
    /// The truth follows the readings: a no-return reading's entries are dropped with it,
    /// unchecked like its bearing, so [`Scan::true_normals`] and [`Scan::moving`] stay aligned
    /// with [`Scan::returns`]. A slice of another length than the readings is
    /// [`IcpError::LengthMismatch`]. Every other given normal must be finite and non-zero
    /// ([`IcpError::NonFinite`] or [`IcpError::ZeroLength`], `what: "true normal"`, naming the
    /// reading's index) and is scaled to unit length; one already unit to within 4 ε is kept
    /// bit for bit, so normalising is idempotent and a normal written out and read back is
    /// unchanged. When no return has a known normal the scan carries none
    /// ([`Scan::true_normals`] is `None`); moving labels, once given, are kept even when all
    /// are `false` (known static).
    pub fn from_polar_with_truth(
        ranges_m: &[f64],
        bearings_rad: &[f64],
        truth: ReadingTruth<'_>,
    ) -> Result<Self, IcpError> {
        let mut scan = Self::from_polar(ranges_m, bearings_rad)?;
        if let Some(normals) = truth.true_normals {
            let kept = of_returns(ranges_m, normals, "true normals")?
                .map(|(index, n)| n.map(|n| unit_normal(n, index)).transpose())
                .collect::<Result<Vec<_>, _>>()?;
            if kept.iter().any(Option::is_some) {
                scan.true_normals = kept;
            }
        }
        if let Some(moving) = truth.moving {
            scan.moving = of_returns(ranges_m, moving, "moving labels")?
                .map(|(_, &m)| m)
                .collect();
        }
        Ok(scan)
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
            true_normals: Vec::new(),
            moving: Vec::new(),
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

    /// The true surface normal behind each return, aligned with [`Scan::returns`]: unit vectors
    /// (unitless) in the scan frame, as given to [`Scan::from_polar_with_truth`].
    /// `None`: the scan carries no true normals at all; an inner `None`: that return's surface
    /// is unknown (e.g. a spurious return).
    pub fn true_normals(&self) -> Option<&[Option<Vector2<f64>>]> {
        (!self.true_normals.is_empty()).then_some(&self.true_normals[..])
    }

    /// Whether each return came from a moving object (another boat), aligned with
    /// [`Scan::returns`], as given to [`Scan::from_polar_with_truth`]: truth for scoring a
    /// detector or an oracle, never read by a registration. `None`: the scan is unlabelled (or
    /// has no return).
    pub fn moving(&self) -> Option<&[bool]> {
        (!self.moving.is_empty()).then_some(&self.moving[..])
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

    /// The scan without the returns where `left_out` is true (aligned with
    /// [`Scan::returns`]; missing entries keep their return): its truth, timestamp and count
    /// of no-returns kept. What a registration sees once a stage has left returns out
    /// ([`crate::moving`]).
    pub fn without(&self, left_out: &[bool]) -> Scan {
        Scan {
            returns: kept(&self.returns, left_out),
            true_normals: kept(&self.true_normals, left_out),
            moving: kept(&self.moving, left_out),
            timestamp_s: self.timestamp_s,
            no_returns: self.no_returns,
        }
    }
}

/// The entries of `v` whose index is not marked in `left_out` (an index beyond it is kept).
fn kept<T: Copy>(v: &[T], left_out: &[bool]) -> Vec<T> {
    v.iter()
        .enumerate()
        .filter(|&(i, _)| !left_out.get(i).copied().unwrap_or(false))
        .map(|(_, x)| *x)
        .collect()
}

/// What a data generator knows about each reading of a scan beyond its range and bearing, one
/// entry per reading (no-returns included): truth that scores an estimate or a detector,
/// carried beside the returns ([`Scan::from_polar_with_truth`]). No registration reads it.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ReadingTruth<'a> {
    /// The true surface normal behind each reading (unitless, scan frame; `None`: unknown,
    /// e.g. a spurious return).
    pub true_normals: Option<&'a [Option<Vector2<f64>>]>,
    /// Whether each reading came from a moving object (another boat's hull).
    pub moving: Option<&'a [bool]>,
}

/// A reading that is a "no return": range NaN or exactly 0. Every constructor drops these.
pub fn is_no_return(range_m: f64) -> bool {
    range_m.is_nan() || range_m == 0.0
}

/// The entries of `per_reading` (one per reading of `ranges_m`; `what` names them in a length
/// error) that belong to returns, each with its reading's index.
fn of_returns<'a, T>(
    ranges_m: &'a [f64],
    per_reading: &'a [T],
    what: &'static str,
) -> Result<impl Iterator<Item = (usize, &'a T)>, IcpError> {
    if per_reading.len() != ranges_m.len() {
        return Err(IcpError::LengthMismatch {
            what,
            expected: ranges_m.len(),
            got: per_reading.len(),
        });
    }
    Ok(ranges_m
        .iter()
        .zip(per_reading)
        .enumerate()
        .filter(|(_, (&r, _))| !is_no_return(r))
        .map(|(index, (_, v))| (index, v)))
}

/// How far from 1 the length of a true normal may be for it to be kept as given (4 ε).
const UNIT_NORMAL_TOLERANCE: f64 = 4.0 * f64::EPSILON;

/// `n` at unit length, or the error naming reading `index`.
fn unit_normal(n: Vector2<f64>, index: usize) -> Result<Vector2<f64>, IcpError> {
    for value in [n.x, n.y] {
        if !value.is_finite() {
            return Err(IcpError::NonFinite {
                what: "true normal",
                index,
                value,
            });
        }
    }
    if (n.x.hypot(n.y) - 1.0).abs() <= UNIT_NORMAL_TOLERANCE {
        return Ok(n);
    }
    // Divided by its largest component first, so that its length neither under- nor overflows.
    let largest = n.x.abs().max(n.y.abs());
    if largest == 0.0 {
        return Err(IcpError::ZeroLength {
            what: "true normal",
            index,
        });
    }
    let m = n / largest;
    Ok(m / m.x.hypot(m.y))
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
    use proptest::prelude::*;

    fn with_normals(
        ranges_m: &[f64],
        bearings_rad: &[f64],
        normals: &[Option<Vector2<f64>>],
    ) -> Result<Scan, IcpError> {
        Scan::from_polar_with_truth(
            ranges_m,
            bearings_rad,
            ReadingTruth {
                true_normals: Some(normals),
                ..ReadingTruth::default()
            },
        )
    }

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
    fn true_normals_follow_the_kept_returns() {
        let v = |x: f64, y: f64| Some(Vector2::new(x, y));
        let scan = with_normals(
            &[1.0, f64::NAN, 2.0, 0.0, 3.0],
            &[0.0, 0.1, 0.2, 0.3, 0.4],
            // The no-returns' normals are dropped unchecked, like their bearings.
            &[
                v(0.0, -2.0),
                v(f64::NAN, 0.0),
                None,
                v(0.0, 0.0),
                v(3.0, 4.0),
            ],
        )
        .unwrap()
        .with_timestamp(1.5)
        .unwrap();
        assert_eq!((scan.len(), scan.no_returns()), (3, 2));
        assert_eq!(
            scan.true_normals(),
            Some(&[v(0.0, -1.0), None, v(0.6, 0.8)][..])
        );
        // A unit normal is kept bit for bit.
        let unit = Vector2::new(0.1f64.cos(), 0.1f64.sin());
        let kept = with_normals(&[1.0], &[0.0], &[Some(unit)]).unwrap();
        assert_eq!(
            kept.true_normals().unwrap()[0].unwrap().map(f64::to_bits),
            unit.map(f64::to_bits)
        );
        // Neither huge nor subnormal vectors over- or underflow on the way.
        let h = std::f64::consts::FRAC_1_SQRT_2;
        assert!(
            (unit_normal(Vector2::new(f64::MAX, -f64::MAX), 0).unwrap() - Vector2::new(h, -h))
                .norm()
                < 1e-15
        );
        assert_eq!(
            unit_normal(Vector2::new(0.0, -5e-324), 0),
            Ok(Vector2::new(0.0, -1.0))
        );
        // No known normal at all: the scan carries none, as one built without them.
        let none = with_normals(&[1.0, 0.0], &[0.0, 1.0], &[None, v(1.0, 0.0)]).unwrap();
        assert_eq!(none.true_normals(), None);
        assert_eq!(none, Scan::from_polar(&[1.0, 0.0], &[0.0, 1.0]).unwrap());
        assert_eq!(
            Scan::from_cartesian(&[[1.0, 2.0]]).unwrap().true_normals(),
            None
        );
    }

    #[test]
    fn bad_true_normals_are_errors_naming_the_reading() {
        let v = |x: f64, y: f64| Some(Vector2::new(x, y));
        assert_eq!(
            with_normals(&[1.0, 2.0], &[0.0, 1.0], &[None]),
            Err(IcpError::LengthMismatch {
                what: "true normals",
                expected: 2,
                got: 1
            })
        );
        assert!(matches!(
            with_normals(&[f64::NAN, 2.0], &[0.0, 1.0], &[None, v(1.0, f64::INFINITY)]),
            Err(IcpError::NonFinite {
                what: "true normal",
                index: 1,
                value
            }) if value == f64::INFINITY
        ));
        assert_eq!(
            with_normals(&[1.0, 0.0, 2.0], &[0.0; 3], &[None, None, v(0.0, -0.0)]),
            Err(IcpError::ZeroLength {
                what: "true normal",
                index: 2
            })
        );
        assert_eq!(
            IcpError::ZeroLength {
                what: "true normal",
                index: 2
            }
            .to_string(),
            "zero-length true normal at index 2"
        );
    }

    #[test]
    fn without_drops_the_marked_returns_and_their_truth() {
        let scan = Scan::from_polar(&[1.0, 2.0, 3.0], &[0.0, 0.5, 1.0])
            .unwrap()
            .with_timestamp(4.0)
            .unwrap();
        let kept = scan.without(&[false, true]);
        assert_eq!(kept.len(), 2);
        assert_eq!(
            kept.returns()[1].range_m,
            3.0,
            "an index beyond the mask is kept"
        );
        assert_eq!(kept.timestamp_s(), Some(4.0));
        assert!(scan.without(&[true, true, true]).is_empty());
    }

    #[test]
    fn moving_labels_follow_the_kept_returns_and_stay_when_all_false() {
        let ranges = [1.0, f64::NAN, 2.0, 0.0, 3.0];
        let labelled = |moving: &[bool]| {
            Scan::from_polar_with_truth(
                &ranges,
                &[0.0; 5],
                ReadingTruth {
                    moving: Some(moving),
                    ..ReadingTruth::default()
                },
            )
        };
        let scan = labelled(&[false, true, true, true, false]).unwrap();
        assert_eq!(scan.moving(), Some(&[false, true, false][..]));
        assert_eq!(scan.true_normals(), None);
        let still = labelled(&[false; 5]).unwrap();
        assert_eq!(still.moving(), Some(&[false; 3][..]));
        assert_ne!(still, Scan::from_polar(&ranges, &[0.0; 5]).unwrap());
        assert_eq!(Scan::from_polar(&ranges, &[0.0; 5]).unwrap().moving(), None);
        assert_eq!(
            labelled(&[false; 4]),
            Err(IcpError::LengthMismatch {
                what: "moving labels",
                expected: 5,
                got: 4
            })
        );
        // A scan without returns has no labels to carry.
        let empty = Scan::from_polar_with_truth(
            &[f64::NAN],
            &[0.0],
            ReadingTruth {
                moving: Some(&[true]),
                ..ReadingTruth::default()
            },
        )
        .unwrap();
        assert_eq!(empty.moving(), None);
    }

    /// Every finite `f64`, of either sign.
    fn finite() -> prop::num::f64::Any {
        prop::num::f64::NORMAL | prop::num::f64::SUBNORMAL | prop::num::f64::ZERO
    }

    proptest! {
        /// Any finite non-zero vector, from subnormal to near `f64::MAX`, comes out unit, and a
        /// normal that came out once comes out again bit for bit.
        #[test]
        fn true_normals_are_unit_and_normalising_is_idempotent(
            x in prop_oneof![finite(), -1.0..1.0f64],
            y in prop_oneof![finite(), -1.0..1.0f64],
        ) {
            if x == 0.0 && y == 0.0 {
                return Ok(()); // the zero vector is an error, tested above
            }
            let once = unit_normal(Vector2::new(x, y), 0).unwrap();
            prop_assert!((once.x.hypot(once.y) - 1.0).abs() <= UNIT_NORMAL_TOLERANCE);
            prop_assert!(once.x * x >= 0.0 && once.y * y >= 0.0, "same direction");
            let twice = unit_normal(once, 0).unwrap();
            prop_assert_eq!(twice.map(f64::to_bits), once.map(f64::to_bits));
        }
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
