//! Returns that move against the rest of the scene (another boat, a walker), found without
//! truth and left out of a registration.
//!
//! A hull that passes beside the vessel moves along its own sides: point-to-line residuals on
//! the sides stay near zero (they cannot see motion along themselves), and the bias of the
//! speed comes from the hull's bow, stern and corners, which point-to-point and plane-to-plane
//! metrics match to where they were. Measured on rough harbours of seeds 7, 11 and 13 with the
//! truth labels: leaving out only those end returns brings PL_ICP's SOG median to within
//! ±0.005 m/s; leaving out only the sides changes nothing. A detector that judges a pair's
//! residuals alone misses the sides and, on a gross pair, sees static surfaces misfit as much as
//! the hull; so the detection here uses the sequence.
//!
//! **The principle** (scan differencing by ray casting, as in DATMO: Wang et al. 2007): the
//! static world agrees with one ego-motion across scans k−L..k+L. Chained through the
//! registrations of consecutive scans, and over the steps the chain does not trust by
//! registrations that skip them ([`Bridges`]) or, where none holds, by the trusted steps on
//! either side ([`predicted`]), a return of scan k falls along some ray of
//! each neighbouring scan; when that scan's rays there all met nothing until well beyond the
//! return ([`range_image`]), the neighbour looked through where the return lies: something
//! moved. The bow of a hull is seen so from the scans before (it had not arrived), its stern
//! from the scans after (it has left). The margin comes from the sensor model (eq. 8 of Naus &
//! Marchel 2019, both ranges) and the chained covariance along the ray, not from the pair's
//! residuals. A surface short enough to be a hull is then left out whole when enough of its
//! returns are seen to move ([`segments`]): its sides go with its ends. A surface kept in a
//! scan but lying where the scans on both sides left returns out goes too ([`between`]).
//!
//! **Where it runs.** A detector needs the sequence, not one pair: the harness registers every
//! pair, detects in each scan from its neighbours' placed by a chain of registrations
//! ([`Placement`]), and registers the pairs again without the returns left out, from the
//! first result (`eval`'s `run::moving`). It is a stage of a variant's configuration (`"moving": "free_space"`), on
//! for PL_ICP, HD_PL_ICP, GICP and HD_GICP and off for the paper's four variants, whose loop
//! stays the paper's.

mod between;
mod chain;
mod free_space;
mod predict;
mod range_image;
mod segments;

use nalgebra::{Isometry2, Matrix3, Point2};
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

pub use between::{beside, left_out_points, Between};
pub use chain::{neighbour_poses, Bridges, Step};
pub use free_space::FreeSpace;
pub use predict::{predicted, run_spread, MAX_UNTRUSTED_STEPS};
pub use range_image::{RangeImage, Window};

use crate::registry::{Family, Kind, NoParams, StageKind, StageSpec};
use crate::{Scan, SensorModel};

/// A scan's neighbour in the sequence, as a detection sees it.
#[derive(Clone, Copy, Debug)]
pub struct Neighbour<'a> {
    /// What the neighbour's scanner saw, by bearing.
    pub image: &'a RangeImage,
    /// Maps points of the scan into the neighbour's frame.
    pub t_nb_scan: Isometry2<f64>,
    /// The covariance of `t_nb_scan` over `(tx m, ty m, θ rad)`.
    pub covariance: Matrix3<f64>,
}

impl<'a> Neighbour<'a> {
    /// Scan `k`'s neighbours within `lag` scans on each side, placed by chaining `steps` and
    /// `bridges` ([`neighbour_poses`]), each with its range image `image(j)` (a scan without one is
    /// left out).
    pub fn placed(
        (steps, bridges): (&[Option<Step>], &Bridges),
        k: usize,
        lag: usize,
        image: impl Fn(usize) -> Option<&'a RangeImage>,
    ) -> Vec<Self> {
        neighbour_poses(steps, bridges, k, lag)
            .into_iter()
            .filter_map(|(j, t_nb_scan, covariance)| {
                Some(Self {
                    image: image(j)?,
                    t_nb_scan,
                    covariance,
                })
            })
            .collect()
    }
}

/// What a detection found in one scan.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Detection {
    /// Per return of the scan: left out of its registrations.
    pub left_out: Vec<bool>,
    /// Returns seen to move by a neighbour themselves (the rest of `left_out` came with their
    /// surface).
    pub seen: usize,
    /// The share of the scene left out, each return weighted by its range (the length of
    /// surface it samples); 0 for an empty scan.
    pub moving_share: f64,
    /// Whether the share is above the detector's bar: the scan's evidence for one motion is
    /// split, and its pairs are flagged.
    pub split: bool,
}

