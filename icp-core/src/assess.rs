//! A pose estimated elsewhere (another tool's registration, read from a file) assessed the way
//! a registration of this crate is at its solution, so that its number is flagged by the same
//! rules: every return of the source scan moved by the pose, matched once to its exact nearest
//! reference return (a k-d tree, as the [`crate::matching::KdTree`] stage), and the quality
//! checks of [`crate::quality`] on those pairs (conditioning and overlap). Nothing is iterated
//! and nothing is estimated: the pose is given and kept.
//!
//! [`local_fit`] asks the same pairs one question more: where they alone pull the pose. A
//! registration that starts from a pose and lands far from it may have found a better fit, or
//! wandered into another basin; the pairs at the start, held fixed, tell which (a start that
//! fits them stays put however far the iteration went).

use nalgebra::{Isometry2, Point2};

use crate::error::ScanRole;
use crate::matching::{Correspondence, KdTree, Matcher};
use crate::metric::{Metric, PointToLine};
use crate::minimize::{GaussNewton, Minimizer};
use crate::pairs::PairSet;
use crate::quality::{conditioning, overlap};
use crate::registration::check_init;
use crate::robust::{Kernel, MedianScaled, RobustKernel, ScaleFrom};
use crate::scan::{check_geometry, MIN_POINTS};
use crate::termination::StopReason;
use crate::{IcpError, Prepared, Registration};

/// The registration `t_ref_src` would be if it were one of ours: `iterations` 0,
/// `stop` [`StopReason::Given`], every source return paired (`n_pairs`, unit weights),
/// `mean_residual_m` the mean nearest-neighbour distance, and the conditioning (from the
/// reference's surface normals) and overlap at the pose. No covariance: the estimator's own
/// uncertainty is not known here. The scans are checked as a registration checks them.
pub fn assess(
    source: Prepared<'_>,
    reference: Prepared<'_>,
    t_ref_src: Isometry2<f64>,
) -> Result<Registration, IcpError> {
    let Matched { dst, moved, pairs } = matched(&source, &reference, t_ref_src)?;
    let n = pairs.len();
    let mean_residual_m = pairs.iter().map(|p| p.dist_sq.sqrt()).sum::<f64>() / n as f64;
    Ok(Registration {
        t_ref_src,
        iterations: 0,
        stop: StopReason::Given,
        n_pairs: n,
        n_unusable: 0,
        weight_sum: n as f64,
        mean_residual_m,
        conditioning: conditioning(&moved, reference.surfaces.points(), &pairs),
        overlap: overlap(&moved, &dst, &pairs),
        covariance: None,
        jackknife_covariance: None,
    })
}

/// Where the returns of `source` alone pull the pose `t_ref_src` onto `reference`: each
/// source return moved by it and paired once with its nearest reference return, then one
/// Gauss-Newton step of point-to-line over those pairs held fixed (PL_ICP's metric and
/// minimiser: the step its iteration would take from here, before it re-matches).
/// Point-to-line over fixed pairs is linear but for the turn, so one step lands at their
/// least-squares pose to within the square of a small turn.
///
/// The fit is local: Tukey's biweight on the pair distance at 4.685 times the median (its
/// usual efficiency constant) gives no say to a return with no surface near it at the start
/// (one the reference does not see, or a hull's). With the paper's Huber each such return
/// pulls with a bounded force, and together they moved right starts (within 0.02 m of the
/// truth) by 0.47 m on `synthetic:rough` seed 7 and 0.4 m along `synthetic:corridor` seed 5:
/// the very wandering this fit is to tell from a misfit. Unlike a registration, nothing is
/// re-matched: a start whose returns sit on the reference's surfaces stays put. The scans are
/// checked as a registration checks them.
pub fn local_fit(
    source: Prepared<'_>,
    reference: Prepared<'_>,
    t_ref_src: Isometry2<f64>,
) -> Result<Isometry2<f64>, IcpError> {
    let Matched { dst, moved, pairs } = matched(&source, &reference, t_ref_src)?;
    let set = PairSet {
        pairs: &pairs,
        src: source.scan.returns(),
        dst: reference.scan.returns(),
        src_moved: &moved,
        dst_points: &dst,
        src_surfaces: source.surfaces.points(),
        dst_surfaces: reference.surfaces.points(),
        t_ref_src,
    };
    let metric = PointToLine::default();
    let distances: Vec<f64> = pairs.iter().map(|p| p.dist_sq.sqrt()).collect();
    let mut residuals = Vec::with_capacity(pairs.len());
    metric.residuals(&set, &distances, &mut residuals);
    let mut weights: Vec<f64> = residuals
        .iter()
        .map(|r| if r.is_nan() { 0.0 } else { 1.0 })
        .collect();
    let local = MedianScaled {
        kernel: Kernel::Tukey,
        c: Kernel::Tukey.default_c(),
        scale_from: ScaleFrom::PairDistance,
    };
    local.reweight(&distances, &residuals, &mut weights, &mut Vec::new());
    let step = GaussNewton::default().solve(&set, &weights, &metric)?;
    Ok(step * t_ref_src)
}

