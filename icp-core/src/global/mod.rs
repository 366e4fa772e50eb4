//! A global initial guess by correlative scan matching (CSM): the pose of a source scan on a
//! likelihood grid of the reference scan that maximises the mean likelihood of the moved
//! source returns, over a square translation window around a centre pose and a set of
//! rotation candidates, found exactly by branch and bound. It gives a fine registration a
//! start within its basin when the motion between the scans is too large for a start at the
//! identity.
//!
//! * [`ambiguity`]: the poses around a result that score almost as well (Olson 2009's
//!   correlative covariance), and the pairs that fit in two distinct places.
//! * [`grid`]: the likelihood grid of the reference (Olson 2009, "Real-time correlative scan
//!   matching", ICRA) and its max-pooled pyramid (Hess et al. 2016, "Real-time loop closure in
//!   2D LIDAR SLAM", ICRA).
//! * `search` (private): the depth-first branch and bound over translations (Hess et al.
//!   2016).
//! * `check` (private): whether any pose scores above a bar, searched only above it: the
//!   check of a result found elsewhere ([`GlobalMatcher::best_above`]).
//! * `histogram` (private): rotation hypotheses from orientation histograms of the surface
//!   normals (Weiss & von Puttkamer 1995).
//!
//! The result is the exact maximum over the discrete search space: rotations on a lattice of
//! `angular_step_deg` around the centre's, translations on the grid's cells around the
//! centre's, each source return scored at the cell it falls in. Nothing refines it below a
//! cell and a step: the fine registration that follows does.
//!
//! # Score
//! The mean is weighted by the returns' ranges. A fan of evenly spaced beams samples a surface
//! at range `r` every `r Δα` (at normal incidence), so weighted by its range each return
//! stands for the length of surface it sampled, and every metre of surface has the same say.
//! Unweighted, the densely sampled near field outvotes the rest: on a 180° scan moving along
//! a corridor, the motion carries the near walls out of the reference's field of view, and the
//! pose that keeps them in view (no motion) beat the true one. On the aces log (full
//! rotation search) 53% of the guesses were within 0.3 m and 3° unweighted, 99% weighted.
//!
//! ```
//! use icp_core::global::{GlobalMatcher, GlobalParams, GlobalWorkspace};
//! use icp_core::{Prepared, Scan, SurfaceParams, Surfaces};
//! use nalgebra::{Isometry2, Point2, Vector2};
//!
//! // A room with a recess, seen from inside, and seen again after a 1.2 m, 60° move.
//! let room: Vec<[f64; 2]> = (0..400)
//!     .map(|i| {
//!         let s = i as f64 * 0.05;
//!         match i / 100 {
//!             0 => [-4.0 + s * 0.5, -3.0],
//!             1 => [6.0, -3.0 + s * 0.4],
//!             2 => [6.0 - s, 5.0],
//!             _ => [-4.0, 5.0 - s * 0.8],
//!         }
//!     })
//!     .chain((0..40).map(|i| [1.0 + i as f64 * 0.05, -3.0 + 0.02 * i as f64]))
//!     .collect();
//! let truth = Isometry2::new(Vector2::new(0.9, -0.8), 60f64.to_radians());
//! let moved: Vec<[f64; 2]> = room
//!     .iter()
//!     .map(|&[x, y]| {
//!         let q = truth.inverse() * Point2::new(x, y);
//!         [q.x, q.y]
//!     })
//!     .collect();
//! let (source, reference) = (Scan::from_cartesian(&moved)?, Scan::from_cartesian(&room)?);
//! let sp = SurfaceParams::default();
//! let (ss, rs) = (Surfaces::estimate(&source, &sp), Surfaces::estimate(&reference, &sp));
//!
//! let params = GlobalParams::default();
//! let matcher = GlobalMatcher::new(Prepared::new(&reference, &rs), &params)?;
//! let guess = matcher.search(
//!     &mut GlobalWorkspace::default(),
//!     Prepared::new(&source, &ss),
//!     Isometry2::identity(),
//! )?;
//! assert!((guess.t_ref_src.translation.vector - truth.translation.vector).norm() < 0.1);
//! assert!((guess.t_ref_src.rotation.angle() - truth.rotation.angle()).abs() < 1f64.to_radians());
//! # Ok::<(), icp_core::IcpError>(())
//! ```

pub mod ambiguity;
mod check;
pub mod grid;
mod histogram;
mod likelihood;
mod search;

