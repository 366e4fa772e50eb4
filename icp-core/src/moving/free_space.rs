//! The `free_space` detector: a return is seen to move when a neighbouring scan of the sequence
//! looked through the place where it lies (scan differencing by ray casting, as in DATMO: Wang,
//! Thorpe, Thrun, Hebert & Durrant-Whyte 2007), and a short surface is left out whole when
//! enough of its returns are.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use nalgebra::Point2;

use super::between::Between;
use super::range_image::Window;
use super::segments::{extent_m, segments};
use super::{Detection, MovingReturns, Neighbour, Placement, FREE_SPACE};
use crate::registry::{ParamError, Params, StageKind, StageSpec};
use crate::{Scan, SensorModel};

/// Parameters of the `free_space` detector. Chosen on rough harbours of seeds 7, 11 and 13
/// (and seed 7 without boats, for what it leaves out where nothing moves); see
/// docs/moving-returns.md for the figures and the checks elsewhere.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(default, deny_unknown_fields)]
pub struct FreeSpace {
    /// Scans compared on each side (k−L..k+L): the further, the further a slow hull has
    /// moved, and the more a registration's error adds up along the chain.
    pub lag_scans: usize,
    /// Detections and second registrations, each round from the registrations of the round
    /// before: the first round's chained poses carry the moving hulls' bias, the second's
    /// much less, the third's less still (rough seeds 7, 11 and 13, per variant: `ok` pairs
    /// off by more than 0.5 m/s 3–24 with two rounds, 2–17 with three; four and five gain
    /// nothing more).
    pub rounds: usize,
    /// Whose registrations of consecutive scans place the neighbours: `point_to_line`, the
    /// stage's own (they are the least biased by the hulls: on rough harbours of seeds 7, 11
    /// and 13 they leave GICP's and HD_GICP's SOG medians within ±0.007 m/s and 7–23 gross
    /// `ok` pairs, where their own leave −0.012..−0.016 and 50–81), or `own`, the variant's.
    pub placement: Placement,
    /// A return is seen to move when at least this many neighbours looked through where it
    /// lies (a low surface that the rolling scanner's beam passes over now and then, or a
    /// return off the water, is looked through by one neighbour, seldom by more).
    pub min_votes: usize,
    /// A neighbour looks through a return when its ray at its bearing met nothing closer
    /// than the return's range plus `n_sigma` standard deviations of the difference (both
    /// ranges' noise by the sensor model, eq. 8, and the chained registrations' covariance
    /// along the ray).
    pub n_sigma: f64,
    /// …and never closer than this, m (the surface roughness and beam footprint the sensor
    /// model leaves out).
    pub min_gap_m: f64,
    /// The neighbour's rays within this many of its beam spacings of the bearing are asked
    /// (at least `n_sigma` standard deviations of the two bearings' difference, eq. 8's σ_α),
    /// and all must have looked past the return: a return at the edge of a surface, or on a
    /// surface seen obliquely, is not seen to move because the nearest ray slipped past.
    pub half_width_beams: f64,
    /// Neighbouring returns closer than this are one surface, m.
    pub segment_gap_m: f64,
    /// A surface longer than this (bounding-box diagonal, m) is never left out whole: a quay
    /// or a wall is not a boat. Its returns seen to move are kept, for the robust kernel.
    pub max_extent_m: f64,
    /// A surface is left out whole when at least this share of its returns is seen to move…
    pub min_share: f64,
    /// …and at least this many.
    pub min_returns: usize,
    /// A neighbour that looks through more than this share of the scene (returns weighted by
    /// range) is not asked: its chained pose is wrong (a gross registration on the way).
    pub max_neighbour_share: f64,
    /// The share of the scene (each return weighted by its range: the length of surface it
    /// samples) left out above which the scan's evidence for one motion is split: the pair is
    /// flagged `dynamic`.
    pub max_moving_share: f64,
    /// Once every scan is detected, a surface kept whole (no longer than `max_extent_m`) is
    /// left out when its returns lie within this distance of returns left out of both the scan
    /// before and the scan after, placed by their registrations, m (0: never). A hull's side
    /// that slides along itself is seen to move in some scans and not in others; the static
    /// scene is seldom left out at one place by the scans on both sides.
    pub between_gap_m: f64,
    /// …for at least this share of the surface's returns.
    pub between_min_share: f64,
}

impl Default for FreeSpace {
    fn default() -> Self {
        Self {
            rounds: 3,
            placement: Placement::PointToLine,
            lag_scans: 8,
            min_votes: 3,
            n_sigma: 3.0,
            min_gap_m: 0.10,
            half_width_beams: 1.0,
            segment_gap_m: 0.8,
            max_extent_m: 12.0,
            min_share: 0.02,
            min_returns: 5,
            max_neighbour_share: 0.15,
            max_moving_share: 0.5,
            between_gap_m: 0.5,
            between_min_share: 0.25,
        }
    }
}

