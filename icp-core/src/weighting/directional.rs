//! Directional weights (Naus & Marchel 2019, eqs. 9, 11 and 12): the HD_ICP variant.

use super::{PairView, PairWeighting};
use crate::registry::{Kind, NoParams, StageKind, StageSpec};
use crate::SensorModel;

/// `w = 1 / sqrt(σ_β²(k) + σ_β²(k+1))`, with `σ_β²` each point's variance (eq. 9) along the
/// line joining the pair, each point's covariance (eq. 8) taken in its own scan's frame.
///
/// The direction `β` is that of `dst − src_moved` in scan k+1's frame, and `β − θ` in scan k's
/// frame. When the two points coincide the direction is undefined, and each point contributes
/// its variance averaged over all directions, `M²/2` (the trace of eq. 8 over two).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Directional {
    /// The error model of both scans.
    pub sensor: SensorModel,
}

/// The registered kind.
pub const KIND: Kind<NoParams, dyn PairWeighting> = Kind::new(
    "directional",
    "w = 1/sqrt(σ²_β(k) + σ²_β(k+1)) along the line joining the pair (Naus & Marchel 2019, eqs. 9, 11, 12: HD_ICP)",
    |_, ctx| Box::new(Directional { sensor: ctx.sensor }),
);

impl PairWeighting for Directional {
    fn spec(&self) -> StageSpec {
        StageSpec::kind(KIND.name())
    }

    /// Computed without trigonometry: the cosine of the angle between the pair's line and a
    /// point's beam is `d · p / (|d| r)` (in scan k's frame for the source point, whose beam
    /// direction `R p` is the moved point minus the translation; in scan k+1's frame for the
    /// reference point), and eq. 9 in the beam frame needs only its square.
    #[inline]
    fn weight(&self, pair: &PairView<'_>) -> f64 {
        let (src, dst) = (pair.src, pair.dst);
        let d = dst.point - pair.src_moved;
        let d2 = d.norm_squared();
        let g = if d2 == 0.0 {
            0.5 * (self.sensor.mean_error_sq(src.range_m) + self.sensor.mean_error_sq(dst.range_m))
        } else {
            let beam_src = pair.rotation_ref_src * src.point.coords; // R p, in scan k+1's axes
            let cos2 = |dot: f64, r: f64| (dot * dot / (d2 * r * r)).min(1.0);
            self.sensor
                .directional_variance_cos2(src.range_m, cos2(d.dot(&beam_src), src.range_m))
                + self.sensor.directional_variance_cos2(
                    dst.range_m,
                    cos2(d.dot(&dst.point.coords), dst.range_m),
                )
        };
        1.0 / g.sqrt()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scan::Return;
    use nalgebra::{Point2, UnitComplex};

    fn ret(r: f64, a: f64) -> Return {
        Return {
            point: Point2::new(r * a.cos(), r * a.sin()),
            range_m: r,
            bearing_rad: a,
        }
    }

    #[test]
    fn along_beam_pairs_weigh_more_than_across_beam_pairs() {
        let sensor = SensorModel::sweep();
        let w = Directional { sensor };
        let src = ret(20.0, 0.0);
        // The pair's line along both beams: only σ_r counts, so the weight is large.
        let dst_along = ret(20.3, 0.0);
        let along = w.weight(&PairView {
            src: &src,
            dst: &dst_along,
            src_moved: src.point,
            rotation_ref_src: UnitComplex::identity(),
            normal: None,
        });
        let sr = |r: f64| 0.004258 * r;
        let hand = 1.0 / (sr(20.0).powi(2) + sr(20.3).powi(2)).sqrt();
        assert!((along - hand).abs() < 1e-9 * hand, "{along} vs {hand}");
        // Across the beams only σ_α r counts: the weight is smaller by about
        // σ_α / k = 0.00873 / 0.004258 = 2.05 (eq. 9 along the ellipse's long axis).
        let dst_across = Return {
            point: Point2::new(20.0, 0.3),
            range_m: 20.0f64.hypot(0.3),
            bearing_rad: 0.3f64.atan2(20.0),
        };
        let across = w.weight(&PairView {
            src: &src,
            dst: &dst_across,
            src_moved: src.point,
            rotation_ref_src: UnitComplex::identity(),
            normal: None,
        });
        let ratio = along / across;
        assert!(
            (ratio - 2.05).abs() < 0.03,
            "{along} vs {across}: ratio {ratio}"
        );
    }

    #[test]
    fn direction_is_taken_in_each_scan_frame() {
        // Rotating scan k by θ and telling the weighting so gives the same weight.
        let w = Directional {
            sensor: SensorModel::sweep(),
        };
        let theta = 0.4;
        let src = ret(15.0, 0.2);
        let dst = ret(15.2, 0.2 + theta + 0.01);
        let rot = UnitComplex::new(theta);
        let moved = rot * src.point;
        let a = w.weight(&PairView {
            src: &src,
            dst: &dst,
            src_moved: moved,
            rotation_ref_src: rot,
            normal: None,
        });
        // Same geometry, with scan k already expressed in scan k+1's orientation.
        let src_rot = ret(15.0, 0.2 + theta);
        let b = w.weight(&PairView {
            src: &src_rot,
            dst: &dst,
            src_moved: src_rot.point,
            rotation_ref_src: UnitComplex::identity(),
            normal: None,
        });
        assert!((a - b).abs() < 1e-9 * a, "{a} vs {b}");
    }

    #[test]
    fn equals_eq_9_in_angle_form() {
        // The trig-free weight against eq. 9 with explicit angles: β the pair's direction in
        // scan k+1's frame, β − θ in scan k's frame.
        let sensor = SensorModel {
            sigma_r_const_m: 0.01,
            ..SensorModel::sweep()
        };
        let w = Directional { sensor };
        for i in 0..100 {
            let theta = -0.5 + 0.01 * i as f64;
            let src = ret(3.0 + 0.3 * i as f64, 0.21 * i as f64);
            let dst = ret(4.0 + 0.25 * i as f64, 0.05 + 0.2 * i as f64);
            let rot = UnitComplex::new(theta);
            let moved = rot * src.point + nalgebra::Vector2::new(0.3, -0.2);
            let d = dst.point - moved;
            let beta = d.y.atan2(d.x);
            let g = sensor.directional_variance(src.range_m, src.bearing_rad, beta - theta)
                + sensor.directional_variance(dst.range_m, dst.bearing_rad, beta);
            let got = w.weight(&PairView {
                src: &src,
                dst: &dst,
                src_moved: moved,
                rotation_ref_src: rot,
                normal: None,
            });
            assert!(
                (got - 1.0 / g.sqrt()).abs() < 1e-9 * got,
                "{got} vs {}",
                1.0 / g.sqrt()
            );
        }
    }

    #[test]
    fn coincident_pair_uses_direction_average() {
        let sensor = SensorModel::sweep();
        let p = ret(10.0, 1.0);
        let w = Directional { sensor }.weight(&PairView {
            src: &p,
            dst: &p,
            src_moved: p.point,
            rotation_ref_src: UnitComplex::identity(),
            normal: None,
        });
        let expected = 1.0 / sensor.mean_error_sq(10.0).sqrt();
        assert!((w - expected).abs() < 1e-12 * w);
    }
}