/// The points of a checked pair of scans at a pose: the reference returns, the source returns
/// moved by it, and each moved return's nearest reference return.
struct Matched {
    dst: Vec<Point2<f64>>,
    moved: Vec<Point2<f64>>,
    pairs: Vec<Correspondence>,
}

/// The scans checked as a registration checks them (a finite pose, one surface estimate per
/// return, enough returns, not all on one point), then every source return moved by
/// `t_ref_src` and matched to its exact nearest reference return.
fn matched(
    source: &Prepared<'_>,
    reference: &Prepared<'_>,
    t_ref_src: Isometry2<f64>,
) -> Result<Matched, IcpError> {
    check_init(&t_ref_src)?;
    for (scan, role) in [(source, ScanRole::Source), (reference, ScanRole::Reference)] {
        if scan.surfaces.points().len() != scan.scan.len() {
            return Err(IcpError::SurfacesMismatch {
                role,
                why: "do not have one estimate per return",
            });
        }
        if scan.scan.len() < MIN_POINTS {
            return Err(IcpError::TooFewPoints {
                role,
                got: scan.scan.len(),
                need: MIN_POINTS,
            });
        }
    }
    let dst: Vec<Point2<f64>> = reference.scan.returns().iter().map(|r| r.point).collect();
    let src: Vec<Point2<f64>> = source.scan.returns().iter().map(|r| r.point).collect();
    check_geometry(src.iter(), ScanRole::Source)?;
    check_geometry(dst.iter(), ScanRole::Reference)?;
    let moved: Vec<Point2<f64>> = src.iter().map(|p| t_ref_src * p).collect();
    let mut pairs = Vec::with_capacity(moved.len());
    KdTree.build(&dst)?.match_all(&moved, &mut pairs);
    Ok(Matched { dst, moved, pairs })
}

#[cfg(test)]
mod tests {
    use nalgebra::Vector2;

    use super::*;
    use crate::variants::builtin;
    use crate::{Registrar, Scan, SurfaceParams, Surfaces, Workspace};

    /// A room: four walls around the origin, sampled every 0.1 m.
    fn room(t_scan_world: Isometry2<f64>) -> Scan {
        let mut pts = Vec::new();
        for i in 0..100 {
            let s = -5.0 + 0.1 * i as f64;
            for p in [[s, -4.0], [s, 6.0], [-5.0, s + 1.0], [5.0, s + 1.0]] {
                let q = t_scan_world * Point2::new(p[0], p[1]);
                pts.push([q.x, q.y]);
            }
        }
        Scan::from_cartesian(&pts).unwrap()
    }

    fn corridor(t_scan_world: Isometry2<f64>) -> Scan {
        let pts: Vec<[f64; 2]> = (0..200)
            .flat_map(|i| {
                let x = -10.0 + 0.1 * i as f64;
                [[x, -1.5], [x, 1.5]]
            })
            .map(|p| {
                let q = t_scan_world * Point2::new(p[0], p[1]);
                [q.x, q.y]
            })
            .collect();
        Scan::from_cartesian(&pts).unwrap()
    }

    fn surfaces(scan: &Scan) -> Surfaces {
        Surfaces::estimate(scan, &SurfaceParams::default())
    }

    /// At the pose a registration of every return with an exact matcher ends at, the
    /// assessment's pairs are the registration's final pairs: the same overlap and
    /// conditioning, bit for bit.
    #[test]
    fn same_checks_as_a_registration_at_its_solution() {
        let motion = Isometry2::new(Vector2::new(0.3, -0.1), 2.0_f64.to_radians());
        let (source, reference) = (room(Isometry2::identity()), room(motion));
        let (s, r) = (surfaces(&source), surfaces(&reference));
        let pl = builtin("PL_ICP").unwrap();
        assert_eq!(
            pl.selection.kind, "all",
            "the oracle needs every return selected"
        );
        let reg = pl
            .build()
            .unwrap()
            .register_prepared(
                &mut Workspace::default(),
                Prepared::new(&source, &s),
                Prepared::new(&reference, &r),
                Isometry2::identity(),
            )
            .unwrap();
        let a = assess(
            Prepared::new(&source, &s),
            Prepared::new(&reference, &r),
            reg.t_ref_src,
        )
        .unwrap();
        assert_eq!(a.t_ref_src, reg.t_ref_src);
        assert_eq!(a.overlap, reg.overlap);
        assert_eq!(a.conditioning, reg.conditioning);
        assert_eq!(a.n_pairs, source.len());
        assert!(!a.iterated() && !a.converged() && a.iterations == 0);
        assert!(a.covariance.is_none());
        assert!(a.mean_residual_m < 1e-6, "{}", a.mean_residual_m);
    }