impl Detection {
    /// A detection leaving out `left_out` of `scan`, `seen` returns seen to move, the scene
    /// split above `max_moving_share`.
    pub fn new(scan: &Scan, left_out: Vec<bool>, seen: usize, max_moving_share: f64) -> Self {
        let (mut out, mut all) = (0.0, 0.0);
        for (r, &o) in scan.returns().iter().zip(&left_out) {
            all += r.range_m;
            if o {
                out += r.range_m;
            }
        }
        let moving_share = if all > 0.0 { out / all } else { 0.0 };
        Self {
            left_out,
            seen,
            moving_share,
            split: moving_share > max_moving_share,
        }
    }

    /// Returns left out.
    pub fn count(&self) -> usize {
        self.left_out.iter().filter(|&&o| o).count()
    }
}

/// Whose registrations of consecutive scans place a detector's neighbours.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Placement {
    /// The variant's own: a metric that the hulls bias most (point-to-point,
    /// plane-to-plane: a hull's ends pull them) places its neighbours worst and finds least.
    #[default]
    Own,
    /// The stage's own point-to-line registrations (PL_ICP's configuration with the
    /// variant's error model, and its detector placing by them: `variants::placement_chain`),
    /// made once per run and shared by every variant whose detector and error model are the
    /// same; the variant then registers each pair once more without what they left out.
    PointToLine,
}

/// Finds the returns of a scan that move against the rest of the scene.
pub trait MovingReturns: Send + Sync {
    /// What this stage is, as configuration data.
    fn spec(&self) -> StageSpec {
        StageSpec::unregistered::<Self>()
    }

    /// How many scans on each side it compares with (0: none, it detects nothing).
    fn lag_scans(&self) -> usize;

    /// How many times the harness detects and registers again, each round from the
    /// registrations of the one before (the first from the registrations with every return).
    fn rounds(&self) -> usize {
        1
    }

    /// Whose registrations place the neighbours.
    fn placement(&self) -> Placement {
        Placement::Own
    }

    /// The returns of `scan` to leave out, judged against `neighbours` under `sensor`.
    fn detect(&self, scan: &Scan, neighbours: &[Neighbour<'_>], sensor: &SensorModel) -> Detection;

    /// Once every scan is detected: `detection` of `scan` completed from what the scans on
    /// either side left out (`before`, `after`: their left-out returns in `scan`'s frame;
    /// empty where a scan or its placing registration is missing). Unchanged by default.
    fn fill_between(
        &self,
        scan: &Scan,
        detection: Detection,
        before: &[Point2<f64>],
        after: &[Point2<f64>],
    ) -> Detection {
        let _ = (scan, before, after);
        detection
    }
}

/// Every registered detector of moving returns, one line each.
pub static MOVING: Family<dyn MovingReturns> = Family {
    name: "moving",
    summary: "returns that move against the rest of the scene, found over the sequence and left out of the pair's registration (beyond Alg. 1: a second registration from the first)",
    kinds: &[&NONE, &FREE_SPACE],
};

/// The registered kind of [`KeepAll`].
pub const NONE: Kind<NoParams, dyn MovingReturns> =
    Kind::new("none", "every return is kept (the paper's loop)", |_, _| {
        Box::new(KeepAll)
    });

/// The registered kind of [`FreeSpace`].
pub const FREE_SPACE: Kind<FreeSpace, dyn MovingReturns> = Kind::new(
    "free_space",
    "a return lies where a neighbouring scan (k−L..k+L, chained registrations) looked through, beyond the sensor model's and the chain's noise; a surface short enough to be a hull goes whole (scan differencing, Wang et al. 2007)",
    |p, _| Box::new(p),
);

/// Every return is kept.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct KeepAll;

impl MovingReturns for KeepAll {
    fn spec(&self) -> StageSpec {
        StageSpec::kind(NONE.name())
    }

    fn lag_scans(&self) -> usize {
        0
    }

    fn detect(&self, scan: &Scan, _: &[Neighbour<'_>], _: &SensorModel) -> Detection {
        Detection::new(scan, vec![false; scan.len()], 0, 1.0)
    }
}
