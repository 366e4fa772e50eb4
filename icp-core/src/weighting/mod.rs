//! Pair weighting, Algorithm 1 step 3 (Naus & Marchel 2019, eqs. 11–13).
//!
//! A scheme sees one pair at a time through [`PairView`], so a new scheme is a few lines: see
//! the README's recipe.

use nalgebra::{Point2, UnitComplex};

use crate::scan::Return;

mod directional;
mod mean_error;
mod uniform;

pub use directional::Directional;
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

/// Gives each pair its weight `w_i` of eq. 14.
pub trait PairWeighting: Send + Sync {
    /// The weight of one pair: finite and positive.
    fn weight(&self, pair: &PairView<'_>) -> f64;
}
