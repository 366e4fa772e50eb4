//! A scaling run's measure: per scan size, the time per registration, the iterations and the
//! time per point and iteration (`studies::scaling` runs it).

use serde::{Deserialize, Serialize};

/// One scan size.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ScalingPoint {
    /// Beams per scanner revolution.
    pub beams: usize,
    /// Valid returns of the source scan.
    pub returns: usize,
    /// Pairs of the last iteration.
    pub pairs: usize,
    /// Minimisation steps taken.
    pub iterations: usize,
    /// Why the loop stopped (`Converged` or `MaxIterations`).
    pub stop: String,
    /// Median wall time per registration, µs (not reproducible).
    pub median_us: f64,
    /// Registrations timed.
    pub repetitions: usize,
    /// Median time over pairs × matchings (iterations + 1), ns (not reproducible).
    pub ns_per_point_iteration: f64,
}

/// A scaling run.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ScalingResult {
    /// The variant timed.
    pub variant: String,
    /// One entry per scan size, ascending.
    pub points: Vec<ScalingPoint>,
}