use nalgebra::{Isometry2, Point2, Translation2, UnitComplex, Vector2};
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::error::ParamError;
use crate::error::{ConfigError, ScanRole};
use crate::{IcpError, Prepared};
pub use check::{Above, SourceSearch};
use grid::{mean_of, range_weight};
pub use grid::{score_at, GridPool, LikelihoodGrid};
use histogram::OrientationHistogram;
use search::{Best, Buffers, Search};

/// How the rotation candidates are chosen.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum RotationMode {
    /// Every `angular_step_deg` within `max_rotation_deg` of the centre's rotation.
    Full,
    /// Every `angular_step_deg` within `histogram_window_deg` of the centre's rotation and of
    /// the `histogram_peaks` best rotations of the orientation histograms (Weiss & von
    /// Puttkamer 1995), those within `max_rotation_deg` of the centre's.
    Histogram,
}

/// The parameters of the global search.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(default, deny_unknown_fields)]
pub struct GlobalParams {
    /// Side of a likelihood-grid cell, which is also the translation step, metres.
    pub resolution_m: f64,
    /// Standard deviation of the likelihood around each reference point, metres.
    pub sigma_m: f64,
    /// Half-width of the square translation window around the centre, metres.
    pub window_m: f64,
    /// How the rotation candidates are chosen: `full` or `histogram`.
    pub rotation: RotationMode,
    /// Largest rotation searched away from the centre's, degrees, in [0, 180].
    pub max_rotation_deg: f64,
    /// Spacing of the rotation candidates, degrees; `null`: the angle that moves the source's
    /// farthest return by one cell, `acos(1 − resolution² / (2 range²))` (Hess et al. 2016),
    /// e.g. 0.21° for a return at 27 m and 0.1 m cells.
    pub angular_step_deg: Option<f64>,
    /// Width of an orientation-histogram bin, degrees (histogram mode).
    pub histogram_bin_deg: f64,
    /// Rotation hypotheses taken from the histograms' correlation peaks (histogram mode).
    pub histogram_peaks: usize,
    /// Rotations searched either side of each hypothesis, degrees (histogram mode).
    pub histogram_window_deg: f64,
    /// The runner-up (see [`GlobalGuess::runner_up_score`]) is searched for down to this
    /// fraction of the best score, in [0, 1]; 1: not searched.
    pub ambiguity_ratio: f64,
    /// A translation more than this from the best along an axis is a distinct hypothesis,
    /// metres.
    pub ambiguity_separation_m: f64,
    /// Most cells of the likelihood grid and its pyramid together (1 byte each).
    pub max_grid_cells: u64,
}

/// The defaults, and what they were chosen on: *aces* (the CARMEN ACES log, 439 pairs of
/// 180-beam 1° scans, steps up to 1.54 m and 78°) and *synthetic* (the first 100 pairs of the
/// synthetic harbour of `datasets`, 750 beams at 0.48°, 0.24 m steps), searched around the
/// identity; a guess is right within 0.3 m and 3° of the reference.
///
/// * `resolution_m` = `sigma_m` = 0.1 m: the best on aces of 0.05–0.2 m (84% of the pairs
///   within 0.1 m and 1°, 98.4% right); 0.05 m was worse there (83%, 96%) and 4–8 times
///   slower on both; all found every synthetic pair.
/// * `window_m` 2 m: aces' largest step is 1.54 m and a 1 s step at the harbour's 1.2 m/s is
///   1.2 m; 1 m lost 1.4% of the aces pairs, 1.5 and 3 m changed nothing.
/// * `rotation` histogram, `histogram_bin_deg` 1°, `histogram_peaks` 4,
///   `histogram_window_deg` 2° (chosen on aces): 98.4% right (the full search 98.6%) at an
///   eighth of its cost; 2 peaks or ±1° lost 0.9–1.6%, 8 peaks or ±4° gained 0.2% for
///   1.4–1.6 times the cells read. Checked on synthetic with the centre moved 45–120° and up
///   to 1.2 m off the truth: every pair found.
/// * `max_rotation_deg` 180, `angular_step_deg` from the farthest return (0.2° for 27 m, the
///   median on aces): no assumption on the turn, and no return moves by more than a cell
///   between two rotation candidates.
/// * `ambiguity_ratio` 0.8, `ambiguity_separation_m` 0.5 m (chosen on aces, the only data
///   with wrong guesses): each of the 7 wrong aces guesses has a runner-up above 0.8 × its
///   score (4 above 0.9, against 15 of the 432 right ones); no synthetic pair has one; 2% more
///   cells read. 0.5 m is beyond the width of a score peak (3σ) and below the corridor
///   shifts of the wrong guesses (0.9–1.4 m).
/// * `max_grid_cells` 2^24 (16 MiB): the largest grid with its pyramid and their padding is
///   2.8 M cells on aces, 3.6 M on the synthetic harbour and 5.5 M on marina.
impl Default for GlobalParams {
    fn default() -> Self {
        Self {
            resolution_m: 0.1,
            sigma_m: 0.1,
            window_m: 2.0,
            rotation: RotationMode::Histogram,
            max_rotation_deg: 180.0,
            angular_step_deg: None,
            histogram_bin_deg: 1.0,
            histogram_peaks: 4,
            histogram_window_deg: 2.0,
            ambiguity_ratio: 0.8,
            ambiguity_separation_m: 0.5,
            max_grid_cells: 1 << 24,
        }
    }
}

