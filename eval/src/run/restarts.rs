//! The perturbed-restart term of the covariance: what the start and the data association add.
//!
//! The closed form and its residuals ([`crate::run::extended`]) see one minimum. Where the scans
//! admit several (a boat moved, a wall's end is ambiguous, returns off the water), the
//! registration lands in one of them depending on where it starts. Re-registering from
//! [`STARTS`] starts around the solution — `±START_M` along x and y and `±START_DEG` in θ, a
//! fixed pattern, so no seed is involved — and taking the spread of the results,
//!
//! ```text
//! C_restart = (1/6) Σ_k (x̂_k − x̂)(x̂_k − x̂)ᵀ,
//! ```
//!
//! measures that (after Brossard, Bonnabel & Barrau 2020, "A new approach to 3D ICP covariance
//! estimation", who use 13 restarts in 3D; the 6 axis starts span SE(2)'s three directions
//! both ways). `--covariance restarts` reports [`crate::run::extended::extended`] plus this term;
//! it costs up to 6 registrations per pair (started close to the solution, they take fewer
//! iterations than the first).

use datasets::{Dataset, ScanPair};
use icp_core::{Covariance, Prepared, Registrar, Surfaces, Workspace};
use nalgebra::{Isometry2, Matrix3, Vector2};

use crate::run::covariance::{closed_form_inflation, pose_error};
use crate::run::extended::extended;
use crate::run::replace;
use crate::run::runner::Runs;

/// Restarts per pair.
pub const STARTS: usize = 6;
/// The starts' translation offset, m.
pub const START_M: f64 = 0.1;
/// The starts' rotation offset, degrees.
pub const START_DEG: f64 = 1.0;

/// The six starts around `solution`: `±START_M` along its frame's x and y axes (applied to
/// the translation) and `±START_DEG` in θ.
pub fn starts(solution: &Isometry2<f64>) -> [Isometry2<f64>; STARTS] {
    let (t, a) = (solution.translation.vector, solution.rotation.angle());
    let d = START_DEG.to_radians();
    [
        Isometry2::new(t + Vector2::new(START_M, 0.0), a),
        Isometry2::new(t - Vector2::new(START_M, 0.0), a),
        Isometry2::new(t + Vector2::new(0.0, START_M), a),
        Isometry2::new(t - Vector2::new(0.0, START_M), a),
        Isometry2::new(t, a + d),
        Isometry2::new(t, a - d),
    ]
}

/// The restart term of `reg` on the prepared pair around `solution` (a failed restart counts
/// as landing where it started); over `(tx m, ty m, θ rad)`.
pub fn restart_term(
    reg: &dyn Registrar,
    workspace: &mut Workspace,
    source: Prepared<'_>,
    reference: Prepared<'_>,
    solution: &Isometry2<f64>,
) -> Matrix3<f64> {
    starts(solution)
        .iter()
        .map(|start| {
            let end = reg
                .register_prepared(workspace, source, reference, *start)
                .map_or(*start, |r| r.t_ref_src);
            let e = pose_error(&end, solution);
            e * e.transpose()
        })
        .sum::<Matrix3<f64>>()
        / STARTS as f64
}

/// Replaces the covariance of every registration of `runs` that has a closed form by the
/// extended covariance plus its restart term (an unbounded one stays unbounded).
pub fn replace_covariances(
    ds: &Dataset,
    pairs: &[ScanPair],
    registrars: &[Box<dyn Registrar>],
    runs: &mut Runs,
) {
    replace::replace_covariances(pairs, registrars, runs, |reg, workspace, _, out, pair| {
        let inflation = closed_form_inflation(&reg.spec().metric);
        let Covariance::Bounded(c) = extended(out, inflation)? else {
            return out.covariance;
        };
        let params = reg.surface_params();
        let (s, r) = (&ds.scans[pair.source], &ds.scans[pair.reference]);
        let (ss, rs) = (
            Surfaces::estimate(s, &params),
            Surfaces::estimate(r, &params),
        );
        let term = restart_term(
            reg,
            workspace,
            Prepared::new(s, &ss),
            Prepared::new(r, &rs),
            &out.t_ref_src,
        );
        Some(Covariance::Bounded(c + term))
    });
}
