//! Pair weighting, Algorithm 1 step 3 (Naus & Marchel 2019, eqs. 11–13).
//!
//! A scheme sees one pair at a time through [`PairView`], so a new scheme is a few lines: see
//! the README's recipe.

use nalgebra::{Point2, UnitComplex};

use crate::matching::Correspondence;
use serde::{Deserialize, Serialize};

use crate::scan::Return;

mod directional;
mod inverse_range;
mod mean_error;
mod uniform;

pub use directional::Directional;
pub use inverse_range::InverseRange;
pub use mean_error::MeanError;
pub use uniform::Uniform;

/// What a weighting scheme knows about one matched pair.
#[derive(Clone, Copy, Debug)]
pub struct PairView<'a> {
    /// The source return (scan k), in scan k's frame.
    pub src: &'a Return,
    /// The matched reference return (scan k+1), in scan k+1's frame.
    pub dst: &'a Return,
    /// The source point moved by the current estimate into scan k+1's frame.
    pub src_moved: Point2<f64>,
    /// Rotation of the current estimate `t_ref_src`: a direction `β` in scan k+1's frame is
    /// `β − θ` in scan k's frame.
    pub rotation_ref_src: UnitComplex<f64>,
}

/// The pairs of one iteration, from which each [`PairView`] is made.
#[derive(Clone, Copy, Debug)]
pub struct PairBatch<'a> {
    /// The matched pairs (indices into `src`/`src_moved` and `dst`).
    pub pairs: &'a [Correspondence],
    /// The source returns (scan k), in scan k's frame.
    pub src: &'a [Return],
    /// The reference returns (scan k+1), in scan k+1's frame.
    pub dst: &'a [Return],
    /// The source points moved by the current estimate into scan k+1's frame.
    pub src_moved: &'a [Point2<f64>],
    /// Rotation of the current estimate `t_ref_src`.
    pub rotation_ref_src: UnitComplex<f64>,
}

/// Gives each pair its weight `w_i` of eq. 14.
pub trait PairWeighting: Send + Sync {
    /// The weight of one pair: finite and positive.
    fn weight(&self, pair: &PairView<'_>) -> f64;

    /// The weights of every pair of `batch`, in order, into `out` (cleared first). There is no
    /// need to override it: it exists so that a boxed scheme costs one dynamic call per
    /// iteration, with [`PairWeighting::weight`] inlined in the loop, not one call per pair.
    fn weigh_all(&self, batch: &PairBatch<'_>, out: &mut Vec<f64>) {
        out.clear();
        out.extend(batch.pairs.iter().map(|c| {
            self.weight(&PairView {
                src: &batch.src[c.src],
                dst: &batch.dst[c.dst],
                src_moved: batch.src_moved[c.src],
                rotation_ref_src: batch.rotation_ref_src,
            })
        }));
    }
}

impl<W: PairWeighting + ?Sized> PairWeighting for Box<W> {
    #[inline]
    fn weight(&self, pair: &PairView<'_>) -> f64 {
        (**self).weight(pair)
    }

    fn weigh_all(&self, batch: &PairBatch<'_>, out: &mut Vec<f64>) {
        (**self).weigh_all(batch, out)
    }
}

/// The weighting schemes by name, for configuration files and the command line. Adding a
/// scheme: one file with its `impl PairWeighting`, one arm here and one in [`WeightingSpec::build`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum WeightingSpec {
    /// [`Uniform`]: every pair weighs 1.
    Uniform,
    /// [`MeanError`]: eq. 13, from the variant's sensor model.
    MeanError,
    /// [`Directional`]: eq. 12, from the variant's sensor model.
    Directional,
    /// [`InverseRange`]: the worked example of a new scheme.
    InverseRange {
        /// Range added to both ranges before weighting, metres (> 0).
        r0_m: f64,
    },
}

impl WeightingSpec {
    /// Checks the scheme's parameters.
    pub fn validate(&self) -> Result<(), crate::IcpError> {
        match *self {
            WeightingSpec::InverseRange { r0_m } if !(r0_m.is_finite() && r0_m > 0.0) => {
                Err(crate::IcpError::InvalidParameter {
                    name: "inverse_range.r0_m",
                    value: r0_m,
                    reason: "must be finite and positive",
                })
            }
            _ => Ok(()),
        }
    }

    /// The scheme, with `sensor` for those that need an error model.
    pub fn build(&self, sensor: crate::SensorModel) -> Box<dyn PairWeighting> {
        match *self {
            WeightingSpec::Uniform => Box::new(Uniform),
            WeightingSpec::MeanError => Box::new(MeanError { sensor }),
            WeightingSpec::Directional => Box::new(Directional { sensor }),
            WeightingSpec::InverseRange { r0_m } => Box::new(InverseRange { r0_m }),
        }
    }
}