/// Most cells either side of the centre in the translation window.
pub const MAX_WINDOW_CELLS: f64 = 4096.0;

/// The largest `max_grid_cells` (4 GiB of cells).
pub const MAX_GRID_CELLS: u64 = 1 << 32;

/// Most rotation candidates of one search.
pub const MAX_ROTATIONS: usize = 1 << 20;

/// Most orientation-histogram bins (a tenth of a degree).
const MAX_HISTOGRAM_BINS: f64 = 3600.0;

impl GlobalParams {
    /// `Err` naming the first parameter outside its domain.
    pub fn validate(&self) -> Result<(), ParamError> {
        ParamError::check_positive("resolution_m", self.resolution_m)?;
        ParamError::check_positive("sigma_m", self.sigma_m)?;
        ParamError::check_non_negative("window_m", self.window_m)?;
        if self.window_m / self.resolution_m > MAX_WINDOW_CELLS {
            return Err(ParamError::new(
                "window_m",
                self.window_m,
                "more than 4096 cells of resolution_m either side of the centre",
            ));
        }
        if !(0.0..=180.0).contains(&self.max_rotation_deg) {
            return Err(ParamError::new(
                "max_rotation_deg",
                self.max_rotation_deg,
                "must be in [0, 180]",
            ));
        }
        if let Some(step) = self.angular_step_deg {
            ParamError::check_positive("angular_step_deg", step)?;
        }
        ParamError::check_positive("histogram_bin_deg", self.histogram_bin_deg)?;
        let bins = 360.0 / self.histogram_bin_deg;
        if !(4.0..=MAX_HISTOGRAM_BINS).contains(&bins) {
            return Err(ParamError::new(
                "histogram_bin_deg",
                self.histogram_bin_deg,
                "must give 4 to 3600 bins over 360 degrees",
            ));
        }
        if self.histogram_peaks == 0 {
            return Err(ParamError::new(
                "histogram_peaks",
                self.histogram_peaks,
                "at least one hypothesis is needed",
            ));
        }
        ParamError::check_non_negative("histogram_window_deg", self.histogram_window_deg)?;
        if !(0.0..=1.0).contains(&self.ambiguity_ratio) {
            return Err(ParamError::new(
                "ambiguity_ratio",
                self.ambiguity_ratio,
                "must be in [0, 1]",
            ));
        }
        ParamError::check_non_negative("ambiguity_separation_m", self.ambiguity_separation_m)?;
        if !(1..=MAX_GRID_CELLS).contains(&self.max_grid_cells) {
            return Err(ParamError::new(
                "max_grid_cells",
                self.max_grid_cells,
                "must be in [1, 2^32]",
            ));
        }
        Ok(())
    }

    /// Offsets either side of the centre, cells.
    fn window_cells(&self) -> i32 {
        (self.window_m / self.resolution_m).round() as i32
    }

    /// The pyramid's depth: the smallest whose top-level blocks cover the window two by two,
    /// four top-level nodes per rotation. Their sorted bounds tell the rotations apart better
    /// than one node over the whole window: on aces and the synthetic harbour, 15% and 3%
    /// fewer cells read at the median and 41% and 25% fewer at the 95th percentile in
    /// histogram mode, 22% and 33% fewer at the 95th percentile in full mode (8% and 21% more
    /// at its median); a level lower reads more in full mode.
    fn depth(&self) -> u32 {
        let width = 2 * self.window_cells() as u32 + 1;
        width.next_power_of_two().trailing_zeros().saturating_sub(1)
    }

