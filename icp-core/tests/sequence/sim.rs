//! Runs drawn from the smoother's own model, and the dense Kalman/RTS oracle of the
//! linear-Gaussian case.

use icp_core::sequence::{
    smooth, Geometry, Mode, MotionPrior, ProcessNoise, ScanErrors, SequenceRegistration, Smoothed,
    SmootherOptions, TwistPrior,
};
use nalgebra::{DMatrix, DVector, Isometry2, Matrix3, SMatrix, Vector2, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use std::f64::consts::PI;

pub type Matrix6 = SMatrix<f64, 6, 6>;
pub type Matrix9 = SMatrix<f64, 9, 9>;

/// `Q(Δt) = [[Δt³/3, Δt²/2], [Δt²/2, Δt]] ⊗ diag(qc)`, ordered `[position(3), velocity(3)]`.
pub fn q_matrix(qc: &[f64; 3], dt: f64) -> Matrix6 {
    let mut q = Matrix6::zeros();
    for a in 0..3 {
        q[(a, a)] = dt.powi(3) / 3.0 * qc[a];
        q[(a, a + 3)] = dt.powi(2) / 2.0 * qc[a];
        q[(a + 3, a)] = dt.powi(2) / 2.0 * qc[a];
        q[(a + 3, a + 3)] = dt * qc[a];
    }
    q
}

/// `Q(Δt) = A ⊗ diag(qc)` of white noise on jerk, ordered `[position(3), velocity(3),
/// acceleration(3)]`: `A = [[Δt⁵/20, Δt⁴/8, Δt³/6], [Δt⁴/8, Δt³/3, Δt²/2], [Δt³/6, Δt²/2, Δt]]`
/// (the integral over the step of the jerk's effect on each derivative, outer product).
pub fn q_matrix_jerk(qc: &[f64; 3], dt: f64) -> Matrix9 {
    let a = [
        [dt.powi(5) / 20.0, dt.powi(4) / 8.0, dt.powi(3) / 6.0],
        [dt.powi(4) / 8.0, dt.powi(3) / 3.0, dt.powi(2) / 2.0],
        [dt.powi(3) / 6.0, dt.powi(2) / 2.0, dt],
    ];
    let mut q = Matrix9::zeros();
    for axis in 0..3 {
        for i in 0..3 {
            for j in 0..3 {
                q[(axis + 3 * i, axis + 3 * j)] = a[i][j] * qc[axis];
            }
        }
    }
    q
}

pub fn gaussian<const D: usize>(
    rng: &mut ChaCha8Rng,
    cov: &SMatrix<f64, D, D>,
) -> SMatrix<f64, D, 1> {
    let l = cov.cholesky().expect("covariance is positive definite").l();
    let z = SMatrix::<f64, D, 1>::from_fn(|_, _| StandardNormal.sample(rng));
    l * z
}

/// A random SPD 3×3 covariance with σ around `(s_xy, s_xy, s_th)`.
pub fn random_cov(rng: &mut ChaCha8Rng, s_xy: f64, s_th: f64) -> Matrix3<f64> {
    let a = Matrix3::from_fn(|_, _| rng.random_range(-0.3..0.3)) + Matrix3::identity();
    let s = Matrix3::from_diagonal(&Vector3::new(s_xy, s_xy, s_th));
    s * a * a.transpose() * s
}

pub fn iso(p: &Vector3<f64>) -> Isometry2<f64> {
    Isometry2::new(Vector2::new(p.x, p.y), p.z)
}

/// A run drawn from the prior: times, true poses `t_world_scan` (scan 0 at the identity),
/// twists, and registrations at lags `1..=lags` with noise drawn from their own covariance,
/// independent ([`simulate_shared`] with a share of 0).
pub struct Run {
    pub times_s: Vec<f64>,
    pub poses: Vec<Isometry2<f64>>,
    pub twists: Vec<Vector3<f64>>,
    pub regs: Vec<SequenceRegistration>,
}

pub fn simulate(seed: u64, n: usize, lags: usize, qc: [f64; 3], linear: bool) -> Run {
    simulate_shared(
        seed,
        n,
        lags,
        qc,
        linear,
        0.0,
        MotionPrior::WhiteAcceleration,
    )
}

/// [`simulate`], with a share `share` of each registration's covariance `Σ` its scans' errors:
/// the registration `a → b` is drawn between the poses `T_a + e_a` and `T_b + e_b` with its own
/// noise of covariance `(1 − share) Σ`, and each scan's error `e_k` (world frame) from
/// `S_k` = `share/2 ×` the mean covariance of the consecutive registrations that use scan k,
/// turned into the world frame by their reference's true heading: the smoother's model
/// (`icp_core::sequence::ScanErrors`). The errors come from their own random stream, so a
/// share of 0 draws every other figure as before. The motion is drawn from `prior` (white
/// noise on jerk: the acceleration from zero, the body-frame twist and pose moved by its
/// Taylor expansion plus the noise).
pub fn simulate_shared(
    seed: u64,
    n: usize,
    lags: usize,
    qc: [f64; 3],
    linear: bool,
    share: f64,
    prior: MotionPrior,
) -> Run {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut times_s = vec![0.0];
    for _ in 1..n {
        let last = *times_s.last().unwrap();
        times_s.push(last + rng.random_range(0.8..1.2));
    }
    let mut twists = vec![Vector3::new(2.0, 0.1, 0.02)];
    let mut accel = Vector3::zeros();
    let mut params = vec![Vector3::zeros()]; // linear: (x, y, θ) as a vector
    let mut poses = vec![Isometry2::identity()];
    for k in 0..n - 1 {
        let dt = times_s[k + 1] - times_s[k];
        let xi = match prior {
            MotionPrior::WhiteAcceleration => {
                let w = gaussian(&mut rng, &q_matrix(&qc, dt));
                twists.push(twists[k] + w.fixed_rows::<3>(3));
                twists[k] * dt + w.fixed_rows::<3>(0)
            }
            MotionPrior::WhiteJerk => {
                let w = gaussian(&mut rng, &q_matrix_jerk(&qc, dt));
                twists.push(twists[k] + accel * dt + w.fixed_rows::<3>(3));
                let xi = twists[k] * dt + accel * (dt * dt / 2.0) + w.fixed_rows::<3>(0);
                accel += w.fixed_rows::<3>(6);
                xi
            }
        };
        params.push(params[k] + xi);
        // SE(2): T_k+1 = T_k Exp(ξ).
        let phi = xi.z;
        let (a, b) = if phi.abs() < 1e-9 {
            (1.0, 0.0)
        } else {
            (phi.sin() / phi, (1.0 - phi.cos()) / phi)
        };
        let d = Vector2::new(a * xi.x - b * xi.y, b * xi.x + a * xi.y);
        poses.push(poses[k] * Isometry2::new(d, phi));
    }
    let mut drawn = Vec::new();
    for lag in 1..=lags {
        for a in 0..n - lag {
            let cov = random_cov(&mut rng, 0.03 * (lag as f64).sqrt(), 0.003);
            let noise = gaussian(&mut rng, &(cov * (1.0 - share)));
            drawn.push((a, a + lag, cov, noise));
        }
    }
    let errors = scan_errors(seed, &poses, &drawn, share, linear);
    let seen = |k: usize| {
        let v = poses[k].translation.vector;
        let e = errors[k];
        Isometry2::new(
            Vector2::new(v.x + e.x, v.y + e.y),
            poses[k].rotation.angle() + e.z,
        )
    };
    let regs = drawn
        .into_iter()
        .map(|(a, b, cov, noise)| {
            let z = if linear {
                params[a] + errors[a] - (params[b] + errors[b]) + noise
            } else if share > 0.0 {
                let t = seen(b).inverse() * seen(a);
                let v = t.translation.vector;
                Vector3::new(v.x, v.y, t.rotation.angle()) + noise
            } else {
                let t = poses[b].inverse() * poses[a];
                let v = t.translation.vector;
                Vector3::new(v.x, v.y, t.rotation.angle()) + noise
            };
            SequenceRegistration {
                source: a,
                reference: b,
                t_ref_src: iso(&z),
                cov,
            }
        })
        .collect();
    Run {
        times_s,
        poses,
        twists,
        regs,
    }
}

/// A registration drawn: source, reference, covariance, own noise.
type Drawn = (usize, usize, Matrix3<f64>, Vector3<f64>);

/// Each scan's error as [`simulate_shared`] draws it (zero for a share of 0).
fn scan_errors(
    seed: u64,
    poses: &[Isometry2<f64>],
    drawn: &[Drawn],
    share: f64,
    linear: bool,
) -> Vec<Vector3<f64>> {
    if share == 0.0 {
        return vec![Vector3::zeros(); poses.len()];
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5ca7_e770);
    let spans: Vec<_> = drawn.iter().map(|&(a, b, cov, _)| (a, b, cov)).collect();
    scan_error_covariances(poses, &spans, share, linear)
        .iter()
        .map(|s| gaussian(&mut rng, s))
        .collect()
}

/// `S_k` of the smoother's model (world frame, by the headings of `poses`) from registrations
/// `(source, reference, covariance)` whose shortest lag is 1: `share/2 ×` the harmonic mean of
/// the covariances of the consecutive registrations that use scan k.
pub fn scan_error_covariances(
    poses: &[Isometry2<f64>],
    spans: &[(usize, usize, Matrix3<f64>)],
    share: f64,
    linear: bool,
) -> Vec<Matrix3<f64>> {
    let mut sum = vec![Matrix3::zeros(); poses.len()];
    let mut count = vec![0.0; poses.len()];
    for &(a, b, cov) in spans.iter().filter(|d| d.1 == d.0 + 1) {
        let g = if linear {
            Matrix3::identity()
        } else {
            let (s, c) = poses[b].rotation.angle().sin_cos();
            Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0)
        };
        for k in [a, b] {
            sum[k] += g * cov.try_inverse().unwrap() * g.transpose();
            count[k] += 1.0;
        }
    }
    sum.iter()
        .zip(&count)
        .map(|(s, c)| (s / *c).try_inverse().unwrap() * (0.5 * share))
        .collect()
}

