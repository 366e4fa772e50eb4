//! The figures, each as PNG and SVG, drawn with plotters from a report: [`run`] for one run's (and [`left_out`], a scan with its moving returns),
//! [`studies`] for the studies' (sweep, basin, scaling), on the shared pieces of [`draw`].

pub mod draw;
pub mod left_out;
pub mod run;
pub mod studies;