    /// Bins of the orientation histograms.
    fn histogram_bins(&self) -> usize {
        (360.0 / self.histogram_bin_deg).round() as usize
    }

    /// The spacing of the rotation candidates for a source whose farthest return is at
    /// `max_range_m`, radians.
    fn angular_step_rad(&self, max_range_m: f64) -> f64 {
        match self.angular_step_deg {
            Some(step) => step.to_radians(),
            // acos(1 − x²/2) = 2 asin(x/2), which keeps its precision for a small x.
            None => 2.0 * (0.5 * self.resolution_m / max_range_m).min(1.0).asin(),
        }
    }
}

/// The global search's best pose.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct GlobalGuess {
    /// Maps source points into the reference frame; the centre when no pose scores above 0.
    pub t_ref_src: Isometry2<f64>,
    /// The mean likelihood of the moved source points, weighted by their ranges, in [0, 1]
    /// (see [`score_at`]).
    pub score: f64,
    /// The best score at the best pose's rotation of a translation distinct from the best one
    /// (more than `ambiguity_separation_m` away along an axis), when it exceeds
    /// `ambiguity_ratio` × `score`; `None`: no distinct translation scores that well (or none
    /// scores above 0, or the ratio is 1). Near `score`, the scans fit in two places, as along
    /// a corridor. Only the best rotation is searched again: an exact runner-up over all the
    /// rotations would cost about as much as the search itself.
    pub runner_up_score: Option<f64>,
    /// Rotation candidates searched.
    pub rotations: usize,
    /// Grid cells read by the search (one per source point per node scored).
    pub grid_lookups: u64,
}

/// Buffers of the global search, reused from one search to the next.
#[derive(Clone, Debug, Default)]
pub struct GlobalWorkspace {
    points: Vec<Point2<f64>>,
    weights: Vec<u32>,
    rotations: Vec<f64>,
    by_weight: Vec<(u32, Point2<f64>)>,
    buffers: Buffers,
}

/// A reference scan made ready for global searches: its likelihood grid and pyramid and, in
/// histogram mode, its orientation histogram. Built once per reference scan.
#[derive(Clone, Debug, PartialEq)]
pub struct GlobalMatcher {
    params: GlobalParams,
    grid: LikelihoodGrid,
    histogram: Option<OrientationHistogram>,
}

/// `angle_rad` wrapped into [−π, π).
fn wrap(angle_rad: f64) -> f64 {
    use std::f64::consts::{PI, TAU};
    (angle_rad + PI).rem_euclid(TAU) - PI
}

/// A parameter error as the crate's error.
fn section_error(source: ParamError) -> IcpError {
    IcpError::Config(ConfigError::Section {
        section: "global",
        source,
    })
}

/// `Err` unless `prepared` has one surface estimate per return.
fn check_surfaces(prepared: &Prepared<'_>, role: ScanRole) -> Result<(), IcpError> {
    prepared.check(prepared.surfaces.params(), role)
}

impl GlobalMatcher {
    /// Prepares `reference` for searches with `params`.
    ///
    /// `Err` when the parameters are invalid (naming the parameter), the scan has no return,
    /// its grid would exceed `max_grid_cells`, or (histogram mode) its surface estimates are
    /// not one per return.
    pub fn new(reference: Prepared<'_>, params: &GlobalParams) -> Result<Self, IcpError> {
        Self::new_in(reference, params, &mut GridPool::default())
    }

    /// [`Self::new`], its grid's levels in storage taken from `pool`: a run that hands each
    /// matcher back when done ([`Self::recycle`]) allocates its grids' memory once.
    pub fn new_in(
        reference: Prepared<'_>,
        params: &GlobalParams,
        pool: &mut GridPool,
    ) -> Result<Self, IcpError> {
        params.validate().map_err(section_error)?;
        let histogram = match params.rotation {
            RotationMode::Full => None,
            RotationMode::Histogram => {
                check_surfaces(&reference, ScanRole::Reference)?;
                Some(OrientationHistogram::new(
                    reference.surfaces,
                    params.histogram_bins(),
                ))
            }
        };
        let grid = LikelihoodGrid::new(
            reference.scan,
            params.resolution_m,
            params.sigma_m,
            params.depth(),
            params.window_cells(),
            params.max_grid_cells,
            pool,
        )?;
        Ok(Self {
            params: *params,
            grid,
            histogram,
        })
    }