/// Per scan the smoothed `[p; v]` mean and covariance; per step the covariance of
/// `p_k − p_k+1`; the registrations' log-likelihood (the filter's innovations').
pub type Oracle = (Vec<DVector<f64>>, Vec<DMatrix<f64>>, Vec<Matrix3<f64>>, f64);

/// Kalman filter and RTS smoother on `s_k = [p_k, v_k, p_k−1, …, p_k−L]` for the linear
/// model: `p_k+1 = p_k + Δt v_k + w_p`, `v_k+1 = v_k + w_v`, registrations
/// `z = p_source − p_reference + n`. `p_0 = 0` is known exactly, `v_0 ~ N(m0, P0)`.
/// Returns per scan the smoothed `[p; v]` mean and covariance, per step the covariance of
/// `p_k − p_k+1`, and the registrations' log-likelihood `Σ ln N(ν; 0, S)` over the filter's
/// innovations ν and their covariances S.
pub fn kalman_rts(run: &Run, lags: usize, qc: &[f64; 3], v0: &TwistPrior) -> Oracle {
    kalman_rts_of(run, lags, qc, &[*v0])
}

/// [`kalman_rts`] for white noise on acceleration (`initial = [v_0]`) or on jerk (`initial =
/// [v_0, a_0]`: `s_k = [p_k, v_k, a_k, p_k−1, …]`, `p_k+1 = p_k + Δt v_k + Δt²/2 a_k + w_p`,
/// `v_k+1 = v_k + Δt a_k + w_v`, `a_k+1 = a_k + w_a`, `Q` of [`q_matrix_jerk`]).
pub fn kalman_rts_of(run: &Run, lags: usize, qc: &[f64; 3], initial: &[TwistPrior]) -> Oracle {
    let n = run.times_s.len();
    let base = 3 + 3 * initial.len();
    let dim = base + 3 * lags;
    let slot = |lag: usize| if lag == 0 { 0 } else { base + 3 * (lag - 1) };
    let mut m = DVector::zeros(dim);
    let mut p = DMatrix::zeros(dim, dim);
    for (d, prior) in initial.iter().enumerate() {
        m.rows_mut(3 + 3 * d, 3).copy_from(&prior.mean);
        p.view_mut((3 + 3 * d, 3 + 3 * d), (3, 3))
            .copy_from(&prior.cov);
    }
    let (mut mf, mut pf, mut mp, mut pp, mut fs) = (vec![], vec![], vec![], vec![], vec![]);
    let mut log_likelihood = 0.0;
    for k in 0..n {
        if k > 0 {
            let dt = run.times_s[k] - run.times_s[k - 1];
            let mut f = DMatrix::zeros(dim, dim);
            for i in 0..base {
                f[(i, i)] = 1.0;
            }
            for i in 0..3 {
                f[(i, i + 3)] = dt;
                if base == 9 {
                    f[(i, i + 6)] = dt * dt / 2.0;
                    f[(i + 3, i + 6)] = dt;
                }
                f[(slot(1) + i, i)] = 1.0;
                for l in 2..=lags {
                    f[(slot(l) + i, slot(l - 1) + i)] = 1.0;
                }
            }
            let mut q = DMatrix::zeros(dim, dim);
            if base == 9 {
                q.view_mut((0, 0), (9, 9)).copy_from(&q_matrix_jerk(qc, dt));
            } else {
                q.view_mut((0, 0), (6, 6)).copy_from(&q_matrix(qc, dt));
            }
            m = &f * &m;
            p = &f * &p * f.transpose() + q;
            mp.push(m.clone());
            pp.push(p.clone());
            fs.push(f);
        }
        for r in run.regs.iter().filter(|r| r.reference == k) {
            let lag = r.reference - r.source;
            let mut h = DMatrix::zeros(3, dim);
            for i in 0..3 {
                h[(i, slot(lag) + i)] += 1.0;
                h[(i, i)] -= 1.0;
            }
            let v = r.t_ref_src.translation.vector;
            let z = DVector::from_vec(vec![v.x, v.y, r.t_ref_src.rotation.angle()]);
            let rr = DMatrix::from_iterator(3, 3, r.cov.iter().copied());
            let s = &h * &p * h.transpose() + &rr;
            let s_inv = s.clone().try_inverse().unwrap();
            let nu = z - &h * &m;
            log_likelihood -=
                0.5 * (nu.dot(&(&s_inv * &nu)) + s.determinant().ln() + 3.0 * (2.0 * PI).ln());
            let k_gain = &p * h.transpose() * s_inv;
            m = &m + &k_gain * nu;
            let ikh = DMatrix::identity(dim, dim) - &k_gain * &h;
            p = &ikh * &p * ikh.transpose() + &k_gain * rr * k_gain.transpose();
        }
        mf.push(m.clone());
        pf.push(p.clone());
    }
    // RTS, with P_pred inverted on its non-degenerate coordinates (p_0 is known exactly).
    let mut ms = vec![mf[n - 1].clone()];
    let mut ps = vec![pf[n - 1].clone()];
    let mut step = vec![Matrix3::zeros(); n - 1];
    for k in (0..n - 1).rev() {
        let live: Vec<usize> = (0..dim).filter(|&i| pp[k][(i, i)] > 0.0).collect();
        let sub = DMatrix::from_fn(live.len(), live.len(), |i, j| pp[k][(live[i], live[j])]);
        let sub_inv = sub.try_inverse().unwrap();
        let mut pinv = DMatrix::zeros(dim, dim);
        for (i, &a) in live.iter().enumerate() {
            for (j, &b) in live.iter().enumerate() {
                pinv[(a, b)] = sub_inv[(i, j)];
            }
        }
        let g = &pf[k] * fs[k].transpose() * pinv;
        let (next_m, next_p) = (ms.last().unwrap().clone(), ps.last().unwrap().clone());
        // The smoothed s_k+1 holds p_k+1 and p_k: the step's covariance from it.
        {
            let mut d = DMatrix::zeros(3, dim);
            for i in 0..3 {
                d[(i, slot(1) + i)] = 1.0;
                d[(i, i)] = -1.0;
            }
            let c = &d * &next_p * d.transpose();
            step[k] = Matrix3::from_fn(|i, j| c[(i, j)]);
        }
        ms.push(&mf[k] + &g * (&next_m - &mp[k]));
        ps.push(&pf[k] + &g * (&next_p - &pp[k]) * g.transpose());
    }
    ms.reverse();
    ps.reverse();
    let means = ms.iter().map(|v| v.rows(0, 6).into_owned()).collect();
    let covs = ps
        .iter()
        .map(|c| c.view((0, 0), (6, 6)).into_owned())
        .collect();
    (means, covs, step, log_likelihood)
}

