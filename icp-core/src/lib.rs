//! Weighted point-to-point ICP for 2D LIDAR scans, after Naus & Marchel (2019), "Use of a
//! Weighted ICP Algorithm to Precisely Determine USV Movement Parameters", Appl. Sci. 9(17) 3530.
//!
//! The crate does no I/O. Its stages follow Algorithm 1 of the paper, one module each:
//! [`scan`] (eq. 10), [`sensor`] (eqs. 5, 8, 9), [`select`] (step 1), [`matching`] (step 2),
//! [`weighting`] (step 3, eqs. 11–13), [`robust`] (step 4, Huber), [`minimize`] (step 5,
//! eqs. 15–20, and Gauss-Newton), [`termination`] (step 6) and the loop itself in [`icp`]
//! (eqs. 14, 21, 22). Beyond the paper, [`metric`] makes the error of eq. 14 a stage
//! (point-to-point, point-to-line, plane-to-plane generalised ICP), [`surface`] estimates the
//! normal and covariance behind every return once per scan, [`quality`] checks a solution's
//! conditioning and overlap, and [`global`] finds an initial guess for large motions by
//! correlative scan matching. Every stage kind is registered once, with typed parameters, in
//! [`registry`]'s model; [`variants`] holds the built-in variants as configuration data, and
//! [`motion`] turns a registration into SOG, ΔCOG, ROT and HDG (eqs. 23–25).
//!
//! # Frames
//! Every transform is named `t_a_b`: it maps points expressed in frame `b` into frame `a`.
//! A scan frame is the sensor frame of eq. 10: `x = r cos α`, `y = r sin α`, angles grow from
//! `+x` towards `+y`. Registering scan k (the *source*) onto scan k+1 (the *reference*) yields
//! `t_ref_src`; the vessel's own motion from k to k+1, expressed in frame k, is its inverse.
//!
//! # Example
//! ```
//! use icp_core::{Scan, SensorModel, Registrar, variants};
//! use nalgebra::{Isometry2, Vector2};
//!
//! // Three walls seen from the origin, and the same walls after the vessel moved.
//! let wall = |i: usize| -> [f64; 2] {
//!     let s = i as f64 * 0.25;
//!     match i % 3 { 0 => [10.0, -5.0 + s], 1 => [-3.0 + s, 8.0], _ => [-3.0 + s * 0.5, -7.0 - s * 0.3] }
//! };
//! let pts: Vec<[f64; 2]> = (0..120).map(wall).collect();
//! let source = Scan::from_cartesian(&pts).unwrap();
//! let t_ref_src = Isometry2::new(Vector2::new(-0.30, 0.02), 0.5_f64.to_radians());
//! let moved: Vec<[f64; 2]> = pts.iter().map(|p| {
//!     let q = t_ref_src * nalgebra::Point2::new(p[0], p[1]);
//!     [q.x, q.y]
//! }).collect();
//! let reference = Scan::from_cartesian(&moved).unwrap();
//!
//! let hd = variants::hd_icp(SensorModel::sweep());
//! let reg = hd.register(&source, &reference, Isometry2::identity()).unwrap();
//! assert!((reg.t_ref_src.translation.vector - t_ref_src.translation.vector).norm() < 1e-6);
//! assert!(reg.converged());
//! ```
#![forbid(unsafe_code)]

pub mod assess;
pub mod bound;
mod cells;
pub mod covariance;
pub mod deskew;
pub mod error;
pub mod global;
pub mod icp;
pub mod matching;
pub mod metric;
pub mod minimize;
pub mod motion;
pub mod moving;
pub mod pairs;
pub mod quality;
pub mod registration;
pub mod registry;
pub mod robust;
pub mod scan;
pub mod select;
pub mod sensor;
pub mod sequence;
pub mod spec;
pub mod static_str;
pub mod surface;
pub mod termination;
pub mod variants;
pub mod weighting;
pub mod workspace;

pub use assess::assess;
pub use covariance::Covariance;
pub use error::{ConfigError, IcpError};

/// The Rust examples of docs/schemes.md, compiled and run as doctests so the page stays true.
#[cfg(doctest)]
#[doc = include_str!("../../docs/schemes.md")]
pub struct DocsDoctests;
pub use icp::Icp;
pub use motion::{BearingSense, MovementParams, MovementSigmas};
pub use quality::Conditioning;
pub use registration::{Prepared, Registrar, Registration};
pub use scan::{ReadingTruth, Scan};
pub use sensor::SensorModel;
pub use surface::{SurfaceParams, Surfaces};
pub use termination::{StopReason, Termination};
pub use workspace::Workspace;
