//! Studies over runs: the convergence [`basin`], parameter [`sweep`]s and the [`scaling`] of a
//! registration's cost.

pub mod basin;
pub mod scaling;
pub mod sweep;