pub fn linear_options(qc: [f64; 3], v0: TwistPrior) -> SmootherOptions {
    SmootherOptions {
        geometry: Geometry::Linear,
        process_noise: ProcessNoise::Fixed(qc),
        huber_k: 1e9, // no robust down-weighting: the Kalman filter has none
        initial_twist: Some(v0),
        // Independent registrations, as the Kalman oracle takes them.
        scan_errors: ScanErrors::Independent,
        ..SmootherOptions::default()
    }
}

pub fn params(t: &Isometry2<f64>) -> Vector3<f64> {
    Vector3::new(
        t.translation.vector.x,
        t.translation.vector.y,
        t.rotation.angle(),
    )
}

/// The largest difference of a linear solution `out` from the Kalman/RTS `oracle`: each
/// scan's pose, twist and covariance, each step's `p_k − p_k+1` and its covariance.
pub fn largest_difference(out: &Smoothed, (means, covs, steps, _): &Oracle) -> f64 {
    let mut worst: f64 = 0.0;
    for (k, s) in out.scans.iter().enumerate() {
        for i in 0..3 {
            worst = worst.max((s.pose[i] - means[k][i]).abs());
            worst = worst.max((s.twist[i] - means[k][i + 3]).abs());
        }
        for i in 0..6 {
            for j in 0..6 {
                worst = worst.max((s.cov[(i, j)] - covs[k][(i, j)]).abs());
            }
        }
    }
    for (k, s) in out.steps.iter().enumerate() {
        // Linear t_ref_src of k → k+1 is p_k − p_k+1.
        let expected = Vector3::from_fn(|i, _| means[k][i] - means[k + 1][i]);
        worst = worst.max((params(&s.t_ref_src) - expected).abs().max());
        worst = worst.max((s.cov - steps[k]).abs().max());
    }
    worst
}

