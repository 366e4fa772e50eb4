//! Measure: pure functions over the run's records. [`record`] makes one record per variant and
//! pair; [`build`] assembles the [`report::RunReport`] from them with [`stats`], [`reference`](mod@reference)
//! checks, [`outcome`]s, [`odometry_word`], [`consistency`], [`trajectory`] metrics and [`bound`]s; [`compare`] and
//! [`gate`] judge reports. The studies' measures ([`basin`], [`sweep`], [`scaling`]) sit here too.

pub mod basin;
pub mod bound;
pub mod build;
pub mod compare;
pub mod consistency;
pub mod cycles;
pub mod gate;
pub mod odometry_word;
pub mod outcome;
pub mod record;
pub mod reference;
pub mod reference_noise;
pub mod report;
pub mod scaling;
pub mod stats;
pub mod sweep;
pub mod trajectory;
pub mod trajectory_metrics;
