//! A run the unit tests of the smoother share.

use nalgebra::{Matrix3, Vector3};

use super::factors;
use super::system::{Model, Reg};
use super::{Geometry, MotionPrior, SmootherOptions};

/// 60 scans a second apart along a weaving track, registered at lags 1 and 2 with a few
/// millimetres of noise (a fixed pseudo-random sequence) and every seventh lag-1
/// registration 0.3 m off (the robust loss's business): the scans' times and the
/// registrations.
pub(crate) fn weaving_run() -> (Vec<f64>, Vec<Reg>) {
    let times_s: Vec<f64> = (0..60).map(f64::from).collect();
    let mut poses = vec![Vector3::zeros()];
    for k in 0..59 {
        let twist = Vector3::new(1.0, 0.0, 0.2 * (0.3 * k as f64).sin());
        poses.push(factors::exp_from(Geometry::Se2, &poses[k], &twist));
    }
    let mut seed = 12_345_u64;
    let mut noise = move || {
        seed = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
        (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    let mut regs = Vec::new();
    for lag in 1..=2 {
        for a in 0..60 - lag {
            let b = a + lag;
            let (mut z, _, _) = factors::relative(Geometry::Se2, &poses[a], &poses[b]);
            z += Vector3::new(noise(), noise(), 0.1 * noise()) * 0.01;
            if lag == 1 && a % 7 == 3 {
                z.x += 0.3;
            }
            regs.push(Reg {
                source: a,
                reference: b,
                z,
                info: Matrix3::from_diagonal(&Vector3::new(1e4, 1e4, 1e6)),
                cov: Matrix3::from_diagonal(&Vector3::new(1e-4, 1e-4, 1e-6)),
            });
        }
    }
    (times_s, regs)
}

/// The model of a run's `times_s` and `regs` on SE(2) at process noise `qc`, with the default
/// robust threshold and neither a first twist nor scan errors.
pub(crate) fn weaving_model<'a>(times_s: &'a [f64], regs: &'a [Reg], qc: [f64; 3]) -> Model<'a> {
    Model {
        geometry: Geometry::Se2,
        times_s,
        regs,
        prior: MotionPrior::WhiteAcceleration,
        qc,
        huber_k: SmootherOptions::default().huber_k,
        twist0: None,
        accel0: None,
        scan_errors: None,
    }
}
