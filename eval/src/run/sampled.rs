//! The sampled covariance of a registration, for every variant (point-to-point included, where
//! no closed form is valid: Bonnabel et al. 2016).
//!
//! For each pair, [`SAMPLES`] times: both scans' returns are perturbed by fresh noise of the
//! dataset's sensor model (eq. 8 of Naus & Marchel 2019: `σ_r(r)` along the beam, `σ_α` on the
//! bearing, independent per return), their surfaces are estimated again, and the variant
//! registers the perturbed pair from its solution moved by a start drawn uniformly in a small
//! ball ([`START_BALL_M`], [`START_BALL_RAD`]). The sample covariance of the `(tx, ty, θ)` of
//! the results is the estimate: it includes re-matching, the noise of the normals and the
//! robust weights, which the closed form leaves out. Perturbing data that are already noisy
//! gives the spread of the estimator around its own value, which to first order is its spread
//! around the truth.
//!
//! The noise of pair `p` is drawn by ChaCha8 seeded with `p`'s position in the run (stream
//! [`STREAM`], apart from the runner's shuffles), the same for every variant of the pair and
//! whatever the thread count. A sample covariance of `N` draws makes the NEES heavier-tailed
//! than χ²(3): its mean is `3 (N − 1)/(N − 5)` (1.15 × 3 for `N = 32`; Wishart moments), which
//! the report does not correct.

use datasets::{Dataset, ScanPair};
use icp_core::{Covariance, Registrar, Scan, SensorModel, Surfaces, Workspace};
use nalgebra::{Isometry2, Matrix3, Vector2, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

use crate::run::covariance::pose_error;
use crate::run::replace;
use crate::run::runner::Runs;

/// Registrations per sampled covariance.
pub const SAMPLES: usize = 32;
/// Fewest successful registrations for an estimate (else none).
pub const MIN_SAMPLES: usize = 8;
/// Radius of the start's translation ball around the solution, m.
pub const START_BALL_M: f64 = 0.02;
/// Half-width of the start's rotation interval around the solution, rad (0.1°).
pub const START_BALL_RAD: f64 = 0.001_745;
/// The ChaCha8 stream of the sampling noise.
pub const STREAM: u64 = 14;

/// `scan` with every return perturbed by the noise of `sensor`.
fn perturbed(scan: &Scan, sensor: &SensorModel, rng: &mut ChaCha8Rng) -> Option<Scan> {
    let (mut ranges, mut bearings) = (Vec::with_capacity(scan.len()), Vec::new());
    for r in scan.returns() {
        let (n_r, n_a): (f64, f64) = (rng.sample(StandardNormal), rng.sample(StandardNormal));
        // A range pushed through zero would read as "no return": kept just outside the sensor.
        ranges.push((r.range_m + sensor.sigma_r_m(r.range_m) * n_r).max(1e-6));
        bearings.push(r.bearing_rad + sensor.sigma_alpha_rad * n_a);
    }
    Scan::from_polar(&ranges, &bearings).ok()
}

/// The sampled covariance of `reg` on (`source`, `reference`) around its solution `solution`,
/// with the noise of `sensor` drawn from `rng`; `None` with fewer than [`MIN_SAMPLES`]
/// successful registrations.
pub fn sampled_covariance(
    reg: &dyn Registrar,
    source: &Scan,
    reference: &Scan,
    solution: &Isometry2<f64>,
    sensor: &SensorModel,
    rng: &mut ChaCha8Rng,
    workspace: &mut Workspace,
) -> Option<Covariance> {
    let params = reg.surface_params();
    let mut errors: Vec<Vector3<f64>> = Vec::with_capacity(SAMPLES);
    for _ in 0..SAMPLES {
        let (s, r) = (
            perturbed(source, sensor, rng),
            perturbed(reference, sensor, rng),
        );
        // A start uniform in the disc of START_BALL_M and ±START_BALL_RAD.
        let (radius, angle, turn): (f64, f64, f64) = (
            START_BALL_M * rng.random::<f64>().sqrt(),
            std::f64::consts::TAU * rng.random::<f64>(),
            START_BALL_RAD * (2.0 * rng.random::<f64>() - 1.0),
        );
        let (Some(s), Some(r)) = (s, r) else {
            continue;
        };
        let start = Isometry2::new(
            solution.translation.vector + Vector2::new(angle.cos(), angle.sin()) * radius,
            solution.rotation.angle() + turn,
        );
        let (ss, rs) = (
            Surfaces::estimate(&s, &params),
            Surfaces::estimate(&r, &params),
        );
        let out = reg.register_prepared(
            workspace,
            icp_core::Prepared::new(&s, &ss),
            icp_core::Prepared::new(&r, &rs),
            start,
        );
        if let Ok(out) = out {
            errors.push(pose_error(&out.t_ref_src, solution));
        }
    }
    if errors.len() < MIN_SAMPLES {
        return None;
    }
    let n = errors.len() as f64;
    let mean = errors.iter().sum::<Vector3<f64>>() / n;
    let cov = errors
        .iter()
        .map(|e| (e - mean) * (e - mean).transpose())
        .sum::<Matrix3<f64>>()
        / (n - 1.0);
    Some(Covariance::Bounded(cov))
}

/// Replaces the covariance of every registration of `runs` by its sampled estimate (`None`
/// where too few samples registered), each pair seeded by its position.
pub fn replace_covariances(
    ds: &Dataset,
    pairs: &[ScanPair],
    registrars: &[Box<dyn Registrar>],
    runs: &mut Runs,
) {
    replace::replace_covariances(
        pairs,
        registrars,
        runs,
        |reg, workspace, position, out, pair| {
            let mut rng = ChaCha8Rng::seed_from_u64(position as u64);
            rng.set_stream(STREAM);
            sampled_covariance(
                reg,
                &ds.scans[pair.source],
                &ds.scans[pair.reference],
                &out.t_ref_src,
                &ds.sensor,
                &mut rng,
                workspace,
            )
        },
    );
}
