//! Run: who registers what, from where. A [`setup::EvalSetup`] says which methods run and how;
//! the [`runner`] registers every method on every pair from the starts of [`init`] (gated by
//! [`start_gate`]), checks each result ([`status`]), and [`sampled`], [`restarts`] (both through
//! [`replace`]) and [`estimates`] add covariances made after the run and estimates made
//! elsewhere.

pub mod covariance;
pub mod deskew;
pub mod estimates;
pub mod extended;
pub mod init;
pub mod lags;
pub mod left_out;
pub mod modes;
pub mod motion;
pub mod moving;
pub mod options;
pub mod pair_search;
pub mod replace;
pub mod restarts;
pub mod runner;
pub mod sampled;
pub mod sequence;
pub mod sequence_records;
pub mod sequence_setup;
pub mod setup;
pub mod start_gate;
pub mod status;