    /// `assess` of `pose` between `source` and `reference`, their surfaces estimated here.
    fn at(source: &Scan, reference: &Scan, pose: Isometry2<f64>) -> Result<Registration, IcpError> {
        let (s, r) = (surfaces(source), surfaces(reference));
        assess(
            Prepared::new(source, &s),
            Prepared::new(reference, &r),
            pose,
        )
    }

    /// The flags' inputs move as they must: a corridor is degenerate at the right pose, a
    /// pose 50 m off overlaps nothing, a wrong pose has a larger residual, a NaN pose is
    /// refused.
    #[test]
    fn flags_a_corridor_a_pose_far_off_and_refuses_nan() {
        let motion = Isometry2::new(Vector2::new(0.5, 0.0), 0.0);
        let (source, reference) = (corridor(Isometry2::identity()), corridor(motion));
        let good = at(&source, &reference, motion).unwrap();
        let cond = good.conditioning.unwrap();
        assert!(cond.degenerate(), "{cond:?}");
        assert!(!good.no_overlap());
        let far = at(
            &source,
            &reference,
            Isometry2::new(Vector2::new(0.0, 50.0), 0.0),
        )
        .unwrap();
        assert!(far.no_overlap(), "{}", far.overlap);
        let (source, reference) = (room(Isometry2::identity()), room(motion));
        let right = at(&source, &reference, motion).unwrap();
        assert!(!right.conditioning.unwrap().degenerate());
        let wrong = Isometry2::new(Vector2::new(0.2, 0.3), 0.05);
        let wrong = at(&source, &reference, wrong).unwrap();
        assert!(wrong.mean_residual_m > right.mean_residual_m + 0.05);
        let nan = Isometry2::new(Vector2::new(f64::NAN, 0.0), 0.0);
        assert!(matches!(
            at(&source, &reference, nan),
            Err(IcpError::NonFinite { .. })
        ));
        // Surfaces of another scan (fewer returns) are refused.
        let pts: Vec<[f64; 2]> = (0..30).map(|i| [i as f64 * 0.1, (i % 7) as f64]).collect();
        let other = surfaces(&Scan::from_cartesian(&pts).unwrap());
        let r = surfaces(&reference);
        assert!(matches!(
            assess(
                Prepared::new(&source, &other),
                Prepared::new(&reference, &r),
                motion
            ),
            Err(IcpError::SurfacesMismatch { .. })
        ));
    }

    /// The kept returns of a room, exactly on its walls: from the true pose they do not move
    /// it, and from a start a few centimetres and a few tenths of a degree off they pull it
    /// back onto the true pose (to within a millimetre and a hundredth of a degree: the
    /// linearised turn), the offset a jump's check measures.
    #[test]
    fn local_fit_pulls_back_to_the_walls_and_leaves_a_fitting_start() {
        let motion = Isometry2::new(Vector2::new(0.3, -0.1), 2.0_f64.to_radians());
        let (source, reference) = (room(Isometry2::identity()), room(motion));
        let (s, r) = (surfaces(&source), surfaces(&reference));
        let fit = |start| {
            local_fit(
                Prepared::new(&source, &s),
                Prepared::new(&reference, &r),
                start,
            )
            .unwrap()
        };
        let stay = motion.inverse() * fit(motion);
        assert!(stay.translation.vector.norm() < 1e-9, "{stay}");
        assert!(stay.rotation.angle().abs() < 1e-12, "{stay}");
        let off = Isometry2::new(Vector2::new(0.03, -0.02), 0.3_f64.to_radians());
        let start = off * motion;
        let back = motion.inverse() * fit(start);
        let pulled = start.inverse() * fit(start);
        assert!(
            back.translation.vector.norm() < 1e-3,
            "{} m",
            back.translation.vector.norm()
        );
        assert!(
            back.rotation.angle().to_degrees().abs() < 0.01,
            "{} deg",
            back.rotation.angle().to_degrees()
        );
        // How far the pairs pull, seen from the start: the offset undone.
        assert!(
            (pulled.translation.vector.norm() - 0.036).abs() < 2e-3,
            "{pulled}"
        );
        // A NaN start is refused, as a registration's.
        let nan = Isometry2::new(Vector2::new(f64::NAN, 0.0), 0.0);
        assert!(local_fit(
            Prepared::new(&source, &s),
            Prepared::new(&reference, &r),
            nan
        )
        .is_err());
    }
}