impl Params for FreeSpace {
    fn validate(&self) -> Result<(), ParamError> {
        let positive = [
            ("n_sigma", self.n_sigma),
            ("segment_gap_m", self.segment_gap_m),
            ("max_extent_m", self.max_extent_m),
        ];
        for (name, value) in positive {
            if !(value.is_finite() && value > 0.0) {
                return Err(ParamError::new(name, value, "must be finite and positive"));
            }
        }
        let non_negative = [
            ("min_gap_m", self.min_gap_m),
            ("half_width_beams", self.half_width_beams),
            ("between_gap_m", self.between_gap_m),
        ];
        for (name, value) in non_negative {
            if !(value.is_finite() && value >= 0.0) {
                return Err(ParamError::new(name, value, "must be finite and ≥ 0"));
            }
        }
        for (name, value) in [
            ("min_share", self.min_share),
            ("max_moving_share", self.max_moving_share),
            ("max_neighbour_share", self.max_neighbour_share),
            ("between_min_share", self.between_min_share),
        ] {
            if !(0.0..=1.0).contains(&value) {
                return Err(ParamError::new(name, value, "must be within [0, 1]"));
            }
        }
        if self.rounds == 0 {
            return Err(ParamError::new("rounds", 0.0, "must be at least 1"));
        }
        if self.lag_scans == 0 {
            return Err(ParamError::new("lag_scans", 0.0, "must be at least 1"));
        }
        if self.min_votes == 0 || self.min_votes > 2 * self.lag_scans {
            return Err(ParamError::new(
                "min_votes",
                self.min_votes as f64,
                "must be within 1..=2·lag_scans (the neighbours asked)",
            ));
        }
        Ok(())
    }
}

impl FreeSpace {
    /// The half width of the window of `neighbour`'s rays asked about a return, rad.
    fn half_width_rad(&self, neighbour: &Neighbour<'_>, sensor: &SensorModel) -> f64 {
        // Both bearings' noise (eq. 8's σ_α) moves a return along its surface, and on a
        // surface seen obliquely that is a change of range: the window covers it.
        (self.half_width_beams * neighbour.image.spacing_rad())
            .max(self.n_sigma * sensor.bearing_difference_sd_rad())
    }

    /// Whether `neighbour`, asked over its `window`, looked through where return `i` of
    /// `scan` lies.
    fn seen_through(
        &self,
        neighbour: &Neighbour<'_>,
        window: &mut Window<'_>,
        sensor: &SensorModel,
        i: usize,
        scan: &Scan,
    ) -> bool {
        let r = scan.returns()[i];
        let q = neighbour.t_nb_scan * r.point;
        let range_m = q.coords.norm();
        if range_m <= 0.0 {
            return false;
        }
        let Some(seen_m) = window.nearest_range_m(q.coords, r.bearing_rad) else {
            return false;
        };
        // The bar below is never nearer than `min_gap_m`: most returns (the static scene, seen
        // where it was) stop here, without the variances.
        if seen_m <= range_m + self.min_gap_m {
            return false;
        }
        // The chained pose's error along the ray: δq = δt + J(q − t) δθ.
        let ray = q.coords / range_m;
        let lever = q.coords - neighbour.t_nb_scan.translation.vector;
        let g = nalgebra::Vector3::new(ray.x, ray.y, ray.y * lever.x - ray.x * lever.y);
        let pose_var = (g.transpose() * neighbour.covariance * g)[(0, 0)].max(0.0);
        let var = sensor.sigma_r_m(range_m).powi(2) + sensor.sigma_r_m(seen_m).powi(2) + pose_var;
        seen_m > range_m + (self.n_sigma * var.sqrt()).max(self.min_gap_m)
    }
}

impl MovingReturns for FreeSpace {
    fn spec(&self) -> StageSpec {
        StageSpec::of(FREE_SPACE.name(), self)
    }

    fn lag_scans(&self) -> usize {
        self.lag_scans
    }

    fn rounds(&self) -> usize {
        self.rounds
    }

    fn placement(&self) -> Placement {
        self.placement
    }

