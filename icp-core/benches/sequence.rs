//! The sequence smoother (`icp_core::sequence`) on a run of the paper harbour's length: 865
//! scans at 0.2 s, registrations at lags 1–3 with covariances of the size HD_GICP reports
//! there (σ ≈ 7 mm, 0.03°), nine tenths of it each scan's own error shared by the
//! registrations that use the scan (the harbours' loops say 0.85–0.95: the smoother then
//! carries a scan error state per scan), a vessel at 1.2 m/s turning slowly. Batch with `Qc`
//! and the share estimated (what `--sequence batch` runs), batch with both given (one solve and
//! its marginals), and causal with both given; each under white noise on acceleration (the
//! default) and on jerk (`--motion-prior white_jerk`: an acceleration state per scan).
//!
//!   cargo bench -p icp-core --bench sequence

use criterion::{criterion_group, criterion_main, Criterion};
use icp_core::sequence::{
    smooth, Mode, MotionPrior, PriorChoice, ProcessNoise, ScanErrors, SequenceRegistration,
    SmootherOptions,
};
use nalgebra::{Isometry2, Matrix3, Vector2};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

const SCANS: usize = 865;
const DT_S: f64 = 0.2;
/// The share of a registration's covariance that is its scans' errors.
const SHARE: f64 = 0.9;

fn run() -> (Vec<f64>, Vec<SequenceRegistration>) {
    let mut rng = ChaCha8Rng::seed_from_u64(35_100);
    let times: Vec<f64> = (0..SCANS).map(|k| k as f64 * DT_S).collect();
    // t_world_scan: 1.2 m/s ahead, a yaw rate swinging ±2 °/s.
    let mut poses = vec![Isometry2::identity()];
    for k in 1..SCANS {
        let yaw_rate = 2f64.to_radians() * (k as f64 * 0.01).sin();
        let step = Isometry2::new(Vector2::new(1.2 * DT_S, 0.0), yaw_rate * DT_S);
        poses.push(poses[k - 1] * step);
    }
    let (s_xy, s_th) = (0.007, 0.03f64.to_radians());
    let cov = Matrix3::from_diagonal(&nalgebra::Vector3::new(
        s_xy * s_xy,
        s_xy * s_xy,
        s_th * s_th,
    ));
    let noise = |rng: &mut ChaCha8Rng, s: f64| Normal::new(0.0, s).unwrap().sample(rng);
    // Each scan seen shifted by its own error (half the share of a registration's variance
    // each), the registrations with the rest as their own noise.
    let (scan, own) = ((SHARE / 2.0).sqrt(), (1.0 - SHARE).sqrt());
    let seen: Vec<Isometry2<f64>> = poses
        .iter()
        .map(|p| {
            let e = Isometry2::new(
                Vector2::new(noise(&mut rng, scan * s_xy), noise(&mut rng, scan * s_xy)),
                noise(&mut rng, scan * s_th),
            );
            p * e
        })
        .collect();
    let mut regs = Vec::new();
    for lag in 1..=3 {
        for a in 0..SCANS - lag {
            let t = seen[a + lag].inverse() * seen[a];
            let v = t.translation.vector;
            let z = Isometry2::new(
                Vector2::new(
                    v.x + noise(&mut rng, own * s_xy),
                    v.y + noise(&mut rng, own * s_xy),
                ),
                t.rotation.angle() + noise(&mut rng, own * s_th),
            );
            regs.push(SequenceRegistration {
                source: a,
                reference: a + lag,
                t_ref_src: z,
                cov,
            });
        }
    }
    (times, regs)
}

fn bench(c: &mut Criterion) {
    let (times, regs) = run();
    let mut group = c.benchmark_group("sequence/865_scans_lags_3");
    group.sample_size(10);
    for (name, motion_prior) in [
        ("", MotionPrior::WhiteAcceleration),
        ("_white_jerk", MotionPrior::WhiteJerk),
    ] {
        let estimate = SmootherOptions {
            motion_prior: PriorChoice::Given(motion_prior),
            ..SmootherOptions::default()
        };
        let estimated = smooth(&times, &regs, Mode::Batch, &estimate).unwrap();
        let fixed = SmootherOptions {
            process_noise: ProcessNoise::Fixed(estimated.qc),
            scan_errors: ScanErrors::Share(estimated.scan_share.share),
            ..estimate
        };
        group.bench_function(format!("batch_qc_estimated{name}"), |b| {
            b.iter(|| smooth(&times, &regs, Mode::Batch, &estimate).unwrap())
        });
        group.bench_function(format!("batch_qc_given{name}"), |b| {
            b.iter(|| smooth(&times, &regs, Mode::Batch, &fixed).unwrap())
        });
        group.bench_function(format!("causal_qc_given{name}"), |b| {
            b.iter(|| smooth(&times, &regs, Mode::Causal { lag_scans: 0 }, &fixed).unwrap())
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
