//! The closed-form covariance of the surface metrics (`icp_core::covariance`, Censi 2007)
//! against a Monte-Carlo of the registration itself, on a small room scanned as the simulator
//! scans (Sweep model, eq. 8: the beam leaves at a deflected bearing, the range is noisy); and a
//! corridor, whose along-corridor variance dominates or is unbounded.

use icp_core::variants::builtin;
use icp_core::{Registrar, Scan, SensorModel};
use nalgebra::{Isometry2, Matrix3, Vector2, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

/// A convex room: its walls as lines `mᵀx = d` with outward unit normals `m`.
fn room() -> Vec<(Vector2<f64>, f64)> {
    let corners = [
        [-10.0, -7.0],
        [14.0, -7.0],
        [16.0, 5.0],
        [3.0, 11.0],
        [-10.0, 8.0],
    ];
    (0..corners.len())
        .map(|k| {
            let (a, b) = (corners[k], corners[(k + 1) % corners.len()]);
            let along = Vector2::new(b[0] - a[0], b[1] - a[1]).normalize();
            let m = Vector2::new(along.y, -along.x); // outward for counter-clockwise corners
            (m, m.x * a[0] + m.y * a[1])
        })
        .collect()
}

/// Range from `o` along the unit ray `u` to the wall of the convex room it hits.
fn range_in(walls: &[(Vector2<f64>, f64)], o: &Vector2<f64>, u: &Vector2<f64>) -> f64 {
    walls
        .iter()
        .filter(|(m, _)| m.dot(u) > 1e-12)
        .map(|(m, d)| (d - m.dot(o)) / m.dot(u))
        .fold(f64::INFINITY, f64::min)
}

/// One noisy scan from `pose` (world ← scan) of `beams` beams over the full turn.
fn scan(
    walls: &[(Vector2<f64>, f64)],
    pose: &Isometry2<f64>,
    beams: usize,
    sensor: &SensorModel,
    rng: &mut ChaCha8Rng,
) -> Scan {
    let o = pose.translation.vector;
    let (mut ranges, mut bearings) = (Vec::new(), Vec::new());
    for j in 0..beams {
        let alpha = std::f64::consts::TAU * j as f64 / beams as f64 - std::f64::consts::PI;
        let n_alpha: f64 = StandardNormal.sample(rng);
        let n_range: f64 = StandardNormal.sample(rng);
        let a = alpha + sensor.sigma_alpha_rad * n_alpha;
        let rho = range_in(walls, &o, &(pose.rotation * Vector2::new(a.cos(), a.sin())));
        ranges.push(rho + sensor.sigma_r_m(rho) * n_range);
        bearings.push(alpha);
    }
    Scan::from_polar(&ranges, &bearings).unwrap()
}

/// `(tx, ty, θ)` of `est` minus those of `truth`, the angle wrapped.
fn error(est: &Isometry2<f64>, truth: &Isometry2<f64>) -> Vector3<f64> {
    let d = est.translation.vector - truth.translation.vector;
    let dt = (est.rotation * truth.rotation.inverse()).angle();
    Vector3::new(d.x, d.y, dt)
}

#[test]
fn closed_form_agrees_with_a_monte_carlo_of_the_registration() {
    const TRIALS: usize = 300;
    let sensor = SensorModel::sweep();
    let walls = room();
    let src_pose = Isometry2::new(Vector2::new(0.5, -0.5), 0.1);
    let ref_pose = src_pose * Isometry2::new(Vector2::new(0.8, 0.25), 2f64.to_radians());
    let truth = ref_pose.inverse() * src_pose;
    let mut ratios = Vec::new();
    for name in ["HD_PL_ICP", "HD_GICP"] {
        let reg = builtin(name).unwrap().build().unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(14);
        let mut errors = Vec::with_capacity(TRIALS);
        let mut mean_cov = Matrix3::zeros();
        for _ in 0..TRIALS {
            let s = scan(&walls, &src_pose, 720, &sensor, &mut rng);
            let r = scan(&walls, &ref_pose, 720, &sensor, &mut rng);
            let out = reg.register(&s, &r, truth).unwrap();
            let cov = *out.covariance.unwrap().bounded().unwrap();
            mean_cov += cov / TRIALS as f64;
            errors.push(error(&out.t_ref_src, &truth));
        }
        let n = TRIALS as f64;
        let mean = errors.iter().sum::<Vector3<f64>>() / n;
        let sample = errors
            .iter()
            .map(|e| (e - mean) * (e - mean).transpose())
            .sum::<Matrix3<f64>>()
            / (n - 1.0);
        for k in 0..3 {
            // The sample variance of n Gaussian draws has relative standard error √(2/(n−1)).
            let se = (2.0 / (n - 1.0)).sqrt();
            let ratio = sample[(k, k)] / mean_cov[(k, k)];
            println!(
                "{name} [{k}]: MC {:.3e}, closed form {:.3e}, ratio {ratio:.3} ± {se:.3}",
                sample[(k, k)],
                mean_cov[(k, k)]
            );
            ratios.push((name, k, ratio, se));
        }
    }
    // Point-to-line: the closed form agrees within 3 standard errors (measured 0.90, 1.11, 0.93
    // ± 0.08). GICP: it is over-confident by 1.2–1.5 in variance (measured 1.24, 1.22, 1.46):
    // the noise of the estimated surface covariances, left out, enters through the tangential
    // part of e that Ω no longer removes. Guarded as the known gap, not as agreement.
    for (name, k, ratio, se) in ratios {
        if name == "HD_PL_ICP" {
            assert!((ratio - 1.0).abs() < 3.0 * se, "{name} [{k}]: {ratio} ± {se}");
        } else {
            assert!(
                ratio > 1.0 - 3.0 * se && ratio < 1.6 + 3.0 * se,
                "{name} [{k}]: {ratio} ± {se}"
            );
        }
    }
}