    fn detect(&self, scan: &Scan, neighbours: &[Neighbour<'_>], sensor: &SensorModel) -> Detection {
        let n = scan.len();
        let mut votes = vec![0usize; n];
        let mut through = vec![false; n];
        let all: f64 = scan.returns().iter().map(|r| r.range_m).sum();
        for nb in neighbours {
            let mut window = nb.image.window(self.half_width_rad(nb, sensor));
            let mut share = 0.0;
            for (i, t) in through.iter_mut().enumerate() {
                *t = self.seen_through(nb, &mut window, sensor, i, scan);
                share += if *t { scan.returns()[i].range_m } else { 0.0 };
            }
            // A chained pose that is wrong makes the static scene look through itself: such a
            // neighbour says nothing about what moves.
            if share > self.max_neighbour_share * all {
                continue;
            }
            for (v, &t) in votes.iter_mut().zip(&through) {
                *v += usize::from(t);
            }
        }
        let seen: Vec<bool> = votes.iter().map(|&v| v >= self.min_votes).collect();
        let mut left_out = vec![false; n];
        for run in segments(scan, self.segment_gap_m) {
            let moved = seen[run.clone()].iter().filter(|&&s| s).count();
            let whole = moved >= self.min_returns
                && moved as f64 >= self.min_share * run.len() as f64
                && extent_m(scan, &run) <= self.max_extent_m;
            for i in run {
                left_out[i] = whole;
            }
        }
        Detection::new(
            scan,
            left_out,
            seen.iter().filter(|&&s| s).count(),
            self.max_moving_share,
        )
    }

    fn fill_between(
        &self,
        scan: &Scan,
        detection: Detection,
        before: &[Point2<f64>],
        after: &[Point2<f64>],
    ) -> Detection {
        if self.between_gap_m == 0.0 {
            return detection;
        }
        let between = Between {
            gap_m: self.between_gap_m,
            min_share: self.between_min_share,
            segment_gap_m: self.segment_gap_m,
            max_extent_m: self.max_extent_m,
        };
        let left_out = between.fill(scan, &detection.left_out, before, after);
        Detection::new(scan, left_out, detection.seen, self.max_moving_share)
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::{Isometry2, Matrix3, Point2, Vector2};

    use super::*;
    use crate::moving::RangeImage;

    /// What a noiseless 360-beam scanner at `pose` sees of a 40 × 30 m room and of a 6 × 2 m
    /// box centred at `boat` (axis-aligned); per beam, whether it met the box.
    fn scan_at(pose: &Isometry2<f64>, boat: Option<Point2<f64>>) -> (Scan, Vec<bool>) {
        let walls = [
            ([-20.0, -15.0], [20.0, -15.0]),
            ([20.0, -15.0], [20.0, 15.0]),
            ([20.0, 15.0], [-20.0, 15.0]),
            ([-20.0, 15.0], [-20.0, -15.0]),
        ];
        let mut segments: Vec<(Point2<f64>, Point2<f64>, bool)> = walls
            .iter()
            .map(|(a, b)| (Point2::from(*a), Point2::from(*b), false))
            .collect();
        if let Some(c) = boat {
            let corners = [(3.0, 1.0), (-3.0, 1.0), (-3.0, -1.0), (3.0, -1.0)]
                .map(|(x, y)| c + Vector2::new(x, y));
            for i in 0..4 {
                segments.push((corners[i], corners[(i + 1) % 4], true));
            }
        }
        let (mut ranges, mut bearings, mut moving) = (vec![], vec![], vec![]);
        for b in 0..360 {
            let bearing = (b as f64 + 0.5).to_radians();
            let dir = pose.rotation * Vector2::new(bearing.cos(), bearing.sin());
            let o = Point2::from(pose.translation.vector);
            let hit = segments
                .iter()
                .filter_map(|(a, b, m)| {
                    let e = b - a;
                    let den = dir.x * e.y - dir.y * e.x;
                    if den.abs() < 1e-12 {
                        return None;
                    }
                    let w = a - o;
                    let t = (w.x * e.y - w.y * e.x) / den;
                    let s = (w.x * dir.y - w.y * dir.x) / den;
                    (t > 0.0 && (0.0..=1.0).contains(&s)).then_some((t, *m))
                })
                .min_by(|a, b| a.0.total_cmp(&b.0));
            if let Some((t, m)) = hit {
                ranges.push(t);
                bearings.push(bearing);
                moving.push(m);
            }
        }
        (Scan::from_polar(&ranges, &bearings).unwrap(), moving)
    }

    /// The vessel at 1 m/s along x, 0.2 s between scans; a boat 4 m to port overtaking at
    /// `boat_mps` (None: no boat). Scan `k`'s detection from its neighbours at their true poses.
    fn detect_at(k: usize, boat_mps: Option<f64>, detector: &FreeSpace) -> (Detection, Vec<bool>) {
        let pose = |i: usize| Isometry2::new(Vector2::new(-6.0 + 0.2 * i as f64, -2.0), 0.0);
        let boat = |i: usize| boat_mps.map(|v| Point2::new(-4.0 + 0.2 * v * i as f64, 2.0));
        let scans: Vec<(Scan, Vec<bool>)> =
            (0..=2 * k).map(|i| scan_at(&pose(i), boat(i))).collect();
        let images: Vec<RangeImage> = scans.iter().map(|(s, _)| RangeImage::new(s)).collect();
        let neighbours: Vec<Neighbour> = (0..=2 * k)
            .filter(|&j| j != k && j.abs_diff(k) <= detector.lag_scans)
            .map(|j| Neighbour {
                image: &images[j],
                t_nb_scan: pose(j).inverse() * pose(k),
                covariance: Matrix3::zeros(),
            })
            .collect();
        let detection = detector.detect(&scans[k].0, &neighbours, &SensorModel::sweep());
        (detection, scans[k].1.clone())
    }

    #[test]
    fn a_passing_hull_is_left_out_whole_and_the_static_room_is_kept() {
        let detector = FreeSpace::default();
        // 0.5 m/s faster than the vessel: 0.8 m over the 8 scans on either side, so its sides,
        // sliding along themselves, are mostly not seen to move.
        let (d, truth) = detect_at(10, Some(1.5), &detector);
        let hull = truth.iter().filter(|&&m| m).count();
        let hull_out = truth
            .iter()
            .zip(&d.left_out)
            .filter(|(&m, &o)| m && o)
            .count();
        let room_out = truth
            .iter()
            .zip(&d.left_out)
            .filter(|(&m, &o)| !m && o)
            .count();
        assert!(hull > 30, "the hull is seen ({hull} returns)");
        assert_eq!(hull_out, hull, "every return of the hull is left out");
        assert_eq!(room_out, 0, "no wall return is left out");
        // The hull's sides slide along themselves: fewer of its returns are seen to move than
        // are left out (the rest go with their surface).
        assert!(d.seen < hull, "{} seen of {hull}", d.seen);
        assert!(!d.split, "share {}", d.moving_share);
    }

    #[test]
    fn a_static_scene_leaves_nothing_out_and_a_hull_keeping_pace_is_found() {
        let detector = FreeSpace::default();
        let (still, _) = detect_at(10, None, &detector);
        assert_eq!(still.count(), 0);
        assert_eq!(still.moving_share, 0.0);
        // A boat at the vessel's own speed sits still against the scanner but moves against the
        // room: the neighbours are placed by the room (the registrations), so it is found.
        let (with_vessel, truth) = detect_at(10, Some(1.0), &detector);
        let hull = truth.iter().filter(|&&m| m).count();
        let hull_out = truth
            .iter()
            .zip(&with_vessel.left_out)
            .filter(|(&m, &o)| m && o)
            .count();
        assert!(hull_out > hull / 2, "{hull_out} of {hull}");
    }

    #[test]
    fn without_neighbours_or_returns_nothing_is_left_out_and_nothing_breaks() {
        let detector = FreeSpace::default();
        let (scan, _) = scan_at(&Isometry2::identity(), Some(Point2::new(3.0, 2.0)));
        let d = detector.detect(&scan, &[], &SensorModel::sweep());
        assert_eq!((d.count(), d.seen, d.split), (0, 0, false));
        let empty = Scan::from_cartesian(&[]).unwrap();
        let image = RangeImage::new(&empty);
        let nb = Neighbour {
            image: &image,
            t_nb_scan: Isometry2::identity(),
            covariance: Matrix3::zeros(),
        };
        let d = detector.detect(&empty, &[nb], &SensorModel::sweep());
        assert_eq!((d.count(), d.moving_share), (0, 0.0));
        let d = detector.detect(&scan, &[nb], &SensorModel::sweep());
        assert_eq!(
            d.count(),
            0,
            "an empty neighbour saw nothing, looked through nothing"
        );
    }

    #[test]
    fn parameters_outside_their_domain_are_refused() {
        for bad in [
            FreeSpace {
                rounds: 0,
                ..FreeSpace::default()
            },
            FreeSpace {
                lag_scans: 0,
                ..FreeSpace::default()
            },
            FreeSpace {
                min_votes: 17,
                ..FreeSpace::default()
            },
            FreeSpace {
                n_sigma: f64::NAN,
                ..FreeSpace::default()
            },
            FreeSpace {
                min_share: 1.5,
                ..FreeSpace::default()
            },
            FreeSpace {
                min_gap_m: -0.1,
                ..FreeSpace::default()
            },
        ] {
            assert!(bad.validate().is_err(), "{bad:?}");
        }
        assert!(FreeSpace::default().validate().is_ok());
    }
}
