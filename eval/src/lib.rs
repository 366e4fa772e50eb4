//! The evaluation harness behind `icp-eval`: runs variants over scan pairs in parallel and
//! reports like the paper (Table 1, Figs. 12–16) and better (robust statistics, reference
//! checks, pose errors, TUM trajectories, covariance consistency).
//!
//! The modules follow the pipeline, and imports point one way, down this list:
//! * [`data`]: what is read from a dataset beyond its scans (the reference's motion, times);
//! * [`run`]: who registers what, from where: the setup and options, the runner, initial
//!   guesses, the start gate, the result checks, lags, covariance modes and external estimates;
//! * [`measure`]: one [`measure::record::PairRecord`] per variant and pair at the bottom, then
//!   statistics, reference checks and noise, loops, outcomes, consistency, trajectory metrics,
//!   bounds, compare
//!   and gate, as pure functions over records, and the [`RunReport`] built from them;
//! * [`pipeline`]: [`evaluate`] (run, then measure);
//! * [`render`]: one file per output format, each reading the report ([`write_outputs`]);
//! * [`studies`] over runs (basin, sweep, scaling) and [`shard`]s (shard, merge).
//!
//! The binary's `cli/` has one file per command; `main.rs` only dispatches.
#![forbid(unsafe_code)]

pub mod data;
pub mod error;
pub mod measure;
pub mod pipeline;
pub mod render;
pub mod run;
pub mod shard;
pub mod studies;

pub use error::EvalError;
pub use measure::report::RunReport;
pub use pipeline::evaluate;
pub use render::outdir::OutputDir;
pub use render::write_outputs;
pub use run::setup::{EvalSetup, GlobalChecks, OffsetChoice, ReferenceChecks};