/// The RMS error of `out`'s smoothed surge speed against `run`'s true twists.
pub fn surge_rmse(run: &Run, out: &Smoothed) -> f64 {
    let se: f64 = out
        .scans
        .iter()
        .zip(&run.twists)
        .map(|(s, t)| (s.twist.x - t.x).powi(2))
        .sum();
    (se / run.twists.len() as f64).sqrt()
}

/// `run` smoothed in batch and causally (no lag) under `options`.
pub fn batch_and_causal(run: &Run, options: &SmootherOptions) -> (Smoothed, Smoothed) {
    let batch = smooth(&run.times_s, &run.regs, Mode::Batch, options).unwrap();
    let causal = smooth(
        &run.times_s,
        &run.regs,
        Mode::Causal { lag_scans: 0 },
        options,
    )
    .unwrap();
    (batch, causal)
}

/// The last step's estimate of two solutions (batch and causal) agree to 1e-9.
pub fn assert_last_steps_equal(batch: &Smoothed, causal: &Smoothed) {
    let (b, c) = (batch.steps.last().unwrap(), causal.steps.last().unwrap());
    assert!((params(&b.t_ref_src) - params(&c.t_ref_src)).abs().max() < 1e-9);
    assert!((b.cov - c.cov).abs().max() < 1e-9);
}

/// The last scan's estimate of two solutions (batch and causal) agree to 1e-9.
pub fn assert_last_scans_equal(batch: &Smoothed, causal: &Smoothed) {
    let (b, c) = (batch.scans.last().unwrap(), causal.scans.last().unwrap());
    assert!((b.pose - c.pose).abs().max() < 1e-9);
    assert!((b.twist - c.twist).abs().max() < 1e-9);
    assert!((b.cov - c.cov).abs().max() < 1e-9);
}