    /// Gives the grid's storage to `pool`, for the next matcher ([`Self::new_in`]).
    pub fn recycle(self, pool: &mut GridPool) {
        self.grid.recycle(pool);
    }

    /// The parameters.
    pub fn params(&self) -> &GlobalParams {
        &self.params
    }

    /// The reference's likelihood grid, to score other poses with [`score_at`].
    pub fn grid(&self) -> &LikelihoodGrid {
        &self.grid
    }

    /// The pose of `source` in the reference frame that scores best within the window around
    /// `centre` (e.g. the identity, or odometry), in the buffers of `workspace`: [`Self::prepare`]
    /// then [`Self::best`].
    ///
    /// `Err` as [`Self::prepare`].
    pub fn search(
        &self,
        workspace: &mut GlobalWorkspace,
        source: Prepared<'_>,
        centre: Isometry2<f64>,
    ) -> Result<GlobalGuess, IcpError> {
        let mut prepared = self.prepare(workspace, source, centre)?;
        Ok(self.best(&mut prepared))
    }

    /// `source` made ready for searches within the window around `centre`, in the buffers of
    /// `workspace` (held until it is dropped): its points and weights and the rotation
    /// candidates, shared by [`Self::best`] and [`Self::best_above`] with the top-level nodes
    /// of the branch and bound that they score.
    ///
    /// `Err` when `centre` is not finite, the source has no return, (histogram mode) its
    /// surface estimates are not one per return, or the rotation candidates would exceed
    /// [`MAX_ROTATIONS`].
    pub fn prepare<'w>(
        &self,
        workspace: &'w mut GlobalWorkspace,
        source: Prepared<'_>,
        centre: Isometry2<f64>,
    ) -> Result<SourceSearch<'w>, IcpError> {
        let centre_angle = centre.rotation.angle();
        let t = centre.translation.vector;
        for value in [t.x, t.y, centre_angle] {
            if !value.is_finite() {
                return Err(IcpError::NonFinite {
                    what: "centre pose",
                    index: 0,
                    value,
                });
            }
        }
        let GlobalWorkspace {
            points,
            weights,
            rotations,
            by_weight,
            ..
        } = workspace;
        // Heaviest (farthest) returns first: off the best poses they miss first, and the
        // bounds' sums give up soonest (the sums, whole numbers, do not depend on the order).
        by_weight.clear();
        by_weight.extend(
            source
                .scan
                .returns()
                .iter()
                .map(|r| (range_weight(r), r.point)),
        );
        by_weight.sort_by_key(|&(w, _)| std::cmp::Reverse(w));
        points.clear();
        points.extend(by_weight.iter().map(|&(_, p)| p));
        weights.clear();
        weights.extend(by_weight.iter().map(|&(w, _)| w));
        if points.is_empty() {
            return Err(IcpError::TooFewPoints {
                role: ScanRole::Source,
                got: 0,
                need: 1,
            });
        }
        let max_range_m = source
            .scan
            .returns()
            .iter()
            .fold(0.0, |m: f64, r| m.max(r.range_m));
        let step_rad = self.params.angular_step_rad(max_range_m);
        self.rotation_candidates(source, centre_angle, step_rad, rotations)?;
        let total_weight = weights.iter().map(|&w| u64::from(w)).sum();
        let prepared = SourceSearch {
            workspace,
            centre,
            total_weight,
            lookups: 0,
            top_floor: None,
            best: None,
            cleared: None,
        };
        Ok(prepared)
    }

    /// Scores into `prepared` the top-level nodes whose bounds exceed `floor`, unless those
    /// of a floor no higher are there already.
    fn top_above(&self, prepared: &mut SourceSearch<'_>, floor: u64) {
        if prepared.top_floor.is_some_and(|f| f <= floor) {
            return;
        }
        let (search, buffers) = self.split(prepared);
        prepared.lookups += search.top_level(buffers, floor);
        prepared.top_floor = Some(floor);
    }

    /// The best pose of `prepared` and its runner-up (the search's whole answer).
    pub fn best(&self, prepared: &mut SourceSearch<'_>) -> GlobalGuess {
        self.top_above(prepared, 0);
        let known = prepared.best;
        let (search, buffers) = self.split(prepared);
        let best = known.unwrap_or_else(|| search.above(buffers, 0));
        let runner_up = (self.params.ambiguity_ratio < 1.0).then(|| {
            search.runner_up(
                buffers,
                &best,
                (self.params.ambiguity_ratio * best.sum as f64) as u64,
                (self.params.ambiguity_separation_m / self.params.resolution_m).round() as i32,
            )
        });
        let fresh = if known.is_some() { 0 } else { best.lookups };
        prepared.lookups += fresh + runner_up.map_or(0, |r| r.lookups);
        prepared.best = Some(best);
        let total = prepared.total_weight;
        GlobalGuess {
            t_ref_src: self.pose_of(prepared, &best),
            score: mean_of(best.sum, total),
            runner_up_score: runner_up
                .filter(|r| r.rotation.is_some())
                .map(|r| mean_of(r.sum, total)),
            rotations: prepared.workspace.rotations.len(),
            grid_lookups: prepared.lookups,
        }
    }

    /// The search over `prepared`'s buffers, and the buffers of its descents.
    fn split<'a>(&'a self, prepared: &'a mut SourceSearch<'_>) -> (Search<'a>, &'a mut Buffers) {
        let GlobalWorkspace {
            points,
            weights,
            rotations,
            buffers,
            ..
        } = &mut *prepared.workspace;
        let search = Search {
            grid: &self.grid,
            points,
            weights,
            rotations,
            centre: prepared.centre.translation.vector,
            window: self.params.window_cells(),
        };
        (search, buffers)
    }

    /// The pose of a search's `best` (the centre when no pose scores above 0).
    fn pose_of(&self, prepared: &SourceSearch<'_>, best: &Best) -> Isometry2<f64> {
        match best.rotation {
            Some(r) => {
                let offset = Vector2::new(f64::from(best.offset[0]), f64::from(best.offset[1]));
                Isometry2::from_parts(
                    Translation2::from(
                        prepared.centre.translation.vector + offset * self.params.resolution_m,
                    ),
                    UnitComplex::new(prepared.workspace.rotations[r]),
                )
            }
            None => prepared.centre,
        }
    }

    /// Fills `out` with the rotation candidates (radians, absolute): the lattice
    /// `centre + j · step` within `max_rotation_deg`, all of it (full mode) or the points
    /// within `histogram_window_deg` of the centre and of the histogram peaks (histogram
    /// mode), in increasing `j`.
    fn rotation_candidates(
        &self,
        source: Prepared<'_>,
        centre_rad: f64,
        step_rad: f64,
        out: &mut Vec<f64>,
    ) -> Result<(), IcpError> {
        let max_rad = self.params.max_rotation_deg.to_radians();
        // A hair of slack so that a step dividing the range reaches its end.
        let slack = 1.0 + 1e-12;
        let reach = (max_rad / step_rad * slack).floor();
        // Ranges of j, inclusive.
        let mut ranges: Vec<(f64, f64)> = Vec::new();
        match &self.histogram {
            None => ranges.push((-reach, reach)),
            Some(reference) => {
                check_surfaces(&source, ScanRole::Source)?;
                let histogram = OrientationHistogram::new(source.surfaces, reference.bins());
                let peaks = OrientationHistogram::rotation_peaks(
                    &histogram,
                    reference,
                    self.params.histogram_peaks,
                );
                let window_rad = self.params.histogram_window_deg.to_radians();
                for delta in std::iter::once(0.0).chain(peaks.iter().map(|p| wrap(p - centre_rad)))
                {
                    ranges.push((
                        ((delta - window_rad) / step_rad).ceil(),
                        ((delta + window_rad) / step_rad).floor(),
                    ));
                }
            }
        }
        let count: f64 = ranges
            .iter()
            .map(|&(lo, hi)| (hi - lo + 1.0).max(0.0))
            .sum();
        if count > MAX_ROTATIONS as f64 {
            return Err(IcpError::GlobalSearchTooLarge {
                what: "rotation candidates",
                count,
                max: MAX_ROTATIONS as f64,
            });
        }
        // The j of every range (whole numbers, exact as floats), in order and once each, then
        // their rotations; beyond ±π a rotation is the same the other way round.
        out.clear();
        out.extend(
            ranges
                .iter()
                .flat_map(|&(lo, hi)| lo as i64..=hi as i64)
                .map(|j| j as f64)
                .filter(|&j| wrap(j * step_rad).abs() <= max_rad * slack),
        );
        out.sort_by(f64::total_cmp);
        out.dedup();
        for j in out.iter_mut() {
            *j = centre_rad + *j * step_rad;
        }
        Ok(())
    }
}
